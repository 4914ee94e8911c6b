//! The boot record: a few words of RAM that survive a reset (not a power cycle), kept
//! in the `.uninit` section (NOLOAD: neither the start-up code nor the loader writes
//! it).
//!
//! | word | meaning |
//! |---|---|
//! | `magic` | [`MAGIC`] once the record was written |
//! | `count` | boots since power-on (1 = the first) |
//! | `pending` | the reset cause a handler recorded just before it reset the board (`wheelset_proto::reset_cause`; 0 = none) |
//! | `check` | `magic ^ count ^ pending ^ CHECK_SALT`: a record of random RAM after power-on is not taken for a valid one |
//!
//! At start-up [`start`] reads the record and returns `(boot_count, reset_cause)`:
//! a valid record after a reset gives `count + 1` and the cause a handler recorded
//! ([`record_cause`]: the watchdog's early-warning interrupt, the HardFault handler),
//! or else the hardware's own cause (the Nucleo's RCC CSR flags; UNKNOWN on QEMU,
//! which has no such register); no valid record, or a power-on reset, gives
//! `(1, POWER_ON)`. The record is then rewritten with no pending cause.
//!
//! QEMU (7.2, measured): a system reset reloads the ELF's flash image and leaves the RAM
//! as it was; the start-up code then zeroes `.bss` and copies `.data`, and `.uninit`
//! (after `.bss`, in the same NOBITS load segment) keeps its words. Measured with the
//! QEMU monitor: `xp /4wx` of the record after each `system_reset` read boot counts
//! 1, 2, 3 (the record's address from `arm-none-eabi-nm`, symbol `boot::RECORD`). A
//! fresh QEMU process starts from zeroed RAM: no valid record, boot 1, POWER_ON.

use core::mem::MaybeUninit;
use core::ptr::{addr_of_mut, read_volatile, write_volatile};
use core::sync::atomic::{AtomicU32, Ordering};

use wheelset_proto::reset_cause;

use crate::board::Board;

/// Marks a written record ("WBR1").
pub const MAGIC: u32 = 0x5742_5231;
const CHECK_SALT: u32 = 0xA5C3_0F96;

#[repr(C)]
#[derive(Clone, Copy)]
struct Record {
    magic: u32,
    count: u32,
    pending: u32,
    check: u32,
}

impl Record {
    fn sealed(count: u32, pending: u32) -> Self {
        Self {
            magic: MAGIC,
            count,
            pending,
            check: MAGIC ^ count ^ pending ^ CHECK_SALT,
        }
    }

    fn valid(&self) -> bool {
        self.magic == MAGIC && self.check == MAGIC ^ self.count ^ self.pending ^ CHECK_SALT
    }
}

#[unsafe(link_section = ".uninit.wheelset_boot")]
static mut RECORD: MaybeUninit<Record> = MaybeUninit::uninit();

/// This boot's count and cause, for the runtime (`(count << 8) | cause`).
static THIS_BOOT: AtomicU32 = AtomicU32::new(0);

fn read() -> Record {
    // SAFETY: RECORD is a plain, aligned static of four u32 words; any bit pattern is a
    // valid `Record` (uninitialised RAM is read as whatever it holds, which `valid`
    // checks). Only this module touches it, single-core, with volatile accesses.
    unsafe { read_volatile(addr_of_mut!(RECORD).cast::<Record>()) }
}

fn write(r: Record) {
    // SAFETY: as in `read`.
    unsafe { write_volatile(addr_of_mut!(RECORD).cast::<Record>(), r) }
}

/// Reads the record at start-up, counts this boot and returns `(boot_count,
/// reset_cause)`. `hw_cause` is the board's own reset cause (`None`: no register);
/// `power_on` says the hardware saw a power-on reset (the RAM is not to be trusted).
pub fn start(hw_cause: Option<u8>, power_on: bool) -> (u32, u8) {
    let r = read();
    let (count, cause) = if r.valid() && !power_on {
        let pending = u8::try_from(r.pending).unwrap_or(reset_cause::UNKNOWN);
        let cause = if pending != reset_cause::UNKNOWN {
            pending
        } else {
            hw_cause.unwrap_or(reset_cause::UNKNOWN)
        };
        (r.count.wrapping_add(1).max(1), cause)
    } else {
        (1, reset_cause::POWER_ON)
    };
    write(Record::sealed(count, 0));
    THIS_BOOT.store(count << 8 | u32::from(cause), Ordering::Relaxed);
    (count, cause)
}

/// [`start`] with the board's own reset cause ([`Board::reset_cause`]).
pub fn start_on<B: Board>() -> (u32, u8) {
    let (hw_cause, power_on) = B::reset_cause();
    start(hw_cause, power_on)
}

/// This boot's `(boot_count, reset_cause)` as [`start`] found them (`(0, UNKNOWN)`
/// before it ran).
pub fn this_boot() -> (u32, u8) {
    let b = THIS_BOOT.load(Ordering::Relaxed);
    (b >> 8, (b & 0xFF) as u8)
}

/// Records why the board is about to reset (a handler, just before the reset), so the
/// next boot reports it.
pub fn record_cause(cause: u8) {
    let r = read();
    let count = if r.valid() { r.count } else { 0 };
    write(Record::sealed(count, u32::from(cause)));
}

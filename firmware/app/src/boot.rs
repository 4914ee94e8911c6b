//! The boot record: `.uninit` words that survive a reset: `magic`, `count` (boots since
//! power-on), `pending` (a cause a handler recorded before resetting), `check` (so random
//! RAM after power-on is not taken for a record).

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
    // SAFETY: RECORD is a plain, aligned static of u32 words and any bit pattern is a valid
    // `Record`; only this module touches it, single-core, volatile.
    unsafe { read_volatile(addr_of_mut!(RECORD).cast::<Record>()) }
}

fn write(r: Record) {
    // SAFETY: as in `read`.
    unsafe { write_volatile(addr_of_mut!(RECORD).cast::<Record>(), r) }
}

/// Reads the record and counts this boot: `(boot_count, reset_cause)`, the recorded cause
/// winning over `hw_cause`; `power_on` distrusts the RAM.
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

/// This boot's `(boot_count, reset_cause)` (`(0, UNKNOWN)` before [`start`]).
pub fn this_boot() -> (u32, u8) {
    let b = THIS_BOOT.load(Ordering::Relaxed);
    (b >> 8, (b & 0xFF) as u8)
}

/// Records why the board is about to reset, for the next boot.
pub fn record_cause(cause: u8) {
    let r = read();
    let count = if r.valid() { r.count } else { 0 };
    write(Record::sealed(count, u32::from(cause)));
}

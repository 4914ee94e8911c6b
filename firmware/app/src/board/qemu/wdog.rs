//! The CMSDK APB watchdog of the mps2 boards (0x4000_8000, WDOGCLK = the 25 MHz system
//! clock; its interrupt is the NMI): the first expiry raises the NMI, the second, with
//! RESEN, resets the machine (QEMU's default `-watchdog-action reset`; the harness does
//! not pass `-no-reboot`, so the board reboots and rejoins on the same chardev).
//!
//! **QEMU 7.2's model, measured** (a bare-metal probe reading WDOGVALUE around
//! 200 000-instruction loops under `-icount shift=10,sleep=off`): the counter runs from
//! the machine reset (0xFFFF_FFFF, before any register is written) and keeps running
//! with CTRL = 0 (the count went down 5 120 000 counts = 200 000 instructions x
//! 1 024 ns x 25 MHz across the loop with INTEN clear); setting INTEN again does not
//! reload it; only the second expiry stops it, for good (`resetstatus` stays set until
//! the machine resets). (The current upstream source, hw/watchdog/cmsdk-apb-watchdog.c, stops the count with
//! INTEN clear and reloads it when INTEN is set; 7.2 does neither.) So the
//! count cannot be paused.
//!
//! **Why the masked-WFI idle broke lock-step** (what these facts explain). Under `sleep=off` QEMU's virtual clock
//! jumps to the next armed timer whenever the guest idles; the watchdog, always armed,
//! is that timer. The earlier idle loop cleared CTRL before WFI (which stopped nothing):
//! the jump expired the count with INTEN clear, so `intstatus` was set silently, and
//! setting INTEN after WFI raised the NMI at once: the safe frame at the first idle of a
//! healthy run, whether or not the board had "started" the watchdog.
//!
//! **A pause emulated in the idle loop, tried and measured.** Before WFI: read what is
//! left of the count, load a short park count and mark the board idle; an expiry while
//! idle (the clock jump) raises the NMI, whose handler clears it (WDOGINTCLR) and
//! returns; after WFI load the budget back. The board-counters test
//! (`hil/harness/tests/qemu_board.rs`) then saw spurious resets: 54 boots in one run (`-d int`:
//! the first reset during the 600-byte burst, one RX interrupt per byte and one clock
//! jump per idle between them, with no NMI taken before it, so the second expiry came
//! before the first was handled; cause UNKNOWN), and every later boot reset as soon as
//! the idle loop started the watchdog. Not pursued further: the pause it needs does not
//! exist in this QEMU, and a guest cycling through clock jumps while it waits for the
//! host also burns the host's CPU.
//!
//! **So the watchdog runs on the free-running build only** ([`ENABLED`]; `free-run`,
//! `hil run --target qemu-free`): without `-icount` QEMU's clock follows the host's and
//! the guest sleeps in WFI without jumps, so the watchdog counts wall time as on a
//! board. The lock-step build leaves CTRL at 0 (the count runs but raises nothing) and
//! idles with a plain WFI, exactly as before: its traces stay bit-identical.
//!
//! **Timeout.** [`TIMEOUT_COUNTS`] = 50 000 000 WDOGCLK counts at 25 MHz = 2 s of wall
//! time without a feed = 1 000 control periods at the free-running build's 500 Hz
//! maximum base rate (`LINK_MAX_RATE_HZ`). A healthy run feeds it every period (a
//! tick and the host's frame for it); 2 s leaves room for a loaded 2-core host's pauses
//! between frames, and a stalled control task resets the board 2 s after the stall,
//! ~20 ms ([`GRACE_COUNTS`]) after the NMI has sent the safe frame. The watchdog starts
//! at the first feed (the host's first bytes and a tick after them), so the time the
//! harness takes to connect and configure does not count; once started it runs until
//! the next reset, so a host that stops sending resets the board 2 s later (a wedged
//! link is a fault too).
//!
//! (The Nucleo's IWDG runs on its own oscillator: `board::nucleo`.)

use core::ptr::write_volatile;

const BASE: usize = 0x4000_8000;
const LOAD: usize = BASE;
const CTRL: usize = BASE + 0x08;
const INTCLR: usize = BASE + 0x0C;
const LOCK: usize = BASE + 0xC00;
const CTRL_INTEN: u32 = 1 << 0;
const CTRL_RESEN: u32 = 1 << 1;
const UNLOCK: u32 = 0x1ACC_E551;

/// Whether the board starts the watchdog: on the free-running build only (see the
/// module's docs for why not in lock-step).
pub const ENABLED: bool = cfg!(feature = "free-run");

/// The timeout: 50 000 000 WDOGCLK counts at 25 MHz = 2 s of wall time without a feed
/// (1 000 periods at 500 Hz) to the NMI.
pub const TIMEOUT_COUNTS: u32 = 50_000_000;

/// From the NMI (first expiry) to the reset (second expiry): 500 000 counts = 20 ms for
/// the handler to record the cause and send the safe frame (17 bytes by polling).
pub const GRACE_COUNTS: u32 = 500_000;

fn write(addr: usize, value: u32) {
    // SAFETY: `addr` is one of the watchdog's registers above: a valid, aligned MMIO
    // word of the mps2 boards; this module alone owns the watchdog.
    unsafe { write_volatile(addr as *mut u32, value) }
}

/// Starts the watchdog with [`TIMEOUT_COUNTS`], interrupt (NMI) and reset enabled. The
/// interrupt is cleared first: the count has run since the machine reset (QEMU 7.2), and
/// an expiry before this point must not count as the first.
pub fn start() {
    write(LOCK, UNLOCK);
    write(LOAD, TIMEOUT_COUNTS);
    write(INTCLR, 1);
    write(CTRL, CTRL_INTEN | CTRL_RESEN);
}

/// Feeds it: the count restarts from [`TIMEOUT_COUNTS`].
pub fn feed() {
    write(LOAD, TIMEOUT_COUNTS);
}

/// In the NMI (the first expiry): the reset follows in [`GRACE_COUNTS`].
pub fn grace() {
    write(LOAD, GRACE_COUNTS);
}

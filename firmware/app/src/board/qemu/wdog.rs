//! The CMSDK APB watchdog of the mps2 boards (0x4000_8000, 25 MHz): the first expiry
//! raises the NMI, the second resets the machine. QEMU 7.2's counts from the machine
//! reset even with CTRL = 0 and cannot be paused, so under `-icount sleep=off` every idle
//! would jump to its expiry: it runs on the free-running build only ([`ENABLED`]).

use core::ptr::write_volatile;

const BASE: usize = 0x4000_8000;
const LOAD: usize = BASE;
const CTRL: usize = BASE + 0x08;
const INTCLR: usize = BASE + 0x0C;
const LOCK: usize = BASE + 0xC00;
const CTRL_INTEN: u32 = 1 << 0;
const CTRL_RESEN: u32 = 1 << 1;
const UNLOCK: u32 = 0x1ACC_E551;

/// Whether the board starts the watchdog: the free-running build only (module docs).
pub const ENABLED: bool = cfg!(feature = "free-run");

/// The timeout: 50 000 000 counts at 25 MHz = 2 s without a feed to the NMI.
pub const TIMEOUT_COUNTS: u32 = 50_000_000;

/// From the NMI to the reset: 500 000 counts = 20 ms to record the cause and send the safe frame.
pub const GRACE_COUNTS: u32 = 500_000;

fn write(addr: usize, value: u32) {
    // SAFETY: `addr` is a watchdog register: valid, aligned MMIO, owned by this module.
    unsafe { write_volatile(addr as *mut u32, value) }
}

/// Starts the watchdog (NMI and reset); the interrupt cleared first (the count ran since reset).
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

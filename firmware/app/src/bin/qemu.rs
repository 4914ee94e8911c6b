//! Firmware for QEMU's `mps2-an386` (processor in the loop). Build with `cargo fw`;
//! run by hand as the README's Firmware section shows.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    wheelset_fw::board::run()
}

#[cfg(not(target_os = "none"))]
fn main() {
    use wheelset_fw::settings;
    println!(
        "wheelset-qemu: QEMU mps2-an386 firmware; base rate {} Hz, {} build, icount shift {}",
        settings::BASE_RATE_HZ,
        settings::NUMERIC,
        settings::QEMU_ICOUNT_SHIFT
    );
    println!("build it for the MCU with `cargo fw` (target/fw/wheelset-qemu.elf)");
}

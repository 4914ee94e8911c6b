//! Firmware for the Nucleo-F446RE. Build with `cargo fw`; flash with
//! `cargo flash-board` (probe-rs).
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
        "wheelset-nucleo: Nucleo-F446RE firmware; base rate {} Hz, {} build, USART2 ({})",
        settings::BASE_RATE_HZ,
        settings::NUMERIC,
        if cfg!(feature = "frame-clock") {
            "ST-LINK VCP at 921600 baud, frame-clocked"
        } else {
            "Arduino D1/D0 at 5.25 Mbaud, free-running"
        }
    );
    println!(
        "build it with `cargo fw` (target/fw/wheelset-nucleo.elf), flash with `cargo flash-board`"
    );
}

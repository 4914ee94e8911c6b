//! The firmware of the board its `board-*` feature names (`cargo fw`).
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    use wheelset_fw::board::{Board, Selected};
    Selected::run()
}

#[cfg(not(target_os = "none"))]
fn main() {
    use wheelset_fw::settings;
    println!(
        "wheelset-fw: base rate {} Hz, {} build; the board firmware is built for the MCU \
         by `cargo fw` (target/fw/*.elf)",
        settings::BASE_RATE_HZ,
        settings::NUMERIC,
    );
}

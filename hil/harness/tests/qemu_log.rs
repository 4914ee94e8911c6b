//! The firmware logs what it refuses: under QEMU the defmt log goes to a file
//! (semihosting stdout, `QemuConfig::log`), decoded here with `defmt-decoder` against the
//! ELF's table, as `defmt-print -e ELF` does. A corrupt frame (CRC) is logged with its
//! kind at once; a burst of corrupt frames and a refused Config (3 kHz: not a whole number
//! of microseconds, `RefuseReason::Period`) behind it give one record for the burst's
//! first with the number after it, at most one record per `RX_LOG_QUIET_TICKS` ticks, not
//! one per frame; a refusal alone is logged with its reason. Skips when QEMU or the ELF
//! is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use std::path::Path;

use common::{config_at, exchange, sensor};
use defmt_decoder::{DecodeError, Table};
use wheelset_targets::qemu::QemuConfig;

/// The firmware's quiet interval between two receive-log records, base ticks
/// (`wheelset_fw::app::RX_LOG_QUIET_TICKS`).
const QUIET: u16 = 500;

/// A Sensor frame with one bit of its body flipped: its CRC no longer matches.
fn corrupt(seq: u16) -> Vec<u8> {
    let mut f = sensor(seq);
    f[3] ^= if f[3] == 1 { 2 } else { 1 };
    f
}

/// Every record of the defmt log `log` of `elf`: (level, message).
fn decode(elf: &Path, log: &[u8]) -> Vec<(String, String)> {
    let bytes = std::fs::read(elf).unwrap();
    let table = Table::parse(&bytes)
        .unwrap()
        .expect("the firmware has a defmt table");
    let mut dec = table.new_stream_decoder();
    dec.received(log);
    let mut out = Vec::new();
    loop {
        match dec.decode() {
            Ok(f) => out.push((format!("{:?}", f.level()), f.display_message().to_string())),
            Err(DecodeError::UnexpectedEof) => break,
            Err(DecodeError::Malformed) => panic!("a malformed defmt frame in the log"),
        }
    }
    out
}

#[test]
fn refused_and_corrupt_frames_are_logged_without_flooding() {
    let dir = std::env::temp_dir().join(format!("hil-qemu-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("defmt.bin");
    let cfg = QemuConfig {
        log: Some(log.clone()),
        ..QemuConfig::new()
    };
    let Some(mut q) = common::start_cfg_or_skip("refusals logged", &cfg) else {
        return;
    };
    let mut seq = 0u16;
    let mut ticks = |q: &mut wheelset_targets::qemu::Qemu, n: u16| {
        for _ in 0..n {
            seq += 1;
            exchange(q, &sensor(seq), 1);
        }
    };
    ticks(&mut q, 3);
    // One corrupt frame: logged on its tick.
    exchange(&mut q, &corrupt(1000), 1);
    ticks(&mut q, 3);
    // A burst of 20 corrupt frames and a refused Config, within the quiet interval.
    for k in 0..20 {
        exchange(&mut q, &corrupt(2000 + k), 1);
    }
    exchange(&mut q, &config_at(3_000), 1);
    ticks(&mut q, QUIET + 10);
    // A refused Config alone, after the burst's record.
    exchange(&mut q, &config_at(3_000), 1);
    ticks(&mut q, QUIET + 10);
    drop(q);
    let bytes = std::fs::read(&log).unwrap();
    let records = decode(&cfg.elf, &bytes);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        records
            .iter()
            .any(|(_, m)| m.starts_with("control task: 5000 Hz")),
        "{records:#?}"
    );
    let rx: Vec<&(String, String)> = records
        .iter()
        .filter(|(_, m)| m.starts_with("rx "))
        .collect();
    let want = [
        "rx Rejected(Crc) (+0 more since the last record)",
        // The burst's first, then 19 more corrupt frames and the refusal.
        "rx Rejected(Crc) (+20 more since the last record)",
        "rx Refused(Period) (+0 more since the last record)",
    ];
    assert_eq!(
        rx.iter().map(|(_, m)| m.as_str()).collect::<Vec<_>>(),
        want,
        "{records:#?}"
    );
    assert!(rx.iter().all(|(l, _)| l == "Some(Warn)"), "{rx:?}");
}

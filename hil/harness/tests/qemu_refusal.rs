//! The rate bug under QEMU: the `wheelset-qemu` firmware refuses a Config
//! whose base period is not a whole number of microseconds (3 kHz: 333.3 us), flags it
//! (`CMD_REFUSED`), counts it (Status `cmd_refused`) and keeps ticking at its 5 kHz;
//! a plausible 4 kHz Config is then accepted. Skips when QEMU or the ELF is missing,
//! unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::{config_at, exchange, sensor};
use wheelset_proto::{encode_vec, Actuation, Command, Flags, Message};
use wheelset_targets::qemu::QemuConfig;

fn actuation(m: &[Message]) -> Actuation {
    match m.first() {
        Some(Message::Actuation(a)) => *a,
        other => panic!("expected an actuation frame, got {other:?}"),
    }
}

#[test]
fn the_qemu_firmware_refuses_a_period_it_cannot_honour() {
    let Some(mut q) = common::start_cfg_or_skip("3 kHz refused", &QemuConfig::new()) else {
        return;
    };
    for k in 1..=5 {
        let a = actuation(&exchange(&mut q, &sensor(k), 1));
        assert!(!a.flags.has(Flags::CMD_REFUSED));
    }
    // 3 kHz: refused; the device keeps its 5 kHz core.
    let a = actuation(&exchange(&mut q, &config_at(3_000), 1));
    assert!(
        a.flags.has(Flags::CMD_REFUSED),
        "3 kHz accepted: {:?}",
        a.flags
    );
    let a = actuation(&exchange(&mut q, &sensor(6), 1));
    assert!(a.flags.has(Flags::CMD_REFUSED) && a.flags.has(Flags::ENABLED));
    assert_eq!(a.seq_echo, 6);
    let st = exchange(
        &mut q,
        &encode_vec(&Message::Command(Command::RequestStatus)).unwrap(),
        2,
    );
    let Some(Message::Status(s)) = st.get(1) else {
        panic!("{st:?}")
    };
    assert_eq!(s.cmd_refused, 1);
    assert_eq!(s.rx_postcard + s.rx_crc + s.rx_length, 0);
    // A rate the ticker can honour and the device has a design for is taken (2.5 kHz =
    // 400 us): the flag clears.
    let a = actuation(&exchange(&mut q, &config_at(2_500), 1));
    assert!(
        !a.flags.has(Flags::CMD_REFUSED),
        "2.5 kHz refused: {:?}",
        a.flags
    );
}

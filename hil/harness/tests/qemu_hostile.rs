//! The hostile-Config table (`wheelset_hostile`) against the firmware
//! `wheelset-qemu.elf` over its UART: one boot, every row from the nominal state (the
//! nominal Config restored between rows, the restore proven by the frames after it),
//! each refused with its reason and nothing else changed, or applied; and every frame
//! and counter the firmware sends equal to the host runtime's on the same frames. The
//! host runs the same table in `firmware/runtime/tests/hostile.rs`. Skips when QEMU or
//! the ELF is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use wheelset_control::Fx;
use wheelset_hostile::{self as hostile, Device, Expect, Reply, Row, Trace};
use wheelset_proto::{Decoder, Message};
use wheelset_runtime::{Runtime, RuntimeConfig};
use wheelset_targets::qemu::{Qemu, QemuConfig};

/// The firmware under QEMU as a [`Device`]: lock-step, one tick per delimiter.
struct OnQemu(Qemu);

impl Device for OnQemu {
    type Error = String;

    fn exchange(&mut self, frame: &[u8], status: bool) -> Result<Reply, String> {
        self.0.send(frame).map_err(|e| e.to_string())?;
        let mut dec: Decoder = Decoder::new();
        let mut next = |q: &mut Qemu| -> Result<Message, String> {
            let mut f = q.recv_frame().map_err(|e| e.to_string())?;
            f.push(0);
            match dec.next_message(&f).0 {
                Some(Ok(m)) => Ok(m),
                other => Err(format!("not a valid frame from the device: {other:?}")),
            }
        };
        let Message::Actuation(actuation) = next(&mut self.0)? else {
            return Err("the tick's first frame is not an Actuation".into());
        };
        let status = if status {
            match next(&mut self.0)? {
                Message::Status(s) => Some(s),
                m => return Err(format!("expected a Status, got {m:?}")),
            }
        } else {
            None
        };
        Ok(Reply { actuation, status })
    }
}

/// The firmware's trace is the host runtime's: every Actuation (outputs, flags, echoed
/// `seq`, tick count) and every counter but what the board measures of itself.
fn same_as_host(what: &str, q: &Trace, h: &Trace) {
    let strip = |a: &wheelset_proto::Actuation| (hostile::outputs(a), a.tick);
    let all = |t: &Trace| {
        t.before
            .iter()
            .chain([&t.at])
            .chain(&t.after)
            .map(strip)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        all(q),
        all(h),
        "{what}: the firmware's frames are not the host's"
    );
    for (name, sq, sh) in [("s0", &q.s0, &h.s0), ("s1", &q.s1, &h.s1)] {
        assert_eq!(
            (
                hostile::counters(sq),
                sq.cmd_refused,
                sq.refuse_reason,
                sq.flags
            ),
            (
                hostile::counters(sh),
                sh.cmd_refused,
                sh.refuse_reason,
                sh.flags
            ),
            "{what}: the firmware's Status {name} is not the host's"
        );
    }
}

#[test]
fn the_firmware_refuses_every_hostile_config_with_its_reason_and_applies_the_nominal_ones() {
    let Some(q) = common::start_cfg_or_skip("hostile Configs", &QemuConfig::new()) else {
        return;
    };
    let mut fw = OnQemu(q);
    // The host runtime, started as the firmware is (its build compiles the default
    // configuration), fed the same frames.
    let mut host = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("the default");
    let nominal = hostile::nominal::<Fx>().expect("the host computes the nominal rates");
    let null = hostile::null_frame();
    let base = hostile::probe(&mut fw, &nominal, null.as_bytes()).expect("the firmware");
    let base_host = hostile::probe(&mut host, &nominal, null.as_bytes()).expect("the host");
    same_as_host("the nominal run", &base, &base_host);
    let mut rows: Vec<Row> = Vec::new();
    hostile::rows::<Fx>(|r| rows.push(r)).expect("the table");
    let (mut refused, mut applied) = (0, 0);
    for row in &rows {
        let what = row.to_string();
        let frame = row.frame();
        let t = hostile::probe(&mut fw, &nominal, frame.as_bytes())
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        let th = hostile::probe(&mut host, &nominal, frame.as_bytes()).expect("the host");
        if let Err(f) = hostile::judge(row.expect, &t, &base) {
            panic!("the firmware, {what}: {f}");
        }
        same_as_host(&what, &t, &th);
        match row.expect {
            Expect::Refused(_) => refused += 1,
            Expect::Applied { .. } => applied += 1,
        }
    }
    eprintln!(
        "hostile Configs on the firmware: {refused} refused with their reasons, {applied} \
         applied, of {} rows",
        rows.len()
    );
    // Every design point and the switches are applied; the rest refused.
    assert!(refused >= 100 && applied >= 20, "{refused} / {applied}");
}

//! The reset detection of [`super::DeviceController`]: a device whose tick counter goes
//! back is counted as reset and sent its Config again.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use super::*;
use crate::transport::Clock;

/// Records the messages the host sent; delivers nothing (the test feeds the frames).
#[derive(Default)]
struct Recorder {
    sent: Vec<Message>,
}

impl Transport for Recorder {
    fn name(&self) -> String {
        "recorder".into()
    }
    fn clock(&self) -> Clock {
        Clock::RealTime
    }
    fn baud(&self) -> u32 {
        1_000_000
    }
    fn exec_unit(&self) -> (&'static str, f64) {
        ("ns", 1.0)
    }
    fn send(&mut self, _t_ns: u64, bytes: &[u8]) -> Result<(), TransportError> {
        let mut dec: Decoder = Decoder::new();
        for r in dec.messages(bytes) {
            self.sent.push(r.expect("the host's own frame decodes"));
        }
        Ok(())
    }
    fn recv(
        &mut self,
        _deadline_ns: u64,
        _sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError> {
        Ok(())
    }
}

fn act(tick: u16, latched: bool) -> Message {
    let mut flags = Flags(0);
    if latched {
        flags.0 |= Flags::FAULT_LATCHED;
    }
    Message::Actuation(wheelset_proto::Actuation {
        seq_echo: 0,
        tick,
        exec: 0,
        flags,
        t_psi_dnm: 0,
        u_a_cv: 0,
    })
}

fn configs(sent: &[Message]) -> usize {
    sent.iter()
        .filter(|m| matches!(m, Message::Config(_)))
        .count()
}

#[test]
fn a_tick_counter_that_goes_back_is_a_reset_and_the_config_goes_out_again() {
    let mut tr = Recorder::default();
    let cfg = crate::device_loop::run_config(&Default::default(), false, false);
    let period = 1_000_000;
    let setup = LoopSetup {
        period_ns: period,
        reset_config: Some(cfg),
        stall_at_ns: Some(2 * period),
        ..LoopSetup::default()
    };
    let mut ctrl = DeviceController::new(&mut tr, 0.0, setup);
    ctrl.run.config_sent = true; // configured before the run, as RealTime::prepare does
    let m = Measurements::default();
    for k in 0..4u16 {
        ctrl.step(u64::from(k) * period, &m);
        ctrl.on_frame(u64::from(k) * period, 10, Ok(act(100 + k, false)));
    }
    assert_eq!(ctrl.rec.stall_sent_ns, Some(2 * period));
    assert_eq!(ctrl.rec.device_resets, 0);
    // The handler's safe frame (tick 0) is not a boot; the new boot's tick 1 is.
    ctrl.on_frame(5 * period, 10, Ok(act(0, false)));
    assert_eq!(ctrl.rec.device_resets, 0);
    ctrl.on_frame(6 * period, 10, Ok(act(1, true)));
    assert_eq!(
        (ctrl.rec.device_resets, ctrl.rec.first_reset_ns),
        (1, Some(6 * period))
    );
    ctrl.step(7 * period, &m);
    ctrl.on_frame(7 * period, 10, Ok(act(2, true)));
    // A 16-bit wrap without a new latch is not a reset; a restart from a high tick
    // that raises the latch is.
    ctrl.on_frame(8 * period, 10, Ok(act(65_535, false)));
    ctrl.on_frame(9 * period, 10, Ok(act(0x0001, false)));
    assert_eq!(ctrl.rec.device_resets, 1);
    ctrl.on_frame(10 * period, 10, Ok(act(40_000, false)));
    ctrl.on_frame(11 * period, 10, Ok(act(3, true)));
    assert_eq!(ctrl.rec.device_resets, 2);
    drop(ctrl);
    let stalls = tr
        .sent
        .iter()
        .filter(|m| matches!(m, Message::Command(Command::InjectStall)))
        .count();
    assert_eq!(stalls, 1);
    // Once after the first reset (the step at 7 T); none before.
    assert_eq!(configs(&tr.sent), 1);
    let first_config = tr
        .sent
        .iter()
        .position(|m| matches!(m, Message::Config(_)))
        .unwrap();
    let sensors_before = tr.sent[..first_config]
        .iter()
        .filter(|m| matches!(m, Message::Sensor(_)))
        .count();
    assert_eq!(sensors_before, 4);
}

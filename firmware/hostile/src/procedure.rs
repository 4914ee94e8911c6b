//! The procedure: one row tried on any device that takes frames ([`Device`]), [`probe`]d
//! and [`judge`]d. A probe: (1) restore: Sensor, the nominal Config with outputs off,
//! Sensor, the nominal Config, `ClearFaults`, `ResetCounters`; (2) Status `s0`;
//! (3) [`PROBE_TICKS`] Sensor frames, `before`; (4) the row's frame, `at`; (5) Sensor
//! frames, [`GAP_TICKS`] ticks without one (the safe state), [`RECOVER_TICKS`] Sensor
//! frames, `after`; (6) Status `s1`. The judgement: `s0` and `before` equal the nominal
//! run's (the restore worked); a refused row has `cmd_refused` 1 with its reason and
//! everything else as the nominal run's; an applied row counts no refusal and, where
//! `visible`, changes the frames.

#[allow(clippy::wildcard_imports)]
use super::*;

/// A device taking frames: the host runtime ([`Runtime`] implements it), the firmware on a link.
pub trait Device {
    /// Why an exchange failed (the link, a garbled answer).
    type Error;
    /// Sends `frame` (with its delimiter, or a bare delimiter: a tick without a frame) and
    /// returns that tick's Actuation and, when `status`, the Status after it.
    fn exchange(&mut self, frame: &[u8], status: bool) -> Result<Reply, Self::Error>;
}

/// The frames of one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reply {
    /// The tick's Actuation.
    pub actuation: Actuation,
    /// The Status after it, if one was asked for and came.
    pub status: Option<Status>,
}

/// The runtime's tick output did not hold the frames asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NoReply;

impl fmt::Display for NoReply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("the tick's output held no Actuation (or no Status where one was asked)")
    }
}

impl<T: SampleBits> Device for Runtime<T> {
    type Error = NoReply;

    /// `receive` then one `tick` (the host's lock-step: a tick per frame).
    fn exchange(&mut self, frame: &[u8], status: bool) -> Result<Reply, NoReply> {
        self.receive(frame);
        let mut dec: Decoder = Decoder::new();
        let (mut actuation, mut got) = (None, None);
        for m in dec.messages(self.tick(0)) {
            match m {
                Ok(Message::Actuation(a)) if actuation.is_none() => actuation = Some(a),
                Ok(Message::Status(s)) => got = Some(s),
                _ => {}
            }
        }
        let status = status.then(|| got.ok_or(NoReply)).transpose()?;
        Ok(Reply {
            actuation: actuation.ok_or(NoReply)?,
            status,
        })
    }
}

/// The probe's lateral velocities, um/s: one period of a 3 mm/s sine.
const PROBE_Y_UM_S: [i32; PROBE_TICKS] = [
    0, 1_148, 2_121, 2_772, 3_000, 2_772, 2_121, 1_148, 0, -1_148, -2_121, -2_772, -3_000, -2_772,
    -2_121, -1_148,
];

/// The probe's Sensor frame `seq`: the `curve` operating point (115 A, 925.6 rad/s,
/// 2 460 N m) with a reference speed 0.5 m/s below the wheel's (a slip the protection acts on).
pub fn probe_sensor(seq: u16) -> Sensor {
    Sensor {
        seq,
        t_us: seq.wrapping_mul(200),
        lateral: Lateral::Velocity(
            PROBE_Y_UM_S
                .get(usize::from(seq) % PROBE_TICKS)
                .copied()
                .unwrap_or(0),
        ),
        i_a_ma: 115_000,
        omega_m_mrad_s: 925_600,
        demand_nm: 2_460,
        v_ref_mm_s: 82_800,
    }
}

/// What one row did on a device ([`probe`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trace {
    /// The Status after the restore.
    pub s0: Status,
    /// The Actuations of the Sensor frames before the row's frame.
    pub before: [Actuation; PROBE_TICKS],
    /// The Actuation of the tick of the row's frame.
    pub at: Actuation,
    /// The Actuations after it.
    pub after: [Actuation; AFTER_TICKS],
    /// The Status at the end.
    pub s1: Status,
}

/// Runs one row's frames on `dev` (module docs): the restore to `nominal`, then `frame`
/// (the nominal run: [`null_frame`]) among the probe's Sensor frames.
pub fn probe<D: Device>(dev: &mut D, nominal: &Config, frame: &[u8]) -> Result<Trace, D::Error> {
    let sensor = |seq| Frame::of(&Message::Sensor(probe_sensor(seq)));
    let command = |c| Frame::of(&Message::Command(c));
    let off = Frame::of(&Message::Config(Config {
        enable: false,
        ..*nominal
    }));
    let on = Frame::of(&Message::Config(*nominal));
    for f in [
        sensor(0),
        off,
        sensor(0),
        on,
        command(Command::ClearFaults),
        command(Command::ResetCounters),
    ] {
        dev.exchange(f.as_bytes(), false)?;
    }
    let status = command(Command::RequestStatus);
    let s0 = dev.exchange(status.as_bytes(), true)?.status;
    let mut seq = 0u16;
    let mut tick = |dev: &mut D, sensed: bool| {
        let f = sensed.then(|| {
            seq += 1;
            sensor(seq)
        });
        let bytes = f.as_ref().map_or(&[0u8][..], Frame::as_bytes);
        dev.exchange(bytes, false).map(|r| r.actuation)
    };
    let mut before = [tick(dev, true)?; PROBE_TICKS];
    for a in before.iter_mut().skip(1) {
        *a = tick(dev, true)?;
    }
    let at = dev.exchange(frame, false)?.actuation;
    let mut after = [at; AFTER_TICKS];
    for (k, a) in after.iter_mut().enumerate() {
        *a = tick(dev, !(PROBE_TICKS..PROBE_TICKS + GAP_TICKS).contains(&k))?;
    }
    let s1 = dev.exchange(status.as_bytes(), true)?.status;
    Ok(Trace {
        s0: s0.unwrap_or_default(),
        before,
        at,
        after,
        s1: s1.unwrap_or_default(),
    })
}

/// The nominal run's frame in place of a row's: `ClearFaults`, which changes nothing.
pub fn null_frame() -> Frame {
    Frame::of(&Message::Command(Command::ClearFaults))
}

/// Why a row failed ([`judge`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The restore did not reach the nominal state (the Status, or this probe frame's Actuation).
    Restore {
        /// The probe frame (`None`: the Status).
        tick: Option<usize>,
    },
    /// The row's Config was not refused once with its reason (`expect` refused) or was
    /// refused (`expect` applied).
    Refusal {
        /// What the row expects.
        expect: Expect,
        /// `cmd_refused` after it.
        cmd_refused: u32,
        /// `refuse_reason` after it.
        reason: u8,
    },
    /// A refused row changed what the device does: this tick's Actuation after the row's
    /// frame (`Some(0)`: its own tick) or (`None`) a counter differs from the nominal run's.
    Changed {
        /// The tick (`None`: the Status).
        tick: Option<usize>,
    },
    /// An applied row that must show left every frame as in the nominal run.
    NotVisible,
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Restore { tick: None } => f.write_str("restore: the Status differs"),
            Self::Restore { tick: Some(k) } => {
                write!(f, "restore: the Actuation of probe frame {k} differs")
            }
            Self::Refusal {
                expect: Expect::Refused(_),
                cmd_refused,
                reason,
            } => write!(
                f,
                "not refused as required: cmd_refused {cmd_refused}, refuse_reason {reason}"
            ),
            Self::Changed { tick: None } => {
                f.write_str("refused, but a counter differs from the nominal run's")
            }
            Self::Changed { tick: Some(k) } => write!(
                f,
                "refused, but the Actuation {k} ticks after it differs from the nominal run's"
            ),
            Self::Refusal {
                cmd_refused,
                reason,
                ..
            } => write!(
                f,
                "refused (cmd_refused {cmd_refused}, refuse_reason {reason}), must be applied"
            ),
            Self::NotVisible => f.write_str("applied, but every frame is the nominal run's"),
        }
    }
}

/// An Actuation as compared: echoed `seq`, flags but `CMD_REFUSED`, the outputs.
pub fn outputs(a: &Actuation) -> (u16, u16, i32, i32) {
    (
        a.seq_echo,
        a.flags.0 & !Flags::CMD_REFUSED,
        a.t_psi_dnm,
        a.u_a_cv,
    )
}

/// A Status as compared: without the refusal, `CMD_REFUSED`, and what the board measures
/// of itself (boot record, stack, timing, overruns, dropped frames).
pub fn counters(s: &Status) -> Status {
    Status {
        cmd_refused: 0,
        refuse_reason: 0,
        flags: Flags(s.flags.0 & !Flags::CMD_REFUSED),
        boot_count: 0,
        reset_cause: 0,
        stack_peak: 0,
        ticks_late: 0,
        ticks_missed: 0,
        rx_overrun: 0,
        tx_dropped: 0,
        ..*s
    }
}

/// Judges one row's trace against the nominal run's (module docs).
pub fn judge(expect: Expect, trace: &Trace, nominal: &Trace) -> Result<(), Fault> {
    if counters(&trace.s0) != counters(&nominal.s0)
        || trace.s0.cmd_refused != 0
        || trace.s0.refuse_reason != 0
    {
        return Err(Fault::Restore { tick: None });
    }
    if let Some(k) = first_difference(&trace.before, &nominal.before) {
        return Err(Fault::Restore { tick: Some(k) });
    }
    let (count, reason) = (trace.s1.cmd_refused, trace.s1.refuse_reason);
    let ticks = || core::iter::once(&trace.at).chain(&trace.after);
    let nominal_ticks = || core::iter::once(&nominal.at).chain(&nominal.after);
    let changed = first_difference(ticks(), nominal_ticks());
    let as_expected = match expect {
        Expect::Refused(why) => count == 1 && reason == why.code(),
        Expect::Applied { .. } => count == 0 && reason == 0,
    };
    if !as_expected {
        return Err(Fault::Refusal {
            expect,
            cmd_refused: count,
            reason,
        });
    }
    match expect {
        Expect::Refused(_) => {
            if let Some(k) = changed {
                return Err(Fault::Changed { tick: Some(k) });
            }
            if counters(&trace.s1) != counters(&nominal.s1) {
                return Err(Fault::Changed { tick: None });
            }
        }
        Expect::Applied { visible } => {
            if visible && changed.is_none() {
                return Err(Fault::NotVisible);
            }
        }
    }
    Ok(())
}

fn first_difference<'a>(
    a: impl IntoIterator<Item = &'a Actuation>,
    b: impl IntoIterator<Item = &'a Actuation>,
) -> Option<usize> {
    a.into_iter()
        .zip(b)
        .position(|(x, y)| outputs(x) != outputs(y))
}

//! The same numbers from the target: the `wheelset-qemu` firmware under QEMU, lock-step
//! over its UART ([`wheelset_targets::qemu`]), fed an audit scenario's inputs as Sensor
//! frames. The host runs [`wheelset_runtime::Runtime`] on `Fx` with the firmware's
//! configuration on the same bytes, and the f64 core on the same codes. Reported: ticks
//! compared, Actuation codes that differ between target and host (the fixed-point core
//! must be bit-identical), and both outputs' largest error against f64 in wire LSBs.

use serde::Serialize;
use wheelset_control::WireLsb;
use wheelset_control::{Config, Controller, Fx, InputCodes};
use wheelset_proto::{encode_vec, Actuation, Decoder, Lateral, Message, Sensor};
use wheelset_runtime::{Runtime, RuntimeConfig};

use super::ranges::{Scenario, Tick};
use wheelset_targets::qemu::{Qemu, QemuConfig, QemuError};

/// One scenario run on the target.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TargetRun {
    /// Scenario.
    pub scenario: String,
    /// First tick of the window.
    pub from_tick: usize,
    /// Ticks exchanged.
    pub ticks: usize,
    /// Ticks whose Actuation differs between target and host in `t_psi` or `u_a`.
    pub mismatches: usize,
    /// Largest |target - host| code difference, `(T_psi dNm, u_a cV)`.
    pub max_code_diff: (i64, i64),
    /// Max |target - f64| (`T_psi`, `u_a`), wire LSBs.
    pub target_vs_f64_wire_lsb: (f64, f64),
    /// Max |host - f64|, wire LSBs.
    pub host_vs_f64_wire_lsb: (f64, f64),
    /// Mean instructions per tick on the target (QEMU icount; the whole tick).
    pub mean_exec: f64,
}

/// What became of the target comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TargetOutcome {
    /// Compared: the runs are in [`TargetReport::runs`].
    Compared,
    /// Not asked for (`--no-target`).
    Skipped,
    /// Not applicable: the firmware runs the production formats and the default
    /// configuration, which this audit does not.
    NotApplicable,
    /// Could not run here: no QEMU, no firmware image, QEMU did not start. A check not
    /// run (the verdict does not claim it).
    NotRun,
    /// Started and broke off: the firmware stopped answering or answered with something
    /// other than an Actuation frame. A failed check.
    Failed,
}

/// The target comparison, or why it is not available.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TargetReport {
    /// Whether target numbers are included.
    pub available: bool,
    /// What became of the comparison.
    pub outcome: TargetOutcome,
    /// Why not, or what was compared.
    pub note: String,
    /// Per scenario.
    pub runs: Vec<TargetRun>,
}

impl TargetReport {
    /// No target numbers: the comparison's `outcome` and why.
    #[must_use]
    pub fn without(outcome: TargetOutcome, note: impl Into<String>) -> Self {
        Self {
            available: false,
            outcome,
            note: note.into(),
            runs: Vec::new(),
        }
    }
}

fn codes(t: &Tick) -> InputCodes {
    let w = WireLsb::default();
    // Rounded, saturated (`as`); a non-finite value is 0.
    let c = |v: f64, lsb: f64| {
        Some((v / lsb).round())
            .filter(|x| x.is_finite())
            .map_or(0, |x| x as i32)
    };
    InputCodes {
        y_dot: c(t.si[0], w.y_dot),
        current: c(t.si[1], w.current),
        speed: c(t.si[2], w.speed),
        demand: c(t.si[3], w.demand),
    }
}

/// The Sensor frame of the codes `c` numbered `seq` (`t_us` = 200 `seq`, no speed reference).
pub fn sensor_frame(seq: u16, c: &InputCodes) -> Result<Vec<u8>, String> {
    let s = Sensor {
        seq,
        t_us: seq.wrapping_mul(200),
        lateral: Lateral::Velocity(c.y_dot),
        i_a_ma: c.current,
        omega_m_mrad_s: c.speed,
        demand_nm: c.demand,
        v_ref_mm_s: 0,
    };
    encode_vec(&Message::Sensor(s))
        .map(|v| v.to_vec())
        .map_err(|e| format!("{e:?}"))
}

fn decode(bytes: &[u8], dec: &mut Decoder) -> Option<Actuation> {
    let mut out = None;
    // The first Actuation; every frame is taken (the decoder carries over).
    for r in dec.messages(bytes) {
        if let (Ok(Message::Actuation(a)), None) = (r, out) {
            out = Some(a);
        }
    }
    out
}

fn not_run(note: impl core::fmt::Display) -> TargetReport {
    TargetReport::without(TargetOutcome::NotRun, format!("target: not run: {note}"))
}

/// Run `window` ticks of each scenario (from `from` seconds) on the target and the host.
/// The firmware runs the runtime's default configuration: `cfg` must equal it (wire
/// LSBs aside, which the runtime takes from the protocol).
pub fn compare(scenarios: &[(&Scenario, f64)], window: usize, cfg: &Config) -> TargetReport {
    let rc = RuntimeConfig::default();
    if (Config {
        wire: rc.control.wire,
        ..*cfg
    }) != rc.control
    {
        return TargetReport::without(
            TargetOutcome::NotApplicable,
            "target: not applicable: the firmware runs the default configuration; this \
             audit's rate, divisors or predictor differ",
        );
    }
    let qc = QemuConfig::new();
    if let Err(e) = qc.check() {
        return not_run(e);
    }
    let mut runs = Vec::new();
    for (sc, from_s) in scenarios {
        let from = (from_s * cfg.base_rate_hz as f64) as usize;
        let ticks: Vec<_> = sc.ticks.iter().skip(from).take(window).collect();
        if ticks.is_empty() {
            continue;
        }
        match run_window(&sc.name, from, &ticks, &qc, rc) {
            Ok(run) => runs.push(run),
            Err(report) => return report,
        }
    }
    let total: usize = runs.iter().map(|r| r.ticks).sum();
    let mism: usize = runs.iter().map(|r| r.mismatches).sum();
    TargetReport {
        available: true,
        outcome: TargetOutcome::Compared,
        note: format!(
            "target: QEMU mps2-an386 (Cortex-M4) running the firmware's runtime on Fx: \
             {total} ticks over {} scenario windows, {mism} Actuation frames differ from \
             the host's Runtime<Fx> on the same bytes",
            runs.len()
        ),
        runs,
    }
}

/// One scenario window on the target and the host (`Err`: the comparison not run or
/// broken off).
fn run_window(
    name: &str,
    from: usize,
    ticks: &[&Tick],
    qc: &QemuConfig,
    rc: RuntimeConfig,
) -> Result<TargetRun, TargetReport> {
    let mut q = Qemu::start(qc).map_err(not_run)?;
    let mut host = Runtime::<Fx>::try_new(rc).map_err(|e| not_run(format!("host runtime: {e}")))?;
    let f64_cfg = Config {
        wire: WireLsb::default(),
        ..rc.control
    };
    let mut fl =
        Controller::<f64>::try_new(&f64_cfg).map_err(|e| not_run(format!("f64 core: {e}")))?;
    let broke = |note: String| {
        TargetReport::without(TargetOutcome::Failed, format!("target: failed: {note}"))
    };
    let (mut dt, mut dh) = (Decoder::new(), Decoder::new());
    let mut run = TargetRun {
        scenario: name.to_string(),
        from_tick: from,
        ..TargetRun::default()
    };
    let mut exec_sum = 0.0;
    for (k, t) in ticks.iter().enumerate() {
        let c = codes(t);
        let seq = (k as u16).wrapping_add(1);
        let bytes = sensor_frame(seq, &c).map_err(|e| not_run(format!("encode: {e}")))?;
        let lost = |e: QemuError| broke(format!("scenario {name} after {k} ticks: {e}"));
        q.send(&bytes).map_err(lost)?;
        let mut tf = q.recv_frame().map_err(lost)?;
        tf.push(0);
        host.receive(&bytes);
        let hb = host.tick(0).to_vec();
        let (Some(at), Some(ah)) = (decode(&tf, &mut dt), decode(&hb, &mut dh)) else {
            return Err(broke(format!(
                "scenario {name} tick {k}: no Actuation frame"
            )));
        };
        let of = fl.tick_codes(&c);
        let d = (
            (at.t_psi_dnm as i64 - ah.t_psi_dnm as i64).abs(),
            (at.u_a_cv as i64 - ah.u_a_cv as i64).abs(),
        );
        if d != (0, 0) {
            run.mismatches += 1;
        }
        let m = &mut run.max_code_diff;
        *m = (m.0.max(d.0), m.1.max(d.1));
        for (m, a) in [
            (&mut run.target_vs_f64_wire_lsb, &at),
            (&mut run.host_vs_f64_wire_lsb, &ah),
        ] {
            let e = |x: i32, y: i32| (f64::from(x) - f64::from(y)).abs();
            *m = (
                m.0.max(e(a.t_psi_dnm, of.yaw_torque)),
                m.1.max(e(a.u_a_cv, of.voltage)),
            );
        }
        if k > 0 {
            exec_sum += at.exec as f64;
        }
        run.ticks += 1;
    }
    run.mean_exec = exec_sum / (run.ticks.max(2) - 1) as f64;
    Ok(run)
}

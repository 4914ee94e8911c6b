//! Closed-loop scenarios from the plant simulator: the f64 reference controller runs the
//! wheelset (sim-host's nonlinear plant, RK4) on the `curve` and `beating` tracks, and
//! on `curve` with link faults; the controller's inputs and events are recorded tick by
//! tick and replayed through the fixed-point and f64 controllers ([`super::ranges`]).
//!
//! Fault runs apply the runtime's hold policy (`wheelset_runtime::HoldPolicy`): a missing
//! frame holds the last valid inputs, then the safe state until the next valid frame; the
//! recorded inputs include the wheelset's response to the safe state.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use wheelset_control::{Config, Controller, Inputs};
use wheelset_loop::drive::drive;
use wheelset_plant::control::{Actuation, Measurements, SampledController, YawLaw};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario as Track;
use wheelset_runtime::{HoldPolicy, SafeChange, DEFAULT_HOLD_TICKS};

use super::ranges::{Event, Scenario, Tick};

/// Which frames are lost.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Faults {
    None,
    /// One outage `[from, to)` seconds.
    Outage(f64, f64),
    /// Each frame lost independently with this probability (deterministic generator).
    Drops(f64),
}

struct Recorder {
    ctrl: Controller<f64>,
    cfg: Config,
    period_ns: u64,
    faults: Faults,
    rng: Pcg64,
    held: [f64; 4],
    hold: HoldPolicy,
    /// The latest tick's record.
    tick: Tick,
    steps: u64,
    frames_lost: u64,
    safe_entries: u64,
}

impl Recorder {
    fn lost(&mut self, t_ns: u64) -> bool {
        let t = t_ns as f64 * 1e-9;
        match self.faults {
            Faults::None => false,
            Faults::Outage(a, b) => t >= a && t < b,
            Faults::Drops(p) => self.rng.random::<f64>() < p,
        }
    }
}

impl SampledController for Recorder {
    fn period_ns(&self) -> u64 {
        self.period_ns
    }

    fn step(&mut self, t_ns: u64, m: &Measurements) -> Actuation {
        let sampled = self.steps > 0;
        let fresh = !self.lost(t_ns) || !sampled;
        self.steps += 1;
        let h = self.hold.step(fresh, sampled, DEFAULT_HOLD_TICKS, false);
        if fresh {
            self.held = [m.yd_mps, m.i_a, m.w_m, m.demand_nm];
        }
        self.frames_lost += u64::from(h.holding);
        let event = h.change.map(|c| Event::Safe(c == SafeChange::Enter));
        if let Some(Event::Safe(b)) = event {
            self.safe_entries += u64::from(b);
            self.ctrl.set_safe(b);
        }
        let si = self.held;
        self.tick = Tick { si, event };
        let s = self.cfg.scales;
        let o = self
            .ctrl
            .tick(&Inputs::<f64>::from_si(&s, si[0], si[1], si[2], si[3]));
        let (t_psi, u_a) = o.to_si(&s);
        Actuation { t_psi, u_a }
    }
}

/// Run one closed loop; `Err` says why it could not run.
fn record(
    cfg: &Config,
    params: &Params,
    track: &str,
    faults: Faults,
    name: &str,
) -> Result<Scenario, String> {
    let mut sc = Track::load(track, params).map_err(|e| e.to_string())?;
    let unstable = (!sc.laws.is_empty() && !sc.laws.contains(&YawLaw::Lead)).then(|| {
        format!(
            "track `{track}` is meant for the {} law(s), not the lead under audit (the lead \
             destabilises it)",
            sc.laws
                .iter()
                .map(|l| l.name())
                .collect::<Vec<_>>()
                .join(", ")
        )
    });
    let period_ns = 1_000_000_000u64 / cfg.base_rate_hz as u64;
    if period_ns * cfg.base_rate_hz as u64 != 1_000_000_000 {
        return Err(format!(
            "base period of {} Hz is not a whole number of ns",
            cfg.base_rate_hz
        ));
    }
    if !period_ns.is_multiple_of(sc.dt_ns) {
        let dt = num_integer::gcd(period_ns, sc.dt_ns);
        if dt < 10_000 || !sc.output_dt_ns.is_multiple_of(dt) {
            return Err(format!(
                "the control period {period_ns} ns does not fit the plant step {} ns",
                sc.dt_ns
            ));
        }
        sc.dt_ns = dt;
    }
    let ctrl = Controller::<f64>::try_new(cfg).map_err(|e| e.to_string())?;
    let mut rec = Recorder {
        ctrl,
        cfg: *cfg,
        period_ns,
        faults,
        rng: Pcg64::seed_from_u64(0x00fa_0175),
        held: [0.0; 4],
        hold: HoldPolicy::default(),
        tick: Tick::default(),
        steps: 0,
        frames_lost: 0,
        safe_entries: 0,
    };
    // One period of computation/transport delay, as the device loop runs.
    let mut ticks = Vec::new();
    drive(&sc, &mut rec, 1, false, "f64 reference", |r, _, _| {
        ticks.push(r.tick);
    })
    .map_err(|e| e.to_string())?;
    if let Some(k) = ticks
        .iter()
        .position(|t| t.si.iter().any(|v| !v.is_finite()))
    {
        return Err(format!(
            "the closed loop diverged (non-finite measurement at t = {:.4} s)",
            k as f64 * period_ns as f64 * 1e-9
        ));
    }
    let fault_note = match faults {
        Faults::None => String::new(),
        _ => format!(
            "; {} frames lost, {} safe-state entries (hold {DEFAULT_HOLD_TICKS} ticks, then safe, \
             recover on the next valid frame)",
            rec.frames_lost, rec.safe_entries
        ),
    };
    Ok(Scenario {
        unstable,
        name: name.to_string(),
        source: format!(
            "closed loop: sim-host plant, track `{track}`, f64 controller (yaw lead, \
             traction on), one period of actuation delay, controller inputs recorded{}{fault_note}",
            match faults {
                Faults::None => String::new(),
                Faults::Outage(a, b) => format!("; link outage {a} s .. {b} s"),
                Faults::Drops(p) => format!("; random frame loss p = {p}"),
            }
        ),
        ticks,
    })
}

/// The closed-loop scenarios (`curve`, `beating`, `curve` with a 30 ms outage at 6 s, with
/// 2 % random frame loss) and a note per scenario that could not run.
pub fn scenarios(cfg: &Config, params: &Params) -> (Vec<Scenario>, Vec<String>) {
    let mut cfg = *cfg;
    cfg.yaw_mode = wheelset_control::YawMode::Lead;
    cfg.traction_enabled = true;
    let runs = [
        ("curve", Faults::None, "curve"),
        ("beating", Faults::None, "beating"),
        ("curve", Faults::Outage(6.0, 6.03), "fault_outage"),
        ("curve", Faults::Drops(0.02), "fault_drops"),
    ];
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for (track, f, name) in runs {
        match record(&cfg, params, track, f, name) {
            Ok(s) => {
                if let Some(why) = &s.unstable {
                    notes.push(format!(
                        "scenario {name}: unstable with the lead ({why}); left out of the \
                         ranges, kept for the noise figures"
                    ));
                }
                out.push(s)
            }
            Err(e) => notes.push(format!("scenario {name}: not run: {e}")),
        }
    }
    (out, notes)
}

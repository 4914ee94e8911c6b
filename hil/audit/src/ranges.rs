//! Ranges, headroom and quantisation noise over input [`Scenario`]s: the fixed-point
//! controller and the f64 reference run in lock-step on the *same* inputs (the f64 one gets
//! the fixed-point inputs exactly, so only arithmetic and coefficient quantisation count).
//! After every tick the observer rebuilds each intermediate signal of the lead and the PI
//! in f64 from the fixed-point states and the quantised coefficients (exact up to one LSB
//! of rounding), *before* any saturation: a value outside the signal format's range is an
//! overflow, counted per signal.

use serde::Serialize;
use wheelset_control::{Config, Controller, Inputs, Sample, YawMode};

use super::qdyn::QFormat;

pub use super::scenarios::synthetic;

mod accumulate;
use accumulate::Acc;

/// A scenario event applied before a tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// Enter (`true`) or leave the safe state.
    Safe(bool),
    /// Traction loop on/off.
    Traction(bool),
}

/// One base tick of a scenario: inputs in SI units (m/s, A, rad/s, N m), and an event.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tick {
    /// `[y', i_a, omega_m, demand]`, SI.
    pub si: [f64; 4],
    /// Event applied before this tick.
    pub event: Option<Event>,
}

/// A named input sequence at the configuration's base rate.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// Name (`curve`, `beating`, `fault_outage`, `full_scale_steps`, ...).
    pub name: String,
    /// Where it comes from (closed-loop plant run, synthetic, ...).
    pub source: String,
    /// The ticks.
    pub ticks: Vec<Tick>,
    /// Why this run is not stable with the law under audit (e.g. the `beating` track
    /// is meant for the passive law: the lead destabilises its high-frequency mode and
    /// sits at the torque limit); such a run is left out of the ranges, and named.
    pub unstable: Option<String>,
}

/// Index of each observed signal in [`Observed::signals`].
enum Sig {
    YDot,
    PredDiff,
    PredRaw,
    LeadSum,
    LeadErr,
    LeadZ,
    LeadX1,
    LeadDiff,
    YawRaw,
    YawOut,
    Current,
    Demand,
    IrefTarget,
    Iref,
    PiErr,
    PiProp,
    PiIntegPre,
    PiInteg,
    PiRaw,
    Voltage,
    BackEmf,
}

/// `(name, full scale selector, is a state)`.
const SIGNALS: [(&str, Fs, bool); 21] = [
    ("y_dot (clamped input)", Fs::YDot, false),
    ("predictor y' - y'[n-1]", Fs::YDot, false),
    ("predictor y' + 2d (before clamp)", Fs::YDot, false),
    ("lead x + x1", Fs::YDot, false),
    ("lead (g/2)(x + x1) - z", Fs::YDot, false),
    ("lead z (state)", Fs::YDot, true),
    ("lead x1 (state)", Fs::YDot, true),
    ("lead x - z", Fs::YDot, false),
    ("T_psi before limit", Fs::Torque, false),
    ("T_psi (output)", Fs::Torque, false),
    ("i_a (clamped input)", Fs::Current, false),
    ("demand (clamped input)", Fs::Demand, false),
    ("i_ref target", Fs::Current, false),
    ("i_ref (ramped, state)", Fs::Current, true),
    ("e = i_ref - i_a", Fs::Current, false),
    ("PI Kp e", Fs::Voltage, false),
    ("PI I + Ki e (before clamp)", Fs::Voltage, false),
    ("PI I (state)", Fs::Voltage, true),
    ("PI Kp e + I (before limit)", Fs::Voltage, false),
    ("u_a (output)", Fs::Voltage, false),
    ("back-EMF preset K_m omega", Fs::Voltage, false),
];

/// A signal's full scale in [`Config::scales`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Fs {
    YDot,
    Torque,
    Current,
    Demand,
    Voltage,
}

impl Fs {
    /// The controller of the signal `name` on this full scale: the lead's (`lead ...`),
    /// the yaw loop's or the PI's.
    pub(crate) fn controller(self, name: &str) -> &'static str {
        match self {
            _ if name.starts_with("lead ") => "yaw_lead",
            Fs::YDot | Fs::Torque => "yaw",
            _ => "traction_pi",
        }
    }
}

/// The full scale (SI per pu) and SI unit of `f`.
pub(crate) fn fs_of(f: Fs, c: &Config) -> (f64, &'static str) {
    let s = &c.scales;
    match f {
        Fs::YDot => (s.y_dot, "m/s"),
        Fs::Torque => (s.torque, "N m"),
        Fs::Current => (s.current, "A"),
        Fs::Demand => (s.demand, "N m"),
        Fs::Voltage => (s.voltage, "V"),
    }
}

/// Range of one signal or state over the scenarios.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SignalRange {
    /// Signal name.
    pub name: String,
    /// Which controller it belongs to (`yaw` = lead and gain paths).
    pub controller: String,
    /// Whether it is a filter state.
    pub state: bool,
    /// SI unit.
    pub unit: String,
    /// SI per pu.
    pub full_scale: f64,
    /// Minimum, pu.
    pub min_pu: f64,
    /// Maximum, pu.
    pub max_pu: f64,
    /// Minimum, SI.
    pub min_si: f64,
    /// Maximum, SI.
    pub max_si: f64,
    /// Scenario in which the largest magnitude occurred.
    pub worst_scenario: String,
    /// `log2(range / max|v|)`, bits (infinite when the signal stayed 0).
    pub headroom_bits: f64,
    /// Samples outside the signal format's range (would saturate).
    pub overflows: u64,
    /// Samples observed.
    pub samples: u64,
}

impl SignalRange {
    /// The largest magnitude, pu.
    pub fn peak(&self) -> f64 {
        self.min_pu.abs().max(self.max_pu.abs())
    }
}

/// Quantisation noise of one output over a scenario: fixed minus f64 on the same inputs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Noise {
    /// Output name (`T_psi` or `u_a`).
    pub output: String,
    /// Scenario.
    pub scenario: String,
    /// Yaw mode of the run (`lead`, `gain`).
    pub yaw_mode: String,
    /// Normal operation, or the safe-state ramps.
    pub phase: Phase,
    /// Max |error| as a fraction of the output's limit.
    pub max_of_limit: f64,
    /// Max |error|, LSB of the signal format.
    pub max_lsb: f64,
    /// RMS error, LSB.
    pub rms_lsb: f64,
    /// Max |error|, SI.
    pub max_si: f64,
    /// RMS error, SI.
    pub rms_si: f64,
    /// Max |error| in wire LSBs of the output (the protocol's resolution).
    pub max_wire_lsb: f64,
    /// `log2(max |error| / LSB)` (bits of the word lost to noise; 0 if <= 1 LSB).
    pub bits_lost: f64,
    /// SI unit.
    pub unit: String,
    /// Samples.
    pub samples: u64,
}

/// Which ticks a [`Noise`] figure covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Outside the safe state and its ramp back.
    Normal,
    /// In the safe state or ramping back out of it: the ramps' quantised per-step
    /// increments accumulate over the ramp (a timing error of the profile).
    SafeRamp,
}

impl Phase {
    /// The phase in words: `normal running` or `safe-state ramps`.
    #[must_use]
    pub fn words(self) -> &'static str {
        match self {
            Phase::Normal => "normal running",
            Phase::SafeRamp => "safe-state ramps",
        }
    }
}

/// Designed clamps counted by the controller (not overflows).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Clamps {
    /// Input y' clamps.
    pub y_dot: u64,
    /// Input current clamps.
    pub current: u64,
    /// Input speed clamps.
    pub speed: u64,
    /// Input demand clamps.
    pub demand: u64,
    /// Output torque limit.
    pub yaw_torque: u64,
    /// Output voltage limit.
    pub voltage: u64,
    /// Integrator anti-windup clamps.
    pub integrator: u64,
}

/// `(t_s, T_psi error N m, u_a error V)`.
pub type ErrSample = (f64, f64, f64);

/// Everything observed over a set of scenarios with one sample type.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Observed {
    /// Per-signal ranges.
    pub signals: Vec<SignalRange>,
    /// Noise per (scenario, yaw mode, output).
    pub noise: Vec<Noise>,
    /// Designed clamps, summed over the runs.
    pub clamps: Clamps,
    /// Saturations counted inside the arithmetic by [`super::qdyn::QDyn`] (`None` for
    /// the production type, whose saturations are inferred from `overflows`).
    pub arithmetic_saturations: Option<u64>,
    /// Per scenario: `(t_s, T_psi error N m, u_a error V)` decimated, for the plots.
    pub traces: Vec<(String, Vec<ErrSample>)>,
}

/// Quantise an input; a non-finite one becomes 0 (`Fx::from_f64` panics on NaN).
pub(crate) fn q<T: Sample>(v: f64) -> T {
    T::from_f64(if v.is_finite() { v } else { 0.0 })
}

/// Run every scenario twice (yaw mode lead, then gain; traction on) with sample type
/// `T` (signal format `fmt`) against f64 built from `reference(cfg)` (`cfg` itself but in
/// the attribution experiments of [`super::diagnose`]: a reference that holds a quantised
/// constant removes that constant's quantisation from the error), collecting ranges,
/// overflows and noise.
pub fn observe<T: Sample>(
    base: &Config,
    scenarios: &[Scenario],
    fmt: QFormat,
    reference: &dyn Fn(&Config) -> Config,
) -> Result<Observed, wheelset_control::ConfigError> {
    let mut sig: Vec<SignalRange> = SIGNALS
        .iter()
        .map(|&(n, f, state)| {
            let (full_scale, unit) = fs_of(f, base);
            SignalRange {
                name: n.to_string(),
                controller: f.controller(n).to_string(),
                state,
                unit: unit.to_string(),
                full_scale,
                ..SignalRange::default()
            }
        })
        .collect();
    let mut noise = Vec::new();
    let mut clamps = Clamps::default();
    let mut traces = Vec::new();
    let range = fmt.range();
    let lsb = fmt.lsb();
    for sc in scenarios {
        for mode in [YawMode::Lead, YawMode::Gain] {
            let mut cfg = *base;
            cfg.yaw_mode = mode;
            cfg.traction_enabled = true;
            let mut fx = Controller::<T>::try_new(&cfg)?;
            let mut fl = Controller::<f64>::try_new(&reference(&cfg))?;
            let s = cfg.scales;
            let l = cfg.limits;
            let lead = fx.compiled().lead().quantised();
            let pi = fx.compiled().pi().quantised();
            let k_gain = T::quantise(cfg.gain_k * s.y_dot / s.torque)
                .map(T::coeff_to_f64)
                .unwrap_or(0.0);
            let d2i = s.demand / (cfg.motor.n * cfg.motor.k_m * s.current);
            let bemf = cfg.motor.k_m * s.speed / s.voltage;
            // Per output (T_psi, u_a): normal ticks, then those in the safe state or its ramp
            // back (the ramps' steps accumulate), judged apart.
            let mut acc: [[Acc; 2]; 2] = Default::default();
            let mut in_safe = false;
            let ramp_ticks = ((cfg.safe.yaw_s.max(cfg.safe.traction_s)) * cfg.base_rate_hz as f64)
                .ceil() as usize
                + 2;
            let mut ramp_end = 0usize;
            let mut trace = Vec::new();
            let dec = (sc.ticks.len() / 2000).max(1);
            // Mirrors the controller's bumpless-start flag: the first traction step
            // after (re)enabling presets the integrator to the back-EMF.
            let mut armed = false;
            // The y' predictor's previous sample and factor (0 when off).
            let mut y_prev = 0.0f64;
            let alpha = cfg.yaw_predict_ticks / cfg.yaw_divisor as f64;
            let base_t = cfg.base_period();
            for (n, t) in sc.ticks.iter().enumerate() {
                match t.event {
                    Some(Event::Safe(b)) => {
                        fx.set_safe(b);
                        fl.set_safe(b);
                        if in_safe && !b {
                            ramp_end = n + ramp_ticks;
                        }
                        in_safe = b;
                    }
                    Some(Event::Traction(b)) => {
                        fx.set_traction(b);
                        fl.set_traction(b);
                        armed = false;
                    }
                    None => {}
                }
                let [y, i, w, d] = t.si.map(|v| if v.is_finite() { v } else { 0.0 });
                let inp = Inputs::<T>::from_si(&s, y, i, w, d);
                let inf = Inputs::<f64> {
                    y_dot: inp.y_dot.to_f64(),
                    current: inp.current.to_f64(),
                    speed: inp.speed.to_f64(),
                    demand: inp.demand.to_f64(),
                };
                let ls0 = *fx.lead_state();
                let ps0 = *fx.pi_state();
                let c0 = *fx.counters();
                let o = fx.tick(&inp);
                let of = fl.tick(&inf);
                let c1 = *fx.counters();
                let stable = sc.unstable.is_none();
                let mut put = |i: Sig, v: f64| {
                    if !stable {
                        return;
                    }
                    let r = &mut sig[i as usize];
                    r.samples += 1;
                    if v < r.min_pu {
                        r.min_pu = v;
                    }
                    if v > r.max_pu {
                        r.max_pu = v;
                    }
                    if v.abs() >= r.peak() && v != 0.0 {
                        r.worst_scenario = sc.name.clone();
                    }
                    if v >= range || v < -range {
                        r.overflows += 1;
                    }
                };
                if c1.yaw_steps != c0.yaw_steps {
                    let ym = l.y_dot / s.y_dot;
                    let x = inf.y_dot.clamp(-ym, ym);
                    let xr = x + alpha * (x - y_prev);
                    let xp = xr.clamp(-2.0, 2.0);
                    put(Sig::YDot, x);
                    put(Sig::PredDiff, x - y_prev);
                    put(Sig::PredRaw, xr);
                    y_prev = x;
                    let raw = match mode {
                        YawMode::Lead => {
                            let ls1 = *fx.lead_state();
                            // The lead's input as it ran (after the predictor): the state keeps it.
                            let x = ls1.x1.to_f64();
                            let m = x + ls0.x1.to_f64();
                            put(Sig::LeadSum, m);
                            put(Sig::LeadErr, m * lead.g_half - ls0.z.to_f64());
                            put(Sig::LeadZ, ls1.z.to_f64());
                            put(Sig::LeadX1, ls1.x1.to_f64());
                            let d = x - ls1.z.to_f64();
                            put(Sig::LeadDiff, d);
                            d * lead.k_hf
                        }
                        YawMode::Gain => xp * k_gain,
                        YawMode::Passive => 0.0,
                    };
                    put(Sig::YawRaw, raw);
                    put(Sig::YawOut, o.yaw_torque.to_f64());
                }
                if c1.traction_steps != c0.traction_steps && fx.traction_enabled() {
                    let im = l.current / s.current;
                    let i = inf.current.clamp(-im, im);
                    let dm = l.demand / s.demand;
                    let d = inf.demand.clamp(-dm, dm);
                    put(Sig::Current, i);
                    put(Sig::Demand, d);
                    put(Sig::IrefTarget, d * d2i);
                    let iref = fx.current_ref().to_f64();
                    put(Sig::Iref, iref);
                    let e = iref - i;
                    put(Sig::PiErr, e);
                    put(Sig::PiProp, e * pi.kp);
                    let integ = fx.pi_state().integ.to_f64();
                    if armed {
                        put(Sig::PiIntegPre, ps0.integ.to_f64() + e * pi.ki);
                    } else {
                        let sm = l.speed / s.speed;
                        put(Sig::BackEmf, inf.speed.clamp(-sm, sm) * bemf);
                        armed = true;
                    }
                    put(Sig::PiInteg, integ);
                    put(Sig::PiRaw, e * pi.kp + integ);
                    put(Sig::Voltage, o.voltage.to_f64());
                }
                let dy = o.yaw_torque.to_f64() - of.yaw_torque;
                let du = o.voltage.to_f64() - of.voltage;
                let ramp = usize::from(in_safe || n < ramp_end);
                acc[0][ramp].add(dy);
                acc[1][ramp].add(du);
                if mode == YawMode::Lead && n % dec == 0 {
                    trace.push((n as f64 * base_t, dy * s.torque, du * s.voltage));
                }
            }
            let c = fx.counters();
            clamps.y_dot += c.y_dot.clamped as u64;
            clamps.current += c.current.clamped as u64;
            clamps.speed += c.speed.clamped as u64;
            clamps.demand += c.demand.clamped as u64;
            clamps.yaw_torque += c.yaw_torque.clamped as u64;
            clamps.voltage += c.voltage.clamped as u64;
            clamps.integrator += c.integrator.clamped as u64;
            let mname = if mode == YawMode::Lead {
                "lead"
            } else {
                "gain"
            };
            let mut push = |out, accs: &[Acc; 2], (fs, wire, limit), unit| {
                for (acc, phase) in accs.iter().zip([Phase::Normal, Phase::SafeRamp]) {
                    if acc.n > 0 {
                        let n = acc.noise(out, &sc.name, mname, phase, lsb, fs, wire, limit, unit);
                        noise.push(n);
                    }
                }
            };
            push(
                "T_psi",
                &acc[0],
                (s.torque, cfg.wire.torque, l.torque),
                "N m",
            );
            // u_a once per scenario: from the lead run.
            if mode == YawMode::Lead {
                let v_limit = l.voltage_max.abs().max(l.voltage_min.abs());
                push("u_a", &acc[1], (s.voltage, cfg.wire.voltage, v_limit), "V");
                traces.push((sc.name.clone(), trace));
            }
        }
    }
    for r in &mut sig {
        r.min_si = r.min_pu * r.full_scale;
        r.max_si = r.max_pu * r.full_scale;
        let p = r.peak();
        r.headroom_bits = if p > 0.0 {
            (range / p).log2()
        } else {
            f64::INFINITY
        };
    }
    Ok(Observed {
        signals: sig,
        noise,
        clamps,
        arithmetic_saturations: None,
        traces,
    })
}

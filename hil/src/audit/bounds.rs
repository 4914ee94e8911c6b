//! Proven ranges and rounding-error bounds of the control core, from the coefficients as
//! the device holds them (quantised), next to what the scenarios observed.
//!
//! # Ranges (no overflow for any input within the clamps)
//!
//! All in per unit (pu); `q` is the signal LSB (`2^-28` for Q4.28). The inputs are
//! clamped first: `|y'| <= Y`, `|i_a| <= I`, `|demand| <= Dm`, `|omega| <= S`.
//!
//! - **Predictor** (interval arithmetic): `y' - y'[n-1]` in `[-2Y, 2Y]` (exact);
//!   `d = round((y' - y'[n-1]) p)` with `p = predict_half`, so `|y' + 2d| <= Y(1 + 4|p|) + q`
//!   before the clamp to `+-P` (2 pu); the lead's input is `|x| <= X = min(P, that)`
//!   (`X = Y` exactly when the predictor is off, `p = 0`).
//! - **Lead** (linear; WCPG, [`super::wcpg`]): state `s[n] = (z[n-1], x[n-1])`,
//!   `a = 1 - kappa`, `h = kappa g/2` (quantised coefficients, exact arithmetic):
//!
//!   ```text
//!   s[n+1] = [[a, h], [0, 0]] s[n] + [h, 1] x[n]
//!   x + x1 = [0, 1] s + 1 x          e = (g/2)(x + x1) - z = [-1, g/2] s + (g/2) x
//!   z[n]   = [a, h] s + h x          x - z[n] = [-a, -h] s + (1 - h) x,   y = K_hf (x - z)
//!   ```
//!
//!   Each signal's exact value is at most `WCPG X`; the fixed-point value differs from
//!   it by at most its rounding-error bound (below), so `proven = WCPG X + error`. The
//!   bumpless start from the steady state of a held input is the response to an input
//!   held forever (within the bound), plus one rounding of `z`, `q/2`, decaying.
//! - **Gain**: `|round(x k)| <= |k| X + q/2`. A law change slews the output between the
//!   old output and the new law's (`|.| <= max(T_max, raw)`); the limit gives `T_max`.
//! - **Traction** (interval arithmetic): target `round(d d2i)`, `|.| <= Dm |d2i| + q/2`;
//!   the ramp moves `i_ref` towards the target by at most one step, so it stays in the
//!   hull of 0 and the targets; the wheel-slip protection only lowers it to a cap in
//!   `[0, i_ref]` ([`wheelset_control::wsp`]); `|e| <= Iref + I`; `|round(Kp e)| <=
//!   |Kp| E + q/2`; the integrator's increment is floored with its remainder carried,
//!   `|.| <= |Ki| E + q`; the integrator is clamped to `[u_min, u_max]` (anti-windup),
//!   so its pre-clamp value is at most `U + |Ki| E + q` and the PI sum `|Kp| E + q/2 +
//!   U`; the output is limited to `U`. The PI's linear part is not BIBO (pole `z = 1`):
//!   only the anti-windup clamp bounds it.
//!
//! # Rounding-error bounds (fixed point vs exact arithmetic on the same quantised
//! coefficients and the same inputs)
//!
//! Every product is rounded to nearest (`|r| <= q/2`); the integrator's increment is
//! floored with error feedback. The error of each signal is a linear filter of the
//! rounding errors (the saturations never act: the ranges above are inside the format):
//!
//! - Lead: `r1` at `(g/2)(x + x1)`, `r2` at `kappa e`, `r3` at `K_hf (x - z)`;
//!   `dz[n] = a dz[n-1] + kappa r1 + r2`, so `|dz| <= W(r1->z) q/2 + W(r2->z) q/2 + q/2`
//!   (WCPGs `1` and `1/kappa`; the last term the bumpless start), `|dy| <= K_hf |dz| + q/2`.
//!   The predictor's rounding `r_p` enters the lead's input twice: `|dx| <= q`, and
//!   adds `W(x->y) q` to the torque.
//! - PI, given its input `e`: `|du| <= q/2 (Kp e) + q (integrator)`. The integrator
//!   bound is an invariant: with `rho` the carried remainder in `[0, q)`, `eps = dI +
//!   rho` stays in `[0, q)` through every step (unclamped: unchanged; clamped: the
//!   clamp is monotone and non-expansive, so `eps` lands between `rho` and its old value).
//! - The reference: the target's rounding (`q/2`) passes through the ramp unchanged in
//!   size (the ramp is monotone in both arguments and commutes with a common shift), so
//!   `|d i_ref| <= q/2`. Open loop, the PI integrates that offset without bound; closed
//!   loop the current loop absorbs it: stated, not bounded here.

use serde::Serialize;
use wheelset_control::{Config, ConfigError, Controller, Lead, LeadPu, Pi, PiState, Sample};

use super::qdyn::QFormat;
use super::ranges::{Observed, Scenario};
use super::wcpg::{wcpg, Siso, Wcpg};

/// One signal's observed and proven magnitude (the issue's record, extended).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Bound {
    /// Signal name (as in the ranges table; predictor and intermediates added).
    pub signal: String,
    /// Controller.
    pub controller: String,
    /// SI unit of the magnitudes.
    pub unit: String,
    /// Largest |value| observed over the scenarios, SI (`null`: not observed).
    pub observed_max: Option<f64>,
    /// Proven largest |value| for any input within the clamps, SI.
    pub proven_max: f64,
    /// The audited signal format.
    pub format: String,
    /// `log2(format range / proven_max)`, bits (negative: the proof does not exclude
    /// an overflow).
    pub margin_bits: f64,
    /// How it is proven.
    pub proof: String,
}

/// One output's rounding error: observed and proven, against exact arithmetic on the
/// same quantised coefficients and inputs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorBound {
    /// Output (`T_psi (lead)`, `T_psi (gain)`, `u_a (PI)`, `i_ref`).
    pub output: String,
    /// Largest |fixed - exact| observed over the scenarios.
    pub observed: f64,
    /// Proven bound.
    pub proven: f64,
    /// Unit of `observed` and `proven`.
    pub unit: String,
    /// The proven bound in wire LSBs of the output.
    pub proven_wire_lsb: f64,
    /// Per rounding point: `(where, contribution in unit)`.
    pub rounding_points: Vec<(String, f64)>,
}

/// The WCPG of one linear part, input -> output.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LinearPart {
    /// Part (`lead`, `PI`, `y'' integrator`, lead rounding-error filters).
    pub part: String,
    /// Input -> output.
    pub path: String,
    /// The WCPG (`null`: infinite, e.g. an integrator).
    pub wcpg: Option<Wcpg>,
    /// What it means.
    pub note: String,
}

/// A format proposal from the bounds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Proposal {
    /// Signal.
    pub signal: String,
    /// Proven |max|, pu.
    pub proven_max_pu: f64,
    /// Integer bits incl. sign: the smallest with `2^(i-1) > proven_max_pu`.
    pub int_bits: u32,
    /// Fraction bits: the smallest meeting the output-error budget of its chain.
    pub frac_bits: u32,
    /// `Qi.f`.
    pub format: String,
    /// What the proposal guarantees.
    pub guarantee: String,
}

/// Everything proven.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Proofs {
    /// Per signal.
    pub bounds: Vec<Bound>,
    /// Per output.
    pub error_bounds: Vec<ErrorBound>,
    /// The linear parts' WCPGs.
    pub linear_parts: Vec<LinearPart>,
    /// Format proposals from the bounds.
    pub proposals: Vec<Proposal>,
    /// The stated result.
    pub statement: String,
    /// Whether every proven bound lies inside the audited format.
    pub overflow_free: bool,
}

/// The quantised constants of the core, pu (exact values of what `T` holds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantised {
    /// Lead coefficients.
    pub lead: LeadPu,
    /// Gain law coefficient.
    pub gain: f64,
    /// PI `Kp`, `Ki`.
    pub kp: f64,
    /// PI `Ki` per step.
    pub ki: f64,
    /// Voltage limits.
    pub u_min: f64,
    /// Voltage limits.
    pub u_max: f64,
    /// demand -> current reference.
    pub d2i: f64,
    /// back-EMF constant.
    pub bemf: f64,
    /// Predictor half factor.
    pub ph: f64,
    /// Input clamps `y'`, current, speed, demand; torque limit; predictor clamp.
    pub y_max: f64,
    /// Current clamp.
    pub i_max: f64,
    /// Speed clamp.
    pub s_max: f64,
    /// Demand clamp.
    pub d_max: f64,
    /// Torque limit.
    pub t_max: f64,
    /// Predicted y' clamp.
    pub p_max: f64,
    /// Torque ramp step.
    pub t_step: f64,
    /// Current reference steps (normal, safe).
    pub i_step: f64,
    /// Safe-state current reference step.
    pub i_safe_step: f64,
}

fn qc<T: Sample>(name: &'static str, v: f64) -> Result<f64, ConfigError> {
    T::quantise(v)
        .map(T::coeff_to_f64)
        .ok_or(ConfigError::Coefficient { name, value: v })
}

fn qs<T: Sample>(v: f64) -> f64 {
    T::from_f64(v).to_f64()
}

impl Quantised {
    /// What `T` holds for `cfg` (the same expressions as the control core's compile
    /// step, read back exactly).
    pub fn of<T: Sample>(cfg: &Config) -> Result<Self, ConfigError> {
        let c = Controller::<T>::try_new(cfg)?;
        let s = &cfg.scales;
        let l = &cfg.limits;
        let pi = c.pi().quantised();
        let iref_max = l.demand / (cfg.motor.n * cfg.motor.k_m) / s.current;
        Ok(Self {
            lead: c.lead().quantised(),
            gain: qc::<T>("gain", cfg.gain_k * s.y_dot / s.torque)?,
            kp: pi.kp,
            ki: pi.ki,
            u_min: c.pi().u_min.to_f64(),
            u_max: c.pi().u_max.to_f64(),
            d2i: qc::<T>(
                "demand_to_iref",
                s.demand / (cfg.motor.n * cfg.motor.k_m * s.current),
            )?,
            bemf: qc::<T>("back_emf", cfg.motor.k_m * s.speed / s.voltage)?,
            ph: qc::<T>(
                "predict_half",
                cfg.yaw_predict_ticks / (2.0 * cfg.yaw_divisor as f64),
            )?,
            y_max: qs::<T>(l.y_dot / s.y_dot),
            i_max: qs::<T>(l.current / s.current),
            s_max: qs::<T>(l.speed / s.speed),
            d_max: qs::<T>(l.demand / s.demand),
            t_max: qs::<T>(l.torque / s.torque),
            p_max: qs::<T>(wheelset_control::config::MAX_LIMIT_PU),
            t_step: qs::<T>(l.torque / s.torque * cfg.yaw_period() / cfg.safe.yaw_s),
            i_step: qs::<T>(l.current_ref_rate * cfg.traction_period() / s.current),
            i_safe_step: qs::<T>(iref_max * cfg.traction_period() / cfg.safe.traction_s),
        })
    }
}

/// The lead's signal systems (input `x`), in the order m, e, z, x1, x - z.
pub fn lead_systems(l: &LeadPu) -> [(&'static str, Siso); 5] {
    let a = 1.0 - l.kappa;
    let h = l.kappa * l.g_half;
    let sys = |c: [f64; 2], d: f64| Siso {
        a: vec![vec![a, h], vec![0.0, 0.0]],
        b: vec![h, 1.0],
        c: c.to_vec(),
        d,
    };
    [
        ("lead x + x1", sys([0.0, 1.0], 1.0)),
        ("lead (g/2)(x + x1) - z", sys([-1.0, l.g_half], l.g_half)),
        ("lead z (state)", sys([a, h], h)),
        ("lead x1 (state)", sys([0.0, 0.0], 1.0)),
        ("lead x - z", sys([-a, -h], 1.0 - h)),
    ]
}

/// The lead's rounding-error filters: `(r1 -> dz[n], r2 -> dz[n], r1 -> de, r2 -> de)`.
pub fn lead_error_systems(l: &LeadPu) -> [Siso; 4] {
    let a = 1.0 - l.kappa;
    let one = |b: f64, c: f64, d: f64| Siso {
        a: vec![vec![a]],
        b: vec![b],
        c: vec![c],
        d,
    };
    [
        one(l.kappa, a, l.kappa),
        one(1.0, a, 1.0),
        one(l.kappa, -1.0, 1.0),
        one(1.0, -1.0, 0.0),
    ]
}

/// The proven quantities in pu (used by [`prove`] and the tests).
#[derive(Clone, Debug, PartialEq)]
pub struct Proven {
    /// Lead input bound `X`.
    pub x: f64,
    /// `(signal, controller, SI unit, full scale, proven pu, proof)`.
    pub signals: Vec<(String, String, String, f64, f64, String)>,
    /// Lead output error bound (pu of torque), with the predictor.
    pub lead_err: f64,
    /// Per rounding point, pu of torque.
    pub lead_err_points: Vec<(String, f64)>,
    /// Gain output error bound, pu.
    pub gain_err: f64,
    /// PI output error given `e`, pu.
    pub pi_err: f64,
    /// Reference error, pu of current.
    pub iref_err: f64,
    /// Linear parts.
    pub parts: Vec<LinearPart>,
}

fn w(s: &Siso) -> f64 {
    wcpg(s).map(|w| w.value).unwrap_or(f64::INFINITY)
}

/// Derive every bound for the quantised constants `k` at signal LSB `q` (pu).
pub fn proven(k: &Quantised, cfg: &Config, q: f64) -> Proven {
    let s = &cfg.scales;
    let h = q / 2.0;
    let y = k.y_max;
    let pred_on = k.ph != 0.0;
    let pred_raw = y * (1.0 + 4.0 * k.ph.abs()) + if pred_on { q } else { 0.0 };
    let x = k.p_max.min(pred_raw);
    let l = &k.lead;
    let sys = lead_systems(l);
    let ws: Vec<f64> = sys.iter().map(|(_, s)| w(s)).collect();
    let es = lead_error_systems(l);
    let we: Vec<f64> = es.iter().map(w).collect();
    // dz: r1, r2 at q/2 each, and the bumpless start's q/2.
    let dz = we[0] * h + we[1] * h + h;
    let de = we[2] * h + we[3] * h + h;
    let err = [0.0, de, dz, 0.0, dz];
    let k_hf = l.k_hf.abs();
    let w_y = k_hf * ws[4];
    let lead_points = vec![
        ("r1: (g/2)(x + x1)".to_string(), k_hf * we[0] * h),
        ("r2: kappa e".to_string(), k_hf * we[1] * h),
        ("bumpless start: z0".to_string(), k_hf * h),
        ("r3: K_hf (x - z)".to_string(), h),
        (
            "predictor: (y' - y'[n-1]) p, twice".to_string(),
            if pred_on { w_y * q } else { 0.0 },
        ),
    ];
    let lead_err: f64 = lead_points.iter().map(|p| p.1).sum();
    let gain_err = k.gain.abs() * if pred_on { q } else { 0.0 } + h;
    let y_lead = w_y * x + k_hf * dz + h;
    let y_gain = k.gain.abs() * x + h;
    let raw = y_lead.max(y_gain).max(k.t_max);
    let fsy = s.y_dot;
    let fst = s.torque;
    let fsi = s.current;
    let fsv = s.voltage;
    let fsd = s.demand;
    let mut sig: Vec<(String, String, String, f64, f64, String)> = Vec::new();
    let mut put = |n: &str, c: &str, u: &str, fs: f64, v: f64, p: String| {
        sig.push((n.into(), c.into(), u.into(), fs, v, p));
    };
    put(
        "y_dot (clamped input)",
        "yaw",
        "m/s",
        fsy,
        y,
        "input clamp limits.y_dot".into(),
    );
    put(
        "predictor y' - y'[n-1]",
        "yaw",
        "m/s",
        fsy,
        2.0 * y,
        "interval: difference of two clamped inputs".into(),
    );
    put(
        "predictor y' + 2d (before clamp)",
        "yaw",
        "m/s",
        fsy,
        pred_raw,
        format!("interval: Y (1 + 4 |p|) + q, p = {:.6e}", k.ph),
    );
    for (i, (n, _)) in sys.iter().enumerate() {
        let v = ws[i] * x + err[i];
        put(
            n,
            "yaw_lead",
            "m/s",
            fsy,
            v,
            format!(
                "WCPG {:.6} x X = {:.6} pu (lead input bound) + rounding error {:.2e} pu",
                ws[i], x, err[i]
            ),
        );
    }
    put(
        "T_psi before limit",
        "yaw",
        "N m",
        fst,
        raw,
        format!(
            "max(lead K_hf WCPG(x - z) X + error = {y_lead:.6}, gain |k| X + q/2 = \
             {y_gain:.6}, slewing within the torque limit {:.6}) pu",
            k.t_max
        ),
    );
    put(
        "T_psi - previous output (slew)",
        "yaw",
        "N m",
        fst,
        raw + k.t_max,
        "interval: raw + torque limit".into(),
    );
    put(
        "torque limit +- step (before clamp)",
        "yaw",
        "N m",
        fst,
        k.t_max + k.t_step,
        "interval: limit in [0, T_max] plus one ramp step".into(),
    );
    put(
        "T_psi (output)",
        "yaw",
        "N m",
        fst,
        k.t_max,
        "output limit limits.torque".into(),
    );
    put(
        "i_a (clamped input)",
        "traction_pi",
        "A",
        fsi,
        k.i_max,
        "input clamp limits.current".into(),
    );
    put(
        "demand (clamped input)",
        "traction_pi",
        "N m",
        fsd,
        k.d_max,
        "input clamp limits.demand".into(),
    );
    let target = k.d_max * k.d2i.abs() + h;
    put(
        "i_ref target",
        "traction_pi",
        "A",
        fsi,
        target,
        "interval: Dm |d2i| + q/2".into(),
    );
    put(
        "i_ref target - i_ref (ramp)",
        "traction_pi",
        "A",
        fsi,
        2.0 * target,
        "interval: two values in the target hull".into(),
    );
    let iref = target;
    put(
        "i_ref (ramped, state)",
        "traction_pi",
        "A",
        fsi,
        iref,
        "interval: the ramp stays in the hull of 0 and the targets; wheel-slip cap in \
         [0, i_ref]"
            .into(),
    );
    let e = iref + k.i_max;
    put(
        "e = i_ref - i_a",
        "traction_pi",
        "A",
        fsi,
        e,
        "interval: Iref + I".into(),
    );
    let prop = k.kp.abs() * e + h;
    put(
        "PI Kp e",
        "traction_pi",
        "V",
        fsv,
        prop,
        "|Kp| E + q/2".into(),
    );
    let u = k.u_min.abs().max(k.u_max.abs());
    put(
        "PI I + Ki e (before clamp)",
        "traction_pi",
        "V",
        fsv,
        u + k.ki.abs() * e + q,
        "anti-windup clamp U + |Ki| E + q (floored increment)".into(),
    );
    put(
        "PI I (state)",
        "traction_pi",
        "V",
        fsv,
        u,
        "anti-windup clamp to the voltage limits".into(),
    );
    put(
        "PI Kp e + I (before limit)",
        "traction_pi",
        "V",
        fsv,
        prop + u,
        "interval: |Kp e| + U".into(),
    );
    put(
        "u_a (output)",
        "traction_pi",
        "V",
        fsv,
        u,
        "output limit to the voltage limits".into(),
    );
    put(
        "back-EMF preset K_m omega",
        "traction_pi",
        "V",
        fsv,
        k.s_max * k.bemf.abs() + h,
        "interval: S |K_m| + q/2".into(),
    );
    let _ = (k.i_step, k.i_safe_step);
    // The linear parts.
    let mut parts: Vec<LinearPart> = sys
        .iter()
        .map(|(n, s)| LinearPart {
            part: "lead".into(),
            path: format!("x -> {n}"),
            wcpg: wcpg(s),
            note: "per pu of lead input".into(),
        })
        .collect();
    parts.push(LinearPart {
        part: "lead".into(),
        path: "x -> T_psi".into(),
        wcpg: wcpg(&sys[4].1.scaled(l.k_hf)),
        note: "pu of torque per pu of y'".into(),
    });
    for (i, n) in [
        "r1 -> dz (rounding of (g/2)(x + x1))",
        "r2 -> dz (rounding of kappa e)",
        "r1 -> de",
        "r2 -> de",
    ]
    .iter()
    .enumerate()
    {
        parts.push(LinearPart {
            part: "lead rounding-error filter".into(),
            path: n.to_string(),
            wcpg: wcpg(&es[i]),
            note: "per unit of rounding error".into(),
        });
    }
    parts.push(LinearPart {
        part: "PI".into(),
        path: "e -> Kp e".into(),
        wcpg: wcpg(&Siso::gain(k.kp)),
        note: "pu of voltage per pu of current".into(),
    });
    parts.push(LinearPart {
        part: "PI".into(),
        path: "e -> integrator".into(),
        wcpg: wcpg(&Siso {
            a: vec![vec![1.0]],
            b: vec![k.ki],
            c: vec![1.0],
            d: k.ki,
        }),
        note: "infinite (pole z = 1): bounded by the anti-windup clamp only".into(),
    });
    // The runtime's y'' integrator: v[n] = (1 - T/tau) v[n-1] + 100 T a[n] um/s per
    // code (0.1 mm/s^2), clamped to the i32 range of um/s.
    let t = cfg.base_period();
    let tau = wheelset_runtime::DEFAULT_ACC_WASHOUT_S;
    let leak = t / tau;
    parts.push(LinearPart {
        part: "y'' integrator (runtime)".into(),
        path: "y'' code -> v (um/s)".into(),
        wcpg: wcpg(&Siso {
            a: vec![vec![1.0 - leak]],
            b: vec![100.0 * t],
            c: vec![1.0 - leak],
            d: 100.0 * t,
        }),
        note: format!(
            "wash-out tau = {tau} s at {:.0} Hz: 100 tau um/s per code; the state is clamped \
             to +-(2^31 - 1) um/s and the result to the y' clamp",
            1.0 / t
        ),
    });
    parts.push(LinearPart {
        part: "y'' integrator (runtime)".into(),
        path: "y' -> v (wash-out reference)".into(),
        wcpg: wcpg(&Siso {
            a: vec![vec![1.0 - leak]],
            b: vec![leak],
            c: vec![1.0 - leak],
            d: leak,
        }),
        note: "the complementary filter's low-frequency path".into(),
    });
    Proven {
        x,
        signals: sig,
        lead_err,
        lead_err_points: lead_points,
        gain_err,
        pi_err: h + q,
        iref_err: h,
        parts,
    }
}

/// Largest |fixed - exact| over the scenarios for the lead (with the predictor), the
/// gain, the PI given its input and the reference, pu: the exact runs use f64 on the
/// quantised coefficients and the fixed runs' own inputs.
pub fn observed_errors<T: Sample>(
    cfg: &Config,
    k: &Quantised,
    scenarios: &[Scenario],
) -> Result<[f64; 4], ConfigError> {
    let c = Controller::<T>::try_new(cfg)?;
    let lead: Lead<T> = *c.lead();
    let pi: Pi<T> = *c.pi();
    let ph = T::quantise(k.ph).ok_or(ConfigError::Coefficient {
        name: "predict_half",
        value: k.ph,
    })?;
    let gain = T::quantise(k.gain).ok_or(ConfigError::Coefficient {
        name: "gain",
        value: k.gain,
    })?;
    let d2i = T::quantise(k.d2i).ok_or(ConfigError::Coefficient {
        name: "demand_to_iref",
        value: k.d2i,
    })?;
    let s = cfg.scales;
    let l = &k.lead;
    let mut worst = [0.0f64; 4];
    let clampf = |v: f64, m: f64| v.clamp(-m, m);
    let yd = cfg.yaw_divisor.max(1) as usize;
    let td = cfg.traction_divisor.max(1) as usize;
    for sc in scenarios {
        // Yaw: fixed and exact predictor + lead + gain.
        let mut st = wheelset_control::LeadState::<T>::default();
        let (mut ez, mut ex1) = (0.0f64, 0.0f64);
        let (mut yp_f, mut yp_e) = (T::ZERO, 0.0f64);
        let tmax = T::from_f64(k.y_max);
        let pmax = T::from_f64(k.p_max);
        for t in sc.ticks.iter().step_by(yd) {
            let v = t.si[0] / s.y_dot;
            let yf = T::from_f64(if v.is_finite() { v } else { 0.0 })
                .limit(T::ZERO.sat_sub(tmax), tmax)
                .0;
            let ye = yf.to_f64();
            let d = yf.sat_sub(yp_f).mul_c(ph);
            let xf = yf
                .sat_add(d)
                .sat_add(d)
                .limit(T::ZERO.sat_sub(pmax), pmax)
                .0;
            yp_f = yf;
            let xe = clampf(ye + 2.0 * (ye - yp_e) * k.ph, k.p_max);
            yp_e = ye;
            let of = lead.process(&mut st, xf).to_f64();
            ez = ez + l.kappa * (l.g_half * (xe + ex1) - ez);
            ex1 = xe;
            let oe = l.k_hf * (xe - ez);
            worst[0] = worst[0].max((of - oe).abs());
            let gf = xf.mul_c(gain).to_f64();
            worst[1] = worst[1].max((gf - xe * k.gain).abs());
        }
        // Traction: the reference path (fixed vs exact ramp), and the PI on the fixed
        // error (fixed vs exact PI on the same input).
        let mut ps = PiState::<T>::new(T::ZERO);
        let mut ie = 0.0f64;
        let (mut rf, mut re) = (T::ZERO, 0.0f64);
        let step = T::from_f64(k.i_step);
        let (imax, dmax) = (T::from_f64(k.i_max), T::from_f64(k.d_max));
        for t in sc.ticks.iter().step_by(td) {
            let fin = |v: f64| if v.is_finite() { v } else { 0.0 };
            let i = T::from_f64(fin(t.si[1] / s.current))
                .limit(T::ZERO.sat_sub(imax), imax)
                .0;
            let d = T::from_f64(fin(t.si[3] / s.demand))
                .limit(T::ZERO.sat_sub(dmax), dmax)
                .0;
            let tf = d.mul_c(d2i);
            rf = rf.sat_add(tf.sat_sub(rf).limit(T::ZERO.sat_sub(step), step).0);
            let te = d.to_f64() * k.d2i;
            re += (te - re).clamp(-k.i_step, k.i_step);
            worst[3] = worst[3].max((rf.to_f64() - re).abs());
            let e = rf.sat_sub(i);
            let uf = pi.process(&mut ps, e).to_f64();
            let ee = e.to_f64();
            ie = (ie + k.ki * ee).clamp(k.u_min, k.u_max);
            let ue = (k.kp * ee + ie).clamp(k.u_min, k.u_max);
            worst[2] = worst[2].max((uf - ue).abs());
        }
    }
    Ok(worst)
}

/// Smallest integer bits (incl. sign) with `2^(i-1) > v`.
pub fn int_bits_for(v: f64) -> u32 {
    let mut i = 1u32;
    while i < 64 && 2f64.powi(i as i32 - 1) <= v {
        i += 1;
    }
    i
}

/// Smallest fraction bits `F` with `err_per_lsb 2^-F <= budget` (both pu).
pub fn frac_bits_for(err_per_lsb: f64, budget: f64) -> u32 {
    if !(err_per_lsb > 0.0 && budget > 0.0) {
        return 0;
    }
    (err_per_lsb / budget).log2().ceil().max(0.0) as u32
}

/// Proofs for the audited configuration and format, with the observed ranges and the
/// observed errors (pu, from [`observed_errors`]).
pub fn prove(
    cfg: &Config,
    k: &Quantised,
    fmt: QFormat,
    observed: &Observed,
    obs_err: [f64; 4],
) -> Proofs {
    let q = fmt.lsb();
    let range = fmt.range();
    let p = proven(k, cfg, q);
    let fmt_s = fmt.to_string();
    let bounds: Vec<Bound> = p
        .signals
        .iter()
        .map(|(n, c, u, fs, v, proof)| {
            let obs = observed
                .signals
                .iter()
                .find(|r| &r.name == n && r.samples > 0)
                .map(|r| r.min_si.abs().max(r.max_si.abs()));
            Bound {
                signal: n.clone(),
                controller: c.clone(),
                unit: u.clone(),
                observed_max: obs,
                proven_max: v * fs,
                format: fmt_s.clone(),
                margin_bits: (range / v).log2(),
                proof: proof.clone(),
            }
        })
        .collect();
    let s = &cfg.scales;
    let wire = &cfg.wire;
    let eb =
        |o: &str, obs: f64, pr: f64, fs: f64, unit: &str, lsb: f64, pts: Vec<(String, f64)>| {
            ErrorBound {
                output: o.into(),
                observed: obs * fs,
                proven: pr * fs,
                unit: unit.into(),
                proven_wire_lsb: pr * fs / lsb,
                rounding_points: pts.into_iter().map(|(n, v)| (n, v * fs)).collect(),
            }
        };
    let error_bounds = vec![
        eb(
            "T_psi (lead, with the predictor)",
            obs_err[0],
            p.lead_err,
            s.torque,
            "N m",
            wire.torque,
            p.lead_err_points.clone(),
        ),
        eb(
            "T_psi (gain, with the predictor)",
            obs_err[1],
            p.gain_err,
            s.torque,
            "N m",
            wire.torque,
            vec![
                ("predictor".into(), p.gain_err - q / 2.0),
                ("x k".into(), q / 2.0),
            ],
        ),
        eb(
            "u_a (PI, given its error input)",
            obs_err[2],
            p.pi_err,
            s.voltage,
            "V",
            wire.voltage,
            vec![
                ("Kp e".into(), q / 2.0),
                ("integrator (floored, remainder carried)".into(), q),
            ],
        ),
        eb(
            "i_ref (ramped reference)",
            obs_err[3],
            p.iref_err,
            s.current,
            "A",
            wire.current,
            vec![("demand d2i".into(), q / 2.0)],
        ),
    ];
    let overflow_free = p.signals.iter().all(|x| x.4 < range);
    // Proposals: integer bits from the proven bound; fraction bits from half a wire LSB
    // of the chain's output (T_psi for the yaw signals, u_a for the traction ones).
    let budget_t = 0.5 * wire.torque / s.torque;
    let budget_u = 0.5 * wire.voltage / s.voltage;
    let f_yaw = frac_bits_for(p.lead_err.max(p.gain_err) / q, budget_t);
    let f_tr = frac_bits_for(p.pi_err / q, budget_u);
    let proposals = p
        .signals
        .iter()
        .map(|(n, c, _, _, v, _)| {
            let i = int_bits_for(*v);
            let (f, out, per, budget, lsb) = if c == "traction_pi" {
                (
                    f_tr,
                    "u_a",
                    p.pi_err / q,
                    budget_u * s.voltage,
                    wire.voltage,
                )
            } else {
                (
                    f_yaw,
                    "T_psi",
                    p.lead_err.max(p.gain_err) / q,
                    budget_t * s.torque,
                    wire.torque,
                )
            };
            let fs = if c == "traction_pi" {
                s.voltage
            } else {
                s.torque
            };
            let e = per * 2f64.powi(-(f as i32)) * fs;
            Proposal {
                signal: n.clone(),
                proven_max_pu: *v,
                int_bits: i,
                frac_bits: f,
                format: format!("Q{i}.{f}"),
                guarantee: format!(
                    "cannot overflow for any input within the clamps (proven {v:.4} pu < \
                     2^{}); {out} rounding error vs exact arithmetic <= {e:.3e} ({:.3} wire \
                     LSB, budget {budget:.3e} = half a wire LSB)",
                    i - 1,
                    e / lsb
                ),
            }
        })
        .collect();
    let statement = if overflow_free {
        format!(
            "No overflow for any input within the clamps: every internal signal's proven \
             bound lies inside {fmt_s} (smallest margin {:.2} bits, {}); the rounding error \
             of T_psi against exact arithmetic on the quantised coefficients is at most \
             {:.3e} N m ({:.3} wire LSB), of u_a given the PI's input {:.3e} V.",
            bounds
                .iter()
                .map(|b| b.margin_bits)
                .fold(f64::INFINITY, f64::min),
            bounds
                .iter()
                .min_by(|a, b| a.margin_bits.total_cmp(&b.margin_bits))
                .map(|b| b.signal.as_str())
                .unwrap_or(""),
            p.lead_err * s.torque,
            p.lead_err * s.torque / wire.torque,
            p.pi_err * s.voltage
        )
    } else {
        format!(
            "Overflow not excluded: {} proven bound(s) exceed the range of {fmt_s}.",
            p.signals.iter().filter(|x| x.4 >= range).count()
        )
    };
    Proofs {
        bounds,
        error_bounds,
        linear_parts: p.parts,
        proposals,
        statement,
        overflow_free,
    }
}

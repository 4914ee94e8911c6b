//! The proofs themselves: the quantised constants as the device holds them, the lead's
//! signal and rounding-error systems, and every proven bound (the equations are in the
//! parent module's docs).

use wheelset_control::{Config, ConfigError, Controller, LeadPu, Sample};

use super::{frac_bits_for, int_bits_for, smallest_margin, Bound, ErrorBound, LinearPart, Proofs};
use crate::model::Recommendation;
use crate::qdyn::QFormat;
use crate::ranges::{fs_of, Fs, Fs::*, Observed};
use crate::wcpg::{wcpg, Siso};

/// The quantised constants of the core, pu (exact values of what `T` holds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantised {
    /// Lead coefficients.
    pub lead: LeadPu,
    /// Gain law coefficient, torque pu per `y'` pu.
    pub gain: f64,
    /// PI `Kp`, voltage pu per current pu.
    pub kp: f64,
    /// PI `Ki` per step, voltage pu per current pu.
    pub ki: f64,
    /// `Ki`'s shift: held as `Ki 2^ki_shift` in the coefficient format (0 for floats).
    pub ki_shift: u32,
    /// Lower voltage limit, pu.
    pub u_min: f64,
    /// Upper voltage limit, pu.
    pub u_max: f64,
    /// Demand pu -> current reference pu.
    pub d2i: f64,
    /// Back-EMF constant, voltage pu per speed pu.
    pub bemf: f64,
    /// Predictor half factor.
    pub ph: f64,
    /// Input clamp of `y'`, pu.
    pub y_max: f64,
    /// Current clamp, pu.
    pub i_max: f64,
    /// Speed clamp, pu.
    pub s_max: f64,
    /// Demand clamp, pu.
    pub d_max: f64,
    /// Torque limit, pu.
    pub t_max: f64,
    /// Predicted `y'` clamp, pu.
    pub p_max: f64,
    /// Torque ramp step, pu.
    pub t_step: f64,
    /// Current reference step per traction step, pu.
    pub i_step: f64,
    /// Safe-state current reference step per traction step, pu.
    pub i_safe_step: f64,
}

/// `v` quantised as the controller holds a coefficient; the error names it.
pub(crate) fn quantise<T: Sample>(name: &'static str, v: f64) -> Result<T::Coeff, ConfigError> {
    T::quantise(v).ok_or(ConfigError::Coefficient { name, value: v })
}

pub(crate) fn qc<T: Sample>(name: &'static str, v: f64) -> Result<f64, ConfigError> {
    quantise::<T>(name, v).map(T::coeff_to_f64)
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
        let pi = c.compiled().pi().quantised();
        let iref_max = l.demand / (cfg.motor.n * cfg.motor.k_m) / s.current;
        Ok(Self {
            lead: c.compiled().lead().quantised(),
            gain: qc::<T>("gain", cfg.gain_k * s.y_dot / s.torque)?,
            kp: pi.kp,
            ki: pi.ki,
            ki_shift: c.compiled().pi().ki_shift(),
            u_min: c.compiled().pi().u_min.to_f64(),
            u_max: c.compiled().pi().u_max.to_f64(),
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

fn w(s: &Siso) -> f64 {
    wcpg(s).map(|w| w.value).unwrap_or(f64::INFINITY)
}

/// Proofs for the audited configuration and format, with the observed ranges and the
/// observed errors (pu, from [`super::observed_errors`]).
pub fn prove(
    cfg: &Config,
    k: &Quantised,
    fmt: QFormat,
    observed: &Observed,
    obs_err: [f64; 4],
) -> Proofs {
    let q = fmt.lsb();
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
    let target = k.d_max * k.d2i.abs() + h;
    let iref = target;
    let e = iref + k.i_max;
    let prop = k.kp.abs() * e + h;
    let u = k.u_min.abs().max(k.u_max.abs());
    let row = |n: &str, f: Fs, v: f64, proof: &str| {
        let (fs, unit) = fs_of(f, cfg);
        (
            n.into(),
            f.controller(n).into(),
            unit.into(),
            fs,
            v,
            proof.into(),
        )
    };
    let mut sig: Vec<(String, String, String, f64, f64, String)> = vec![
        row("y_dot (clamped input)", YDot, y, "input clamp limits.y_dot"),
        row(
            "predictor y' - y'[n-1]",
            YDot,
            2.0 * y,
            "interval: difference of two clamped inputs",
        ),
        row(
            "predictor y' + 2d (before clamp)",
            YDot,
            pred_raw,
            &format!("interval: Y (1 + 4 |p|) + q, p = {:.6e}", k.ph),
        ),
    ];
    for (i, (n, _)) in sys.iter().enumerate() {
        let v = ws[i] * x + err[i];
        let proof = format!(
            "WCPG {:.6} x X = {:.6} pu (lead input bound) + rounding error {:.2e} pu",
            ws[i], x, err[i]
        );
        sig.push(row(n, YDot, v, &proof));
    }
    sig.extend([
        row(
            "T_psi before limit",
            Torque,
            raw,
            &format!(
                "max(lead K_hf WCPG(x - z) X + error = {y_lead:.6}, gain |k| X + q/2 = \
                 {y_gain:.6}, slewing within the torque limit {:.6}) pu",
                k.t_max
            ),
        ),
        row(
            "T_psi - previous output (slew)",
            Torque,
            raw + k.t_max,
            "interval: raw + torque limit",
        ),
        row(
            "torque limit +- step (before clamp)",
            Torque,
            k.t_max + k.t_step,
            "interval: limit in [0, T_max] plus one ramp step",
        ),
        row(
            "T_psi (output)",
            Torque,
            k.t_max,
            "output limit limits.torque",
        ),
        row(
            "i_a (clamped input)",
            Current,
            k.i_max,
            "input clamp limits.current",
        ),
        row(
            "demand (clamped input)",
            Demand,
            k.d_max,
            "input clamp limits.demand",
        ),
        row("i_ref target", Current, target, "interval: Dm |d2i| + q/2"),
        row(
            "i_ref target - i_ref (ramp)",
            Current,
            2.0 * target,
            "interval: two values in the target hull",
        ),
        row(
            "i_ref (ramped, state)",
            Current,
            iref,
            "interval: the ramp stays in the hull of 0 and the targets; wheel-slip cap in \
             [0, i_ref]",
        ),
        row("e = i_ref - i_a", Current, e, "interval: Iref + I"),
        row("PI Kp e", Voltage, prop, "|Kp| E + q/2"),
        row(
            "PI I + Ki e (before clamp)",
            Voltage,
            u + k.ki.abs() * e + q,
            "anti-windup clamp U + |Ki| E + q (floored increment)",
        ),
        row(
            "PI I (state)",
            Voltage,
            u,
            "anti-windup clamp to the voltage limits",
        ),
        row(
            "PI Kp e + I (before limit)",
            Voltage,
            prop + u,
            "interval: |Kp e| + U",
        ),
        row(
            "u_a (output)",
            Voltage,
            u,
            "output limit to the voltage limits",
        ),
        row(
            "back-EMF preset K_m omega",
            Voltage,
            k.s_max * k.bemf.abs() + h,
            "interval: S |K_m| + q/2",
        ),
    ]);
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
        wcpg: wcpg(&Siso::recursive(1.0, k.ki)),
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
        wcpg: wcpg(&Siso::recursive(1.0 - leak, 100.0 * t)),
        note: format!(
            "wash-out tau = {tau} s at {:.0} Hz: 100 tau um/s per code; the state is clamped \
             to +-(2^31 - 1) um/s and the result to the y' clamp",
            1.0 / t
        ),
    });
    parts.push(LinearPart {
        part: "y'' integrator (runtime)".into(),
        path: "y' -> v (wash-out reference)".into(),
        wcpg: wcpg(&Siso::recursive(1.0 - leak, leak)),
        note: "the complementary filter's low-frequency path".into(),
    });
    let (pi_err, iref_err) = (h + q, h);
    let range = fmt.range();
    let fmt_s = fmt.to_string();
    let seen = |n: &str| {
        observed
            .signals
            .iter()
            .find(|r| r.name == n && r.samples > 0)
    };
    let bounds: Vec<Bound> = sig
        .iter()
        .map(|(n, c, u, fs, v, proof)| {
            let obs = seen(n).map(|r| r.min_si.abs().max(r.max_si.abs()));
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
    let wire = &cfg.wire;
    let torque = (s.torque, "N m", wire.torque);
    let pts = |v: &[(&str, f64)]| v.iter().map(|&(n, x)| (n.to_string(), x)).collect();
    // `(output, proven pu, (full scale, unit, wire LSB), rounding points pu)`.
    let rows: [(_, _, _, Vec<(String, f64)>); 4] = [
        (
            "T_psi (lead, with the predictor)",
            lead_err,
            torque,
            lead_points,
        ),
        (
            "T_psi (gain, with the predictor)",
            gain_err,
            torque,
            pts(&[("predictor", gain_err - q / 2.0), ("x k", q / 2.0)]),
        ),
        (
            "u_a (PI, given its error input)",
            pi_err,
            (s.voltage, "V", wire.voltage),
            pts(&[
                ("Kp e", q / 2.0),
                ("integrator (floored, remainder carried)", q),
            ]),
        ),
        (
            "i_ref (ramped reference)",
            iref_err,
            (s.current, "A", wire.current),
            pts(&[("demand d2i", q / 2.0)]),
        ),
    ];
    let error_bounds = rows
        .into_iter()
        .zip(obs_err)
        .map(|((o, pr, (fs, unit, lsb), pts), obs)| ErrorBound {
            output: o.into(),
            observed: obs * fs,
            proven: pr * fs,
            unit: unit.into(),
            proven_wire_lsb: pr * fs / lsb,
            rounding_points: pts.into_iter().map(|(n, v)| (n, v * fs)).collect(),
        })
        .collect();
    let overflow_free = sig.iter().all(|x| x.4 < range);
    let budget_t = 0.5 * wire.torque / s.torque;
    let budget_u = 0.5 * wire.voltage / s.voltage;
    let yaw_per = lead_err.max(gain_err) / q;
    let f_yaw = frac_bits_for(yaw_per, budget_t);
    let f_tr = frac_bits_for(pi_err / q, budget_u);
    let recommendations = sig
        .iter()
        .map(|(n, c, _, _, v, _)| {
            let i = int_bits_for(*v);
            let (f, out, per, fs, lsb) = if c == "traction_pi" {
                (f_tr, "u_a", pi_err / q, s.voltage, wire.voltage)
            } else {
                (f_yaw, "T_psi", yaw_per, s.torque, wire.torque)
            };
            let budget = lsb / 2.0;
            let e = per * 2f64.powi(-(f as i32)) * fs;
            let peak = seen(n).map(|s| s.peak());
            let word = i + f;
            let note = if word > 32 {
                format!("; {word} bits exceed an i32")
            } else {
                String::new()
            };
            Recommendation {
                signal: n.clone(),
                controller: c.clone(),
                peak_pu: peak.unwrap_or(0.0),
                observed: peak.is_some(),
                proven_max_pu: *v,
                int_bits: i,
                frac_bits: f,
                word,
                format: format!("Q{i}.{f}"),
                margin: format!("integer bits from the proven bound{note}"),
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
    let tightest = smallest_margin(&bounds);
    let statement = if overflow_free {
        format!(
            "No overflow for any input within the clamps: every internal signal's proven \
             bound lies inside {fmt_s} (smallest margin {:.2} bits, {}); the rounding error \
             of T_psi against exact arithmetic on the quantised coefficients is at most \
             {:.3e} N m ({:.3} wire LSB), of u_a given the PI's input {:.3e} V.",
            tightest.0,
            tightest.1,
            lead_err * s.torque,
            lead_err * s.torque / wire.torque,
            pi_err * s.voltage
        )
    } else {
        format!(
            "Overflow not excluded: {} proven bound(s) exceed the range of {fmt_s}.",
            sig.iter().filter(|x| x.4 >= range).count()
        )
    };
    Proofs {
        bounds,
        error_bounds,
        linear_parts: parts,
        recommendations,
        statement,
        overflow_free,
    }
}

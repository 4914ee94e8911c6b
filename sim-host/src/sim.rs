//! Time integration: fixed-step RK4 on integer-nanosecond time, the continuous-time
//! reference run, and the sampled-data run with a [`SampledController`] behind optional
//! sensor and actuator models.
//!
//! Inputs: the track (piecewise linear) is evaluated at each RK4 stage time; the step
//! inputs (traction demand, `F_run`) are sampled once at the start of each step, so a
//! step at 5 s acts from exactly 5 s. Time is `k * dt_ns`, never accumulated in floats.

use crate::control::{
    closed_loop_rhs, Actuation, ContinuousController, Exogenous, Measurements, SampledController,
    YawLaw,
};
use crate::plant::{ix, Inputs, Plant, PlantConfig, State, NX};
use crate::scenario::{Scenario, TrackCursor};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;
use std::collections::VecDeque;
use std::fmt;
use std::io::Write;

/// One classical RK4 step of length `h` seconds. `f(stage, x)` returns `dx/dt`; stage 0
/// is at the step start, 1 and 2 at the midpoint, 3 at the end.
#[inline(always)]
pub fn rk4_step<F: FnMut(usize, &State) -> State>(x: &State, h: f64, f: F) -> State {
    rk4_step_with(x, h, f)
}

/// A right-hand side `dx/dt = f(stage, x)` for [`rk4_step_with`].
pub trait Rhs {
    /// `dx/dt` at RK4 stage `stage` (0: step start, 1 and 2: midpoint, 3: end).
    fn eval(&mut self, stage: usize, x: &State) -> State;
}

impl<F: FnMut(usize, &State) -> State> Rhs for F {
    #[inline(always)]
    fn eval(&mut self, stage: usize, x: &State) -> State {
        self(stage, x)
    }
}

/// The plant alone with fixed inputs per stage slot (start, midpoint, end), built once
/// per step. Its right-hand side is inlined into each RK4 stage; as a closure it was an
/// out-of-line call per stage (closed loop over the link: 684 M -> 623 M instructions,
/// callgrind). Same arithmetic, bit-identical states.
struct PlantStages<'a> {
    plant: &'a Plant,
    u: [Inputs<f64>; 3],
}

impl Rhs for PlantStages<'_> {
    #[inline(always)]
    fn eval(&mut self, stage: usize, x: &State) -> State {
        let u = &self.u[stage_slot(stage)];
        self.plant.rhs(x, u).0
    }
}

/// [`rk4_step`] for any [`Rhs`]: the same arithmetic.
#[inline(always)]
pub fn rk4_step_with<R: Rhs>(x: &State, h: f64, mut f: R) -> State {
    let mut f = |stage: usize, x: &State| f.eval(stage, x);
    let k1 = f(0, x);
    let mut xt = [0.0; NX];
    for i in 0..NX {
        xt[i] = x[i] + 0.5 * h * k1[i];
    }
    let k2 = f(1, &xt);
    for i in 0..NX {
        xt[i] = x[i] + 0.5 * h * k2[i];
    }
    let k3 = f(2, &xt);
    for i in 0..NX {
        xt[i] = x[i] + h * k3[i];
    }
    let k4 = f(3, &xt);
    let mut out = [0.0; NX];
    for i in 0..NX {
        out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    }
    out
}

/// One output sample. CSV column names are in [`Record::COLUMNS`] (SI, unit suffix).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Record {
    /// Time, s.
    pub t_s: f64,
    /// Lateral displacement `y`, m.
    pub y_m: f64,
    /// Yaw angle `psi`, rad.
    pub psi_rad: f64,
    /// Total yaw torque on the wheelset `T_psi` (spring + actuator), N m, eq. 5 sign.
    pub t_psi_nm: f64,
    /// Right longitudinal creep force, N.
    pub fx_r_n: f64,
    /// Left longitudinal creep force, N.
    pub fx_l_n: f64,
    /// Lateral creep force per wheel, N.
    pub fy_n: f64,
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Armature current, A.
    pub i_a_a: f64,
    /// Armature voltage, V.
    pub u_a_v: f64,
    /// Lateral velocity relative to the track, m/s.
    pub yd_mps: f64,
    /// Actuator (control) part of the yaw torque, N m.
    pub t_ctrl_nm: f64,
    /// Passive spring part of the yaw torque `k_yaw psi`, N m.
    pub t_spring_nm: f64,
    /// Right wheel speed, rad/s.
    pub w_r_radps: f64,
    /// Left wheel speed, rad/s.
    pub w_l_radps: f64,
    /// Motor speed, rad/s.
    pub w_m_radps: f64,
    /// Axle twist, rad.
    pub twist_rad: f64,
    /// Gear wind-up, rad.
    pub wind_rad: f64,
    /// Current reference, A.
    pub i_ref_a: f64,
    /// Traction demand at the wheel, N m.
    pub demand_nm: f64,
    /// Running resistance, N.
    pub f_run_n: f64,
    /// Track curvature, 1/m.
    pub curvature_1pm: f64,
    /// Cant, rad.
    pub cant_rad: f64,
    /// Pure rolling line `r0 Lg / (lambda R)` for the current curvature, m.
    pub y0_m: f64,
    /// Longitudinal slip velocity of the wheelset, the mean of the two wheels'
    /// `v s_x` (`s_x` the creepage of eqs. 1-2: circumferential minus forward speed over
    /// `v`), m/s; + = the wheels turn faster than the vehicle runs (traction).
    pub slip_mps: f64,
    /// Adhesion available: the peak `F/Q` of the present rail condition's longitudinal
    /// characteristic at the present speed ([`crate::adhesion::Adhesion::peak`]); `inf`
    /// under the linear law (no limit).
    pub mu_avail: f64,
    /// Adhesion used: the traction coefficient `(F_xR + F_xL) / (2 Q)`.
    pub mu_used: f64,
}

impl Record {
    /// CSV header names, in the order of [`Record::values`].
    pub const COLUMNS: [&'static str; 27] = [
        "t_s",
        "y_m",
        "psi_rad",
        "T_psi_Nm",
        "Fx_R_N",
        "Fx_L_N",
        "Fy_N",
        "v_mps",
        "i_a_A",
        "u_a_V",
        "yd_mps",
        "T_ctrl_Nm",
        "T_spring_Nm",
        "w_R_radps",
        "w_L_radps",
        "w_m_radps",
        "twist_rad",
        "wind_rad",
        "i_ref_A",
        "demand_Nm",
        "F_run_N",
        "curvature_1pm",
        "cant_rad",
        "y0_m",
        "slip_mps",
        "mu_avail",
        "mu_used",
    ];

    /// The values in [`Record::COLUMNS`] order.
    pub fn values(&self) -> [f64; 27] {
        [
            self.t_s,
            self.y_m,
            self.psi_rad,
            self.t_psi_nm,
            self.fx_r_n,
            self.fx_l_n,
            self.fy_n,
            self.v_mps,
            self.i_a_a,
            self.u_a_v,
            self.yd_mps,
            self.t_ctrl_nm,
            self.t_spring_nm,
            self.w_r_radps,
            self.w_l_radps,
            self.w_m_radps,
            self.twist_rad,
            self.wind_rad,
            self.i_ref_a,
            self.demand_nm,
            self.f_run_n,
            self.curvature_1pm,
            self.cant_rad,
            self.y0_m,
            self.slip_mps,
            self.mu_avail,
            self.mu_used,
        ]
    }
}

/// What a run did, for reports.
#[derive(Debug, Clone, Serialize)]
pub struct RunInfo {
    /// Scenario name.
    pub scenario: String,
    /// Where the scenario came from.
    pub source: String,
    /// Control mode label (`passive`, `gain`, `lead`, or the sampled controller's).
    pub control: String,
    /// Integration step, s.
    pub dt_s: f64,
    /// Number of RK4 steps.
    pub steps: u64,
    /// Controller calls (sampled runs).
    pub controller_calls: u64,
    /// Actuator clamps counted (sampled runs).
    pub actuator_clamps: u64,
    /// Time at which the run was stopped because it diverged (a state not finite or
    /// `|y|` beyond [`DIVERGED_Y_M`]: an unstable loop), s; records end there.
    pub diverged_at_s: Option<f64>,
}

/// `|y|` beyond which a run counts as diverged (far outside the flange clearance and
/// the linear creep law), m.
pub const DIVERGED_Y_M: f64 = 0.05;

fn diverged(x: &State) -> bool {
    !x.iter().all(|v| v.is_finite()) || x[ix::Y].abs() > DIVERGED_Y_M
}

/// A run's records and description.
#[derive(Debug, Clone)]
pub struct Trajectory {
    /// Samples at the scenario's output interval, first at t = 0, last at the end.
    pub records: Vec<Record>,
    /// Description.
    pub info: RunInfo,
}

impl Trajectory {
    /// Writes the CSV (header row [`Record::COLUMNS`], one row per record).
    pub fn write_csv<W: Write>(&self, mut w: W) -> std::io::Result<()> {
        writeln!(w, "{}", Record::COLUMNS.join(","))?;
        let mut line = String::with_capacity(512);
        for r in &self.records {
            line.clear();
            for (i, v) in r.values().iter().enumerate() {
                if i > 0 {
                    line.push(',');
                }
                use std::fmt::Write as _;
                let _ = write!(line, "{v:.9e}");
            }
            writeln!(w, "{line}")?;
        }
        Ok(())
    }

    /// The record nearest to time `t_s`.
    pub fn at(&self, t_s: f64) -> Option<&Record> {
        self.records.iter().min_by(|a, b| {
            (a.t_s - t_s)
                .abs()
                .partial_cmp(&(b.t_s - t_s).abs())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    }
}

/// Errors of a sampled run's configuration.
#[derive(Debug, Clone, PartialEq)]
pub enum SimError {
    /// The controller period is not a positive multiple of the integration step.
    Period {
        /// Period, ns.
        period_ns: u64,
        /// Step, ns.
        dt_ns: u64,
    },
    /// The actuator delay is not a multiple of the integration step.
    Delay {
        /// Delay, ns.
        delay_ns: u64,
        /// Step, ns.
        dt_ns: u64,
    },
}

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimError::Period { period_ns, dt_ns } => write!(
                f,
                "controller period {period_ns} ns is not a positive multiple of the integration step {dt_ns} ns"
            ),
            SimError::Delay { delay_ns, dt_ns } => write!(
                f,
                "actuator delay {delay_ns} ns is not a multiple of the integration step {dt_ns} ns"
            ),
        }
    }
}

impl std::error::Error for SimError {}

/// Per-step exogenous inputs shared by both run kinds.
struct Exo {
    demand: f64,
    f_run: f64,
    i_ref: f64,
    curv: [f64; 3],
    cant: [f64; 3],
}

fn stage_slot(stage: usize) -> usize {
    match stage {
        0 => 0,
        3 => 2,
        _ => 1,
    }
}

/// Sets up the plant, initial state and exogenous input function for a scenario.
struct Setup<'a> {
    sc: &'a Scenario,
    plant: Plant,
    track: TrackCursor,
    /// `(condition, v, peak)` of the last [`Setup::mu_avail`], recomputed when the
    /// condition changes or the speed moves by more than 1 mm/s.
    peak_cache: Option<(crate::adhesion::Condition, f64, f64)>,
}

impl<'a> Setup<'a> {
    fn new(sc: &'a Scenario, yaw_spring: bool) -> Self {
        let cfg = PlantConfig {
            axle: sc.axle,
            drive: sc.drive,
            yaw_spring,
        };
        Setup {
            sc,
            plant: Plant::new(&sc.params, cfg),
            track: TrackCursor::new(),
            peak_cache: None,
        }
    }

    /// Puts the rail condition of `t_ns` on the setup's plant and returns the law (the
    /// run copies it onto its own plant). A no-op without `[[adhesion]]` sections.
    fn adhesion(&mut self, t_ns: u64) -> Option<crate::adhesion::Adhesion> {
        let a = self.sc.adhesion_at(t_ns);
        self.plant.adhesion = a;
        a
    }

    /// The peak adhesion of the present condition at speed `v` (`inf` without a law).
    fn mu_avail(&mut self, v: f64) -> f64 {
        let Some(a) = self.plant.adhesion else {
            return f64::INFINITY;
        };
        if let Some((c, v0, peak)) = self.peak_cache {
            if c == a.condition && (v - v0).abs() <= 1e-3 {
                return peak;
            }
        }
        let peak = a.peak(self.sc.params.f11, v);
        self.peak_cache = Some((a.condition, v, peak));
        peak
    }

    fn exo(&mut self, t_ns: u64) -> Exo {
        let sc = self.sc;
        let h = sc.dt_ns;
        let mut curv = [0.0; 3];
        let mut cant = [0.0; 3];
        for (j, t) in [t_ns, t_ns + h / 2, t_ns + h].into_iter().enumerate() {
            let (c, th) = self.track.at(&sc.track, t);
            curv[j] = c;
            cant[j] = th;
        }
        let demand = sc.traction.at(t_ns);
        Exo {
            demand,
            f_run: sc.resistance.at(t_ns),
            i_ref: demand / (sc.params.n_gear * sc.params.k_m),
            curv,
            cant,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn record(&mut self, t_ns: u64, x: &State, e: &Exo, t_ctrl: f64, u_a: f64) -> Record {
        let mu_avail = self.mu_avail(x[ix::V]);
        let p = &self.sc.params;
        let cr = self.plant.creep(x, e.curv[0]);
        let mut linear = self.plant;
        linear.adhesion = None;
        let lin = linear.creep(x, e.curv[0]);
        let slip = 0.5 * (lin.fx_r + lin.fx_l) / p.f11 * x[ix::V];
        let t_spring = self.plant.spring_torque(x);
        Record {
            t_s: t_ns as f64 * 1e-9,
            y_m: x[ix::Y],
            psi_rad: x[ix::PSI],
            t_psi_nm: t_ctrl + t_spring,
            fx_r_n: cr.fx_r,
            fx_l_n: cr.fx_l,
            fy_n: cr.fy,
            v_mps: x[ix::V],
            i_a_a: x[ix::IA],
            u_a_v: u_a,
            yd_mps: x[ix::YD],
            t_ctrl_nm: t_ctrl,
            t_spring_nm: t_spring,
            w_r_radps: x[ix::WR],
            w_l_radps: if self.plant.cfg.axle == crate::scenario::Axle::Rigid {
                x[ix::WR]
            } else {
                x[ix::WL]
            },
            w_m_radps: x[ix::WM],
            twist_rad: x[ix::TWIST],
            wind_rad: x[ix::WIND],
            i_ref_a: e.i_ref,
            demand_nm: e.demand,
            f_run_n: e.f_run,
            curvature_1pm: e.curv[0],
            cant_rad: e.cant[0],
            y0_m: p.pure_rolling_y(e.curv[0]),
            slip_mps: slip,
            mu_avail,
            mu_used: (cr.fx_r + cr.fx_l) / (2.0 * p.q()),
        }
    }

    fn steps(&self) -> (u64, u64) {
        let sc = self.sc;
        (
            sc.duration_ns.div_ceil(sc.dt_ns),
            sc.output_dt_ns / sc.dt_ns,
        )
    }
}

/// Runs `sc` with the continuous-time controllers (yaw `law`, PI current loop when the
/// drive is modelled). The plant has the passive spring only for [`YawLaw::Passive`].
pub fn run_continuous(sc: &Scenario, law: YawLaw) -> Trajectory {
    run_continuous_with(sc, ContinuousController::new(&sc.params, law))
}

/// As [`run_continuous`] with an explicit controller (e.g. a reversed sign in tests).
pub fn run_continuous_with(sc: &Scenario, ctrl: ContinuousController) -> Trajectory {
    let mut s = Setup::new(sc, ctrl.law.has_spring());
    let mut plant = s.plant;
    let drive = sc.drive;
    let mut x = plant.rolling_state(sc.params.v);
    if drive {
        x[ix::PI] = plant.back_emf(&x);
    }
    let (n_steps, every) = s.steps();
    let h = sc.dt_ns as f64 * 1e-9;
    let mut records = Vec::with_capacity((n_steps / every + 2) as usize);
    let mut diverged_at = None;
    for k in 0..n_steps {
        let t_ns = k * sc.dt_ns;
        let e = s.exo(t_ns);
        plant.adhesion = s.adhesion(t_ns);
        // A scenario's actuator fault scales the (linear) yaw law: the delivered torque.
        let ctrl = match &sc.actuator_fault {
            Some(f) => ContinuousController {
                k: ctrl.k * f.gain(t_ns),
                ..ctrl
            },
            None => ctrl,
        };
        if k % every == 0 {
            let u_a = if drive {
                ctrl.voltage(&x, e.i_ref)
            } else {
                0.0
            };
            records.push(s.record(t_ns, &x, &e, ctrl.yaw_torque(&x), u_a));
            if diverged(&x) {
                diverged_at = Some(t_ns as f64 * 1e-9);
                break;
            }
        }
        x = rk4_step(&x, h, |stage, xs| {
            let j = stage_slot(stage);
            let ex = Exogenous {
                curvature: e.curv[j],
                cant: e.cant[j],
                f_run: e.f_run,
                i_ref: e.i_ref,
                demand: e.demand,
            };
            closed_loop_rhs(&plant, &ctrl, xs, &ex)
        });
    }
    if diverged_at.is_none() {
        let t_end = n_steps * sc.dt_ns;
        let e = s.exo(t_end);
        s.adhesion(t_end);
        let u_a = if drive {
            ctrl.voltage(&x, e.i_ref)
        } else {
            0.0
        };
        let g = sc.actuator_fault.map_or(1.0, |f| f.gain(t_end));
        records.push(s.record(t_end, &x, &e, g * ctrl.yaw_torque(&x), u_a));
    }
    Trajectory {
        records,
        info: RunInfo {
            scenario: sc.name.clone(),
            source: sc.source.clone(),
            control: ctrl.law.name().to_string(),
            dt_s: h,
            steps: n_steps,
            controller_calls: 0,
            actuator_clamps: 0,
            diverged_at_s: diverged_at,
        },
    }
}

/// Sensor model applied to each measurement before the controller sees it: additive
/// Gaussian noise (standard deviation per channel) then quantisation to an LSB
/// (0 = none). Deterministic: seeded PCG64.
#[derive(Debug, Clone)]
pub struct SensorModel {
    /// Noise standard deviations for `[yd, ydd, i_a, w_m, w_wheel]`.
    pub noise_std: [f64; 5],
    /// Quantisation steps for the same channels (0 = none).
    pub lsb: [f64; 5],
    rng: Pcg64,
}

impl SensorModel {
    /// Perfect sensors.
    pub fn ideal() -> Self {
        Self::new([0.0; 5], [0.0; 5], 0)
    }

    /// Sensors with noise and quantisation; `seed` makes runs repeatable.
    pub fn new(noise_std: [f64; 5], lsb: [f64; 5], seed: u64) -> Self {
        SensorModel {
            noise_std,
            lsb,
            rng: Pcg64::seed_from_u64(seed),
        }
    }

    fn gauss(&mut self) -> f64 {
        // Box-Muller; u1 in (0, 1].
        let u1: f64 = 1.0 - self.rng.random::<f64>();
        let u2: f64 = self.rng.random::<f64>();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// Applies noise then quantisation.
    pub fn apply(&mut self, m: &Measurements) -> Measurements {
        let mut ch = [m.yd_mps, m.ydd_mps2, m.i_a, m.w_m, m.w_wheel];
        for (i, v) in ch.iter_mut().enumerate() {
            if self.noise_std[i] > 0.0 {
                *v += self.noise_std[i] * self.gauss();
            }
            if self.lsb[i] > 0.0 {
                *v = (*v / self.lsb[i]).round() * self.lsb[i];
            }
        }
        Measurements {
            yd_mps: ch[0],
            ydd_mps2: ch[1],
            i_a: ch[2],
            w_m: ch[3],
            w_wheel: ch[4],
            ..*m
        }
    }
}

/// Actuator model: limits on torque and voltage (each clamp counted), then a transport
/// delay (a multiple of the integration step), then zero-order hold until the next
/// command takes effect.
#[derive(Debug, Clone, PartialEq)]
pub struct ActuatorModel {
    /// `|T_psi|` limit, N m (infinite = none).
    pub t_psi_max: f64,
    /// Voltage range `[min, max]`, V.
    pub u_a_range: (f64, f64),
    /// Delay from the controller call to the actuation taking effect, ns.
    pub delay_ns: u64,
    /// Clamps counted so far.
    pub clamps: u64,
}

impl ActuatorModel {
    /// No limits, no delay.
    pub fn ideal() -> Self {
        ActuatorModel {
            t_psi_max: f64::INFINITY,
            u_a_range: (f64::NEG_INFINITY, f64::INFINITY),
            delay_ns: 0,
            clamps: 0,
        }
    }

    /// Clamps `a` to the limits, counting each clamp.
    pub fn limit(&mut self, a: Actuation) -> Actuation {
        let mut out = a;
        if !a.t_psi.is_finite() || a.t_psi.abs() > self.t_psi_max {
            out.t_psi = if a.t_psi.is_nan() {
                0.0
            } else {
                a.t_psi.clamp(-self.t_psi_max, self.t_psi_max)
            };
            self.clamps += 1;
        }
        let (lo, hi) = self.u_a_range;
        if !a.u_a.is_finite() || a.u_a < lo || a.u_a > hi {
            out.u_a = if a.u_a.is_nan() {
                0.0f64.clamp(lo, hi)
            } else {
                a.u_a.clamp(lo, hi)
            };
            self.clamps += 1;
        }
        out
    }
}

/// The sensor frame the plant produces at state `x` with actuation `held` in force.
pub fn measure(
    plant: &Plant,
    x: &State,
    held: &Actuation,
    u: &Inputs<f64>,
    demand: f64,
    i_ref: f64,
) -> Measurements {
    let uu = Inputs {
        t_psi: held.t_psi,
        u_a: held.u_a,
        ..*u
    };
    let (dx, _) = plant.rhs(x, &uu);
    let w_l = if plant.cfg.axle == crate::scenario::Axle::Rigid {
        x[ix::WR]
    } else {
        x[ix::WL]
    };
    Measurements {
        yd_mps: x[ix::YD],
        ydd_mps2: dx[ix::YD],
        i_a: x[ix::IA],
        w_m: if plant.cfg.drive {
            x[ix::WM]
        } else {
            plant.n() * 0.5 * (x[ix::WR] + w_l)
        },
        w_wheel: 0.5 * (x[ix::WR] + w_l),
        demand_nm: demand,
        i_ref,
        v_mps: x[ix::V],
    }
}

/// Runs `sc` with a discrete controller. The plant has no yaw spring unless
/// `yaw_spring` (the active controller replaces it). Each period: measure (with the
/// actuation held from before), apply the sensor model, call the controller, apply the
/// actuator model, and hold the result from `t + delay` (ZOH). Records carry the held
/// actuation. Without the drive, `u_a` is ignored and the demand acts on the wheel.
pub fn run_sampled(
    sc: &Scenario,
    ctrl: &mut dyn SampledController,
    sensor: &mut SensorModel,
    actuator: &mut ActuatorModel,
    yaw_spring: bool,
    label: &str,
) -> Result<Trajectory, SimError> {
    let period = ctrl.period_ns();
    if period == 0 || !period.is_multiple_of(sc.dt_ns) {
        return Err(SimError::Period {
            period_ns: period,
            dt_ns: sc.dt_ns,
        });
    }
    if !actuator.delay_ns.is_multiple_of(sc.dt_ns) {
        return Err(SimError::Delay {
            delay_ns: actuator.delay_ns,
            dt_ns: sc.dt_ns,
        });
    }
    let mut s = Setup::new(sc, yaw_spring);
    let mut plant = s.plant;
    let drive = sc.drive;
    let mut x = plant.rolling_state(sc.params.v);
    let (n_steps, every) = s.steps();
    let h = sc.dt_ns as f64 * 1e-9;
    let mut records = Vec::with_capacity((n_steps / every + 2) as usize);
    let mut pending: VecDeque<(u64, Actuation)> = VecDeque::new();
    let mut calls = 0u64;
    let inputs = |e: &Exo, j: usize, a: &Actuation| Inputs {
        t_psi: a.t_psi,
        u_a: if drive { a.u_a } else { 0.0 },
        curvature: e.curv[j],
        cant: e.cant[j],
        f_run: e.f_run,
        t_drive: if drive { 0.0 } else { e.demand },
    };
    // The plant's actuator: the torque it delivers for the held command (a scenario
    // fault scales it from its time on; sampled at integrator step starts).
    let fault = |t_ns: u64, a: &Actuation| match &sc.actuator_fault {
        Some(f) => Actuation {
            t_psi: f.delivered(t_ns, a.t_psi),
            ..*a
        },
        None => *a,
    };
    let e0 = s.exo(0);
    plant.adhesion = s.adhesion(0);
    let m0 = measure(
        &plant,
        &x,
        &Actuation::default(),
        &inputs(&e0, 0, &Actuation::default()),
        e0.demand,
        e0.i_ref,
    );
    let mut held = ctrl.initial(&m0, plant.k_m());
    let mut diverged_at = None;
    for k in 0..=n_steps {
        let t_ns = k * sc.dt_ns;
        let e = s.exo(t_ns);
        plant.adhesion = s.adhesion(t_ns);
        if k < n_steps && t_ns.is_multiple_of(period) {
            let on = fault(t_ns, &held);
            let m = measure(&plant, &x, &on, &inputs(&e, 0, &on), e.demand, e.i_ref);
            let m = sensor.apply(&m);
            let a = actuator.limit(ctrl.step(t_ns, &m));
            calls += 1;
            pending.push_back((t_ns + actuator.delay_ns, a));
        }
        while let Some(&(due, a)) = pending.front() {
            if due > t_ns {
                break;
            }
            held = a;
            pending.pop_front();
        }
        if k % every == 0 || k == n_steps {
            let t_psi = fault(t_ns, &held).t_psi;
            let mut r = s.record(t_ns, &x, &e, t_psi, if drive { held.u_a } else { 0.0 });
            if !drive {
                r.u_a_v = 0.0;
            }
            records.push(r);
            if diverged(&x) {
                diverged_at = Some(t_ns as f64 * 1e-9);
                break;
            }
        }
        if k == n_steps {
            break;
        }
        let a = fault(t_ns, &held);
        let u = [inputs(&e, 0, &a), inputs(&e, 1, &a), inputs(&e, 2, &a)];
        x = rk4_step_with(&x, h, PlantStages { plant: &plant, u });
    }
    Ok(Trajectory {
        records,
        info: RunInfo {
            scenario: sc.name.clone(),
            source: sc.source.clone(),
            control: label.to_string(),
            dt_s: h,
            steps: n_steps,
            controller_calls: calls,
            actuator_clamps: actuator.clamps,
            diverged_at_s: diverged_at,
        },
    })
}

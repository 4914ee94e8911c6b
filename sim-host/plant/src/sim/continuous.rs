//! The continuous-time reference run (the f64 controllers in the state), and the set-up
//! shared with the sampled run.

use super::*;
use crate::adhesion::{Adhesion, Condition};
use crate::control::{ContinuousController, Exogenous, YawLaw};
use crate::plant::{ix, Flags, Plant, PlantConfig, State};
use crate::scenario::{Scenario, TrackCursor};

#[inline(always)]
pub(super) fn stage_slot(stage: usize) -> usize {
    match stage {
        0 => 0,
        3 => 2,
        _ => 1,
    }
}

/// Sets up the plant, initial state and exogenous input function for a scenario.
pub(super) struct Setup<'a> {
    pub(super) sc: &'a Scenario,
    pub(super) plant: Plant,
    pub(super) track: TrackCursor,
    /// `(condition, v, peak)` of the last [`Setup::mu_avail`] (recomputed when the
    /// condition changes or the speed moves by more than 1 mm/s).
    pub(super) peak_cache: Option<(Condition, f64, f64)>,
    /// `(t_ns, curvature, cant)` of the last step's end: the next step's start.
    pub(super) track_end: Option<(u64, f64, f64)>,
    /// The rail condition of the last [`Setup::adhesion`], `None` before the first.
    pub(super) condition: Option<Option<Condition>>,
}

impl<'a> Setup<'a> {
    pub(super) fn new(sc: &'a Scenario, yaw_spring: bool) -> Self {
        let cfg = PlantConfig {
            axle: sc.axle,
            drive: sc.drive,
            yaw_spring,
        };
        Setup {
            sc,
            plant: Plant::new(&sc.params, cfg),
            track: TrackCursor::default(),
            peak_cache: None,
            track_end: None,
            condition: None,
        }
    }

    /// Puts the rail condition of `t_ns` on the setup's plant and returns the law.
    pub(super) fn adhesion(&mut self, t_ns: u64) -> Option<Adhesion> {
        let a = self
            .sc
            .condition_at(t_ns)
            .map(|c| Adhesion::new(c, self.sc.params.q()));
        self.plant.adhesion = a;
        self.condition = Some(a.map(|a| a.condition));
        a
    }

    /// [`Setup::adhesion`] if the rail condition of `t_ns` is new since the last call, else `None`.
    #[inline(always)]
    pub(super) fn adhesion_change(&mut self, t_ns: u64) -> Option<Option<Adhesion>> {
        if self.condition == Some(self.sc.condition_at(t_ns)) {
            return None;
        }
        Some(self.adhesion(t_ns))
    }

    /// The peak adhesion of the present condition at speed `v` (`inf` without a law).
    pub(super) fn mu_avail(&mut self, v: f64) -> f64 {
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

    /// The exogenous inputs of the step from `t_ns` at its stage slots (start, midpoint, end).
    #[inline(always)]
    pub(super) fn exo(&mut self, t_ns: u64) -> [Exogenous<f64>; 3] {
        let sc = self.sc;
        let h = sc.dt_ns;
        let (c0, th0) = match self.track_end {
            Some((te, c, th)) if te == t_ns => (c, th),
            _ => self.track.at(&sc.track, t_ns),
        };
        let (c1, th1) = self.track.at(&sc.track, t_ns + h / 2);
        let (c2, th2) = self.track.at(&sc.track, t_ns + h);
        self.track_end = Some((t_ns + h, c2, th2));
        let demand = sc.traction.at(t_ns);
        let f_run = sc.resistance.at(t_ns);
        let i_ref = demand / (sc.params.n_gear * sc.params.k_m);
        [(c0, th0), (c1, th1), (c2, th2)].map(|(curvature, cant)| Exogenous {
            curvature,
            cant,
            f_run,
            i_ref,
            demand,
        })
    }

    /// The record of state `x` with inputs `e` at `t_ns` (by value, so a run's state
    /// need not stay in memory across this out-of-line call).
    pub(super) fn record(
        &mut self,
        t_ns: u64,
        x: State,
        e: Exogenous<f64>,
        t_ctrl: f64,
        u_a: f64,
    ) -> Record {
        let (x, e) = (&x, &e);
        let mu_avail = self.mu_avail(x[ix::V]);
        let p = &self.sc.params;
        let cr = self.plant.creep(self.plant.cfg, x, e.curvature);
        // The linear law's forces (those of the plant without its adhesion law).
        let lin = if self.plant.adhesion.is_none() {
            cr
        } else {
            let mut linear = self.plant;
            linear.adhesion = None;
            linear.creep(linear.cfg, x, e.curvature)
        };
        let slip = 0.5 * (lin.fx_r + lin.fx_l) / p.f11 * x[ix::V];
        let t_spring = self.plant.spring_torque(self.plant.cfg, x);
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
            w_l_radps: self.plant.w_l(self.plant.cfg, x),
            w_m_radps: x[ix::WM],
            twist_rad: x[ix::TWIST],
            wind_rad: x[ix::WIND],
            i_ref_a: e.i_ref,
            demand_nm: e.demand,
            f_run_n: e.f_run,
            curvature_1pm: e.curvature,
            cant_rad: e.cant,
            y0_m: p.pure_rolling_y(e.curvature),
            slip_mps: slip,
            mu_avail,
            mu_used: (cr.fx_r + cr.fx_l) / (2.0 * p.q()),
        }
    }
}

/// `(RK4 steps, steps per record)` of a run of `sc`.
pub(super) fn steps(sc: &Scenario) -> (u64, u64) {
    (
        sc.duration_ns.div_ceil(sc.dt_ns),
        sc.output_dt_ns / sc.dt_ns,
    )
}

/// Runs `sc` with the continuous-time controllers (yaw `law`, PI current loop when the
/// drive is modelled). The plant has the passive spring only for [`YawLaw::Passive`].
pub fn run_continuous(sc: &Scenario, law: YawLaw) -> Trajectory {
    let (n_steps, every) = steps(sc);
    let mut records = Vec::with_capacity((n_steps / every + 2) as usize);
    let ctrl = ContinuousController::new(&sc.params, law);
    let info = run_continuous_each(sc, ctrl, |r| records.push(r));
    Trajectory { records, info }
}

/// [`run_continuous`] with `ctrl`, each record to `on_record` in time order, none kept.
pub fn run_continuous_each(
    sc: &Scenario,
    ctrl: ContinuousController,
    on_record: impl FnMut(Record),
) -> RunInfo {
    let s = Setup::new(sc, ctrl.law.has_spring());
    crate::with_flags!(s.plant.cfg, flags => continuous(s, ctrl, flags, on_record))
}

fn continuous<F: Flags>(
    mut s: Setup<'_>,
    ctrl: ContinuousController,
    flags: F,
    mut on_record: impl FnMut(Record),
) -> RunInfo {
    let sc = s.sc;
    let mut plant = s.plant;
    let drive = sc.drive;
    let mut x = crate::linear::operating_point(&plant, &sc.params);
    let (n_steps, every) = steps(sc);
    let h = sc.dt_ns as f64 * 1e-9;
    let mut diverged_at = None;
    let mut next_record = 0;
    for k in 0..n_steps {
        let t_ns = k * sc.dt_ns;
        let e = s.exo(t_ns);
        if let Some(a) = s.adhesion_change(t_ns) {
            plant.adhesion = a;
        }
        let ctrl = match &sc.actuator_fault {
            Some(f) => ContinuousController {
                k: ctrl.k * f.gain(t_ns),
                ..ctrl
            },
            None => ctrl,
        };
        if k == next_record {
            next_record += every;
            let u_a = ctrl.inputs(&x, &e[0], drive).u_a;
            on_record(s.record(t_ns, x, e[0], ctrl.yaw_torque(&x), u_a));
            if diverged(x) {
                diverged_at = Some(t_ns as f64 * 1e-9);
                break;
            }
        }
        x = crate::with_creep_law!(plant, flags => rk4_step_with(
            &x,
            h,
            ClosedLoopStages {
                plant: &plant,
                flags,
                ctrl: &ctrl,
                e,
            },
        ));
    }
    if diverged_at.is_none() {
        let t_end = n_steps * sc.dt_ns;
        let [e, ..] = s.exo(t_end);
        s.adhesion(t_end);
        let u_a = ctrl.inputs(&x, &e, drive).u_a;
        let g = sc.actuator_fault.map_or(1.0, |f| f.gain(t_end));
        on_record(s.record(t_end, x, e, g * ctrl.yaw_torque(&x), u_a));
    }
    RunInfo {
        scenario: sc.name.clone(),
        source: sc.source.clone(),
        control: ctrl.law.name().to_string(),
        dt_s: h,
        steps: n_steps,
        controller_calls: 0,
        actuator_clamps: 0,
        diverged_at_s: diverged_at,
    }
}

//! The sampled-data run: a [`SampledController`] at its period behind optional sensor
//! and actuator models, the plant between its calls.

use super::*;
use crate::control::{Actuation, Exogenous, Measurements, SampledController};
use crate::plant::{ix, Flags, Inputs, Plant, State};
use crate::scenario::Scenario;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use std::collections::VecDeque;

/// Sensor model: additive Gaussian noise (standard deviation per channel), then
/// quantisation to an LSB (0 = none). Deterministic: seeded PCG64.
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

    /// Applies noise then quantisation.
    #[inline]
    pub fn apply(&mut self, m: &Measurements) -> Measurements {
        if self.noise_std == [0.0; 5] && self.lsb == [0.0; 5] {
            return *m;
        }
        self.apply_any(m)
    }

    /// [`SensorModel::apply`] for any channel settings.
    #[inline(never)]
    fn apply_any(&mut self, m: &Measurements) -> Measurements {
        let mut ch = [m.yd_mps, m.ydd_mps2, m.i_a, m.w_m, m.w_wheel];
        for (i, v) in ch.iter_mut().enumerate() {
            if self.noise_std[i] > 0.0 {
                *v += self.noise_std[i] * self.rng.sample::<f64, _>(StandardNormal);
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

/// Actuator model: limits on torque and voltage (each clamp counted), a transport delay
/// (a multiple of the integration step), then zero-order hold.
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
        // NaN becomes 0 (within the limits).
        let mut clamp = |v: f64, (lo, hi): (f64, f64)| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                return v;
            }
            self.clamps += 1;
            if v.is_nan() { 0.0 } else { v }.clamp(lo, hi)
        };
        Actuation {
            t_psi: clamp(a.t_psi, (-self.t_psi_max, self.t_psi_max)),
            u_a: clamp(a.u_a, self.u_a_range),
        }
    }
}

/// The sensor frame at `x` under the inputs `u` (the actuation held), `e`'s demand and `i_ref`.
fn measure<F: Flags>(
    plant: &Plant,
    flags: F,
    x: &State,
    u: &Inputs<f64>,
    e: &Exogenous<f64>,
) -> Measurements {
    let (dx, _) = plant.rhs(flags, x, u);
    let w_l = plant.w_l(flags, x);
    Measurements {
        yd_mps: x[ix::YD],
        ydd_mps2: dx[ix::YD],
        i_a: x[ix::IA],
        w_m: if flags.cfg().drive {
            x[ix::WM]
        } else {
            plant.n * 0.5 * (x[ix::WR] + w_l)
        },
        w_wheel: 0.5 * (x[ix::WR] + w_l),
        demand_nm: e.demand,
        i_ref: e.i_ref,
        v_mps: x[ix::V],
    }
}

/// Runs `sc` with a discrete controller (no yaw spring unless `yaw_spring`). Each
/// period: measure (the actuation held), the sensor model, the controller, the actuator
/// model, and hold the result from `t + delay`. Without the drive `u_a` is ignored. A
/// [deferring](SampledController::defers) controller hands each actuation over when due.
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
    let s = Setup::new(sc, yaw_spring);
    crate::with_flags!(s.plant.cfg, flags => {
        Ok(sampled(s, ctrl, sensor, actuator, period, label, flags))
    })
}

fn sampled<F: Flags>(
    mut s: Setup<'_>,
    ctrl: &mut dyn SampledController,
    sensor: &mut SensorModel,
    actuator: &mut ActuatorModel,
    period: u64,
    label: &str,
    flags: F,
) -> Trajectory {
    let sc = s.sc;
    // The integrator's own copy of the plant, read only by inlined code (so it is not
    // reloaded every step); calls out of line get the set-up's, with the same law.
    let mut plant = s.plant;
    let drive = sc.drive;
    let mut x = s.plant.rolling_state(sc.params.v);
    let (n_steps, every) = steps(sc);
    let h = sc.dt_ns as f64 * 1e-9;
    let mut records = Vec::with_capacity((n_steps / every + 2) as usize);
    let mut pending: VecDeque<(u64, Actuation)> = VecDeque::new();
    // When the front of `pending` is due, ns; `u64::MAX` while none is pending.
    let mut next_due = u64::MAX;
    let mut calls = 0u64;
    let defers = ctrl.defers();
    let inputs = |e: &Exogenous<f64>, a: &Actuation| Inputs {
        t_psi: a.t_psi,
        u_a: if drive { a.u_a } else { 0.0 },
        curvature: e.curvature,
        cant: e.cant,
        f_run: e.f_run,
        t_drive: if drive { 0.0 } else { e.demand },
    };
    let fault = |t_ns: u64, a: &Actuation| match &sc.actuator_fault {
        Some(f) => Actuation {
            t_psi: f.delivered(t_ns, a.t_psi),
            ..*a
        },
        None => *a,
    };
    let [e0, ..] = s.exo(0);
    plant.adhesion = s.adhesion(0);
    let m0 = measure(
        &s.plant,
        flags,
        &x,
        &inputs(&e0, &Actuation::default()),
        &e0,
    );
    let mut held = ctrl.initial(&m0, s.plant.k_m);
    let mut diverged_at = None;
    let (mut next_call, mut next_record) = (0, 0);
    for k in 0..=n_steps {
        let t_ns = k * sc.dt_ns;
        let e = s.exo(t_ns);
        if let Some(a) = s.adhesion_change(t_ns) {
            plant.adhesion = a;
        }
        if k < n_steps && t_ns == next_call {
            next_call += period;
            let on = fault(t_ns, &held);
            let m = measure(&s.plant, flags, &x, &inputs(&e[0], &on), &e[0]);
            let m = sensor.apply(&m);
            let a = ctrl.step(t_ns, &m);
            // A deferring controller's actuation is taken (and limited) when due.
            let a = if defers { a } else { actuator.limit(a) };
            calls += 1;
            let due = t_ns + actuator.delay_ns;
            if pending.is_empty() {
                next_due = due;
            }
            pending.push_back((due, a));
        }
        while next_due <= t_ns {
            if let Some((due, a)) = pending.pop_front() {
                held = if defers {
                    actuator.limit(ctrl.take_deferred(due))
                } else {
                    a
                };
            }
            next_due = pending.front().map_or(u64::MAX, |&(due, _)| due);
        }
        let record = k == next_record;
        if record {
            next_record += every;
        }
        if record || k == n_steps {
            let t_psi = fault(t_ns, &held).t_psi;
            records.push(s.record(t_ns, x, e[0], t_psi, if drive { held.u_a } else { 0.0 }));
            if diverged(x) {
                diverged_at = Some(t_ns as f64 * 1e-9);
                break;
            }
        }
        if k == n_steps {
            break;
        }
        let a = fault(t_ns, &held);
        let u = e.map(|e| inputs(&e, &a));
        x = crate::with_creep_law!(plant, flags => rk4_step_with(
            &x,
            h,
            PlantStages {
                plant: &plant,
                flags,
                u,
            },
        ));
    }
    // The steps whose actuation was not due by the end: taken and limited all the same.
    if defers {
        for (due, _) in pending.drain(..) {
            actuator.limit(ctrl.take_deferred(due));
        }
    }
    Trajectory {
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
    }
}

//! The one driver of a controller on the plant: `run_sampled` with an ideal sensor, the
//! actuation computed from the sample at `t_k` in force from `t_k + d T` (ZOH), and each
//! period's record handed to the caller as it happens (nothing kept per period here).

use wheelset_plant::control::{Actuation, Measurements, SampledController};
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_sampled, ActuatorModel, SensorModel, SimError, Trajectory};

/// Runs `sc` with `ctrl`, its actuation delayed by `delay_ticks` periods (at least one);
/// the plant keeps its passive yaw spring only with `yaw_spring`. After every step,
/// `each(ctrl, t_ns, actuation)` gets the controller and what the step returned (a
/// [deferring](SampledController::defers) controller's actuation comes later).
pub fn drive<C: SampledController>(
    sc: &Scenario,
    ctrl: &mut C,
    delay_ticks: u32,
    yaw_spring: bool,
    label: &str,
    each: impl FnMut(&C, u64, &Actuation),
) -> Result<Trajectory, SimError> {
    let mut actuator = ActuatorModel {
        delay_ns: ctrl.period_ns() * u64::from(delay_ticks.max(1)),
        ..ActuatorModel::ideal()
    };
    let mut each = Each { ctrl, each };
    run_sampled(
        sc,
        &mut each,
        &mut SensorModel::ideal(),
        &mut actuator,
        yaw_spring,
        label,
    )
}

/// `ctrl` with `each` called after every step.
struct Each<'c, C, F> {
    ctrl: &'c mut C,
    each: F,
}

impl<C: SampledController, F: FnMut(&C, u64, &Actuation)> SampledController for Each<'_, C, F> {
    fn period_ns(&self) -> u64 {
        self.ctrl.period_ns()
    }

    fn step(&mut self, t_ns: u64, m: &Measurements) -> Actuation {
        let a = self.ctrl.step(t_ns, m);
        (self.each)(self.ctrl, t_ns, &a);
        a
    }

    fn initial(&self, m: &Measurements, k_m: f64) -> Actuation {
        self.ctrl.initial(m, k_m)
    }

    fn defers(&self) -> bool {
        self.ctrl.defers()
    }

    fn take_deferred(&mut self, due_ns: u64) -> Actuation {
        self.ctrl.take_deferred(due_ns)
    }
}

//! The warning before a device-loop run at a rate the project's own sampled-data
//! analysis ([`wheelset_plant::sampled`]) finds unstable: the device's configuration for the
//! scenario (its law, gains, the requested base rate) is closed around the linear plant
//! of case (d) at the scenario's creep coefficient and conicity, with the firmware's one
//! tick of delay, and the monodromy eigenvalues are checked (`|mu| < 1`).

use crate::device_loop::control_config;
use wheelset_plant::control::YawLaw;
use wheelset_plant::sampled::{closed_loop, Model};
use wheelset_plant::scenario::Scenario;

/// The firmware's actuation delay, ticks.
const DELAY_TICKS: usize = 1;

/// A warning when the sampled loop of `sc` with `law` at `base_rate_hz` is unstable
/// at the scenario's operating point (or the analysis cannot be done); `None` when it
/// is stable, or the rate is refused later anyway (not a divisor of 1 s, invalid).
#[must_use]
pub fn warning(sc: &Scenario, law: YawLaw, base_rate_hz: u32) -> Option<String> {
    let mut cfg = control_config(&sc.params, law, sc.drive);
    cfg.base_rate_hz = base_rate_hz;
    if cfg.validate().is_err() {
        return None;
    }
    let p = &sc.params;
    let plant = Model::Full.plant(p, p.f11, p.lambda, law.has_spring());
    match closed_loop(&plant, &cfg, DELAY_TICKS) {
        Ok(cl) if cl.stable() => None,
        Ok(cl) => Some(format!(
            "--rate-hz {base_rate_hz}: the sampled-data analysis finds the {} loop unstable at \
             f11 = {:.3e} N, conicity {} (spectral radius {:.4} per tick; worst mode {:.2} Hz, \
             zeta {:.4}); the run will diverge: see `sim-host rates --control {}` for the rates \
             that are stable",
            law.name(),
            p.f11,
            p.lambda,
            cl.spectral_radius,
            cl.worst.freq_hz,
            cl.worst.zeta,
            law.name()
        )),
        Err(e) => Some(format!(
            "--rate-hz {base_rate_hz}: the sampled-data analysis could not be done ({e})"
        )),
    }
}

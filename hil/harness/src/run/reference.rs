//! The yardstick of a run's numerics: the f64 continuous-time controllers on the plant,
//! or, on a track with `[[adhesion]]` sections (the continuous controllers have no
//! wheel-slip protection) or at a designed rate other than the scenario's, the control
//! core itself in f64 (`wheelset_loop::core`, the run's protection and gains).

use wheelset_plant::control::YawLaw;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_continuous, Trajectory};

use super::RunError;
use crate::check::numerics::every_nth;
use num_integer::gcd;

/// The reference of `sc` under `law` at the output interval and, where it is the control
/// core, the same run at the gcd of that and `period_ns` for
/// [`crate::check::numerics::compare_fine`] (its every `output / gcd`-th record the first).
pub(super) fn make(
    sc: &Scenario,
    law: YawLaw,
    wsp: bool,
    period_ns: u64,
    designed: Option<&wheelset_control::Config>,
) -> Result<(Trajectory, Option<Trajectory>), RunError> {
    if sc.adhesion.is_empty() && designed.is_none() {
        return Ok((run_continuous(sc, law), None));
    }
    let mut at_ticks = sc.clone();
    at_ticks.output_dt_ns = gcd(sc.output_dt_ns, period_ns);
    let cfg = designed
        .copied()
        .unwrap_or_else(|| wheelset_loop::device_loop::control_config(&sc.params, law, sc.drive));
    let fine = wheelset_loop::core::run_core_with::<f64>(&at_ticks, &cfg, law, wsp)
        .map_err(|e| RunError::Input(format!("scenario {}: {e}", sc.source)))?
        .0;
    let every = sc.output_dt_ns / at_ticks.output_dt_ns.max(1);
    Ok((every_nth(&fine, every as usize), Some(fine)))
}

/// The part of `tr` before `t_s` (a run that diverged later did not diverge there).
pub(super) fn before(tr: &Trajectory, t_s: f64) -> Trajectory {
    let mut t = Trajectory {
        records: tr.records.iter().filter(|r| r.t_s < t_s).cloned().collect(),
        info: tr.info.clone(),
    };
    t.info.diverged_at_s = tr.info.diverged_at_s.filter(|d| *d < t_s);
    t
}

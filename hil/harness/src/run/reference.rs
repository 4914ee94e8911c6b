//! The yardstick of a run's numerics: the f64 continuous-time controllers on the plant,
//! or, on a track with `[[adhesion]]` sections or at a rate other than the paper's, the
//! control core itself in f64.

use wheelset_plant::control::YawLaw;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_continuous, Trajectory};

use super::RunError;
use crate::check::numerics::{every_nth, gcd};

/// The reference of `sc` under `law` at the output interval, and the same run recorded at
/// the control period `period_ns` where there is one (for the numerics' tube,
/// [`crate::check::numerics::compare_fine`]).
///
/// With `[[adhesion]]` sections the continuous controllers (no wheel-slip protection)
/// are no yardstick: the reference is then the control core in f64 with the device's
/// protection (as the run set it, `Config.wsp`), timing and wire quantisation
/// (`wheelset_loop::core`). It is recorded at the greatest common divisor of the output
/// interval and the control period (a multiple of the integration step, since both are),
/// and every `output / that`-th record is the output-interval reference: the same run, so
/// the two agree on every record they share. The protection's cuts are shorter than the
/// output interval (`crate::check::numerics`), the continuous reference has none.
///
/// At another rate than the scenario's (`designed`: the device's control core with the
/// gains designed for that rate, `wheelset_control::design`) the gains are not the
/// continuous controllers' either: the reference is the same f64 core at the same rate.
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

//! The warning before a device-loop run whose loops the sampled-data analysis finds
//! unstable: the device's configuration for the scenario is closed around the linear
//! plant of case (d) at the scenario's creep and conicity, with the run's delay, one loop
//! at a time ([`wheelset_plant::sampled::margins`]), so the warning names the loop.

use crate::device_loop::control_config;
use wheelset_control::YawMode;
use wheelset_plant::control::YawLaw;
use wheelset_plant::sampled::{margins, Loop};
use wheelset_plant::scenario::Scenario;

/// The warning naming the loop (traction, yaw) of `sc` with `law` at `base_rate_hz` and
/// `delay_ticks` that is unstable there; `None` when both are stable or the rate is invalid.
#[must_use]
pub fn warning(sc: &Scenario, law: YawLaw, base_rate_hz: u32, delay_ticks: u8) -> Option<String> {
    let base = control_config(&sc.params, law, sc.drive);
    let cfg = base
        .designed(base_rate_hz, delay_ticks)
        .unwrap_or(wheelset_control::Config {
            base_rate_hz,
            delay_ticks,
            ..base
        });
    if cfg.validate().is_err() {
        return None;
    }
    let p = &sc.params;
    let mut loops = vec![];
    if cfg.traction_enabled && sc.drive {
        loops.push(Loop::Traction);
    }
    if cfg.yaw_mode != YawMode::Passive {
        loops.push(Loop::Yaw);
    }
    let mut unstable = vec![];
    for l in loops {
        match margins(p, &cfg, usize::from(delay_ticks.max(1)), l) {
            Ok(m) if m.stable => {}
            Ok(_) => unstable.push(match l {
                Loop::Traction => "the traction current loop (armature and PI)".to_string(),
                Loop::Yaw => format!("the yaw loop ({})", law.name()),
            }),
            Err(e) => {
                return Some(format!(
                    "--rate-hz {base_rate_hz}: the sampled-data analysis could not be done ({e})"
                ))
            }
        }
    }
    (!unstable.is_empty()).then(|| {
        format!(
            "--rate-hz {base_rate_hz}: the sampled-data analysis finds {} unstable at f11 = \
             {:.3e} N, conicity {}, with these parameters; it will diverge or limit-cycle: see \
             `sim-host rates` for the designed rates and their margins",
            unstable.join(" and "),
            p.f11,
            p.lambda
        )
    })
}

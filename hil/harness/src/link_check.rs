//! The link against the rate, before a run: one exchange per period must fit the
//! project's one link budget (`wheelset_proto::link`: the worst-case Sensor frame of
//! the harness (one lateral value) up and Actuation frame down x 10 bits / baud plus
//! twice the link latency, within [`LINK_SHARE_MAX_PERMILLE`] of the period; the rest of
//! the period is the device's execution time and margin). A combination that does not
//! fit is refused with the highest rate this baud carries and the lowest baud this rate
//! needs, from the same budget.

use wheelset_proto::link::{link_fits, max_rate_hz, min_baud, LinkError, LINK_SHARE_MAX_PERMILLE};
use wheelset_proto::{ACTUATION_MAX_FRAME, SENSOR_ONE_LATERAL_MAX_FRAME};

const UP: u32 = SENSOR_ONE_LATERAL_MAX_FRAME as u32;
const DOWN: u32 = ACTUATION_MAX_FRAME as u32;

/// Checks the link of a run; the error names the budget's numbers, the highest rate this
/// baud carries and the lowest baud this rate needs.
pub fn check(baud: u32, rate_hz: u32, latency_ns: u64) -> Result<(), String> {
    let share = LINK_SHARE_MAX_PERMILLE;
    match link_fits(rate_hz, baud, UP, DOWN, latency_ns, share) {
        Ok(_) => Ok(()),
        Err(e) => {
            let why = match e {
                LinkError::TooSlow {
                    needed_ns,
                    allowed_ns,
                } => format!(
                    "({UP} + {DOWN}) bytes x 10 bits / {baud} baud + 2 x {latency_ns} ns latency \
                     = {:.1} us per period, but only {:.0} % of the {:.1} us period = {:.1} us \
                     is allowed",
                    needed_ns as f64 * 1e-3,
                    f64::from(share) / 10.0,
                    1e6 / f64::from(rate_hz.max(1)),
                    allowed_ns as f64 * 1e-3
                ),
                other => format!("{other:?}"),
            };
            Err(format!(
                "link budget exceeded: --baud {baud} cannot carry --rate-hz {rate_hz}: {why}. \
                 At {baud} baud the \
                 highest rate is {} Hz; {rate_hz} Hz needs at least {}",
                max_rate_hz(baud, UP, DOWN, latency_ns, share),
                min_baud(rate_hz, UP, DOWN, latency_ns, share).map_or(
                    "a shorter latency (no baud suffices)".to_string(),
                    |b| format!("{b} baud")
                )
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_refusal_names_the_budget_s_edges() {
        let lat = 2_000;
        let s = LINK_SHARE_MAX_PERMILLE;
        let r = max_rate_hz(921_600, UP, DOWN, lat, s);
        assert!(link_fits(r, 921_600, UP, DOWN, lat, s).is_ok());
        assert!(link_fits(r + 1, 921_600, UP, DOWN, lat, s).is_err());
        let b = min_baud(5_000, UP, DOWN, lat, s).unwrap_or(0);
        let e = check(921_600, 5_000, lat).err().unwrap_or_default();
        assert!(e.contains(&format!("highest rate is {r} Hz")), "{e}");
        assert!(e.contains(&format!("at least {b} baud")), "{e}");
        assert!(check(wheelset_loop::link::DEFAULT_BAUD, 5_000, lat).is_ok());
        assert!(check(b, 5_000, lat).is_ok());
        assert!(check(b - 1, 5_000, lat).is_err());
    }
}

//! The link against the rate, before a run: one exchange per period must fit the
//! project's one link budget (`sim_host::link::check_budget`: the worst-case Sensor and
//! Actuation frames x 10 bits / baud plus the link latency, within its share of the
//! period). A combination that does not fit is refused with the highest rate this baud
//! carries and the lowest baud this rate needs, both found by asking the same budget
//! (no second formula).

use sim_host::device::{ACTUATION_WORST_BYTES, SENSOR_WORST_BYTES};
use sim_host::link::check_budget;

fn fits(baud: u32, rate_hz: u32, latency_ns: u64) -> bool {
    rate_hz > 0
        && check_budget(
            SENSOR_WORST_BYTES,
            ACTUATION_WORST_BYTES,
            baud,
            latency_ns,
            1_000_000_000 / u64::from(rate_hz),
        )
        .is_ok()
}

/// The highest rate (Hz) whose exchange `baud` carries (0: none).
#[must_use]
pub fn max_rate_hz(baud: u32, latency_ns: u64) -> u32 {
    let (mut lo, mut hi) = (0u32, 10_000_000u32);
    // Invariant: `lo` fits (or is 0), `hi` does not.
    if fits(baud, hi, latency_ns) {
        return hi;
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if fits(baud, mid, latency_ns) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The lowest baud that carries the exchange at `rate_hz` (None: no baud does, the
/// latency alone takes the period).
#[must_use]
pub fn min_baud(rate_hz: u32, latency_ns: u64) -> Option<u32> {
    if !fits(u32::MAX, rate_hz, latency_ns) {
        return None;
    }
    let (mut lo, mut hi) = (0u32, u32::MAX);
    // Invariant: `hi` fits, `lo` does not.
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if fits(mid, rate_hz, latency_ns) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

/// Checks the link of a run; the error names the budget's numbers, the highest rate this
/// baud carries and the lowest baud this rate needs.
pub fn check(baud: u32, rate_hz: u32, latency_ns: u64) -> Result<(), String> {
    let period_ns = 1_000_000_000 / u64::from(rate_hz.max(1));
    match check_budget(
        SENSOR_WORST_BYTES,
        ACTUATION_WORST_BYTES,
        baud,
        latency_ns,
        period_ns,
    ) {
        Ok(_) => Ok(()),
        Err(e) => Err(format!(
            "--baud {baud} with --rate-hz {rate_hz}: {e}. At {baud} baud the highest rate is \
             {} Hz; {rate_hz} Hz needs at least {}",
            max_rate_hz(baud, latency_ns),
            min_baud(rate_hz, latency_ns).map_or(
                "a shorter latency (no baud suffices)".to_string(),
                |b| format!("{b} baud")
            )
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_limits_found_are_the_budget_s_edges() {
        let lat = sim_host::link::DEFAULT_LATENCY_NS;
        let r = max_rate_hz(921_600, lat);
        assert!(fits(921_600, r, lat) && !fits(921_600, r + 1, lat), "{r}");
        let b = min_baud(5_000, lat).unwrap_or(0);
        assert!(fits(b, 5_000, lat) && !fits(b - 1, 5_000, lat), "{b}");
        let e = check(921_600, 5_000, lat).err().unwrap_or_default();
        assert!(e.contains(&format!("highest rate is {r} Hz")), "{e}");
        assert!(e.contains(&format!("at least {b} baud")), "{e}");
        assert!(check(4_000_000, 5_000, lat).is_ok());
    }
}

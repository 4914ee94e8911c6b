//! The estimate of what a run or a sweep keeps in memory, checked against [`MAX_BYTES`]
//! before anything is allocated; a refusal gives the estimate and how to lower it.

use crate::sim::Record;

/// The most memory a run or a sweep may plan for: 2 GiB (of 24 GiB for up to eight
/// builds and runs at once).
pub const MAX_BYTES: u64 = 2 << 30;

/// Bytes of one output record.
pub const RECORD_BYTES: u64 = std::mem::size_of::<Record>() as u64;

/// Bytes kept per control period by the device loop: its link record (24 B) and the
/// fate of each of the period's two frames (`wheelset-loop` asserts the size).
pub const DEVICE_BYTES_PER_PERIOD: u64 = 24 + 16;

/// Bytes per creep point and case of `sim-host modes`: an upper bound of what a sweep keeps.
pub const MODES_BYTES_PER_POINT: u64 = 8_000;

/// Estimated bytes of a run (a record per `output_dt_ns`, one per `device_period_ns` if given).
#[must_use]
pub fn run_bytes(duration_ns: u64, output_dt_ns: u64, device_period_ns: Option<u64>) -> u64 {
    let records = duration_ns / output_dt_ns.max(1) + 2;
    let mut bytes = records.saturating_mul(RECORD_BYTES);
    if let Some(p) = device_period_ns {
        let periods = duration_ns / p.max(1) + 2;
        bytes = bytes.saturating_add(periods.saturating_mul(DEVICE_BYTES_PER_PERIOD));
    }
    bytes
}

/// `bytes` in MiB or GiB, for messages.
#[must_use]
pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= (1u64 << 30) as f64 {
        format!("{:.1} GiB", b / (1u64 << 30) as f64)
    } else {
        format!("{:.1} MiB", b / (1u64 << 20) as f64)
    }
}

/// Refuses `runs` trajectories kept at once (the device records count once) whose
/// estimate is above [`MAX_BYTES`]: the reason names the estimate, the limit, and the
/// longest duration that fits at this output interval.
pub fn check_runs(
    duration_ns: u64,
    output_dt_ns: u64,
    device_period_ns: Option<u64>,
    runs: u64,
) -> Result<(), String> {
    let runs = runs.max(1);
    let bytes_for = |d: u64| {
        let extra = run_bytes(d, output_dt_ns, None).saturating_mul(runs - 1);
        run_bytes(d, output_dt_ns, device_period_ns).saturating_add(extra)
    };
    let bytes = bytes_for(duration_ns);
    if bytes <= MAX_BYTES {
        return Ok(());
    }
    let fits_s = MAX_BYTES / bytes_for(1_000_000_000).max(1);
    Err(format!(
        "{} would keep about {} in memory ({} records of {RECORD_BYTES} B at sim.output_dt_s = {} s{}), \
         above the limit of {}: lower duration_s to at most about {fits_s} s, or raise sim.output_dt_s",
        if runs == 1 {
            "the run".to_string()
        } else {
            format!("{runs} runs kept together (--compare, the reference)")
        },
        human(bytes),
        duration_ns / output_dt_ns.max(1) + 2,
        output_dt_ns as f64 * 1e-9,
        match device_period_ns {
            Some(p) => format!(
                ", plus {} link records of {DEVICE_BYTES_PER_PERIOD} B, one per {} us period",
                duration_ns / p.max(1) + 2,
                p as f64 * 1e-3
            ),
            None => String::new(),
        },
        human(MAX_BYTES),
    ))
}

/// Refuses a modal sweep above [`MAX_BYTES`], naming the largest `--points` that fits.
pub fn check_modes(points: u64, cases: u64) -> Result<(), String> {
    let bytes = points
        .saturating_mul(cases)
        .saturating_mul(MODES_BYTES_PER_POINT);
    if bytes <= MAX_BYTES {
        return Ok(());
    }
    Err(format!(
        "--points {points}: the sweep of {cases} case(s) would keep about {} in memory, above the \
         limit of {}: use at most --points {}{}",
        human(bytes),
        human(MAX_BYTES),
        MAX_BYTES / MODES_BYTES_PER_POINT / cases.max(1),
        if cases > 1 {
            format!(
                ", or one case (--case) for up to {}",
                MAX_BYTES / MODES_BYTES_PER_POINT
            )
        } else {
            String::new()
        }
    ))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn estimates_scale_with_the_output_and_refuse_above_the_limit() {
        assert_eq!(RECORD_BYTES as usize, 8 * Record::COLUMNS.len());
        assert!(check_runs(20_000_000_000, 1_000_000, Some(200_000), 1).is_ok());
        let e = check_runs(100_000_000_000_000, 1_000_000, None, 1).unwrap_err();
        assert!(
            e.contains(&format!(
                "{:.1} GiB",
                (100_000_002 * RECORD_BYTES) as f64 / (1u64 << 30) as f64
            )) && e.contains("lower duration_s"),
            "{e}"
        );
        // Raising the output interval is the way out that the message names.
        assert!(check_runs(100_000_000_000_000, 100_000_000, None, 1).is_ok());
        // Runs kept together count together.
        assert!(check_runs(2_000_000_000_000, 1_000_000, None, 1).is_ok());
        let e = check_runs(2_000_000_000_000, 1_000_000, None, 8).unwrap_err();
        assert!(e.contains("8 runs"), "{e}");
        assert!(check_modes(1000, 4).is_ok());
        let e = check_modes(1_000_000, 4).unwrap_err();
        assert!(
            e.contains("--points 1000000") && e.contains("use at most"),
            "{e}"
        );
    }
}

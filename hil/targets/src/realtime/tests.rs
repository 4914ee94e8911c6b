//! The baseline arithmetic of the frame accounting and the transmit queue.

use super::*;

#[test]
fn the_counters_are_taken_relative_to_the_baseline() {
    let baseline = Status {
        ticks: 1_000,
        rx_ok: 7,
        rx_crc: 2,
        ..Status::default()
    };
    let start = RunStart {
        baseline,
        ticks_before_run: 3,
        pre_run: 1_200,
    };
    let end = Status {
        ticks: 3_003,
        rx_ok: 2_008,
        rx_crc: 2,
        safe_ticks: 9,
        ..Status::default()
    };
    let r = start.relative(&end);
    assert_eq!((r.ticks, r.rx_ok, r.rx_crc), (2_000, 2_001, 0));
    // Fields the accounting does not read stay as the device sent them.
    assert_eq!(r.safe_ticks, 9);
    // Counters wrap at 2^32.
    let wrapped = RunStart {
        baseline: Status {
            ticks: u32::MAX,
            ..Status::default()
        },
        ticks_before_run: 0,
        pre_run: 0,
    };
    assert_eq!(
        wrapped
            .relative(&Status {
                ticks: 4,
                ..Status::default()
            })
            .ticks,
        5
    );
}

#[test]
fn a_frame_that_does_not_fit_the_queue_is_dropped_whole() {
    let mut q = VecDeque::new();
    assert!(queue_frame(&mut q, 8, &[1, 2, 3, 0]));
    assert!(!queue_frame(&mut q, 8, &[1, 2, 3, 4, 0]));
    assert_eq!(q.len(), 4);
    let mut out = Vec::new();
    flush_queue(&mut out, &mut q).unwrap_or_default();
    assert_eq!(out, vec![1, 2, 3, 0]);
    assert!(q.is_empty());
}

#[test]
fn the_period_is_found_through_burst_reads() {
    // A device ticking every 203 us (1.5 % slow against a 200 us run), its frames
    // read in bursts of 5: each burst stamped at the read of its last frame.
    let t = 200_000.0;
    let tick = 203_000.0;
    let ticks: Vec<u16> = (0..32u16).map(|i| 65_520u16.wrapping_add(i)).collect();
    let outs: Vec<f64> = (0..32)
        .map(|i| {
            let last_of_burst = (i / 5) * 5 + 4;
            7_000.0 + f64::from(last_of_burst) * tick
        })
        .collect();
    let p = envelope_period(&ticks, &outs, t);
    assert!((p - tick).abs() < 1.0, "{p}");
    // The median spacing of the same frames says 0 (most of them share a stamp).
    let mut sp: Vec<f64> = outs.windows(2).map(|w| w[1] - w[0]).collect();
    sp.sort_by(f64::total_cmp);
    assert_eq!(sp[sp.len() / 2], 0.0);
    assert_eq!(envelope_period(&ticks[..3], &outs[..3], t), 0.0);
}

#[test]
fn the_run_starts_at_the_first_answer_to_any_of_its_sensor_frames() {
    // The run sent seqs 7, 8, 9: the device echoing 8 (7 was superseded within one of
    // its ticks) answers the run; 0 (no sample) and 6 (before the run) do not.
    assert!(echoes_this_run(7, 7, 9));
    assert!(echoes_this_run(8, 7, 9));
    assert!(echoes_this_run(9, 7, 9));
    assert!(!echoes_this_run(10, 7, 9));
    assert!(!echoes_this_run(6, 7, 9));
    assert!(!echoes_this_run(0, 7, 9));
    // Across the wrap of the 16-bit seq.
    assert!(echoes_this_run(2, 65_534, 3));
    assert!(!echoes_this_run(65_533, 65_534, 3));
}

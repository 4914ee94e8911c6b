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

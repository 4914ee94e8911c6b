//! The link budget's edges (`wheelset_proto::link`, the module docs' equations): the
//! comparisons are exact, so an exchange that takes exactly its share fits and one
//! nanosecond more does not; each direction's frame is judged on its own when the
//! exchange is pipelined, the larger of the two whichever way it goes; `min_baud` is the
//! least baud that fits, also where the rounding up of the time on the line makes the
//! real-valued bound too low; `max_rate_hz` and `min_baud` at their degenerate inputs;
//! the errors' messages.

use wheelset_proto::link::*;

/// 1 Mbaud: one byte (10 bits with start and stop) takes 10 us on the line.
const MBAUD: u32 = 1_000_000;

#[test]
fn the_time_on_the_line_is_rounded_up_and_saturates() {
    // ceil(bytes x 10 x 1e9 / baud).
    assert_eq!(wire_ns(1, 10), 1_000_000_000);
    assert_eq!(wire_ns(3, 7), 30_000_000_000_u64.div_ceil(7));
    assert_eq!(wire_ns(100, MBAUD), 1_000_000);
    // Beyond u64 nanoseconds: the largest.
    assert_eq!(wire_ns(u64::MAX, 1), u64::MAX);
    assert_eq!(wire_ns(u64::MAX / 10, 1), u64::MAX);
    // The round trip: both frames on the line, the latency each way.
    assert_eq!(round_trip_ns(MBAUD, 60, 40, 7), 1_000_000 + 14);
    assert_eq!(round_trip_ns(MBAUD, 0, 0, u64::MAX), u64::MAX);
    // The share of a period: floor(share x 1e6 / rate).
    assert_eq!(allowed_ns(3, 1_000), 333_333_333);
    assert_eq!(allowed_ns(7, 850), 121_428_571);
    assert_eq!(allowed_ns(0, 850), 0);
}

#[test]
fn a_round_trip_of_exactly_its_share_fits_and_one_nanosecond_more_does_not() {
    // 1 kHz, the whole period (1 ms): 100 bytes at 1 Mbaud take 1 ms.
    assert_eq!(link_fits(1_000, MBAUD, 50, 50, 0, 1_000), Ok(1_000_000));
    assert_eq!(
        link_fits(1_000, MBAUD, 50, 50, 1, 1_000),
        Err(LinkError::TooSlow {
            needed_ns: 1_000_002,
            allowed_ns: 1_000_000
        })
    );
    // The same at 85 %: 850 us allowed; 85 bytes take 850 us.
    assert_eq!(
        link_fits(1_000, MBAUD, 45, 40, 0, LINK_SHARE_MAX_PERMILLE),
        Ok(850_000)
    );
    assert!(link_fits(1_000, MBAUD, 45, 41, 0, LINK_SHARE_MAX_PERMILLE).is_err());
    // The shares at the ends of their range: 1 and 1000 permille are shares.
    assert!(link_fits(1, MBAUD, 1, 1, 0, 1).is_ok());
    assert!(link_fits(1_000, MBAUD, 50, 50, 0, 1_000).is_ok());
}

#[test]
fn pipelined_each_frame_must_fit_its_period_the_larger_either_way() {
    // Two ticks of delay: the round trip has 2 ms, each direction 1 ms.
    for (up, down) in [(100, 0), (0, 100), (100, 100)] {
        assert_eq!(
            link_fits_delayed(1_000, MBAUD, up, down, 0, 1_000, 2),
            Ok(wire_ns(u64::from(up) + u64::from(down), MBAUD)),
            "{up} + {down} bytes"
        );
    }
    // One byte more in either direction: that frame alone overruns its period, though
    // the round trip (1.01 ms) fits the delay.
    for (up, down) in [(101, 0), (0, 101), (101, 3), (3, 101)] {
        assert_eq!(
            link_fits_delayed(1_000, MBAUD, up, down, 0, 1_000, 2),
            Err(LinkError::TooSlow {
                needed_ns: 1_010_000,
                allowed_ns: 1_000_000
            }),
            "{up} + {down} bytes"
        );
    }
    // The round trip's limit is the share of the whole delay.
    assert_eq!(
        link_fits_delayed(1_000, MBAUD, 100, 100, 1, 1_000, 2),
        Err(LinkError::TooSlow {
            needed_ns: 2_000_002,
            allowed_ns: 2_000_000
        })
    );
}

#[test]
fn min_baud_is_the_least_baud_that_fits() {
    // A baud fits wherever `u32::MAX` does, and `min_baud` gives the least: no lower one
    // fits, also at a period of no whole number of nanoseconds, where the least lies
    // several bauds above the real-valued bound (3 kHz, 21 + 28 bytes, 70 %: 2 100 004).
    assert_eq!(
        min_baud(3_000, 21, 28, 0, LINK_SHARE_WARN_PERMILLE),
        Some(2_100_004)
    );
    let (mut given, mut rounded_up) = (0, 0);
    // (3 and 7 kHz: periods of no whole number of nanoseconds.)
    for rate in [500u32, 1_000, 3_000, 3_125, 5_000, 7_000, 20_000] {
        for up in 1u32..=60 {
            for down in [1u32, 28] {
                for lat in [0u64, 1_234] {
                    for share in [LINK_SHARE_WARN_PERMILLE, LINK_SHARE_MAX_PERMILLE, 1_000] {
                        let fits = |baud| link_fits(rate, baud, up, down, lat, share).is_ok();
                        let Some(b) = min_baud(rate, up, down, lat, share) else {
                            assert!(!fits(u32::MAX), "{rate} {up} {down} {lat} {share}");
                            continue;
                        };
                        given += 1;
                        assert!(fits(b) && !fits(b - 1), "{rate} {up} {down} {lat} {share}");
                        // The real-valued bound: bits x 1e9 / baud <= share x T - 2 lat.
                        let avail = u128::from(share) * 1_000_000_000
                            - u128::from(lat) * 2 * 1_000 * u128::from(rate);
                        let bits = u128::from(up + down) * 10;
                        let bound =
                            (bits * 1_000_000_000 * 1_000 * u128::from(rate)).div_ceil(avail);
                        assert!(u128::from(b) >= bound);
                        rounded_up += usize::from(u128::from(b) > bound);
                    }
                }
            }
        }
    }
    // Every case is given, and some need a baud above the real-valued bound (the time on
    // the line rounded up).
    assert_eq!(given, 7 * 60 * 2 * 2 * 3);
    assert!(rounded_up > 0, "{rounded_up}");
}

#[test]
fn degenerate_links() {
    // No bytes and no latency: every rate, and the least baud.
    assert_eq!(max_rate_hz(1, 0, 0, 0, LINK_SHARE_MAX_PERMILLE), u32::MAX);
    assert_eq!(min_baud(1_000, 0, 0, 0, LINK_SHARE_MAX_PERMILLE), Some(1));
    // No share, or more than the whole period: no rate, no baud.
    for share in [0, 1_001] {
        assert_eq!(max_rate_hz(MBAUD, 10, 10, 0, share), 0, "{share}");
        assert_eq!(min_baud(1_000, 10, 10, 0, share), None, "{share}");
    }
    assert_eq!(min_baud(0, 10, 10, 0, 850), None);
    assert_eq!(max_rate_hz(MBAUD, 50, 50, 0, 1_000), 1_000);
    // The latency alone takes the whole share (2 x 500 us of a 1 ms period): no baud.
    assert_eq!(min_baud(1_000, 10, 10, 500_000, 1_000), None);
    // 2 x 499 us: 2 us left for 200 bits, 100 Mbaud.
    assert_eq!(min_baud(1_000, 10, 10, 499_000, 1_000), Some(100_000_000));
    // More than u32 baud needed: none.
    assert_eq!(min_baud(20_000, 1_000, 1_000, 0, 1), None);
}

#[test]
fn the_link_errors_say_why() {
    let s = |e: LinkError| e.to_string();
    assert!(s(LinkError::ZeroRate).contains("rate is 0"));
    assert!(s(LinkError::ZeroBaud).contains("baud is 0"));
    assert!(s(LinkError::Share).contains("permille"));
    assert!(s(LinkError::ZeroDelay).contains("delay is 0"));
    let slow = s(LinkError::TooSlow {
        needed_ns: 614_000,
        allowed_ns: 170_000,
    });
    assert!(
        slow.contains("614000 ns") && slow.contains("170000 ns"),
        "{slow}"
    );
}

#[test]
fn the_largest_baud_is_a_baud() {
    // A link that needs exactly u32::MAX baud gets it. 1 Hz, the whole period: 1 000 949
    // bytes take T = ceil(1 000 949 x 10 x 1e9 / (2^32 - 1)) = 2 330 516 ns at 2^32 - 1
    // baud, and just over T at one baud less (T - x < x / (2^32 - 2) for the exact
    // time x); the latency, twice, makes up the rest of the second.
    let (bytes, t) = (1_000_949u32, 2_330_516u64);
    assert_eq!(wire_ns(u64::from(bytes), u32::MAX), t);
    let lat = (1_000_000_000 - t) / 2;
    assert_eq!(
        link_fits(1, u32::MAX, bytes, 0, lat, 1_000),
        Ok(1_000_000_000)
    );
    assert!(link_fits(1, u32::MAX - 1, bytes, 0, lat, 1_000).is_err());
    assert_eq!(min_baud(1, bytes, 0, lat, 1_000), Some(u32::MAX));
}

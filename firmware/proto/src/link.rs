//! The link budget: whether the frames of one tick fit the period (lock-step), or
//! pipelined over `d` ticks ([`link_fits_delayed`]); `latency_ns` one way:
//!
//! ```text
//! needed  = ceil((up + down) bytes x BITS_PER_BYTE / baud)  + 2 latency     (ns)
//! allowed = share x T = share_permille / 1000 x 1e9 / rate_hz               (ns)
//! lock-step:  needed <= allowed
//! pipelined:  ceil(max(up, down) bytes x BITS_PER_BYTE / baud) <= share x T,  needed <= share x d T
//! ```
//!
//! ```
//! use wheelset_proto::link::{link_fits, LINK_SHARE_MAX_PERMILLE};
//! use wheelset_proto::{ACTUATION_MAX_FRAME, SENSOR_MAX_FRAME};
//! const _: () = assert!(link_fits(
//!     5_000, 5_000_000, SENSOR_MAX_FRAME as u32, ACTUATION_MAX_FRAME as u32, 2_000,
//!     LINK_SHARE_MAX_PERMILLE,
//! ).is_ok());
//! ```

/// Bits on the line per byte: start, 8 data, stop (8N1).
pub const BITS_PER_BYTE: u64 = 10;

/// The largest share of the period the round trip may take (85 %); above it, refused.
pub const LINK_SHARE_MAX_PERMILLE: u32 = 850;

/// The design target (70 %): the rate table sizes the baud for it; above it, a warning.
pub const LINK_SHARE_WARN_PERMILLE: u32 = 700;

const NS_PER_S: u128 = 1_000_000_000;

/// Why a link does not carry the exchange.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkError {
    /// The rate is zero.
    ZeroRate,
    /// The baud is zero.
    ZeroBaud,
    /// The share is zero or above 1000 permille.
    Share,
    /// The delay is zero ticks.
    ZeroDelay,
    /// The round trip (pipelined: or one direction's frame) does not fit.
    TooSlow {
        /// Round-trip time needed, ns.
        needed_ns: u64,
        /// Round-trip time allowed (the share of the period), ns.
        allowed_ns: u64,
    },
}

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::ZeroRate => write!(f, "link budget: the rate is 0 Hz"),
            Self::ZeroBaud => write!(f, "link budget: the baud is 0"),
            Self::Share => write!(f, "link budget: the share must be 1 ..= 1000 permille"),
            Self::ZeroDelay => write!(f, "link budget: the delay is 0 ticks"),
            Self::TooSlow {
                needed_ns,
                allowed_ns,
            } => write!(
                f,
                "link budget exceeded: the exchange needs {needed_ns} ns, its share of the \
                 period (or of the delay) allows {allowed_ns} ns"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for LinkError {}

/// Time on the line, ns: `ceil(bytes x BITS_PER_BYTE x 1e9 / baud)` (saturating; baud 0: max).
#[must_use]
pub const fn wire_ns(bytes: u64, baud: u32) -> u64 {
    if baud == 0 {
        return u64::MAX;
    }
    let bits = bytes as u128 * BITS_PER_BYTE as u128 * NS_PER_S;
    let ns = bits.div_ceil(baud as u128);
    if ns > u64::MAX as u128 {
        u64::MAX
    } else {
        ns as u64
    }
}

/// The round trip of one tick, ns: `wire_ns(up + down, baud) + 2 latency_ns` (saturating).
#[must_use]
pub const fn round_trip_ns(baud: u32, up_bytes: u32, down_bytes: u32, latency_ns: u64) -> u64 {
    wire_ns(up_bytes as u64 + down_bytes as u64, baud).saturating_add(latency_ns.saturating_mul(2))
}

/// The share of the period allowed, ns: `floor(share_permille x 1e6 / rate_hz)` (0 for rate 0).
#[must_use]
pub const fn allowed_ns(rate_hz: u32, share_permille: u32) -> u64 {
    if rate_hz == 0 {
        return 0;
    }
    (share_permille as u128 * 1_000_000 / rate_hz as u128) as u64
}

/// Whether one tick fits (exact: `needed x rate x 1000 <= share x 1e9`); the round trip, ns.
pub const fn link_fits(
    rate_hz: u32,
    baud: u32,
    up_bytes: u32,
    down_bytes: u32,
    latency_ns: u64,
    share_permille: u32,
) -> Result<u64, LinkError> {
    link_fits_delayed(
        rate_hz,
        baud,
        up_bytes,
        down_bytes,
        latency_ns,
        share_permille,
        1,
    )
}

/// [`link_fits`] pipelined over `delay_ticks` periods (module docs); the round-trip time, ns.
pub const fn link_fits_delayed(
    rate_hz: u32,
    baud: u32,
    up_bytes: u32,
    down_bytes: u32,
    latency_ns: u64,
    share_permille: u32,
    delay_ticks: u32,
) -> Result<u64, LinkError> {
    if delay_ticks == 0 {
        return Err(LinkError::ZeroDelay);
    }
    if rate_hz == 0 {
        return Err(LinkError::ZeroRate);
    }
    if baud == 0 {
        return Err(LinkError::ZeroBaud);
    }
    if share_permille == 0 || share_permille > 1000 {
        return Err(LinkError::Share);
    }
    let share = share_permille as u128 * NS_PER_S;
    let larger = if up_bytes > down_bytes {
        up_bytes
    } else {
        down_bytes
    };
    let needed_ns = round_trip_ns(baud, up_bytes, down_bytes, latency_ns);
    if needed_ns as u128 * rate_hz as u128 * 1000 > share * delay_ticks as u128 {
        return Err(LinkError::TooSlow {
            needed_ns,
            allowed_ns: allowed_ns(rate_hz, share_permille).saturating_mul(delay_ticks as u64),
        });
    }
    let one_way = wire_ns(larger as u64, baud);
    if one_way as u128 * rate_hz as u128 * 1000 > share {
        return Err(LinkError::TooSlow {
            needed_ns: one_way,
            allowed_ns: allowed_ns(rate_hz, share_permille),
        });
    }
    Ok(needed_ns)
}

/// The highest rate, Hz, at which [`link_fits`] holds; 0 if none.
#[must_use]
pub const fn max_rate_hz(
    baud: u32,
    up_bytes: u32,
    down_bytes: u32,
    latency_ns: u64,
    share_permille: u32,
) -> u32 {
    if baud == 0 || share_permille == 0 || share_permille > 1000 {
        return 0;
    }
    let needed = round_trip_ns(baud, up_bytes, down_bytes, latency_ns) as u128;
    if needed == 0 {
        return u32::MAX;
    }
    // rate <= share x 1e9 / (1000 needed)
    let r = share_permille as u128 * NS_PER_S / (1000 * needed);
    if r > u32::MAX as u128 {
        u32::MAX
    } else {
        r as u32
    }
}

/// The lowest baud at which [`link_fits`] holds at `rate_hz`, if any within `u32`.
#[must_use]
pub fn min_baud(
    rate_hz: u32,
    up_bytes: u32,
    down_bytes: u32,
    latency_ns: u64,
    share_permille: u32,
) -> Option<u32> {
    let fits = |baud| {
        link_fits(
            rate_hz,
            baud,
            up_bytes,
            down_bytes,
            latency_ns,
            share_permille,
        )
        .is_ok()
    };
    if !fits(u32::MAX) {
        return None;
    }
    // Monotone in baud; `fits(hi)`, `lo` 1 or not fitting: 32 halvings leave `hi` the least.
    let (mut lo, mut hi) = (1u32, u32::MAX);
    for _ in 0..32 {
        let mid = lo + (hi - lo) / 2;
        if fits(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_link_fits_with_its_round_trip() {
        // 61 bytes x 10 bits at 4 Mbaud = 152.5 us -> 152 500 ns, + 2 x 2 us.
        assert_eq!(link_fits(5_000, 4_000_000, 33, 28, 2_000, 850), Ok(156_500));
        // 1 Mbaud: 610 us > 170 us.
        assert_eq!(
            link_fits(5_000, 1_000_000, 33, 28, 2_000, 850),
            Err(LinkError::TooSlow {
                needed_ns: 614_000,
                allowed_ns: 170_000
            })
        );
    }

    #[test]
    fn a_pipelined_link_carries_a_round_trip_longer_than_the_period() {
        // An ST-LINK-like bridge: 921 600 baud, 1 ms each way. 1 kHz: 43 + 30 bytes take
        // 793 us on the line, the round trip 2.793 ms.
        let (rate, baud, lat) = (1_000, 921_600, 1_000_000);
        let rt = 2_000_000 + wire_ns(73, baud);
        for d in 1..=3 {
            assert_eq!(
                link_fits_delayed(rate, baud, 43, 30, lat, 850, d),
                Err(LinkError::TooSlow {
                    needed_ns: rt,
                    allowed_ns: 850_000 * u64::from(d)
                })
            );
        }
        assert_eq!(link_fits_delayed(rate, baud, 43, 30, lat, 850, 4), Ok(rt));
        // 2 kHz: one direction's frame alone (43 bytes, 467 us) overruns 85 % of 500 us,
        // however long the delay.
        assert_eq!(
            link_fits_delayed(2_000, baud, 43, 30, 0, 850, 10),
            Err(LinkError::TooSlow {
                needed_ns: wire_ns(43, baud),
                allowed_ns: 425_000
            })
        );
        assert_eq!(
            link_fits_delayed(1, 1, 1, 1, 0, 850, 0),
            Err(LinkError::ZeroDelay)
        );
        // One tick is link_fits.
        for baud in [1_000_000, 4_000_000, 5_000_000] {
            assert_eq!(
                link_fits_delayed(5_000, baud, 43, 30, 2_000, 850, 1),
                link_fits(5_000, baud, 43, 30, 2_000, 850)
            );
        }
    }

    #[test]
    fn degenerate_inputs_are_errors_not_panics() {
        assert_eq!(link_fits(0, 1, 1, 1, 0, 850), Err(LinkError::ZeroRate));
        assert_eq!(link_fits(1, 0, 1, 1, 0, 850), Err(LinkError::ZeroBaud));
        assert_eq!(link_fits(1, 1, 1, 1, 0, 0), Err(LinkError::Share));
        assert_eq!(link_fits(1, 1, 1, 1, 0, 1001), Err(LinkError::Share));
        assert!(link_fits(u32::MAX, 1, u32::MAX, u32::MAX, u64::MAX, 1000).is_err());
        assert_eq!(max_rate_hz(0, 1, 1, 0, 850), 0);
        assert_eq!(min_baud(5_000, 33, 28, 100_000, 850), None);
        assert_eq!(wire_ns(1, 0), u64::MAX);
    }

    #[test]
    fn the_helpers_are_the_edges_of_link_fits() {
        for (rate, up, down, lat) in [
            (5_000u32, 33u32, 28u32, 2_000u64),
            (3_125, 38, 28, 0),
            (20_000, 33, 28, 500),
            (100, 1, 1, 1_000_000),
        ] {
            for share in [LINK_SHARE_WARN_PERMILLE, LINK_SHARE_MAX_PERMILLE, 1000] {
                let b = min_baud(rate, up, down, lat, share).expect("some baud");
                assert!(link_fits(rate, b, up, down, lat, share).is_ok());
                assert!(link_fits(rate, b - 1, up, down, lat, share).is_err());
                let r = max_rate_hz(b, up, down, lat, share);
                assert!(r >= rate);
                assert!(link_fits(r, b, up, down, lat, share).is_ok());
                assert!(link_fits(r + 1, b, up, down, lat, share).is_err());
            }
        }
    }
}

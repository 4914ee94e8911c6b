//! Which designed point a link carries: every base rate and delay the device accepts
//! judged by the pipelined link budget ([`wheelset_proto::link::link_fits_delayed`]),
//! the fastest carried chosen for the active yaw laws and for the passive one; where
//! none is carried, what the link would need (latency at this baud, baud at this latency).

use wheelset_control::design::{DesignPoint, DESIGNED};
use wheelset_proto::link::{link_fits_delayed, round_trip_ns, wire_ns, LINK_SHARE_MAX_PERMILLE};
use wheelset_proto::{ACTUATION_MAX_FRAME, SENSOR_ONE_LATERAL_MAX_FRAME};

const UP: u32 = SENSOR_ONE_LATERAL_MAX_FRAME as u32;
const DOWN: u32 = ACTUATION_MAX_FRAME as u32;

/// One designed point against the link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkPoint {
    /// The design point.
    pub point: DesignPoint,
    /// Round trip of the worst-case frames, ns.
    pub round_trip_ns: u64,
    /// What the delay allows it: 85 % of `d T`, ns.
    pub allowed_ns: u64,
    /// The larger frame's time on the line, ns (within 85 % of `T` when carried).
    pub one_way_ns: u64,
    /// The link carries the point.
    pub carried: bool,
    /// The largest one-way latency with which this baud carries the point, ns.
    pub max_latency_ns: Option<u64>,
    /// The lowest baud that carries the point at this latency.
    pub min_baud: Option<u32>,
}

/// The designed points against one link, and the fastest carried.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkChoice {
    /// Baud (10 bits per byte).
    pub baud: u32,
    /// One-way latency, ns.
    pub latency_ns: u64,
    /// The longest delay considered, ticks.
    pub max_delay: u8,
    /// Every designed point with a delay up to `max_delay`, in the table's order.
    pub points: Vec<LinkPoint>,
    /// The fastest carried point whose yaw law is designed (shortest delay first).
    pub active: Option<DesignPoint>,
    /// The fastest carried point (the passive law: the traction loop alone).
    pub passive: Option<DesignPoint>,
}

fn fits(p: &DesignPoint, baud: u32, latency_ns: u64) -> bool {
    link_fits_delayed(
        p.base_rate_hz,
        baud,
        UP,
        DOWN,
        latency_ns,
        LINK_SHARE_MAX_PERMILLE,
        u32::from(p.delay_ticks),
    )
    .is_ok()
}

/// The least `x` in `lo..=hi` with `pred(x)`, `pred` false then true, true at `hi` (bisection).
fn least(mut lo: u64, mut hi: u64, pred: impl Fn(u64) -> bool) -> u64 {
    if pred(lo) {
        return lo;
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// The largest latency carrying `p` at `baud` (bisection on the budget itself).
fn max_latency(p: &DesignPoint, baud: u32) -> Option<u64> {
    fits(p, baud, 0).then(|| least(0, 1_000_000_000, |l| !fits(p, baud, l)) - 1)
}

/// The lowest baud carrying `p` at `latency_ns` (bisection; `None` above 1 Gbaud).
fn min_baud(p: &DesignPoint, latency_ns: u64) -> Option<u32> {
    let top = 1_000_000_000u32;
    fits(p, top, latency_ns).then(|| {
        let b = least(1, u64::from(top), |b| fits(p, b as u32, latency_ns));
        b as u32
    })
}

/// Every designed point with up to `max_delay` ticks of delay on a link of `baud`, `latency_ns`.
#[must_use]
pub fn link_choice(baud: u32, latency_ns: u64, max_delay: u8) -> LinkChoice {
    let points: Vec<LinkPoint> = DESIGNED
        .iter()
        .filter(|p| p.delay_ticks <= max_delay)
        .map(|p| {
            let period_share =
                wheelset_proto::link::allowed_ns(p.base_rate_hz, LINK_SHARE_MAX_PERMILLE);
            LinkPoint {
                point: *p,
                round_trip_ns: round_trip_ns(baud, UP, DOWN, latency_ns),
                allowed_ns: period_share.saturating_mul(u64::from(p.delay_ticks)),
                one_way_ns: wire_ns(u64::from(UP.max(DOWN)), baud),
                carried: fits(p, baud, latency_ns),
                max_latency_ns: max_latency(p, baud),
                min_baud: min_baud(p, latency_ns),
            }
        })
        .collect();
    // Fastest first; among equal rates the shortest delay (less phase lost).
    let best = |yaw_needed: bool| {
        points
            .iter()
            .filter(|l| l.carried && (l.point.yaw || !yaw_needed))
            .map(|l| l.point)
            .min_by_key(|p| (std::cmp::Reverse(p.base_rate_hz), p.delay_ticks))
    };
    LinkChoice {
        baud,
        latency_ns,
        max_delay,
        active: best(true),
        passive: best(false),
        points,
    }
}

impl LinkChoice {
    /// The table and the choice, as `sim-host rates` prints them.
    #[must_use]
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let us = |ns: u64| ns as f64 / 1e3;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "== the designed points over a link of {} baud, {:.1} us each way (worst-case \
             frames {UP} B up, {DOWN} B down; pipelined over d ticks: each frame within \
             {} % of T, the round trip within {} % of d T)",
            self.baud,
            us(self.latency_ns),
            LINK_SHARE_MAX_PERMILLE / 10,
            LINK_SHARE_MAX_PERMILLE / 10,
        );
        let _ = writeln!(
            s,
            "   base  d  yaw law   | frame us / allowed | round trip us / allowed | carried | latency at most us  baud at least"
        );
        for l in &self.points {
            let p = &l.point;
            let period_share = l.allowed_ns / u64::from(p.delay_ticks.max(1));
            let _ = writeln!(
                s,
                "  {:>5} {:>2}  {:<9} | {:>8.1} / {:>7.1} | {:>12.1} / {:>8.1} | {:<7} | {:>18} {:>14}",
                p.base_rate_hz,
                p.delay_ticks,
                if p.yaw { "designed" } else { "passive" },
                us(l.one_way_ns),
                us(period_share),
                us(l.round_trip_ns),
                us(l.allowed_ns),
                if l.carried { "yes" } else { "no" },
                l.max_latency_ns
                    .map_or("-".to_string(), |n| format!("{:.1}", us(n))),
                l.min_baud.map_or("-".to_string(), |b| b.to_string()),
            );
        }
        let name = |p: &DesignPoint| {
            format!(
                "{} Hz with {} tick(s) of delay",
                p.base_rate_hz, p.delay_ticks
            )
        };
        let _ = match &self.active {
            Some(a) => writeln!(s, "chosen (lead, gain): {}", name(a)),
            None => writeln!(
                s,
                "chosen (lead, gain): none: no designed yaw law at delays up to {} tick(s) \
                 is carried by this link; it would need, for one of them, the latency or \
                 the baud in the last two columns",
                self.max_delay
            ),
        };
        let _ = match &self.passive {
            Some(p) => writeln!(s, "chosen (passive): {}", name(p)),
            None => writeln!(s, "chosen (passive): none carried"),
        };
        let _ = writeln!(
            s,
            "columns: frame = the larger frame's time on the line, allowed {} % of T; round \
             trip = both frames + twice the latency, allowed {} % of d T; latency at most = \
             the longest one-way latency this baud carries the point with; baud at least = \
             the slowest line carrying it at this latency",
            LINK_SHARE_MAX_PERMILLE / 10,
            LINK_SHARE_MAX_PERMILLE / 10,
        );
        s
    }

    /// The table and the choice as JSON.
    #[must_use]
    pub fn to_json(&self) -> serde_json::Value {
        let point = |p: &DesignPoint| {
            serde_json::json!({
                "base_rate_hz": p.base_rate_hz,
                "delay_ticks": p.delay_ticks,
            })
        };
        serde_json::json!({
            "baud": self.baud,
            "latency_ns": self.latency_ns,
            "max_delay_ticks": self.max_delay,
            "points": self.points.iter().map(|l| serde_json::json!({
                "base_rate_hz": l.point.base_rate_hz,
                "delay_ticks": l.point.delay_ticks,
                "yaw_designed": l.point.yaw,
                "round_trip_ns": l.round_trip_ns,
                "allowed_ns": l.allowed_ns,
                "one_way_ns": l.one_way_ns,
                "carried": l.carried,
                "max_latency_ns": l.max_latency_ns,
                "min_baud": l.min_baud,
            })).collect::<Vec<_>>(),
            "chosen_active": self.active.as_ref().map(point),
            "chosen_passive": self.passive.as_ref().map(point),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fastest_carried_point_is_chosen() {
        // The default simulated link (5 Mbaud, 2 us) carries 5 kHz in one tick, 10 kHz
        // only pipelined over two.
        let c = link_choice(5_000_000, 2_000, 3);
        let a = c.active.expect("a yaw design");
        assert_eq!((a.base_rate_hz, a.delay_ticks), (10_000, 2));
        let c = link_choice(5_000_000, 2_000, 1);
        let a = c.active.expect("a yaw design");
        assert_eq!((a.base_rate_hz, a.delay_ticks), (5_000, 1));
        // Every carried point fits and every other does not; the edges are the budget's.
        for l in &c.points {
            assert_eq!(l.carried, fits(&l.point, c.baud, c.latency_ns));
            if let Some(m) = l.max_latency_ns {
                assert!(fits(&l.point, c.baud, m) && !fits(&l.point, c.baud, m + 1));
            }
            if let Some(b) = l.min_baud {
                assert!(fits(&l.point, b, c.latency_ns) && !fits(&l.point, b - 1, c.latency_ns));
            }
        }
    }

    #[test]
    fn a_usb_bridge_carries_no_yaw_design_and_says_what_it_would_need() {
        // 921 600 baud, 1 ms each way (full-speed USB frames): the round trip is 2.8 ms.
        let c = link_choice(921_600, 1_000_000, 3);
        assert_eq!(c.active, None);
        let p = c.passive.expect("the passive law at a slow rate");
        assert_eq!((p.base_rate_hz, p.delay_ticks), (500, 2));
        assert!(c.render().contains("chosen (lead, gain): none"));
        // 1 kHz with one tick: the frames leave about 56 us of latency each way at this
        // baud.
        let l = c
            .points
            .iter()
            .find(|l| l.point.base_rate_hz == 1_000 && l.point.delay_ticks == 1)
            .expect("designed");
        let wire = wire_ns(u64::from(UP + DOWN), 921_600);
        assert_eq!(l.max_latency_ns, Some((850_000 - wire) / 2));
    }
}

//! The track: its knots (curvature and cant, piecewise linear in time) and the two
//! ways of reading it, [`track_at`] (from any time) and [`TrackCursor`] (forwards, as the
//! integrator steps; bit-identical to [`track_at`]).

/// One knot of the track: curvature and cant at a time; linear in between.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knot {
    /// Time, ns (the track is laid out in time at the initial speed).
    pub t_ns: u64,
    /// Curvature `1/R`, 1/m; positive = curve to the left (right wheel on the outer rail).
    pub curvature: f64,
    /// Cant angle `theta`, rad.
    pub cant: f64,
}

/// Curvature and cant at `t_ns`, with a cursor `hint` that makes monotone time
/// look-ups O(1). Straight, level track if there are no knots.
pub fn track_at(track: &[Knot], t_ns: u64, hint: &mut usize) -> (f64, f64) {
    let n = track.len();
    let (Some(first), Some(last)) = (track.first(), track.last()) else {
        return (0.0, 0.0);
    };
    if t_ns <= first.t_ns {
        return (first.curvature, first.cant);
    }
    if t_ns >= last.t_ns {
        return (last.curvature, last.cant);
    }
    let mut i = (*hint).min(n - 2);
    if track[i].t_ns > t_ns {
        i = 0;
    }
    while i + 1 < n - 1 && track[i + 1].t_ns <= t_ns {
        i += 1;
    }
    *hint = i;
    let (a, b) = (&track[i], &track[i + 1]);
    lerp(a, b, (b.t_ns - a.t_ns) as f64, t_ns)
}

/// Curvature and cant at `t_ns` on the segment from knot `a` to knot `b`, `span_ns` =
/// `(b.t_ns - a.t_ns) as f64`: `a + s (b - a)`.
#[inline(always)]
fn lerp(a: &Knot, b: &Knot, span_ns: f64, t_ns: u64) -> (f64, f64) {
    let s = (t_ns - a.t_ns) as f64 / span_ns;
    (
        a.curvature + s * (b.curvature - a.curvature),
        a.cant + s * (b.cant - a.cant),
    )
}

/// [`track_at`] for monotone times, remembering the span of the last look-up over which
/// the value holds (before the first knot, after the last, on a level segment) or one
/// sloped segment interpolates; inside it a look-up is one comparison, the values
/// bit-identical to [`track_at`]'s (default: at the start, an empty span).
#[derive(Debug, Clone, Copy, Default)]
pub struct TrackCursor {
    hint: usize,
    /// `[from, to)` ns over which `value` holds, or `seg` interpolates.
    span: (u64, u64),
    value: (f64, f64),
    /// The knots of the sloped segment and its duration, ns; `None`: `value` holds.
    seg: Option<(Knot, Knot, f64)>,
}

impl TrackCursor {
    /// Curvature `1/R` (1/m) and cant (rad) at `t_ns`, as [`track_at`].
    #[inline]
    pub fn at(&mut self, track: &[Knot], t_ns: u64) -> (f64, f64) {
        if t_ns >= self.span.0 && t_ns < self.span.1 {
            return match &self.seg {
                None => self.value,
                Some((a, b, span_ns)) => lerp(a, b, *span_ns, t_ns),
            };
        }
        self.seek(track, t_ns)
    }

    /// [`TrackCursor::at`] outside the span: [`track_at`], then the span of `t_ns`.
    #[inline(never)]
    fn seek(&mut self, track: &[Knot], t_ns: u64) -> (f64, f64) {
        let v = track_at(track, t_ns, &mut self.hint);
        self.value = v;
        self.span = (0, 0);
        self.seg = None;
        if let (Some(first), Some(last)) = (track.first(), track.last()) {
            if t_ns <= first.t_ns {
                // `track_at` returns the first knot for every t <= first.
                self.span = (0, first.t_ns + 1);
            } else if t_ns >= last.t_ns {
                self.span = (last.t_ns, u64::MAX);
            } else if let (Some(a), Some(b)) = (track.get(self.hint), track.get(self.hint + 1)) {
                // Interior: `hint` is the segment `[a, b)` that holds `t_ns` (the span
                // starts after the first knot, which `track_at` returns as is).
                self.span = (a.t_ns.max(first.t_ns + 1), b.t_ns);
                if a.curvature != b.curvature || a.cant != b.cant {
                    self.seg = Some((*a, *b, (b.t_ns - a.t_ns) as f64));
                }
            }
        }
        v
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::params::Params;
    use crate::scenario::{Scenario, BUILTIN};

    #[test]
    fn track_cursor_is_bit_identical_to_track_at() {
        // Every built-in track, a hand-made one with a level segment at the start and
        // signed zeros, stepped forwards at RK4 stage times, then at scattered times.
        let mut tracks: Vec<Vec<Knot>> = BUILTIN
            .iter()
            .map(|(name, _)| Scenario::load(name, &Params::default()).unwrap().track)
            .collect();
        let k = |t_ns, curvature, cant| Knot {
            t_ns,
            curvature,
            cant,
        };
        // (At 5 us `track_at` gives `-0 + 0 (-1e-3 + 0) = -0`, the level span's `+0`.)
        tracks.push(vec![
            k(1_000, -0.0, -0.0),
            k(5_000, -0.0, -0.0),
            k(9_000, -1e-3, -0.1),
            k(12_000, -1e-3, -0.1),
            k(13_000, 0.0, 0.0),
        ]);
        tracks.push(Vec::new());
        for track in &tracks {
            let end = track.last().map_or(20_000, |k| k.t_ns + 20_000);
            let step = (end / 20_000).max(1);
            let mut cur = TrackCursor::default();
            let mut spans = 0;
            let mut t = 0;
            while t <= end {
                for tt in [t, t + step / 2, t + step] {
                    let (a, b) = (cur.at(track, tt), track_at(track, tt, &mut 0));
                    assert_eq!(
                        (a.0.to_bits(), a.1.to_bits()),
                        (b.0.to_bits(), b.1.to_bits()),
                        "t = {tt} ns"
                    );
                    spans += usize::from(cur.span.1 > cur.span.0);
                }
                t += step;
            }
            assert!(track.len() < 2 || spans > 0, "no span was ever cached");
            // Around every knot: from each time of the neighbourhood to each other.
            for knot in track {
                let near = (knot.t_ns.saturating_sub(2))..=(knot.t_ns + 2);
                for p in near.clone() {
                    for q in near.clone() {
                        let mut cur = TrackCursor::default();
                        let _ = cur.at(track, p);
                        let (a, b) = (cur.at(track, q), track_at(track, q, &mut 0));
                        assert_eq!(
                            (a.0.to_bits(), a.1.to_bits()),
                            (b.0.to_bits(), b.1.to_bits()),
                            "{p} ns then {q} ns"
                        );
                    }
                }
            }
            for i in 0..5_000u64 {
                let tt = (i * 7_919_993) % (end + 1);
                let (a, b) = (cur.at(track, tt), track_at(track, tt, &mut 0));
                assert_eq!(
                    (a.0.to_bits(), a.1.to_bits()),
                    (b.0.to_bits(), b.1.to_bits())
                );
            }
        }
    }

    #[test]
    fn cursor_lookup_equals_fresh_lookup() {
        let s = Scenario::load("curve", &Params::default()).unwrap();
        let mut hint = 0;
        for k in 0..2000u64 {
            let t = k * 10_000_000;
            assert_eq!(
                track_at(&s.track, t, &mut hint),
                track_at(&s.track, t, &mut 0)
            );
        }
    }
}

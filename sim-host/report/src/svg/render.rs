//! Drawing a [`Plot`], its legend in a column right of the plotting area.

use std::fmt::Write as _;

use super::ticks::{fmt_log, log_ticks};
use super::{axis_labels, decimate, esc, fmt_tick, nice_ticks, Plot, Series, Style, PALETTE};

/// `v` on an axis: itself, or its `log10` on a log axis (NaN for `v <= 0`: never drawn).
fn axis(log: bool, v: f64) -> f64 {
    if !log {
        v
    } else if v > 0.0 {
        v.log10()
    } else {
        f64::NAN
    }
}

/// A box in px: left, top, right, bottom.
type Rect = (f64, f64, f64, f64);

/// Estimated width of a character at font-size 11, px (see [`super::lint`]).
const LABEL_CHAR_PX: f64 = 11.0 * super::lint::CHAR_WIDTH;

fn overlap(a: &Rect, b: &Rect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

impl Plot {
    /// The colour series `k` is drawn in.
    fn colour(&self, k: usize, s: &Series) -> String {
        s.color
            .clone()
            .unwrap_or_else(|| PALETTE[k % PALETTE.len()].to_string())
    }

    /// The colour of series `k` as an attribute's value, with its opacity when below 1.
    fn paint(&self, k: usize, s: &Series) -> String {
        let col = self.colour(k, s);
        if s.opacity < 1.0 {
            format!(
                "{col}\" stroke-opacity=\"{0}\" fill-opacity=\"{0}",
                s.opacity
            )
        } else {
            col
        }
    }

    /// The points of every series as drawn, px (at most about 2000 per series).
    fn drawn_px(&self, sx: &dyn Fn(f64) -> f64, sy: &dyn Fn(f64) -> f64) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        for s in &self.series {
            let step = (s.points.len() / 2000).max(1);
            for &(x, y) in s.points.iter().step_by(step) {
                let (x, y) = (sx(self.tx(x)), sy(self.ty(y)));
                if x.is_finite() && y.is_finite() {
                    out.push((x, y));
                }
            }
        }
        out
    }

    /// The points of series `k` (axis units) where it leaves the ranges drawn: the first
    /// point of each run outside them (each point for a scatter; at most 200).
    pub(super) fn clipped_exits(
        &self,
        k: usize,
        xr: (f64, f64),
        yr: (f64, f64),
    ) -> Vec<(f64, f64)> {
        let Some(s) = self.series.get(k) else {
            return Vec::new();
        };
        let (ex, ey) = (1e-9 * (xr.1 - xr.0), 1e-9 * (yr.1 - yr.0));
        let scatter = matches!(s.style, Style::Markers | Style::Crosses);
        let mut out = Vec::new();
        let mut inside = true;
        for &(x, y) in &s.points {
            let (x, y) = (self.tx(x), self.ty(y));
            if !(x.is_finite() && y.is_finite()) {
                inside = true;
                continue;
            }
            let outside = x < xr.0 - ex || x > xr.1 + ex || y < yr.0 - ey || y > yr.1 + ey;
            if outside && (inside || scatter) && out.len() < 200 {
                out.push((x, y));
            }
            inside = !outside;
        }
        out
    }

    /// The legend's rows: each labelled series, then a row per series with data beyond
    /// the ranges drawn: `(series index, text, clipped)`.
    fn legend_rows(&self) -> Vec<(usize, String, bool)> {
        let mut rows: Vec<(usize, String, bool)> = self
            .series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.label.is_empty())
            .map(|(k, s)| (k, s.label.clone(), false))
            .collect();
        if self.series.iter().any(|s| !s.points.is_empty()) {
            let (xr, yr) = self.data_range();
            for (k, s) in self.series.iter().enumerate() {
                if self.clipped_exits(k, xr, yr).is_empty() {
                    continue;
                }
                // An unlabelled series goes by the labelled one of its colour.
                let col = self.colour(k, s);
                let name = if s.label.is_empty() {
                    self.series
                        .iter()
                        .enumerate()
                        .find(|(j, o)| !o.label.is_empty() && self.colour(*j, o) == col)
                        .map_or("data", |(_, o)| o.label.as_str())
                } else {
                    &s.label
                };
                let short = name.split(':').next().unwrap_or(name);
                let text = format!("{short}: beyond the axes");
                if !rows.iter().any(|r| r.2 && r.1 == text) {
                    rows.push((k, text, true));
                }
            }
        }
        rows
    }

    fn tx(&self, x: f64) -> f64 {
        axis(self.x_log, x)
    }

    fn ty(&self, y: f64) -> f64 {
        axis(self.y_log, y)
    }

    /// A panel that carries only a note: no data and no marks, so no axes to read.
    fn note_only(&self) -> bool {
        !self.note.is_empty()
            && self.marks.is_empty()
            && self.bars.is_empty()
            && self.series.iter().all(|s| s.points.is_empty())
    }

    /// The ranges drawn, axis units (`log10` on a log axis): of data, bars and marks, or as given.
    pub(super) fn data_range(&self) -> ((f64, f64), (f64, f64)) {
        let (xl, yl) = (self.x_log, self.y_log);
        let mut xs = (f64::INFINITY, f64::NEG_INFINITY);
        let mut ys = xs;
        let grow = |r: &mut (f64, f64), v: f64| {
            if v.is_finite() {
                *r = (r.0.min(v), r.1.max(v));
            }
        };
        for s in &self.series {
            for &(x, y) in &s.points {
                let (x, y) = (axis(xl, x), axis(yl, y));
                if x.is_finite() && y.is_finite() {
                    grow(&mut xs, x);
                    grow(&mut ys, y);
                }
            }
        }
        for &(a, b, h) in &self.bars {
            if yl && h <= 0.0 {
                continue;
            }
            grow(&mut xs, axis(xl, a));
            grow(&mut xs, axis(xl, b));
            grow(&mut ys, axis(yl, h));
            if !yl {
                grow(&mut ys, 0.0);
            }
        }
        for m in &self.marks {
            if m.vertical {
                grow(&mut xs, axis(xl, m.at));
            } else {
                grow(&mut ys, axis(yl, m.at));
            }
        }
        let fix = |r: (f64, f64)| {
            if !r.0.is_finite() {
                (0.0, 1.0)
            } else if r.1 - r.0 <= 1e-9 * r.0.abs().max(1e-300) {
                // A constant (to rounding): a range around it, not ticks in its noise.
                let d = if r.0 == 0.0 { 1.0 } else { r.0.abs() * 0.1 };
                (r.0 - d, r.1 + d)
            } else {
                r
            }
        };
        let given = |r: Option<(f64, f64)>, log: bool| {
            r.map(|(a, b)| (axis(log, a), axis(log, b)))
                .filter(|(a, b)| a.is_finite() && b.is_finite() && b > a)
        };
        (
            given(self.x_range, xl).unwrap_or_else(|| fix(xs)),
            given(self.y_range, yl).unwrap_or_else(|| {
                let r = fix(ys);
                let pad = 0.05 * (r.1 - r.0);
                (r.0 - pad, r.1 + pad)
            }),
        )
    }

    /// Ticks of one axis (axis units) with their labels (the values, on a log axis too).
    fn ticks(log: bool, lo: f64, hi: f64, n: usize) -> Vec<(f64, String)> {
        if log {
            log_ticks(lo, hi)
                .into_iter()
                .map(|t| (t, fmt_log(10f64.powf(t))))
                .collect()
        } else {
            let t = nice_ticks(lo, hi, n);
            t.iter().map(|&v| (v, fmt_tick(v, &t))).collect()
        }
    }

    /// Width of the legend column, px (0 without labelled series).
    pub fn legend_width(&self) -> f64 {
        self.legend_rows()
            .iter()
            .map(|r| r.1.chars().count())
            .max()
            .map_or(0.0, |n| n as f64 * 6.8 + 34.0)
    }

    /// The panel as an SVG group translated to `(ox, oy)`, its legend column `legend_w` px
    /// wide or wider (a figure uses its widest legend so the plotting areas line up).
    pub fn render_group_with(&self, ox: f64, oy: f64, legend_w: f64) -> String {
        let legend_w = legend_w.max(self.legend_width());
        // Slanted category names (40 degrees, [`LABEL_CHAR_PX`] per character)
        // take sin(40) of their length below the axis.
        let longest = self
            .x_categories
            .iter()
            .map(|c| c.chars().count())
            .max()
            .unwrap_or(0);
        let cat_h = if longest == 0 {
            0.0
        } else {
            longest as f64 * LABEL_CHAR_PX * 0.643 + 8.0
        };
        let (mr, mt, mb) = (16.0 + legend_w, 30.0, 46.0 + cat_h);
        // The first category's slanted name reaches left of its centre by its length
        // times cos(40): the left margin grows so that the edge does not cut it off.
        let first = self.x_categories.first().map_or(0.0, |c| {
            c.chars().count() as f64 * LABEL_CHAR_PX * 0.766 + 6.0
        });
        let half = 0.5 / self.x_categories.len().max(1) as f64;
        let ((x0, x1), (y0, y1)) = self.data_range();
        let blank = self.note_only();
        let yt = if blank {
            Vec::new()
        } else {
            Self::ticks(self.y_log, y0, y1, 6)
        };
        // Room for the longest y tick label right of the rotated y label.
        let tick_w = yt
            .iter()
            .map(|t| t.1.chars().count() as f64 * LABEL_CHAR_PX)
            .fold(0.0, f64::max);
        let ml =
            f64::max(78.0, (first - (self.width - mr) * half) / (1.0 - half)).max(tick_w + 28.0);
        let (pw, ph) = (self.width - ml - mr, self.height - mt - mb);
        let xt = if blank || !self.x_categories.is_empty() {
            Vec::new()
        } else {
            Self::ticks(self.x_log, x0, x1, 7)
        };
        // Axis units to px (`sx`, `sy`); data units to px (`px`, `py`).
        let sx = |x: f64| ml + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| mt + ph - (y - y0) / (y1 - y0) * ph;
        let px = |x: f64| sx(self.tx(x));
        let py = |y: f64| sy(self.ty(y));
        let mut o = String::new();
        let _ = writeln!(
            o,
            r#"<g transform="translate({ox},{oy})" font-family="sans-serif" font-size="11">"#
        );
        let _ = writeln!(
            o,
            r##"<rect x="{ml:.1}" y="{mt}" width="{pw:.1}" height="{ph:.1}" fill="#fff" stroke="#333"/>"##
        );
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="18" text-anchor="middle" font-size="13" font-weight="bold">{}</text>"#,
            ml + pw / 2.0,
            esc(&self.title)
        );
        for (i, c) in self.x_categories.iter().enumerate() {
            let x = px(i as f64 + 0.5);
            let y = mt + ph + 12.0;
            let _ = writeln!(
                o,
                r#"<text transform="translate({x:.1},{y:.1}) rotate(-40)" text-anchor="end">{}</text>"#,
                esc(c)
            );
        }
        let (bottom, right) = (mt + ph, ml + pw);
        for (t, label) in &xt {
            let (x, ty) = (sx(*t), bottom + 15.0);
            let _ = writeln!(
                o,
                r##"<line x1="{x:.1}" y1="{mt}" x2="{x:.1}" y2="{bottom:.1}" stroke="#ddd"/>"##
            );
            let _ = writeln!(
                o,
                r#"<text x="{x:.1}" y="{ty:.1}" text-anchor="middle">{label}</text>"#
            );
        }
        for (t, label) in &yt {
            let (y, tx, ty) = (sy(*t), ml - 5.0, sy(*t) + 4.0);
            let _ = writeln!(
                o,
                r##"<line x1="{ml:.1}" y1="{y:.1}" x2="{right:.1}" y2="{y:.1}" stroke="#ddd"/>"##
            );
            let _ = writeln!(
                o,
                r#"<text x="{tx:.1}" y="{ty:.1}" text-anchor="end">{label}</text>"#
            );
        }
        if !blank {
            let x_at = (ml + pw / 2.0, self.height - 8.0);
            axis_labels(&mut o, x_at, mt + ph / 2.0, &self.x_label, &self.y_label);
        }
        let clip = (ox + 10000.0 * oy) as i64;
        let _ = writeln!(
            o,
            r#"<clipPath id="c{clip}"><rect x="{ml:.1}" y="{mt}" width="{pw:.1}" height="{ph:.1}"/></clipPath><g clip-path="url(#c{clip})">"#
        );
        // The bars as drawn (a label over one hides it as much as over fifty points).
        let bar_px: Vec<Rect> = self
            .bars
            .iter()
            .filter(|b| !(self.y_log && b.2 <= 0.0))
            .map(|&(a, b, h)| {
                let top = sy(self.ty(h).max(y0));
                let bottom = sy(if self.y_log { y0 } else { 0f64.max(y0) });
                (px(a), top.min(bottom), px(b), top.max(bottom))
            })
            .collect();
        for &(xa, y, xb, yb) in &bar_px {
            let (w, h) = ((xb - xa).max(0.5), yb - y);
            let _ = writeln!(
                o,
                r##"<rect x="{xa:.1}" y="{y:.1}" width="{w:.1}" height="{h:.1}" fill="#56B4E9" stroke="#0072B2"/>"##
            );
        }
        for (k, s) in self.series.iter().enumerate() {
            let drawn: Vec<(f64, f64)> = s
                .points
                .iter()
                .map(|&(x, y)| (self.tx(x), self.ty(y)))
                .collect();
            let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
            let col = self.paint(k, s);
            match s.style {
                Style::Line | Style::Dashed => {
                    let dash = dash(s);
                    for run in drawn.split(|p| !(p.0.is_finite() && p.1.is_finite())) {
                        if run.is_empty() {
                            continue;
                        }
                        let mut d = String::with_capacity(run.len() * 16);
                        for (i, &(x, y)) in decimate(run, pw as usize * 2).iter().enumerate() {
                            let _ = write!(
                                d,
                                "{}{:.2},{:.2}",
                                if i == 0 { "M" } else { " L" },
                                sx(x),
                                sy(y)
                            );
                        }
                        let _ = writeln!(
                            o,
                            r#"<path d="{d}" fill="none" stroke="{col}" stroke-width="{}"{dash}/>"#,
                            s.width
                        );
                    }
                }
                Style::Markers => {
                    let r = 1.3 + s.width / 2.0;
                    for &(x, y) in drawn.iter().filter(finite) {
                        let _ = writeln!(
                            o,
                            r#"<circle cx="{:.1}" cy="{:.1}" r="{r:.1}" fill="{col}"/>"#,
                            sx(x),
                            sy(y)
                        );
                    }
                }
                Style::Crosses => {
                    for &(x, y) in drawn.iter().filter(finite) {
                        cross(&mut o, sx(x), sy(y), &col);
                    }
                }
            }
        }
        // The marks on top of the data, each label beside its line where it hides the
        // fewest data points and no other label.
        let placed_pts = self.drawn_px(&sx, &sy);
        let mut taken: Vec<Rect> = Vec::new();
        let lines: Vec<(f64, bool)> = self
            .marks
            .iter()
            .map(|m| (if m.vertical { px(m.at) } else { py(m.at) }, m.vertical))
            .filter(|l| l.0.is_finite())
            .collect();
        for m in &self.marks {
            let label = esc(&m.label);
            let c = &m.color;
            let at = if m.vertical { px(m.at) } else { py(m.at) };
            if !at.is_finite() {
                continue;
            }
            // A horizontal mark's extent, px.
            let (left, right) = m
                .span
                .map_or((ml, ml + pw), |(a, b)| (px(a).max(ml), px(b).min(ml + pw)));
            if m.vertical {
                let _ = writeln!(
                    o,
                    r#"<line x1="{at:.1}" y1="{mt}" x2="{at:.1}" y2="{:.1}" stroke="{c}" stroke-width="1.2" stroke-dasharray="5,3"/>"#,
                    mt + ph
                );
            } else {
                let _ = writeln!(
                    o,
                    r#"<line x1="{left:.1}" y1="{at:.1}" x2="{right:.1}" y2="{at:.1}" stroke="{c}" stroke-width="1.2" stroke-dasharray="5,3"/>"#
                );
            }
            if m.label.is_empty() {
                continue;
            }
            let w = m.label.chars().count() as f64 * LABEL_CHAR_PX;
            // Candidates: beside a vertical line, in rows down the top of the area; above
            // or below a horizontal one, at either end.
            let mut cands: Vec<(f64, f64, bool)> = Vec::new();
            if m.vertical {
                for row in 0..((ph / 12.0).floor() as usize).max(1) {
                    let y = mt + 12.0 + 12.0 * row as f64;
                    cands.push((at + 3.0, y, false));
                    cands.push((at - 3.0, y, true));
                }
            } else {
                for dy in [-3.0, 12.0, -15.0, 24.0, -27.0, 36.0] {
                    let y = at + dy;
                    cands.push((left + 4.0, y, false));
                    cands.push((right - 4.0, y, true));
                }
            }
            let rect_of = |(x, y, end): (f64, f64, bool)| -> Rect {
                let x0 = if end { x - w } else { x };
                (x0, y - 9.0, x0 + w, y + 3.0)
            };
            // Outside the area, over another label, across another mark's line, over
            // data: in that order of cost (rows further down cost a little, so that
            // labels stay near the top).
            let score = |i: usize, cand: (f64, f64, bool)| -> (bool, bool, bool, usize) {
                let r = rect_of(cand);
                let outside = r.0 < ml || r.2 > ml + pw || r.1 < mt || r.3 > mt + ph;
                let clash = taken.iter().any(|t| overlap(t, &r));
                // Another mark's line through the label (its own runs beside it).
                let crosses = lines.iter().any(|&(l, vertical)| {
                    let (lo, hi) = if vertical { (r.0, r.2) } else { (r.1, r.3) };
                    (m.vertical != vertical || (l - at).abs() > 0.5) && l > lo && l < hi
                });
                let hidden = placed_pts
                    .iter()
                    .filter(|p| p.0 >= r.0 && p.0 <= r.2 && p.1 >= r.1 && p.1 <= r.3)
                    .count()
                    + 50 * bar_px.iter().filter(|b| overlap(b, &r)).count();
                (outside, clash, crosses, hidden + i / 2)
            };
            let best = cands
                .iter()
                .copied()
                .enumerate()
                .min_by_key(|&(i, cand)| score(i, cand))
                .map(|(_, cand)| cand);
            let Some(cand) = best else { continue };
            taken.push(rect_of(cand));
            let (x, y, anchor) = (cand.0, cand.1, if cand.2 { "end" } else { "start" });
            let _ = writeln!(
                o,
                r##"<text x="{x:.1}" y="{y:.1}" text-anchor="{anchor}" fill="{c}" stroke="#fff" stroke-width="3" paint-order="stroke">{label}</text>"##
            );
        }
        // Data beyond a fixed range: a triangle on the edge where each run leaves the axes.
        for (k, s) in self.series.iter().enumerate() {
            let col = self.colour(k, s);
            for &(x, y) in &self.clipped_exits(k, (x0, x1), (y0, y1)) {
                let (cx, cy) = (sx(x.clamp(x0, x1)), sy(y.clamp(y0, y1)));
                let d = if y > y1 {
                    (0.0, -1.0)
                } else if y < y0 {
                    (0.0, 1.0)
                } else if x > x1 {
                    (1.0, 0.0)
                } else {
                    (-1.0, 0.0)
                };
                // The tip on the edge, the base inside the area (the group clips).
                let (bx, by) = (cx - 8.0 * d.0, cy - 8.0 * d.1);
                let (ax, ay, bx, by) = (
                    bx - 5.0 * d.1,
                    by + 5.0 * d.0,
                    bx + 5.0 * d.1,
                    by - 5.0 * d.0,
                );
                let _ = writeln!(
                    o,
                    r##"<path class="clipped" d="M{cx:.1},{cy:.1} L{ax:.1},{ay:.1} L{bx:.1},{by:.1} Z" fill="{col}" stroke="#fff" stroke-width="0.8"/>"##
                );
            }
        }
        o.push_str("</g>\n");
        let rows = self.legend_rows();
        if !rows.is_empty() {
            let lw = legend_w;
            let lx = ml + pw + 8.0;
            let ly = mt + 6.0;
            let _ = writeln!(
                o,
                r##"<rect x="{lx:.1}" y="{ly:.1}" width="{lw:.1}" height="{:.1}" fill="#fff" fill-opacity="0.85" stroke="#999"/>"##,
                rows.len() as f64 * 15.0 + 6.0
            );
            for (row, (k, text, clipped)) in rows.iter().enumerate() {
                let s = &self.series[*k];
                let col = self.paint(*k, s);
                let y = ly + 13.0 + row as f64 * 15.0;
                let (cx, cy) = (lx + 14.0, y - 4.0);
                if *clipped {
                    let (l, r, t, b) = (cx - 5.0, cx + 5.0, y - 10.0, y - 2.0);
                    let _ = writeln!(
                        o,
                        r#"<path d="M{cx:.1},{t:.1} L{l:.1},{b:.1} L{r:.1},{b:.1} Z" fill="{col}"/>"#
                    );
                } else if s.style == Style::Crosses {
                    cross(&mut o, cx, cy, &col);
                } else if s.style == Style::Markers {
                    let _ = writeln!(
                        o,
                        r#"<circle cx="{cx:.1}" cy="{cy:.1}" r="3" fill="{col}"/>"#
                    );
                } else {
                    let (l, r, w, dash) = (lx + 5.0, lx + 24.0, s.width.clamp(2.0, 6.0), dash(s));
                    let _ = writeln!(
                        o,
                        r#"<line x1="{l:.1}" y1="{cy:.1}" x2="{r:.1}" y2="{cy:.1}" stroke="{col}" stroke-width="{w}"{dash}/>"#
                    );
                }
                let (tx, text) = (lx + 29.0, esc(text));
                let _ = writeln!(o, r#"<text x="{tx:.1}" y="{y:.1}">{text}</text>"#);
            }
        }
        if !self.note.is_empty() {
            let (x, y, note) = (ml + pw / 2.0, mt + ph / 2.0, esc(&self.note));
            let _ = writeln!(
                o,
                r##"<text x="{x:.1}" y="{y:.1}" text-anchor="middle" font-size="14" fill="#555" stroke="#fff" stroke-width="4" paint-order="stroke">{note}</text>"##
            );
        }
        o.push_str("</g>\n");
        o
    }
}

fn dash(s: &Series) -> &'static str {
    if s.style == Style::Dashed {
        r#" stroke-dasharray="6,4""#
    } else {
        ""
    }
}

/// A cross of 8 px centred on `(cx, cy)`: a `Style::Crosses` point or its legend swatch.
fn cross(o: &mut String, cx: f64, cy: f64, col: &str) {
    let (l, r, t, b) = (cx - 4.0, cx + 4.0, cy - 4.0, cy + 4.0);
    let _ = writeln!(
        o,
        r#"<path d="M{l:.1},{t:.1} L{r:.1},{b:.1} M{l:.1},{b:.1} L{r:.1},{t:.1}" stroke="{col}" stroke-width="1.5"/>"#
    );
}

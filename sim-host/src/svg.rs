//! A small, dependency-free SVG plotting module: line plots with several series,
//! scatter plots (root loci), bar histograms, vertical stacks of panels, and heat maps
//! of a parameter grid ([`heatmap`]).
//!
//! ```
//! use sim_host::svg::{Plot, Series};
//! let s = Series::line("sin", (0..100).map(|i| (i as f64 * 0.1, (i as f64 * 0.1).sin())).collect());
//! let svg = Plot::new("A sine").x_label("t (s)").y_label("y").series(s).to_svg();
//! assert!(svg.starts_with("<svg"));
//! ```
//!
//! Output is plain SVG 1.1 text; write it with [`Plot::save`] or [`Figure::save`].
//!
//! # Why SVG by hand rather than `plotters` (measured 2026-12-02)
//!
//! Cost is not the reason: `plotters` 0.3.7 with only its `svg_backend` (plus
//! `line_series`, `point_series`, `histogram`; `default-features = false`) is 5 crates
//! (`plotters`, `plotters-backend`, `plotters-svg`, `num-traits`, `autocfg`) and builds
//! in release in 3.9 s of CPU (10 s wall at load average 8 on the 2-core machine), and
//! its SVG backend writes `<text>` without system fonts (a probe crate drawing a line
//! chart with a caption and axis labels: 25 `<text>` elements). The reasons to keep this
//! module:
//! - `plotters`' backends take integer pixel coordinates (`BackendCoord = (i32, i32)`):
//!   the probe's polylines are whole pixels (`points="39,20 39,329"`); this module writes
//!   0.1 px, which keeps sub-pixel traces (`y - y0` around the traction step, the
//!   monitor's mean square far below its threshold) as they are instead of stair steps.
//! - Without a font feature `plotters` sizes text from estimates (the probe's 13 px
//!   caption came out at `font-size="10.48"`); this module lays out labels itself.
//! - 43 call sites in `sim-host` and `hil` use what this module has and `plotters` would
//!   need code for at each site: the legend in a column right of the plotting area (it
//!   never hides data), one legend width across stacked panels so their axes line up,
//!   reference lines, notes ("not measured"), category axes and heat maps.

use std::fmt::Write as _;
use std::path::Path;

pub mod heatmap;

/// Default colour cycle (colour-blind friendly).
pub const PALETTE: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442",
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// A polyline.
    Line,
    /// A dashed polyline.
    Dashed,
    /// Markers only (scatter).
    Markers,
    /// Crosses only (scatter; e.g. poles).
    Crosses,
}

/// One data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label (empty = not in the legend).
    pub label: String,
    /// Points `(x, y)`; non-finite points are skipped (and break a line).
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: Style,
    /// Colour (`None` = next palette colour).
    pub color: Option<String>,
}

impl Series {
    /// A solid line.
    pub fn line(label: &str, points: Vec<(f64, f64)>) -> Self {
        Series {
            label: label.to_string(),
            points,
            style: Style::Line,
            color: None,
        }
    }
    /// A scatter of dots.
    pub fn scatter(label: &str, points: Vec<(f64, f64)>) -> Self {
        Series {
            style: Style::Markers,
            ..Self::line(label, points)
        }
    }
    /// Sets the style.
    pub fn style(mut self, style: Style) -> Self {
        self.style = style;
        self
    }
    /// Sets the colour (any SVG colour).
    pub fn color(mut self, c: &str) -> Self {
        self.color = Some(c.to_string());
        self
    }
}

/// A single plot panel with axes, ticks, labels, grid and legend.
#[derive(Debug, Clone, PartialEq)]
pub struct Plot {
    /// Title above the panel.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Series drawn in order.
    pub series: Vec<Series>,
    /// Fixed x range (`None` = from the data).
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range (`None` = from the data).
    pub y_range: Option<(f64, f64)>,
    /// Bars `(x_lo, x_hi, height)` drawn before the series (histograms).
    pub bars: Vec<(f64, f64, f64)>,
    /// Width, px.
    pub width: f64,
    /// Height, px.
    pub height: f64,
    /// Vertical reference lines at these x.
    pub vlines: Vec<f64>,
    /// Horizontal reference lines at these y.
    pub hlines: Vec<f64>,
    /// A note written across the middle of the plotting area (e.g. "not measured" for
    /// a panel without data to show; empty = none).
    pub note: String,
    /// Category names of the x axis: when given, category `i` spans `[i, i + 1)` and
    /// its name is written under `i + 0.5`, slanted, instead of numeric x ticks (a bar
    /// or scatter per named item; the bottom margin grows to fit the longest name).
    pub x_categories: Vec<String>,
}

impl Plot {
    /// An empty 860 x 360 panel.
    pub fn new(title: &str) -> Self {
        Plot {
            title: title.to_string(),
            x_label: String::new(),
            y_label: String::new(),
            series: Vec::new(),
            x_range: None,
            y_range: None,
            bars: Vec::new(),
            width: 860.0,
            height: 360.0,
            vlines: Vec::new(),
            hlines: Vec::new(),
            note: String::new(),
            x_categories: Vec::new(),
        }
    }
    /// Names the x axis's categories (see [`Plot::x_categories`]); the x range becomes
    /// `[0, names.len()]`.
    pub fn x_categories(mut self, names: &[String]) -> Self {
        self.x_range = Some((0.0, names.len().max(1) as f64));
        self.x_categories = names.to_vec();
        self
    }
    /// Sets the note written across the plotting area.
    pub fn note(mut self, s: &str) -> Self {
        self.note = s.to_string();
        self
    }
    /// Sets the x label.
    pub fn x_label(mut self, s: &str) -> Self {
        self.x_label = s.to_string();
        self
    }
    /// Sets the y label.
    pub fn y_label(mut self, s: &str) -> Self {
        self.y_label = s.to_string();
        self
    }
    /// Adds a series.
    pub fn series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }
    /// Fixes the x range.
    pub fn x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }
    /// Fixes the y range.
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }
    /// Sets the size in px.
    pub fn size(mut self, w: f64, h: f64) -> Self {
        self.width = w;
        self.height = h;
        self
    }
    /// Adds a vertical reference line.
    pub fn vline(mut self, x: f64) -> Self {
        self.vlines.push(x);
        self
    }
    /// Adds a horizontal reference line.
    pub fn hline(mut self, y: f64) -> Self {
        self.hlines.push(y);
        self
    }
    /// A histogram: `edges` has one more entry than `counts`.
    pub fn histogram(title: &str, edges: &[f64], counts: &[f64]) -> Self {
        let mut p = Plot::new(title);
        p.bars = edges
            .windows(2)
            .zip(counts)
            .map(|(e, &c)| (e[0], e[1], c))
            .collect();
        p
    }

    fn data_range(&self) -> ((f64, f64), (f64, f64)) {
        let mut xs = (f64::INFINITY, f64::NEG_INFINITY);
        let mut ys = xs;
        let mut add = |x: f64, y: f64| {
            if x.is_finite() && y.is_finite() {
                xs = (xs.0.min(x), xs.1.max(x));
                ys = (ys.0.min(y), ys.1.max(y));
            }
        };
        for s in &self.series {
            for &(x, y) in &s.points {
                add(x, y);
            }
        }
        for &(a, b, h) in &self.bars {
            add(a, 0.0);
            add(b, h);
        }
        let fix = |r: (f64, f64)| {
            if !r.0.is_finite() {
                (0.0, 1.0)
            } else if r.1 - r.0 <= f64::EPSILON * r.0.abs().max(1e-300) {
                let d = if r.0 == 0.0 { 1.0 } else { r.0.abs() * 0.1 };
                (r.0 - d, r.1 + d)
            } else {
                r
            }
        };
        (
            self.x_range.unwrap_or_else(|| fix(xs)),
            self.y_range.unwrap_or_else(|| {
                let r = fix(ys);
                let pad = 0.05 * (r.1 - r.0);
                (r.0 - pad, r.1 + pad)
            }),
        )
    }

    /// Width of the legend column, px (0 without labelled series).
    pub fn legend_width(&self) -> f64 {
        self.series
            .iter()
            .filter(|s| !s.label.is_empty())
            .map(|s| s.label.chars().count())
            .max()
            .map_or(0.0, |n| n as f64 * 6.5 + 34.0)
    }

    /// Renders the panel as an SVG group translated to `(ox, oy)`.
    pub fn render_group(&self, ox: f64, oy: f64) -> String {
        self.render_group_with(ox, oy, self.legend_width())
    }

    /// As [`Plot::render_group`] with the legend column `legend_w` px wide (a figure
    /// uses its widest legend for every panel so the plotting areas line up).
    pub fn render_group_with(&self, ox: f64, oy: f64, legend_w: f64) -> String {
        // The legend sits in a column right of the plotting area, so it never hides data.
        let legend_w = legend_w.max(self.legend_width());
        // Slanted category names (40 degrees, ~6 px per character at font-size 11)
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
            longest as f64 * 6.0 * 0.643 + 8.0
        };
        let (ml, mr, mt, mb) = (78.0, 16.0 + legend_w, 30.0, 46.0 + cat_h);
        let (pw, ph) = (self.width - ml - mr, self.height - mt - mb);
        let ((x0, x1), (y0, y1)) = self.data_range();
        let xt = nice_ticks(x0, x1, 7);
        let yt = nice_ticks(y0, y1, 6);
        let sx = |x: f64| ml + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| mt + ph - (y - y0) / (y1 - y0) * ph;
        let mut o = String::new();
        let _ = writeln!(
            o,
            r#"<g transform="translate({ox},{oy})" font-family="sans-serif" font-size="11">"#
        );
        let _ = writeln!(
            o,
            r##"<rect x="{ml}" y="{mt}" width="{pw:.1}" height="{ph:.1}" fill="#fff" stroke="#333"/>"##
        );
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="18" text-anchor="middle" font-size="13" font-weight="bold">{}</text>"#,
            ml + pw / 2.0,
            esc(&self.title)
        );
        for (i, c) in self.x_categories.iter().enumerate() {
            let x = sx(i as f64 + 0.5);
            let y = mt + ph + 12.0;
            let _ = writeln!(
                o,
                r#"<text transform="translate({x:.1},{y:.1}) rotate(-40)" text-anchor="end">{}</text>"#,
                esc(c)
            );
        }
        for &t in xt.iter().filter(|_| self.x_categories.is_empty()) {
            let x = sx(t);
            let _ = writeln!(
                o,
                r##"<line x1="{x:.1}" y1="{mt}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/>"##,
                mt + ph
            );
            let _ = writeln!(
                o,
                r#"<text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                mt + ph + 15.0,
                fmt_tick(t, &xt)
            );
        }
        for &t in &yt {
            let y = sy(t);
            let _ = writeln!(
                o,
                r##"<line x1="{ml}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/>"##,
                ml + pw
            );
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
                ml - 5.0,
                y + 4.0,
                fmt_tick(t, &yt)
            );
        }
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            ml + pw / 2.0,
            self.height - 8.0,
            esc(&self.x_label)
        );
        let _ = writeln!(
            o,
            r#"<text transform="translate(14,{:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            mt + ph / 2.0,
            esc(&self.y_label)
        );
        let _ = writeln!(
            o,
            r#"<clipPath id="c{}"><rect x="{ml}" y="{mt}" width="{pw:.1}" height="{ph:.1}"/></clipPath><g clip-path="url(#c{})">"#,
            (ox + 10000.0 * oy) as i64,
            (ox + 10000.0 * oy) as i64
        );
        for &(a, b, h) in &self.bars {
            let (xa, xb) = (sx(a), sx(b));
            let (ya, yb) = (sy(h.max(y0)), sy(0f64.max(y0)));
            let _ = writeln!(
                o,
                r##"<rect x="{xa:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#56B4E9" stroke="#0072B2"/>"##,
                ya.min(yb),
                (xb - xa).max(0.5),
                (yb - ya).abs()
            );
        }
        for &v in &self.vlines {
            let _ = writeln!(
                o,
                r##"<line x1="{0:.1}" y1="{mt}" x2="{0:.1}" y2="{1:.1}" stroke="#888" stroke-dasharray="3,3"/>"##,
                sx(v),
                mt + ph
            );
        }
        for &h in &self.hlines {
            let _ = writeln!(
                o,
                r##"<line x1="{ml}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="#888" stroke-dasharray="3,3"/>"##,
                sy(h),
                ml + pw
            );
        }
        for (k, s) in self.series.iter().enumerate() {
            let col = s
                .color
                .clone()
                .unwrap_or_else(|| PALETTE[k % PALETTE.len()].to_string());
            match s.style {
                Style::Line | Style::Dashed => {
                    let dash = if s.style == Style::Dashed {
                        r#" stroke-dasharray="6,4""#
                    } else {
                        ""
                    };
                    for run in s.points.split(|p| !(p.0.is_finite() && p.1.is_finite())) {
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
                            r#"<path d="{d}" fill="none" stroke="{col}" stroke-width="1.4"{dash}/>"#
                        );
                    }
                }
                Style::Markers => {
                    for &(x, y) in s
                        .points
                        .iter()
                        .filter(|p| p.0.is_finite() && p.1.is_finite())
                    {
                        let _ = writeln!(
                            o,
                            r#"<circle cx="{:.1}" cy="{:.1}" r="2" fill="{col}"/>"#,
                            sx(x),
                            sy(y)
                        );
                    }
                }
                Style::Crosses => {
                    for &(x, y) in s
                        .points
                        .iter()
                        .filter(|p| p.0.is_finite() && p.1.is_finite())
                    {
                        let (cx, cy) = (sx(x), sy(y));
                        let _ = writeln!(
                            o,
                            r#"<path d="M{:.1},{:.1} L{:.1},{:.1} M{:.1},{:.1} L{:.1},{:.1}" stroke="{col}" stroke-width="1.5"/>"#,
                            cx - 4.0,
                            cy - 4.0,
                            cx + 4.0,
                            cy + 4.0,
                            cx - 4.0,
                            cy + 4.0,
                            cx + 4.0,
                            cy - 4.0
                        );
                    }
                }
            }
        }
        o.push_str("</g>\n");
        // legend
        let labelled: Vec<(usize, &Series)> = self
            .series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.label.is_empty())
            .collect();
        if !labelled.is_empty() {
            let lw = legend_w;
            let lx = ml + pw + 8.0;
            let ly = mt + 6.0;
            let _ = writeln!(
                o,
                r##"<rect x="{lx:.1}" y="{ly:.1}" width="{lw:.1}" height="{:.1}" fill="#fff" fill-opacity="0.85" stroke="#999"/>"##,
                labelled.len() as f64 * 15.0 + 6.0
            );
            for (row, (k, s)) in labelled.iter().enumerate() {
                let col = s
                    .color
                    .clone()
                    .unwrap_or_else(|| PALETTE[k % PALETTE.len()].to_string());
                let y = ly + 13.0 + row as f64 * 15.0;
                match s.style {
                    Style::Markers | Style::Crosses => {
                        let _ = writeln!(
                            o,
                            r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="{col}"/>"#,
                            lx + 14.0,
                            y - 4.0
                        );
                    }
                    _ => {
                        let dash = if s.style == Style::Dashed {
                            r#" stroke-dasharray="6,4""#
                        } else {
                            ""
                        };
                        let _ = writeln!(
                            o,
                            r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{col}" stroke-width="2"{dash}/>"#,
                            lx + 5.0,
                            y - 4.0,
                            lx + 24.0,
                            y - 4.0
                        );
                    }
                }
                let _ = writeln!(
                    o,
                    r#"<text x="{:.1}" y="{y:.1}">{}</text>"#,
                    lx + 29.0,
                    esc(&s.label)
                );
            }
        }
        if !self.note.is_empty() {
            let _ = writeln!(
                o,
                r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="14" fill="#555">{}</text>"##,
                ml + pw / 2.0,
                mt + ph / 2.0,
                esc(&self.note)
            );
        }
        o.push_str("</g>\n");
        o
    }

    /// The complete SVG document.
    pub fn to_svg(&self) -> String {
        Figure::new("").panel(self.clone()).to_svg()
    }

    /// Writes the SVG document to `path` (parent directories created).
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        write_file(path, &self.to_svg())
    }
}

/// Several panels stacked vertically under an optional title.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Figure {
    /// Title on top (empty = none).
    pub title: String,
    /// Panels, top to bottom.
    pub panels: Vec<Plot>,
}

impl Figure {
    /// An empty figure.
    pub fn new(title: &str) -> Self {
        Figure {
            title: title.to_string(),
            panels: Vec::new(),
        }
    }
    /// Adds a panel below the others.
    pub fn panel(mut self, p: Plot) -> Self {
        self.panels.push(p);
        self
    }
    /// The complete SVG document.
    pub fn to_svg(&self) -> String {
        let top = if self.title.is_empty() { 0.0 } else { 28.0 };
        let w = self.panels.iter().map(|p| p.width).fold(100.0, f64::max);
        let h = top + self.panels.iter().map(|p| p.height).sum::<f64>();
        let mut o = String::new();
        let _ = writeln!(
            o,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">"#
        );
        let _ = writeln!(o, r##"<rect width="100%" height="100%" fill="#fff"/>"##);
        if !self.title.is_empty() {
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="20" text-anchor="middle" font-family="sans-serif" font-size="15" font-weight="bold">{}</text>"#,
                w / 2.0,
                esc(&self.title)
            );
        }
        let lw = self
            .panels
            .iter()
            .map(Plot::legend_width)
            .fold(0.0, f64::max);
        let mut y = top;
        for p in &self.panels {
            o.push_str(&p.render_group_with(0.0, y, lw));
            y += p.height;
        }
        o.push_str("</svg>\n");
        o
    }
    /// Writes the SVG document to `path` (parent directories created).
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        write_file(path, &self.to_svg())
    }
}

fn write_file(path: &Path, text: &str) -> std::io::Result<()> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)?;
        }
    }
    std::fs::write(path, text)
}

/// Escapes text for SVG.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// "Nice" tick positions (1-2-5 steps) covering `[lo, hi]`, about `n` of them.
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo || n == 0 {
        return vec![];
    }
    let raw = (hi - lo) / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let start = (lo / step).ceil() as i64;
    let end = (hi / step).floor() as i64;
    (start..=end).map(|k| k as f64 * step).collect()
}

/// Decimal places needed to write multiples of `step` exactly (at most 12).
fn decimals(step: f64) -> usize {
    (0..12)
        .find(|&d| {
            let x = step * 10f64.powi(d as i32);
            (x - x.round()).abs() < 1e-6 * x.abs().max(1.0)
        })
        .unwrap_or(12)
}

fn fmt_tick(v: f64, ticks: &[f64]) -> String {
    let step = if ticks.len() > 1 {
        (ticks[1] - ticks[0]).abs()
    } else {
        v.abs().max(1.0)
    };
    let big = ticks.iter().fold(0f64, |a, t| a.max(t.abs()));
    if v == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&big) {
        let e = big.log10().floor() as i32;
        return format!(
            "{:.*}e{e}",
            decimals(step / 10f64.powi(e)),
            v / 10f64.powi(e)
        );
    }
    format!("{v:.*}", decimals(step))
}

/// Keeps at most about `max` points by taking min/max pairs per bucket (so peaks stay).
fn decimate(p: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if p.len() <= max.max(4) {
        return p.to_vec();
    }
    let buckets = (max / 2).max(2);
    let per = p.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(buckets * 2 + 1);
    for chunk in p.chunks(per) {
        let mut lo = chunk[0];
        let mut hi = chunk[0];
        for &q in chunk {
            if q.1 < lo.1 {
                lo = q;
            }
            if q.1 > hi.1 {
                hi = q;
            }
        }
        if lo.0 <= hi.0 {
            out.push(lo);
            out.push(hi);
        } else {
            out.push(hi);
            out.push(lo);
        }
    }
    if let Some(&last) = p.last() {
        out.push(last);
    }
    out
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn ticks_cover_range_with_nice_steps() {
        let t = nice_ticks(0.0, 20.0, 7);
        assert_eq!(t.first(), Some(&0.0));
        assert_eq!(t.last(), Some(&20.0));
        let t = nice_ticks(-0.37, 1.2, 6);
        assert!(t.iter().all(|v| *v >= -0.37 && *v <= 1.2));
        assert!(t.len() >= 3 && t.len() <= 9, "{t:?}");
    }

    #[test]
    fn tick_labels_are_exact() {
        let t = nice_ticks(0.0, 1.2, 5); // step 0.25
        let labels: Vec<String> = t.iter().map(|v| fmt_tick(*v, &t)).collect();
        assert_eq!(labels, ["0", "0.25", "0.50", "0.75", "1.00"]);
        let t = nice_ticks(0.0, 3e6, 3);
        assert_eq!(fmt_tick(t[1], &t), "1e6");
        let t = nice_ticks(1.0, 10.0, 4); // step 2.5
        assert_eq!(fmt_tick(2.5, &t), "2.5");
    }

    #[test]
    fn svg_contains_series_legend_and_escapes() {
        let p = Plot::new("a<b")
            .series(Series::line("y & z", vec![(0.0, 1.0), (1.0, 2.0)]))
            .series(Series::scatter("pts", vec![(0.5, 1.5), (f64::NAN, 0.0)]));
        let s = p.to_svg();
        assert!(s.contains("a&lt;b"));
        assert!(s.contains("y &amp; z"));
        assert_eq!(s.matches("<circle").count(), 2); // one point + one legend marker
        assert!(s.trim_end().ends_with("</svg>"));
    }

    #[test]
    fn histogram_has_one_rect_per_bin() {
        let p = Plot::histogram("h", &[0.0, 1.0, 2.0, 3.0], &[1.0, 4.0, 2.0]);
        let s = p.to_svg();
        assert_eq!(s.matches("fill=\"#56B4E9\"").count(), 3);
    }

    #[test]
    fn categories_replace_the_numeric_x_ticks_and_a_note_is_written() {
        let names = ["yaw_lead.x".to_string(), "traction_pi.e".to_string()];
        let p = Plot::histogram("h", &[0.0, 1.0, 2.0], &[1.0, 2.0])
            .x_categories(&names)
            .note("not measured");
        let s = p.to_svg();
        assert!(s.contains(">yaw_lead.x</text>"), "{s}");
        assert!(s.contains(">traction_pi.e</text>"), "{s}");
        assert_eq!(s.matches("rotate(-40)").count(), 2);
        // No numeric x tick label (the tick labels are the names).
        let numeric_x = s
            .split("text-anchor=\"middle\">")
            .skip(1)
            .filter_map(|t| t.split('<').next())
            .filter(|t| t.parse::<f64>().is_ok())
            .count();
        assert_eq!(numeric_x, 0, "{s}");
        assert!(s.contains(">not measured</text>"), "{s}");
    }
}

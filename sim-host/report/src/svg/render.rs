//! Drawing a [`Plot`]: its data range, the axes with their ticks, the series, the
//! reference lines and notes, and the legend in a column right of the plotting area.

use std::fmt::Write as _;
use std::path::Path;

use super::{
    decimate, esc, fmt_tick, nice_ticks, write_file, Figure, Plot, Series, Style, PALETTE,
};

impl Plot {
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

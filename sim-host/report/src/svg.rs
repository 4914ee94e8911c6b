//! SVG plots: lines, scatters (root loci), histograms, stacked panels and heat maps
//! ([`heatmap`]), linear or log axes, labelled marks. By hand, not with `plotters`, whose
//! SVG backend takes whole-pixel coordinates (this module writes 0.1 px, so sub-pixel
//! traces stay smooth) and estimates text sizes.

use std::fmt::Write as _;
use std::path::Path;

mod figure;
pub mod heatmap;
pub mod lint;
mod render;
mod ticks;

pub use figure::Figure;
use ticks::{decimate, fmt_tick};
pub use ticks::{esc, nice_ticks};

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

/// A labelled reference line (a threshold, a budget, an event), drawn dashed across the
/// plotting area with its label beside it; a plot's range always includes it.
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    /// A vertical line at `x = at` (else a horizontal one at `y = at`).
    pub vertical: bool,
    /// Where, in data units.
    pub at: f64,
    /// Label written beside the line (empty = none).
    pub label: String,
    /// Colour (any SVG colour).
    pub color: String,
    /// A horizontal mark drawn only over `x` in this range (data units; `None`: across).
    pub span: Option<(f64, f64)>,
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
    /// Line width, px (a marker's radius is `1.3 + width / 2`).
    pub width: f64,
    /// Opacity, 0 to 1 (a wide pale series beneath a thin one that coincides lets both show).
    pub opacity: f64,
}

impl Series {
    /// A solid line.
    pub fn line(label: &str, points: Vec<(f64, f64)>) -> Self {
        Series {
            label: label.to_string(),
            points,
            style: Style::Line,
            color: None,
            width: 1.4,
            opacity: 1.0,
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
    /// Sets the line width, px.
    pub fn width(mut self, px: f64) -> Self {
        self.width = px;
        self
    }
    /// Sets the opacity (0 to 1).
    pub fn opacity(mut self, a: f64) -> Self {
        self.opacity = a;
        self
    }
}

/// A single plot panel with axes, ticks, labels, grid and legend (sized by [`Plot::new`]).
#[derive(Debug, Clone, PartialEq, Default)]
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
    /// A note written across the middle of the plotting area (empty = none).
    pub note: String,
    /// Labelled reference lines ([`Mark`]).
    pub marks: Vec<Mark>,
    /// Logarithmic x axis (points with `x <= 0` are skipped).
    pub x_log: bool,
    /// Logarithmic y axis (points with `y <= 0` are skipped; bars rise from the axis).
    pub y_log: bool,
    /// Category names of the x axis: category `i` spans `[i, i + 1)`, its name written
    /// slanted under `i + 0.5` instead of numeric x ticks.
    pub x_categories: Vec<String>,
}

impl Plot {
    /// An empty 860 x 360 panel.
    pub fn new(title: &str) -> Self {
        Plot {
            title: title.to_string(),
            width: 860.0,
            height: 360.0,
            ..Plot::default()
        }
    }
    /// A labelled horizontal reference line at `y` ([`Mark`]).
    pub fn hmark(self, y: f64, label: &str, color: &str) -> Self {
        self.mark(false, y, label, color)
    }
    /// A labelled vertical reference line at `x` ([`Mark`]).
    pub fn vmark(self, x: f64, label: &str, color: &str) -> Self {
        self.mark(true, x, label, color)
    }
    fn mark(mut self, vertical: bool, at: f64, label: &str, color: &str) -> Self {
        self.marks.push(Mark {
            vertical,
            at,
            label: label.to_string(),
            color: color.to_string(),
            span: None,
        });
        self
    }
    /// The last mark drawn only over `x` in `[lo, hi]` (data units; see [`Mark::span`]).
    pub fn over(mut self, lo: f64, hi: f64) -> Self {
        if let Some(m) = self.marks.last_mut() {
            m.span = Some((lo, hi));
        }
        self
    }
    /// A logarithmic x axis.
    pub fn log_x(mut self) -> Self {
        self.x_log = true;
        self
    }
    /// A logarithmic y axis.
    pub fn log_y(mut self) -> Self {
        self.y_log = true;
        self
    }
    /// Names the x categories ([`Plot::x_categories`]); the x range becomes `[0, names.len()]`.
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
}

/// The SVG document `w` px wide: `title` (28 px high, when given) over the groups
/// `group(i, y)` of panels `heights` high, stacked from the top at `y`.
fn document(title: &str, w: f64, heights: &[f64], group: impl Fn(usize, f64) -> String) -> String {
    let top = if title.is_empty() { 0.0 } else { 28.0 };
    let h = top + heights.iter().sum::<f64>();
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">"#
    );
    let _ = writeln!(o, r##"<rect width="100%" height="100%" fill="#fff"/>"##);
    if !title.is_empty() {
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="20" text-anchor="middle" font-family="sans-serif" font-size="15" font-weight="bold">{}</text>"#,
            w / 2.0,
            esc(title)
        );
    }
    let mut y = top;
    for (i, ph) in heights.iter().enumerate() {
        o.push_str(&group(i, y));
        y += ph;
    }
    o.push_str("</svg>\n");
    o
}

/// The x label centred at `x_at` and the y label turned upright, centred at height `y_mid`.
fn axis_labels(o: &mut String, x_at: (f64, f64), y_mid: f64, x_label: &str, y_label: &str) {
    let _ = writeln!(
        o,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
        x_at.0,
        x_at.1,
        esc(x_label)
    );
    let _ = writeln!(
        o,
        r#"<text transform="translate(14,{y_mid:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
        esc(y_label)
    );
}

fn write_file(path: &Path, text: &str) -> std::io::Result<()> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)?;
        }
    }
    std::fs::write(path, text)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests;

//! Heat maps: a grid of coloured cells over two categorical axes (a parameter campaign's
//! grid), each cell with an optional text, and a legend of the colours.

use std::fmt::Write as _;

use super::esc;

/// One cell: its fill colour and the text written in it.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Any SVG colour.
    pub fill: String,
    /// Text in the cell (empty: none).
    pub text: String,
}

impl Cell {
    /// A cell of colour `fill` with `text`.
    #[must_use]
    pub fn new(fill: &str, text: &str) -> Self {
        Cell {
            fill: fill.into(),
            text: text.into(),
        }
    }
}

/// A heat map: `x_ticks.len()` columns by `y_ticks.len()` rows; the cells row by row,
/// the first row at the bottom (the y axis grows upwards, as in a plot).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HeatMap {
    /// Title above the map.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Column labels, left to right.
    pub x_ticks: Vec<String>,
    /// Row labels, bottom to top.
    pub y_ticks: Vec<String>,
    /// `y_ticks.len() * x_ticks.len()` cells, row by row from the bottom (missing: empty).
    pub cells: Vec<Cell>,
    /// Legend entries `(colour, label)`, right of the map.
    pub legend: Vec<(String, String)>,
}

/// Size of a cell, px.
const CELL: (f64, f64) = (78.0, 34.0);
/// Margins left, right (without the legend), top, bottom, px.
const MARGIN: (f64, f64, f64, f64) = (90.0, 16.0, 30.0, 50.0);

impl HeatMap {
    /// An empty map with its axes.
    #[must_use]
    pub fn new(title: &str, x_ticks: Vec<String>, y_ticks: Vec<String>) -> Self {
        HeatMap {
            title: title.into(),
            x_ticks,
            y_ticks,
            ..HeatMap::default()
        }
    }
    /// Sets the axis labels.
    #[must_use]
    pub fn labels(mut self, x: &str, y: &str) -> Self {
        self.x_label = x.into();
        self.y_label = y.into();
        self
    }
    /// Sets the cells.
    #[must_use]
    pub fn cells(mut self, cells: Vec<Cell>) -> Self {
        self.cells = cells;
        self
    }
    /// Adds a legend entry (colour `none`: a line of text without a swatch).
    #[must_use]
    pub fn legend(mut self, color: &str, label: &str) -> Self {
        self.legend.push((color.into(), label.into()));
        self
    }

    fn legend_width(&self) -> f64 {
        self.legend
            .iter()
            .map(|(_, l)| l.chars().count())
            .max()
            .map_or(0.0, |n| n as f64 * 6.5 + 40.0)
    }

    /// The title's estimated width at font-size 13, px (see [`super::lint`]).
    fn title_width(&self) -> f64 {
        self.title.chars().count() as f64 * 13.0 * super::lint::CHAR_WIDTH
    }

    /// Width and height of the panel, px.
    #[must_use]
    pub fn size(&self) -> (f64, f64) {
        let (ml, mr, mt, mb) = MARGIN;
        let w = ml + mr + self.legend_width() + CELL.0 * self.x_ticks.len().max(1) as f64;
        let h = mt + mb + CELL.1 * self.y_ticks.len().max(1) as f64;
        (w.max(300.0).max(self.title_width() + 16.0), h)
    }

    /// The panel as an SVG group translated to `(ox, oy)`.
    #[must_use]
    pub fn render_group(&self, ox: f64, oy: f64) -> String {
        let (ml, _, mt, _) = MARGIN;
        let (nx, ny) = (self.x_ticks.len(), self.y_ticks.len().max(1));
        let (pw, ph) = (CELL.0 * nx as f64, CELL.1 * ny as f64);
        let mut o = String::new();
        let _ = writeln!(
            o,
            r#"<g transform="translate({ox},{oy})" font-family="sans-serif" font-size="11">"#
        );
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="18" text-anchor="middle" font-size="13" font-weight="bold">{}</text>"#,
            // Over the cells, or as far right as a title wider than them needs.
            (ml + pw / 2.0).max(self.title_width() / 2.0 + 8.0),
            esc(&self.title)
        );
        for (k, c) in self.cells.iter().enumerate().take(nx * ny) {
            let (col, row) = (k % nx.max(1), k / nx.max(1));
            let x = ml + col as f64 * CELL.0;
            let y = mt + ph - (row + 1) as f64 * CELL.1;
            let _ = writeln!(
                o,
                r##"<rect class="cell" x="{x:.1}" y="{y:.1}" width="{:.1}" height="{:.1}" fill="{}" stroke="#fff"/>"##,
                CELL.0,
                CELL.1,
                esc(&c.fill)
            );
            if !c.text.is_empty() {
                let _ = writeln!(
                    o,
                    r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="{}">{}</text>"##,
                    x + CELL.0 / 2.0,
                    y + CELL.1 / 2.0 + 4.0,
                    text_colour(&c.fill),
                    esc(&c.text)
                );
            }
        }
        let _ = writeln!(
            o,
            r##"<rect x="{ml}" y="{mt}" width="{pw:.1}" height="{ph:.1}" fill="none" stroke="#333"/>"##
        );
        for (k, t) in self.x_ticks.iter().enumerate() {
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                ml + (k as f64 + 0.5) * CELL.0,
                mt + ph + 15.0,
                esc(t)
            );
        }
        for (k, t) in self.y_ticks.iter().enumerate() {
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
                ml - 5.0,
                mt + ph - (k as f64 + 0.5) * CELL.1 + 4.0,
                esc(t)
            );
        }
        let x_at = (ml + pw / 2.0, mt + ph + 36.0);
        super::axis_labels(&mut o, x_at, mt + ph / 2.0, &self.x_label, &self.y_label);
        let lx = ml + pw + 12.0;
        for (row, (col, label)) in self.legend.iter().enumerate() {
            let y = mt + row as f64 * 16.0;
            if col != "none" {
                let _ = writeln!(
                    o,
                    r##"<rect x="{lx:.1}" y="{y:.1}" width="14" height="12" fill="{}" stroke="#999"/>"##,
                    esc(col)
                );
            }
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
                lx + 20.0,
                y + 10.0,
                esc(label)
            );
        }
        o.push_str("</g>\n");
        o
    }
}

/// Several maps stacked vertically under an optional title, as one SVG document.
#[must_use]
pub fn stack(title: &str, maps: &[HeatMap]) -> String {
    let w = maps.iter().map(|m| m.size().0).fold(100.0, f64::max);
    let heights: Vec<f64> = maps.iter().map(|m| m.size().1).collect();
    super::document(title, w, &heights, |i, y| maps[i].render_group(0.0, y))
}

/// A sequential colour for `t` in `[0, 1]` (clamped; NaN: grey): 5 viridis stops, sRGB lerp.
#[must_use]
pub fn sequential(t: f64) -> String {
    const STOPS: [(u8, u8, u8); 5] = [
        (68, 1, 84),
        (59, 82, 139),
        (33, 145, 140),
        (94, 201, 98),
        (253, 231, 37),
    ];
    if t.is_nan() {
        return "#999999".into();
    }
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let k = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - k as f64;
    let mix = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * f).round() as u8;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    format!(
        "#{:02X}{:02X}{:02X}",
        mix(a.0, b.0),
        mix(a.1, b.1),
        mix(a.2, b.2)
    )
}

/// Black or white text, whichever reads better on `fill` (`#RRGGBB`; else black).
fn text_colour(fill: &str) -> &'static str {
    let hex = fill.trim_start_matches('#');
    let c = |i: usize| {
        hex.get(i..i + 2)
            .and_then(|h| u8::from_str_radix(h, 16).ok())
            .map_or(255.0, f64::from)
    };
    if hex.len() != 6 {
        return "#000";
    }
    // Relative luminance (ITU-R BT.709 weights on the sRGB values, roughly).
    let l = 0.2126 * c(0) + 0.7152 * c(2) + 0.0722 * c(4);
    if l < 128.0 {
        "#fff"
    } else {
        "#000"
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn cells_rows_and_legend_are_drawn() {
        let h = HeatMap::new(
            "a<b",
            vec!["x0".into(), "x1".into(), "x2".into()],
            vec!["y0".into(), "y1".into()],
        )
        .labels("f11 (N)", "lambda")
        .cells(
            (0..6)
                .map(|k| Cell::new(&sequential(k as f64 / 5.0), &k.to_string()))
                .collect(),
        )
        .legend("#009E73", "pass");
        let s = stack("", std::slice::from_ref(&h));
        assert_eq!(s.matches(r#"<rect class="cell""#).count(), 6);
        assert!(s.contains("a&lt;b") && s.contains("f11 (N)") && s.contains(">pass<"));
        // The first row is at the bottom: cell 0 below cell 3.
        let y_of = |k: usize| {
            let at = s.find(&format!(">{k}</text>")).unwrap();
            let pre = &s[..at];
            let y = pre.rfind(" y=\"").unwrap();
            pre[y + 4..]
                .split('"')
                .next()
                .unwrap()
                .parse::<f64>()
                .unwrap()
        };
        assert!(y_of(0) > y_of(3), "{} {}", y_of(0), y_of(3));
        assert!(s.trim_end().ends_with("</svg>"));
    }

    #[test]
    fn the_colour_scale_runs_from_dark_to_light() {
        assert_eq!(sequential(0.0), "#440154");
        assert_eq!(sequential(1.0), "#FDE725");
        assert_eq!(sequential(2.0), sequential(1.0));
        assert_eq!(text_colour(&sequential(0.0)), "#fff");
        assert_eq!(text_colour(&sequential(1.0)), "#000");
    }
}

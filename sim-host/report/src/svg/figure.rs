//! A [`Figure`]: plots stacked vertically, one legend width for all so their axes line
//! up.

use std::fmt::Write as _;
use std::path::Path;

use super::{esc, write_file, Plot};

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

//! A [`Figure`], one legend width for all its plots so their axes line up.

use std::path::Path;

use super::{document, write_file, Plot};

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
        let w = self.panels.iter().map(|p| p.width).fold(100.0, f64::max);
        let heights: Vec<f64> = self.panels.iter().map(|p| p.height).collect();
        let lw = self
            .panels
            .iter()
            .map(Plot::legend_width)
            .fold(0.0, f64::max);
        document(&self.title, w, &heights, |i, y| {
            self.panels[i].render_group_with(0.0, y, lw)
        })
    }
    /// Writes the SVG document to `path` (parent directories created).
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        write_file(path, &self.to_svg())
    }
}

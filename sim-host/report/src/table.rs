//! The one Markdown table writer of the reports: GitHub-flavoured rows, cells escaped
//! (`|` as `\|`, a line break as a space) so content cannot break a table; a short row
//! is padded, a long one truncated to the header's width.

use std::fmt::Display;

/// A Markdown table under construction.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

/// `s` with `|` escaped and line breaks turned into spaces.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace(['\n', '\r'], " ")
}

impl Table {
    /// A table with these column titles.
    pub fn new<I, S>(header: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: Display,
    {
        Self {
            header: header.into_iter().map(|h| cell(&h.to_string())).collect(),
            rows: Vec::new(),
        }
    }

    /// Append one row (cells formatted with `Display`).
    pub fn row<I, S>(&mut self, cells: I) -> &mut Self
    where
        I: IntoIterator<Item = S>,
        S: Display,
    {
        let mut r: Vec<String> = cells
            .into_iter()
            .take(self.header.len())
            .map(|c| cell(&c.to_string()))
            .collect();
        r.resize(self.header.len(), String::new());
        self.rows.push(r);
        self
    }

    /// Number of body rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// No body rows?
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The Markdown text, every line ending in `\n`.
    pub fn render(&self) -> String {
        let line = |v: &[String]| {
            format!(
                "|{}\n",
                v.iter().map(|c| format!(" {c} |")).collect::<String>()
            )
        };
        let mut s = line(&self.header);
        s += &format!("|{}\n", "---|".repeat(self.header.len()));
        for r in &self.rows {
            s += &line(r);
        }
        s
    }
}

impl std::fmt::Display for Table {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_header_separator_and_rows() {
        let mut t = Table::new(["a", "b"]);
        t.row([1, 2]).row(["x", "y"]);
        assert_eq!(t.render(), "| a | b |\n|---|---|\n| 1 | 2 |\n| x | y |\n");
        assert_eq!(t.len(), 2);
    }

    #[test]
    fn escapes_pipes_and_line_breaks_and_fits_rows_to_the_header() {
        let mut t = Table::new(["h|1", "h2"]);
        t.row(["a|b\nc"]).row(["1", "2", "3"]);
        let s = t.render();
        assert_eq!(s, "| h\\|1 | h2 |\n|---|---|\n| a\\|b c |  |\n| 1 | 2 |\n");
        // Every line has as many unescaped separators as the header.
        let bars = |l: &str| l.replace("\\|", "").matches('|').count();
        assert!(s.lines().all(|l| bars(l) == 3));
    }
}

//! Tables of text cells, rendered for the terminal, for HTML and as JSON rows.

use serde::{Deserialize, Serialize};
use std::fmt;

/// A titled table of text cells. Rows may be shorter than the header (missing cells render
/// empty); columns whose cells all look like numbers are right-aligned.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Table {
    /// Title shown above the table (may be empty).
    pub title: String,
    /// Column headers.
    pub headers: Vec<String>,
    /// Rows of cells.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with a title and column headers.
    pub fn new<I, S>(title: impl Into<String>, headers: I) -> Table
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        Table {
            title: title.into(),
            headers: headers.into_iter().map(Into::into).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row.
    pub fn push_row<I, S>(&mut self, cells: I) -> &mut Table
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        self.rows.push(cells.into_iter().map(Into::into).collect());
        self
    }

    /// Number of columns: the longest of the header and the rows.
    pub fn columns(&self) -> usize {
        self.rows
            .iter()
            .map(Vec::len)
            .chain([self.headers.len()])
            .max()
            .unwrap_or(0)
    }

    fn cell(row: &[String], c: usize) -> &str {
        row.get(c).map(String::as_str).unwrap_or("")
    }

    /// Whether column `c` holds numbers (every non-empty cell starts like one).
    fn numeric(&self, c: usize) -> bool {
        let mut any = false;
        for row in &self.rows {
            let cell = Self::cell(row, c).trim();
            if cell.is_empty() {
                continue;
            }
            any = true;
            if !looks_numeric(cell) {
                return false;
            }
        }
        any
    }

    /// Aligned plain text: title, header, a rule, then rows; two spaces between columns.
    pub fn to_text(&self) -> String {
        let n = self.columns();
        let width = |c: usize| {
            self.rows
                .iter()
                .map(|r| Self::cell(r, c).chars().count())
                .chain([Self::cell(&self.headers, c).chars().count()])
                .max()
                .unwrap_or(0)
        };
        let widths: Vec<usize> = (0..n).map(width).collect();
        let numeric: Vec<bool> = (0..n).map(|c| self.numeric(c)).collect();
        let line = |row: &[String]| {
            let cells: Vec<String> = (0..n)
                .map(|c| {
                    let (s, w) = (Self::cell(row, c), widths[c]);
                    if numeric[c] {
                        format!("{s:>w$}")
                    } else {
                        format!("{s:<w$}")
                    }
                })
                .collect();
            cells.join("  ").trim_end().to_string()
        };
        let mut out = String::new();
        if !self.title.is_empty() {
            out.push_str(&self.title);
            out.push('\n');
        }
        if !self.headers.is_empty() {
            out.push_str(&line(&self.headers));
            out.push('\n');
            let rule: Vec<String> = widths.iter().map(|w| "-".repeat(*w)).collect();
            out.push_str(&rule.join("  "));
            out.push('\n');
        }
        for row in &self.rows {
            out.push_str(&line(row));
            out.push('\n');
        }
        out
    }

    /// An HTML `<table>` (with the title as its caption); every cell is escaped.
    pub fn to_html(&self) -> String {
        self.html(true)
    }

    /// [`Table::to_html`], leaving out the caption when `caption` is false.
    pub(crate) fn html(&self, caption: bool) -> String {
        let n = self.columns();
        let numeric: Vec<bool> = (0..n).map(|c| self.numeric(c)).collect();
        let class = |c: usize| if numeric[c] { " class=\"num\"" } else { "" };
        let mut out = String::from("<table>\n");
        if caption && !self.title.is_empty() {
            out.push_str(&format!("<caption>{}</caption>\n", escape(&self.title)));
        }
        if !self.headers.is_empty() {
            out.push_str("<thead><tr>");
            for c in 0..n {
                let h = escape(Self::cell(&self.headers, c));
                out.push_str(&format!("<th{}>{h}</th>", class(c)));
            }
            out.push_str("</tr></thead>\n");
        }
        out.push_str("<tbody>\n");
        for row in &self.rows {
            out.push_str("<tr>");
            for c in 0..n {
                let v = escape(Self::cell(row, c));
                out.push_str(&format!("<td{}>{v}</td>", class(c)));
            }
            out.push_str("</tr>\n");
        }
        out.push_str("</tbody>\n</table>\n");
        out
    }

    /// One JSON object per row, keyed by header (for `--json` output of studies). Cells that
    /// parse as numbers become JSON numbers; columns without a header are keyed `col{i}`.
    pub fn to_json_rows(&self) -> serde_json::Value {
        let n = self.columns();
        let keys: Vec<String> = (0..n)
            .map(|c| match self.headers.get(c) {
                Some(h) if !h.is_empty() => h.clone(),
                _ => format!("col{c}"),
            })
            .collect();
        let rows = self
            .rows
            .iter()
            .map(|row| {
                let obj = keys
                    .iter()
                    .enumerate()
                    .map(|(c, k)| {
                        let cell = Self::cell(row, c);
                        let v = match cell.trim().parse::<f64>() {
                            Ok(x) if x.is_finite() => serde_json::json!(x),
                            _ => serde_json::Value::String(cell.to_string()),
                        };
                        (k.clone(), v)
                    })
                    .collect();
                serde_json::Value::Object(obj)
            })
            .collect();
        serde_json::Value::Array(rows)
    }
}

impl fmt::Display for Table {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_text())
    }
}

/// "12", "-0.5 m", "97.3 %", "1.2°", "0.1 / 0.2 / 0.3 m": starts with a number.
fn looks_numeric(cell: &str) -> bool {
    let s = cell.strip_prefix(['-', '+', '±']).unwrap_or(cell);
    let s = s.strip_prefix('.').unwrap_or(s);
    s.starts_with(|c: char| c.is_ascii_digit()) || matches!(cell, "NaN" | "nan" | "inf" | "-inf")
}

/// Escapes text for HTML element content and attribute values.
pub(crate) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Table {
        let mut t = Table::new("Results", ["method", "median (m)", "note"]);
        t.push_row(["posenet", "0.5", "baseline"]);
        t.push_row(["ours with cuts", "12.25", ""]);
        t.push_row(["short"]);
        t
    }

    #[test]
    fn text_columns_align() {
        let text = sample().to_text();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "Results");
        assert_eq!(lines[1], "method          median (m)  note");
        assert_eq!(lines[2], "--------------  ----------  --------");
        // numbers right-aligned under their header
        assert_eq!(lines[3], "posenet                0.5  baseline");
        assert_eq!(lines[4], "ours with cuts       12.25");
        assert_eq!(lines[5], "short");
        let col = lines[1].find("note");
        assert_eq!(lines[3].find("baseline"), col);
    }

    #[test]
    fn html_escapes_and_marks_numbers() {
        let mut t = sample();
        t.push_row(["<b>&", "1", "x"]);
        let html = t.to_html();
        assert!(html.contains("<caption>Results</caption>"));
        assert!(html.contains("&lt;b&gt;&amp;"));
        assert!(html.contains("<td class=\"num\">12.25</td>"));
        assert!(!html.contains("<b>"));
    }

    #[test]
    fn json_rows_are_keyed_and_typed() {
        let rows = sample().to_json_rows();
        assert_eq!(rows[0]["method"], "posenet");
        assert_eq!(rows[1]["median (m)"], 12.25);
        assert_eq!(rows[2]["note"], "");
    }

    #[test]
    fn empty_table_renders() {
        assert_eq!(Table::default().to_text(), "");
        assert!(Table::default().to_html().contains("<table>"));
    }
}

//! Self-contained HTML reports: one file, figures inline, no external assets.

use crate::error::Result;
use crate::figure::Figure;
use crate::io::write_atomic;
use crate::table::{Table, escape};
use std::path::Path;

/// A report under construction: a title, then sections of paragraphs, highlight cards, tables
/// and figures. Figures are embedded inline (SVG markup, or PNG as a base64 `data:` URI), so
/// the written file works offline and can be mailed or attached as it is.
///
/// Methods add to the last section started with [`HtmlReport::section`] (content added before
/// any section goes into an untitled one).
#[derive(Clone, Debug, Default)]
pub struct HtmlReport {
    title: String,
    subtitle: String,
    sections: Vec<Section>,
}

#[derive(Clone, Debug, Default)]
struct Section {
    heading: String,
    blocks: Vec<Block>,
}

#[derive(Clone, Debug)]
enum Block {
    Paragraph(String),
    Highlights(Vec<(String, String)>),
    Table(Table),
    Svg { svg: String, caption: String },
    Png { base64: String, caption: String },
    Preformatted(String),
}

impl HtmlReport {
    /// An empty report with a title.
    pub fn new(title: impl Into<String>) -> HtmlReport {
        HtmlReport {
            title: title.into(),
            ..HtmlReport::default()
        }
    }

    /// A line under the title (e.g. what was compared, when, on what data).
    pub fn subtitle(&mut self, text: impl Into<String>) -> &mut HtmlReport {
        self.subtitle = text.into();
        self
    }

    /// Starts a new section with a heading.
    pub fn section(&mut self, heading: impl Into<String>) -> &mut HtmlReport {
        self.sections.push(Section {
            heading: heading.into(),
            blocks: Vec::new(),
        });
        self
    }

    fn push(&mut self, block: Block) -> &mut HtmlReport {
        if self.sections.is_empty() {
            self.sections.push(Section::default());
        }
        if let Some(s) = self.sections.last_mut() {
            s.blocks.push(block);
        }
        self
    }

    /// A paragraph of plain text (escaped; blank lines start new paragraphs).
    pub fn paragraph(&mut self, text: impl Into<String>) -> &mut HtmlReport {
        self.push(Block::Paragraph(text.into()))
    }

    /// A row of headline figures, each a value in large type over a short label,
    /// e.g. `("median position error", "0.23 m")`.
    pub fn highlights<I, K, V>(&mut self, items: I) -> &mut HtmlReport
    where
        I: IntoIterator<Item = (K, V)>,
        K: Into<String>,
        V: Into<String>,
    {
        let items = items
            .into_iter()
            .map(|(k, v)| (k.into(), v.into()))
            .collect();
        self.push(Block::Highlights(items))
    }

    /// A table.
    pub fn table(&mut self, table: &Table) -> &mut HtmlReport {
        self.push(Block::Table(table.clone()))
    }

    /// A figure, rendered now and embedded as inline SVG.
    pub fn figure(
        &mut self,
        figure: &Figure,
        caption: impl Into<String>,
    ) -> Result<&mut HtmlReport> {
        let svg = figure.to_svg()?;
        Ok(self.svg(svg, caption))
    }

    /// An SVG document embedded inline, as is (e.g. from [`Figure::to_svg`]); an XML
    /// declaration at its start is dropped.
    pub fn svg(&mut self, svg: impl Into<String>, caption: impl Into<String>) -> &mut HtmlReport {
        let svg = svg.into();
        let svg = match svg.trim_start().strip_prefix("<?xml") {
            Some(rest) => rest
                .split_once("?>")
                .map(|(_, body)| body.to_string())
                .unwrap_or_default(),
            None => svg,
        };
        self.push(Block::Svg {
            svg,
            caption: caption.into(),
        })
    }

    /// PNG file bytes embedded as a base64 `data:` URI (e.g. a camera frame or a
    /// [`Figure::to_png`]).
    pub fn png(&mut self, png: &[u8], caption: impl Into<String>) -> &mut HtmlReport {
        self.push(Block::Png {
            base64: base64(png),
            caption: caption.into(),
        })
    }

    /// Preformatted text in a monospace block (commands, logs, configuration).
    pub fn preformatted(&mut self, text: impl Into<String>) -> &mut HtmlReport {
        self.push(Block::Preformatted(text.into()))
    }

    /// The whole report as one HTML document.
    pub fn to_html(&self) -> String {
        let mut out = String::with_capacity(64 * 1024);
        out.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
        out.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
        out.push_str(&format!("<title>{}</title>\n", escape(&self.title)));
        out.push_str("<style>\n");
        out.push_str(CSS);
        out.push_str("</style>\n</head>\n<body>\n<main>\n<header>\n");
        out.push_str(&format!("<h1>{}</h1>\n", escape(&self.title)));
        if !self.subtitle.is_empty() {
            out.push_str(&format!(
                "<p class=\"sub\">{}</p>\n",
                escape(&self.subtitle)
            ));
        }
        out.push_str("</header>\n");
        let titled: Vec<(usize, &Section)> = self
            .sections
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.heading.is_empty())
            .collect();
        if titled.len() >= 3 {
            out.push_str("<nav>");
            for (i, s) in &titled {
                out.push_str(&format!("<a href=\"#s{i}\">{}</a>", escape(&s.heading)));
            }
            out.push_str("</nav>\n");
        }
        for (i, s) in self.sections.iter().enumerate() {
            out.push_str(&format!("<section id=\"s{i}\">\n"));
            if !s.heading.is_empty() {
                out.push_str(&format!("<h2>{}</h2>\n", escape(&s.heading)));
            }
            for b in &s.blocks {
                render_block(&mut out, b, &s.heading);
            }
            out.push_str("</section>\n");
        }
        out.push_str(&format!(
            "<footer>Made by indoorloc {} — a single file with no external assets.</footer>\n",
            env!("CARGO_PKG_VERSION")
        ));
        out.push_str("</main>\n</body>\n</html>\n");
        out
    }

    /// Writes the report to `path`, atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_atomic(path, self.to_html().as_bytes())
    }
}

fn render_block(out: &mut String, b: &Block, heading: &str) {
    match b {
        Block::Paragraph(text) => {
            for para in text.split("\n\n").filter(|p| !p.trim().is_empty()) {
                out.push_str(&format!("<p>{}</p>\n", escape(para.trim())));
            }
        }
        Block::Highlights(items) => {
            out.push_str("<div class=\"cards\">\n");
            for (k, v) in items {
                out.push_str(&format!(
                    "<div class=\"card\"><div class=\"v\">{}</div><div class=\"k\">{}</div></div>\n",
                    escape(v),
                    escape(k)
                ));
            }
            out.push_str("</div>\n");
        }
        Block::Table(t) => {
            out.push_str("<div class=\"table-wrap\">\n");
            // a caption repeating the section heading just above it is noise
            out.push_str(&t.html(t.title != heading));
            out.push_str("</div>\n");
        }
        Block::Svg { svg, caption } => {
            out.push_str("<figure>\n");
            out.push_str(svg);
            out.push('\n');
            caption_html(out, caption);
            out.push_str("</figure>\n");
        }
        Block::Png { base64, caption } => {
            out.push_str(&format!(
                "<figure>\n<img alt=\"{}\" src=\"data:image/png;base64,{base64}\">\n",
                escape(caption)
            ));
            caption_html(out, caption);
            out.push_str("</figure>\n");
        }
        Block::Preformatted(text) => {
            out.push_str(&format!("<pre>{}</pre>\n", escape(text)));
        }
    }
}

fn caption_html(out: &mut String, caption: &str) {
    if !caption.is_empty() {
        out.push_str(&format!("<figcaption>{}</figcaption>\n", escape(caption)));
    }
}

/// Standard base64 (RFC 4648, with padding); small enough not to need a dependency.
pub(crate) fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(char::from(ABC[((n >> (18 - 6 * k)) & 63) as usize]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Light, readable styling; system fonts for text (the plots carry their own font).
const CSS: &str = r#":root { color-scheme: light; --fg: #1f2328; --muted: #59636e; --line: #d1d9e0;
  --soft: #eef1f4; --bg: #f6f8fa; --card: #ffffff; --accent: #1f77b4; }
* { box-sizing: border-box; }
body { margin: 0; background: var(--bg); color: var(--fg);
  font: 16px/1.55 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
main { max-width: 1180px; margin: 0 auto; padding: 32px 24px 40px; }
header h1 { font-size: 1.85rem; line-height: 1.2; margin: 0 0 6px; letter-spacing: -0.01em; }
header .sub { color: var(--muted); margin: 0 0 18px; }
nav { display: flex; flex-wrap: wrap; gap: 6px 18px; margin: 0 0 8px; font-size: .95rem; }
nav a { color: var(--accent); text-decoration: none; }
nav a:hover { text-decoration: underline; }
section { background: var(--card); border: 1px solid var(--line); border-radius: 10px;
  padding: 20px 24px; margin: 18px 0; box-shadow: 0 1px 2px rgba(31, 35, 40, .04); }
section h2 { font-size: 1.2rem; margin: 0 0 12px; }
p { margin: 0 0 12px; max-width: 80ch; }
.table-wrap { overflow-x: auto; }
table { border-collapse: collapse; margin: 6px 0 18px; font-size: .94rem;
  font-variant-numeric: tabular-nums; }
caption { text-align: left; font-weight: 600; padding: 0 0 6px; }
th, td { padding: 6px 14px; text-align: left; border-bottom: 1px solid var(--soft); white-space: nowrap; }
th { background: var(--bg); font-weight: 600; border-bottom: 1px solid var(--line); }
th.num, td.num { text-align: right; }
tbody tr:nth-child(even) { background: #fafbfc; }
tbody tr:hover { background: #eef5fc; }
.cards { display: grid; grid-template-columns: repeat(auto-fit, minmax(190px, 1fr)); gap: 12px;
  margin: 4px 0 16px; }
.card { border: 1px solid var(--line); border-radius: 8px; padding: 12px 16px; background: #fbfcfd; }
.card .v { font-size: 1.55rem; font-weight: 650; font-variant-numeric: tabular-nums; }
.card .k { color: var(--muted); font-size: .86rem; }
figure { margin: 8px 0 20px; }
figure svg, figure img { display: block; width: 100%; height: auto; background: #fff;
  border: 1px solid var(--soft); border-radius: 6px; }
figcaption { color: var(--muted); font-size: .9rem; margin-top: 6px; }
pre { background: var(--bg); border: 1px solid var(--soft); border-radius: 6px; padding: 12px;
  overflow: auto; font-size: .88rem; }
footer { color: var(--muted); font-size: .85rem; text-align: center; margin-top: 28px; }
@media print { body { background: #fff; } section { box-shadow: none; break-inside: avoid; } }
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figure::error_cdf;
    use crate::series::Series;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (raw, enc) in cases {
            assert_eq!(base64(raw.as_bytes()), enc);
        }
    }

    #[test]
    fn report_is_one_self_contained_file() -> Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let fig = error_cdf("Errors", &[Series::new("net", vec![0.1, 0.2, 0.4])], &[]);
        let mut t = Table::new("Numbers", ["k", "v"]);
        t.push_row(["a", "1"]);
        let mut r = HtmlReport::new("A <test> report");
        r.subtitle("sub")
            .paragraph("one\n\ntwo")
            .section("Figures")
            .highlights([("median", "0.2 m")])
            .table(&t);
        r.figure(&fig, "the CDF")?;
        r.png(&fig.to_png()?, "as PNG");
        r.preformatted("indoorloc eval");
        let path = dir.path().join("report.html");
        r.write(&path)?;
        let html = std::fs::read_to_string(&path)?;
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert!(html.contains("<title>A &lt;test&gt; report</title>"));
        assert!(html.contains("<svg") && html.contains("data:image/png;base64,iVBORw0KGgo"));
        assert!(html.contains("<p>one</p>\n<p>two</p>"));
        assert!(html.contains("0.2 m") && html.contains("<caption>Numbers</caption>"));
        // nothing fetched from elsewhere
        assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));
        assert!(!html.contains("<link") && !html.contains("<script"));
        Ok(())
    }

    #[test]
    fn xml_declaration_is_dropped() {
        let mut r = HtmlReport::new("t");
        r.svg("<?xml version=\"1.0\"?>\n<svg></svg>", "");
        let html = r.to_html();
        assert!(!html.contains("<?xml") && html.contains("<svg></svg>"));
    }
}

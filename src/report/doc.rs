//! One section of the report built as HTML and Markdown side by side: headings, paragraphs,
//! tables, figures and links, with the text helpers they share.

use crate::plot;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// One section of the report (HTML and Markdown built side by side).
#[derive(Default)]
pub(super) struct Doc {
    pub(super) html: String,
    pub(super) md: String,
}

pub(super) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Text for HTML with its Markdown code spans rendered: escaped, and each `…` pair of
/// backticks shown as `<code>…</code>` (an unpaired backtick stays as it is).
pub fn inline_html(s: &str) -> String {
    let parts: Vec<&str> = s.split('`').collect();
    let mut out = String::new();
    for (k, part) in parts.iter().enumerate() {
        let code = k % 2 == 1 && k + 1 < parts.len();
        if code {
            let _ = write!(out, "<code>{}</code>", esc(part));
        } else {
            if k % 2 == 1 {
                out.push('`');
            }
            out.push_str(&esc(part));
        }
    }
    out
}

/// Channels up to which a data file's summary lists each channel's value range inline; with
/// more (a 31-wavelength file) the ranges are folded under one overall line.
const RANGES_INLINE: usize = 6;

/// The summary of a data file (`brdfit info`) as it opens a data set's section: with more
/// than `RANGES_INLINE` channels, their per-channel `range` lines become one line (the
/// overall range and the count) and the list is folded away (HTML `<details>`), so the
/// results are not pushed down by 31 lines of ranges.
pub fn folded_summary(text: &str) -> (String, Option<String>) {
    let ranges: Vec<&str> = text.lines().filter(|l| l.starts_with("range ")).collect();
    if ranges.len() <= RANGES_INLINE {
        return (text.to_string(), None);
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for l in &ranges {
        let w: Vec<&str> = l.split_whitespace().collect();
        if let (Some(a), Some(b)) = (
            w.get(2).and_then(|v| v.parse::<f64>().ok()),
            w.get(4).and_then(|v| v.parse::<f64>().ok()),
        ) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    let mut head = String::new();
    let mut said = false;
    for l in text.lines() {
        if l.starts_with("range ") {
            if !said {
                let _ = writeln!(
                    head,
                    "range:       {lo:.6e} … {hi:.6e} over all {} channels (each below)",
                    ranges.len()
                );
                said = true;
            }
        } else {
            head.push_str(l);
            head.push('\n');
        }
    }
    let mut list = ranges.join("\n");
    list.push('\n');
    (head, Some(list))
}

impl Doc {
    pub(super) fn h(&mut self, level: usize, text: &str, id: &str) {
        let _ = writeln!(self.html, "<h{level} id=\"{id}\">{}</h{level}>", esc(text));
        let _ = writeln!(self.md, "\n{} {text}\n", "#".repeat(level));
    }
    pub(super) fn p(&mut self, text: &str) {
        let _ = writeln!(self.html, "<p>{}</p>", inline_html(text));
        let _ = writeln!(self.md, "{text}\n");
    }
    pub(super) fn pre(&mut self, text: &str) {
        let _ = writeln!(self.html, "<pre>{}</pre>", esc(text));
        let _ = writeln!(self.md, "```text\n{}```\n", text);
    }
    /// A data file's summary, its per-channel ranges folded when there are many
    /// ([`folded_summary`]).
    pub(super) fn info(&mut self, text: &str) {
        let (head, list) = folded_summary(text);
        self.pre(&head);
        if let Some(list) = list {
            let n = list.lines().count();
            let _ = writeln!(
                self.html,
                "<details><summary>value range of each of the {n} channels</summary><pre>{}</pre></details>",
                esc(&list)
            );
            let _ = writeln!(
                self.md,
                "<details><summary>value range of each of the {n} channels</summary>\n\n```text\n{list}```\n\n</details>\n"
            );
        }
    }
    pub(super) fn table(&mut self, head: &[&str], rows: &[Vec<String>]) {
        self.html.push_str("<table>\n<tr>");
        for h in head {
            let _ = write!(self.html, "<th>{}</th>", esc(h));
        }
        self.html.push_str("</tr>\n");
        let _ = writeln!(self.md, "| {} |", head.join(" | "));
        let _ = writeln!(self.md, "|{}", "---|".repeat(head.len()));
        for r in rows {
            self.html.push_str("<tr>");
            for c in r {
                let _ = write!(self.html, "<td>{}</td>", inline_html(c));
            }
            self.html.push_str("</tr>\n");
            let _ = writeln!(self.md, "| {} |", r.join(" | "));
        }
        self.html.push_str("</table>\n");
        self.md.push('\n');
    }
    /// A figure: PNG shown, SVG linked (paths relative to the report directory).
    pub(super) fn figure(&mut self, png: &str, svg: Option<&str>, caption: &str) {
        let link = svg.map_or(String::new(), |s| format!(" (<a href=\"{s}\">SVG</a>)"));
        let _ = writeln!(
            self.html,
            "<figure><img src=\"{png}\" alt=\"{}\"><figcaption>{}{link}</figcaption></figure>",
            esc(caption),
            inline_html(caption)
        );
        let _ = writeln!(self.md, "![{caption}]({png})\n");
    }
    pub(super) fn link(&mut self, href: &str, text: &str) {
        let _ = writeln!(
            self.html,
            "<p><a href=\"{href}\">{}</a></p>",
            inline_html(text)
        );
        let _ = writeln!(self.md, "[{text}]({href})\n");
    }
}

pub(super) fn rel(p: &Path, root: &Path) -> String {
    p.strip_prefix(root)
        .unwrap_or(p)
        .to_string_lossy()
        .replace('\\', "/")
}

pub(super) fn save_chart(
    chart: &impl plot::Chart,
    root: &Path,
    rel_base: &str,
) -> Result<(String, String)> {
    let (svg, png) = plot::save(chart, &root.join(rel_base))?;
    Ok((rel(&png, root), rel(&svg, root)))
}

/// A Markdown pipe table as an HTML table (for the study tables, built once as Markdown).
pub(super) fn md_table_to_html(md: &str) -> String {
    let mut out = String::from("<table>\n");
    for (k, line) in md.lines().filter(|l| l.starts_with('|')).enumerate() {
        if k == 1 {
            continue;
        }
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        let tag = if k == 0 { "th" } else { "td" };
        out.push_str("<tr>");
        for c in cells {
            // A short cell (a number, a count, a name) is never broken, say at the hyphen of
            // 3.2e-2.
            if tag == "td" && c.chars().count() <= 18 {
                let _ = write!(out, "<td class=\"short\">{}</td>", inline_html(c));
            } else {
                let _ = write!(out, "<{tag}>{}</{tag}>", inline_html(c));
            }
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</table>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn code_spans_become_code_elements() {
        assert_eq!(
            inline_html("run `brdfit choose` then `a<b`"),
            "run <code>brdfit choose</code> then <code>a&lt;b</code>"
        );
        // An unpaired backtick is left as written.
        assert_eq!(inline_html("x ` y"), "x ` y");
        assert_eq!(inline_html("`a` b ` c"), "<code>a</code> b ` c");
        assert_eq!(inline_html("plain & simple"), "plain &amp; simple");
    }

    /// Three channels are listed as they are; eight are folded into one line with the
    /// overall range (the smallest low, 1e-3, and the largest high, 8) and the count.
    #[test]
    fn many_channel_ranges_are_folded() {
        let few = "file:        x\nrange r      1.0e-1 … 2.0e0\nrange g      1.0e-1 … 2.0e0\nmissing:     0\n";
        assert_eq!(folded_summary(few), (few.to_string(), None));
        let mut many = String::from("file:        x\n");
        for k in 1..=8 {
            many.push_str(&format!(
                "range {k}00nm  {:.6e} … {:.6e}\n",
                k as f64 * 1e-3,
                k as f64
            ));
        }
        many.push_str("missing:     0\n");
        let (head, list) = folded_summary(&many);
        assert_eq!(
            head,
            "file:        x\nrange:       1.000000e-3 … 8.000000e0 over all 8 channels (each below)\nmissing:     0\n"
        );
        assert_eq!(list.unwrap().lines().count(), 8);
    }
}

//! The report's files: `index.html` (the page around the sections), `report.md`,
//! `results.json` and `timings.json`.

use super::doc::{Doc, esc};
use crate::support::output::write_bytes_atomic;
use anyhow::Result;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// index.html, report.md, results.json and timings.json.
pub(super) fn assemble(
    root: &Path,
    doc: &Doc,
    toc: &[(String, String)],
    summary: &[Vec<String>],
    results: Vec<Value>,
    mut timings: serde_json::Map<String, Value>,
    t_all: Instant,
) -> Result<()> {
    let mut html = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>brdfit report</title>\n<style>\nbody{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\ntable{border-collapse:collapse;margin:0.5em 0}\ntd,th{border:1px solid #bbb;padding:3px 8px;text-align:left}\ntd.short{white-space:nowrap}\nimg{max-width:100%}\nfigure{margin:1em 0}\nfigure.small{display:inline-block;width:24%;margin:0.3em}\npre{background:#f4f4f4;padding:0.6em;overflow-x:auto}\n@media print{pre{white-space:pre-wrap;overflow:visible;overflow-wrap:anywhere}}\n</style>\n</head>\n<body>\n<h1>brdfit report</h1>\n",
    );
    let mut md = String::from("# brdfit report\n\n");
    let head = [
        "data set",
        "channel",
        "recommended (fewest parameters within 2 BIC)",
        "parameters ± standard error",
        "verified by 8 random starts",
        "flags",
        "front lit needs",
        "edge lit needs",
    ];
    html.push_str("<p>The answer for each data set first: the model its data support, and the simplest model each lighting of Blinn's Figure 7 needs (judged by images, ꟻLIP p99 ≤ 0.05). Flags: <code>weak:NAME</code> a parameter only weakly determined by the data, <code>bound:NAME</code> on a bound, <code>not usable: N of M fits</code> how many of the data set's model fits failed a check (the reasons are under its parameters). Details per data set follow, then Blinn's Figures 5–7. Every fit is in <a href=\"results.json\">results.json</a>; run times in <a href=\"timings.json\">timings.json</a>; the same content as Markdown in <a href=\"report.md\">report.md</a>.</p>\n<table>\n<tr>");
    md.push_str("The answer for each data set first; details per data set follow, then Blinn's Figures 5–7. Every fit is in [results.json](results.json); run times in [timings.json](timings.json).\n\n");
    for h in head {
        let _ = write!(html, "<th>{}</th>", esc(h));
    }
    html.push_str("</tr>\n");
    let _ = writeln!(
        md,
        "| {} |\n|{}",
        head.join(" | "),
        "---|".repeat(head.len())
    );
    for r in summary {
        html.push_str("<tr>");
        for (k, c) in r.iter().enumerate() {
            if k == 0 {
                let _ = write!(html, "<td><a href=\"#{0}\">{0}</a></td>", esc(c));
            } else {
                let _ = write!(html, "<td>{}</td>", esc(c));
            }
        }
        html.push_str("</tr>\n");
        let _ = writeln!(md, "| {} |", r.join(" | "));
    }
    html.push_str("</table>\n<ul>\n");
    md.push('\n');
    for (name, id) in toc {
        let _ = writeln!(html, "<li><a href=\"#{id}\">{}</a></li>", esc(name));
        let _ = writeln!(md, "- {name}");
    }
    html.push_str("<li><a href=\"#blinn\">Blinn 1977, Figures 5–7</a></li>\n</ul>\n");
    md.push_str("- [Blinn 1977, Figures 5–7](#blinn-1977-figures-57)\n\n");
    html.push_str(&doc.html);
    html.push_str("</body>\n</html>\n");
    md.push_str(&doc.md);
    write_bytes_atomic(&root.join("index.html"), html.as_bytes())?;
    write_bytes_atomic(&root.join("report.md"), md.as_bytes())?;
    write_bytes_atomic(
        &root.join("results.json"),
        (serde_json::to_string_pretty(&json!({ "data_sets": results }))? + "\n").as_bytes(),
    )?;
    timings.insert("total".into(), json!(t_all.elapsed().as_secs_f64()));
    write_bytes_atomic(
        &root.join("timings.json"),
        (serde_json::to_string_pretty(&Value::Object(timings))? + "\n").as_bytes(),
    )?;
    Ok(())
}

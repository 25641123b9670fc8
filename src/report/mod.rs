//! `brdfit report`: from measured files to one shareable folder — per data set the summary,
//! the model comparison, the fitted parameters with uncertainty and warnings, lobe plots with
//! the in-plane data, residual and albedo plots, renders of the fitted material and the two
//! studies; plus Blinn's Figures 5–7. Written as `index.html` (self-contained, relative links,
//! no script), `report.md`, `results.json` (every fit) and `timings.json` (the only file that
//! changes between runs of the same inputs).

use crate::data::{self, Dataset, LoadOptions};
use crate::fit::{self, FitOptions, FitResult};
use crate::model::{Model, ModelKind};
use crate::output::write_bytes_atomic;
use crate::{plot, render, study};
use anyhow::{Context, Result};
use rayon::prelude::*;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of a report.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// Output directory.
    pub out: PathBuf,
    /// Random starts per configuration in the stability study.
    pub stability_starts: usize,
    /// Render resolution of the material previews.
    pub render_res: u32,
    /// Progress messages on stderr.
    pub verbose: bool,
    /// Told each stage as it starts (instead of the messages on stderr), e.g. to draw a
    /// progress bar.
    pub progress: Option<Progress>,
}

/// A progress hook: called with (work done, total work, what runs now), the work counted in
/// [`STAGE_WEIGHTS`] units (each stage's rough share of a file's time).
#[derive(Clone)]
pub struct Progress(pub std::sync::Arc<ProgressFn>);

/// The function behind [`Progress`].
pub type ProgressFn = dyn Fn(u64, u64, &str) + Send + Sync;

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress")
    }
}

/// The stages of one file's section, in order, with their rough relative cost (measured on
/// data/: the fits, `choose` and the studies dominate). Blinn's figures at the end count 1.
pub const STAGE_WEIGHTS: [(&str, u64); 6] = [
    ("loading", 1),
    ("fitting", 6),
    ("plots", 2),
    ("renders", 2),
    ("what each scene needs", 6),
    ("studies", 10),
];

/// The bundled data files: `data/*.csv`, `data/*.astm`, `data/*.brdf`, `data/*.binary`, sorted.
pub fn bundled_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    matches!(
                        p.extension().and_then(|e| e.to_str()),
                        Some("csv" | "astm" | "brdf" | "binary")
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// One section of the report (HTML and Markdown built side by side).
#[derive(Default)]
struct Doc {
    html: String,
    md: String,
}

fn esc(s: &str) -> String {
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
    fn h(&mut self, level: usize, text: &str, id: &str) {
        let _ = writeln!(self.html, "<h{level} id=\"{id}\">{}</h{level}>", esc(text));
        let _ = writeln!(self.md, "\n{} {text}\n", "#".repeat(level));
    }
    fn p(&mut self, text: &str) {
        let _ = writeln!(self.html, "<p>{}</p>", inline_html(text));
        let _ = writeln!(self.md, "{text}\n");
    }
    fn pre(&mut self, text: &str) {
        let _ = writeln!(self.html, "<pre>{}</pre>", esc(text));
        let _ = writeln!(self.md, "```text\n{}```\n", text);
    }
    /// A data file's summary, its per-channel ranges folded when there are many
    /// ([`folded_summary`]).
    fn info(&mut self, text: &str) {
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
    fn table(&mut self, head: &[&str], rows: &[Vec<String>]) {
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
    fn figure(&mut self, png: &str, svg: Option<&str>, caption: &str) {
        let link = svg.map_or(String::new(), |s| format!(" (<a href=\"{s}\">SVG</a>)"));
        let _ = writeln!(
            self.html,
            "<figure><img src=\"{png}\" alt=\"{}\"><figcaption>{}{link}</figcaption></figure>",
            esc(caption),
            inline_html(caption)
        );
        let _ = writeln!(self.md, "![{caption}]({png})\n");
    }
    fn link(&mut self, href: &str, text: &str) {
        let _ = writeln!(
            self.html,
            "<p><a href=\"{href}\">{}</a></p>",
            inline_html(text)
        );
        let _ = writeln!(self.md, "[{text}]({href})\n");
    }
}

fn rel(p: &Path, root: &Path) -> String {
    p.strip_prefix(root)
        .unwrap_or(p)
        .to_string_lossy()
        .replace('\\', "/")
}

fn save_chart(chart: &impl plot::Chart, root: &Path, rel_base: &str) -> Result<(String, String)> {
    let (svg, png) = plot::save(chart, &root.join(rel_base))?;
    Ok((rel(&png, root), rel(&svg, root)))
}

/// Fit JSON without its timing (so results.json is the same bytes on every run).
fn fit_json(f: &FitResult) -> Value {
    let mut v = f.to_json();
    if let Some(o) = v.as_object_mut() {
        o.remove("seconds");
        o.remove("geometry_seconds");
        o.remove("solve_seconds");
        o.remove("statistics_seconds");
    }
    v
}

fn is_synthetic(ds: &Dataset) -> bool {
    study::parse_truth(ds).is_some()
}

/// Run the whole report for `files`.
/// What one data set's section needs from the steps before it.
struct DataSet<'a> {
    /// File stem: the section's id and its folder under the report root.
    name: String,
    /// Single-channel samples the fits use.
    ds: Dataset,
    /// The report root.
    root: &'a Path,
    /// The report options.
    opts: &'a ReportOptions,
    /// This file's place among the report's files: (index, count), for the progress hook.
    place: (usize, usize),
}

/// Write the report for `files` into `opts.out`: index.html, report.md, results.json,
/// timings.json, and one folder per data set. The steps are the functions below, in order.
pub fn report(files: &[PathBuf], opts: &ReportOptions) -> Result<()> {
    let root = &opts.out;
    crate::output::create_dir(root).with_context(|| format!("creating {}", root.display()))?;
    let t_all = Instant::now();
    let mut doc = Doc::default();
    let mut results = Vec::new();
    let mut timings = serde_json::Map::new();
    let mut toc = Vec::new();
    let mut summary = Vec::new();
    for (fi, file) in files.iter().enumerate() {
        let t0 = Instant::now();
        let name = file
            .file_stem()
            .map_or("data".into(), |s| s.to_string_lossy().into_owned());
        stage(opts, fi, files.len(), 0, &format!("{name}: loading"));
        let full = data::load(file, &LoadOptions::default())?;
        let (ds, channel_note) = data::representative_channel(&full).map_err(anyhow::Error::msg)?;
        toc.push((name.clone(), name.clone()));
        doc.h(2, &format!("{name} ({})", file.display()), &name);
        doc.info(&data::summary(&full));
        for w in &full.meta.warnings {
            eprintln!("warning: {w}");
            doc.p(&format!("Warning: {w}"));
        }
        doc.p(&format!("Fits use {channel_note}."));
        let set = DataSet {
            name: name.clone(),
            ds,
            root,
            opts,
            place: (fi, files.len()),
        };
        let mut tm = serde_json::Map::new();
        stage(opts, fi, files.len(), 1, &format!("{name}: fitting"));
        let (fits, rec, recommended) = model_comparison(&mut doc, &set, file, &mut tm)?;
        let ts_i = ts_index(&fits);
        parameters(&mut doc, &set, &fits, ts_i, rec)?;
        results.push(json!({ "file": file.display().to_string(), "channel": channel_note, "recommended": recommended, "fits": fits.iter().map(fit_json).collect::<Vec<_>>() }));
        stage(opts, fi, files.len(), 2, &format!("{name}: plots"));
        let t = Instant::now();
        plots(&mut doc, &set, &fits, ts_i, rec)?;
        tm.insert("plots".into(), json!(t.elapsed().as_secs_f64()));
        stage(opts, fi, files.len(), 3, &format!("{name}: renders"));
        let t = Instant::now();
        renders(&mut doc, &set, &fits[ts_i])?;
        tm.insert("renders".into(), json!(t.elapsed().as_secs_f64()));
        stage(
            opts,
            fi,
            files.len(),
            4,
            &format!("{name}: what each scene needs"),
        );
        let t = Instant::now();
        let needs = scene_needs(&mut doc, &set, &fits)?;
        summary.push(summary_row(&set, &channel_note, &fits, rec, &needs));
        tm.insert("choose".into(), json!(t.elapsed().as_secs_f64()));
        stage(opts, fi, files.len(), 5, &format!("{name}: studies"));
        let t = Instant::now();
        studies(&mut doc, &set, &fits[ts_i], &mut tm)?;
        tm.insert("studies".into(), json!(t.elapsed().as_secs_f64()));
        tm.insert("total".into(), json!(t0.elapsed().as_secs_f64()));
        timings.insert(name.clone(), Value::Object(tm));
    }
    // Blinn's figures after the user's data.
    let per: u64 = STAGE_WEIGHTS.iter().map(|s| s.1).sum();
    let total = files.len() as u64 * per + 1;
    say(
        opts,
        (total - 1) * UNITS,
        total * UNITS,
        "Blinn's figures 5–7",
    );
    let t = Instant::now();
    let mut blinn = Doc::default();
    blinn_figures(&mut blinn, root, opts)?;
    doc.html.push_str(&blinn.html);
    doc.md.push_str(&blinn.md);
    timings.insert("blinn_figures".into(), json!(t.elapsed().as_secs_f64()));
    assemble(root, &doc, &toc, &summary, results, timings, t_all)
}

/// One row of the report's opening summary: data set, channel, recommended model with its
/// parameters ± standard error, verification, short flags, and what each Figure 7 scene needs.
fn summary_row(
    set: &DataSet,
    channel: &str,
    fits: &[FitResult],
    rec: usize,
    needs: &[String],
) -> Vec<String> {
    let f = &fits[rec];
    let params: Vec<String> = f
        .params
        .iter()
        .zip(&f.stderr)
        .map(|((n, v), e)| {
            if e.is_finite() && *e > 0.0 && *e <= 10.0 * v.abs() {
                format!(
                    "{n} {} ± {}",
                    crate::model::readable(*v),
                    crate::model::readable(*e)
                )
            } else {
                format!("{n} {}", crate::model::readable(*v))
            }
        })
        .collect();
    let verified = fits
        .iter()
        .filter(|f| f.verification.as_ref().is_some_and(|v| v.verified))
        .count();
    let mut flags = f.flags();
    let unusable = fits.iter().filter(|f| !f.usable()).count();
    if unusable > 0 {
        flags.push(format!("not usable: {unusable} of {} fits", fits.len()));
    }
    vec![
        set.name.clone(),
        channel.trim_start_matches("the ").to_string(),
        if f.usable() {
            f.label()
        } else {
            "none usable".into()
        },
        params.join(", "),
        format!("{verified}/{} fits", fits.len()),
        flags.join(", "),
        needs.first().cloned().unwrap_or_default(),
        needs.get(1).cloned().unwrap_or_default(),
    ]
}

/// Progress units per [`STAGE_WEIGHTS`] unit, so that the steps inside a stage (each study
/// fit, each `choose` candidate) move the bar and its estimate of the time left.
const UNITS: u64 = 100;

/// Announce stage `k` ([`STAGE_WEIGHTS`]) of file `f` of `n`.
fn stage(opts: &ReportOptions, f: usize, n: usize, k: usize, what: &str) {
    stage_at(opts, f, n, k, 0.0, what);
}

/// [`stage`] with the share `part` (0–1) of stage `k` done.
fn stage_at(opts: &ReportOptions, f: usize, n: usize, k: usize, part: f64, what: &str) {
    let per: u64 = STAGE_WEIGHTS.iter().map(|s| s.1).sum();
    let start = f as u64 * per + STAGE_WEIGHTS[..k].iter().map(|s| s.1).sum::<u64>();
    let within = (part.clamp(0.0, 1.0) * (STAGE_WEIGHTS[k].1 * UNITS) as f64) as u64;
    say(
        opts,
        start * UNITS + within,
        (n as u64 * per + 1) * UNITS,
        what,
    );
}

/// A step inside stage `k` of a file's section, e.g. one study.
fn step(set: &DataSet, k: usize, what: &str) {
    step_at(set, k, 0.0, what);
}

/// [`step`] with the share `part` (0–1) of stage `k` done; only to a progress hook (the
/// messages on stderr name the stages and the studies, not each step).
fn step_at(set: &DataSet, k: usize, part: f64, what: &str) {
    if set.opts.progress.is_some() {
        stage_at(
            set.opts,
            set.place.0,
            set.place.1,
            k,
            part,
            &format!("{}: {what}", set.name),
        );
    }
}

/// What runs now: to the progress hook, else on stderr when verbose.
fn say(opts: &ReportOptions, done: u64, total: u64, m: &str) {
    match &opts.progress {
        Some(p) => (p.0)(done, total, m),
        None if opts.verbose => eprintln!("report: {m}"),
        None => {}
    }
}

/// Blinn 1977, Figures 5–7, with his parameters.
fn blinn_figures(doc: &mut Doc, root: &Path, opts: &ReportOptions) -> Result<()> {
    doc.h(2, "Blinn 1977, Figures 5–7", "blinn");
    let (p5, s5) = save_chart(&plot::blinn_figure(30.0, 5), root, "blinn/figure5")?;
    let (p6, s6) = save_chart(&plot::blinn_figure(70.0, 6), root, "blinn/figure6")?;
    doc.p("Phong ((N·H)^c1, c1 = 50) against Torrance–Sparrow (D3 with the same half-angle β, n 1.8, ps .667, pd .333); Phong's ps matches the Torrance–Sparrow highlight at normal incidence. At 30° the two are nearly identical; at 70° the Torrance–Sparrow bump is far larger and points off-specular, toward grazing.");
    doc.figure(&p5, Some(&s5), "Figure 5: incident light at 30°");
    doc.figure(&p6, Some(&s6), "Figure 6: incident light at 70°");
    let imgs = render::fig7_images(
        &Model::blinn_aluminium(),
        &Model::blinn_mgo(),
        opts.render_res,
        render::AntiAlias::Adaptive {
            threshold: 0.02,
            max_level: 3,
            block: 1,
            jitter: false,
        },
    );
    write_bytes_atomic(&root.join("blinn/fig7.png"), &render::contact_sheet(&imgs)?)?;
    doc.p("Figure 7 with Blinn's parameters (aluminium ps .4 pd .6 n 200 c3 .5; MgO ps .667 pd .333 n 1.8 c3 .35), rendered by brdfit's Whitted ray tracer: front lit the models agree; edge lit the ceramic's Torrance–Sparrow highlight is several times brighter than Phong's.");
    doc.figure(
        "blinn/fig7.png",
        None,
        "Figure 7: aluminium and MgO, front and edge lit, Phong and Torrance–Sparrow",
    );

    Ok(())
}

/// Fit every model (verified), rank them and write the comparison; returns the fits, the
/// index shown as recommended (Torrance–Sparrow when none is usable) and its label.
fn model_comparison(
    doc: &mut Doc,
    set: &DataSet,
    file: &Path,
    tm: &mut serde_json::Map<String, Value>,
) -> Result<(Vec<FitResult>, usize, Option<String>)> {
    let (ds, name) = (&set.ds, &set.name);
    // Every model in parallel (each fit is deterministic, so the order of work is free); a
    // step as each ends (a full MERL table's take about 30 s together).
    // Every fit counts its passes over the data in one watch, shown as it grows.
    let t = Instant::now();
    let models = fit::all_models();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let watch = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let share = || done.load(std::sync::atomic::Ordering::Relaxed) as f64 / models.len() as f64;
    let tick = |k: usize| step_at(set, 1, share(), &format!("fitting: {k} evaluations in all"));
    let fits: Vec<FitResult> = fit::ticking(&watch, &tick, || {
        models
            .par_iter()
            .map(|&(k, d)| {
                let mut o = FitOptions::new(k);
                o.dist = d;
                o.verify = REPORT_VERIFY;
                o.watch = Some(watch.clone());
                let f = fit::fit(ds, &o).map(|mut v| v.remove(0));
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                step_at(set, 1, share(), &format!("fitting: {} done", k.label(d)));
                f
            })
            .collect::<std::result::Result<_, _>>()
    })
    .with_context(|| format!("fitting {}", file.display()))?;
    // timings.json: the step's wall time like every other entry, and each model's own clock
    // (the models run in parallel, so these add up to more than the wall time).
    tm.insert("fits".into(), json!(t.elapsed().as_secs_f64()));
    tm.insert(
        "fit_seconds_per_model".into(),
        Value::Object(fits.iter().map(|f| (f.label(), json!(f.seconds))).collect()),
    );
    let (order, rec) = fit::rank(&fits);
    doc.h(3, "Model comparison", &format!("{name}-models"));
    let best_bic = fits[order[0]].bic;
    let rows: Vec<Vec<String>> = order
        .iter()
        .map(|&i| {
            let f = &fits[i];
            vec![
                f.label(),
                f.n_free.to_string(),
                format!("{:.6e}", f.cost),
                format!("{:.1}", f.aic),
                format!("{:.1}", f.bic),
                if f.usable() {
                    format!("{:.1}", f.bic - best_bic)
                } else {
                    "—".into()
                },
                if Some(i) == rec {
                    "← simplest the data support".into()
                } else if !f.usable() {
                    format!("not usable: {}", f.unusable.join("; "))
                } else {
                    String::new()
                },
            ]
        })
        .collect();
    doc.table(&["model", "k", "cost", "AIC", "BIC", "ΔBIC", ""], &rows);
    doc.p(&format!(
    "Every fit was checked by {REPORT_VERIFY} seeded random starts (`brdfit fit --verify {REPORT_VERIFY}`): {}.",
    if fits.iter().all(|f| f.verification.as_ref().is_some_and(|v| v.verified)) {
        "none ended lower than the fit shown".to_string()
    } else {
        "a fit that one of them beats is marked not usable".to_string()
    }
));
    let recommended = rec.map(|r| fits[r].label());
    let rec = match rec {
        Some(r) => {
            doc.p(&format!(
                "Recommended: {} — the model with the fewest parameters within 2 BIC of the best.",
                fits[r].label()
            ));
            r
        }
        None => {
            doc.p("No fit is usable, so no model is recommended; the Torrance–Sparrow fit is shown below for inspection only.");
            ts_index(&fits)
        }
    };

    Ok((fits, rec, recommended))
}

/// Parameters of Torrance–Sparrow (D3) and of the recommended model, with the fit's JSON.
fn parameters(
    doc: &mut Doc,
    set: &DataSet,
    fits: &[FitResult],
    ts_i: usize,
    rec: usize,
) -> Result<()> {
    let (name, root, dir) = (&set.name, set.root, &set.name);
    doc.h(3, "Parameters", &format!("{name}-params"));
    let mut shown = vec![ts_i];
    if rec != ts_i {
        shown.push(rec);
    }
    for &i in &shown {
        let f = &fits[i];
        let rows: Vec<Vec<String>> = f
            .params
            .iter()
            .zip(&f.stderr)
            .map(|((n, v), s)| {
                let range = f
                    .ranges
                    .iter()
                    .find(|r| r.0 == *n)
                    .map_or(String::new(), |r| fit::describe_range(n, (r.1, r.2)));
                vec![
                    n.clone(),
                    crate::model::readable(*v),
                    if s.is_finite() && (*s <= 10.0 * v.abs() || *v == 0.0) {
                        format!("{s:.3e}")
                    } else {
                        "not determined".into()
                    },
                    range,
                ]
            })
            .collect();
        doc.p(&format!(
            "{} (log loss, {} samples, termination: {}):",
            f.label(),
            f.samples_used,
            f.termination
        ));
        doc.table(
            &[
                "parameter",
                "value",
                "std. error",
                "range within 1 % of the minimum cost",
            ],
            &rows,
        );
        for w in &f.warnings {
            doc.p(&format!("⚠ {w}"));
        }
        for why in &f.unusable {
            doc.p(&format!("✗ Not usable: {why}"));
        }
    }
    // The recommended model's fit first (what a reader takes elsewhere), then Torrance–Sparrow.
    for &i in shown.iter().rev() {
        let f = &fits[i];
        let file = if i == ts_i {
            "fit-torrance-sparrow.json".to_string()
        } else {
            format!("fit-{}.json", f.label().replace(" (", "-").replace(')', ""))
        };
        let fit_path = root.join(dir).join(file);
        write_bytes_atomic(
            &fit_path,
            (serde_json::to_string_pretty(&fit_json(f))? + "\n").as_bytes(),
        )?;
        let what = if i == rec && f.usable() {
            format!("{} fit (the recommended model) as JSON", f.label())
        } else {
            format!("{} fit as JSON", f.label())
        };
        doc.link(
            &rel(&fit_path, root),
            &format!("{what} (input to brdfit render, plot and export)"),
        );
    }

    Ok(())
}

/// Lobes against the in-plane data, residuals and albedo.
fn plots(doc: &mut Doc, set: &DataSet, fits: &[FitResult], ts_i: usize, rec: usize) -> Result<()> {
    let (ds, name, root, dir) = (&set.ds, &set.name, set.root, &set.name);
    let ts = &fits[ts_i];
    let synthetic = is_synthetic(ds);
    let thetas = lobe_angles(ds);
    let models = vec![
        (format!("{} fit", fits[ts_i].label()), ts.model_for(0)),
        (format!("{} fit", fits[rec].label()), fits[rec].model_for(0)),
    ];
    let models: Vec<(String, Model)> = if rec == ts_i {
        models[..1].to_vec()
    } else {
        models
    };
    let chart = plot::lobe_chart(
        &format!("{name}: reflection in the plane of incidence"),
        &models,
        Some((ds, 0)),
        &thetas,
        plot::LobeQuantity::Intensity,
        !synthetic,
        plot::InPlane {
            theta_i: 0.5,
            azimuth: if synthetic { 5.0 } else { 1.0 },
        },
    );
    doc.h(3, "Lobes, residuals and albedo", &format!("{name}-plots"));
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/lobes"))?;
    doc.figure(
        &png,
        Some(&svg),
        &format!(
            "Lobes at θi = {:?}° ({} radius; markers: measured samples in the plane of incidence)",
            thetas,
            if synthetic { "linear" } else { "logarithmic" }
        ),
    );
    doc.p(&lobe_takeaway(&chart));
    // A step per chart (a full MERL table's million residuals take seconds to draw).
    let pts = plot::residual_points(ds, 0, &ts.model_for(0), true);
    let charts = plot::residual_charts(&ts.label(), &pts);
    for (i, (file_name, chart)) in charts.iter().enumerate() {
        let part = (1 + i) as f64 / (2 + charts.len()) as f64;
        step_at(set, 2, part, &format!("plots: {file_name}"));
        let (png, svg) = save_chart(chart, root, &format!("{dir}/{file_name}"))?;
        doc.figure(&png, Some(&svg), &chart.title);
        doc.p(&residual_takeaway(chart));
    }
    step_at(
        set,
        2,
        (1 + charts.len()) as f64 / (2 + charts.len()) as f64,
        "plots: albedo",
    );
    let measured = plot::measured_albedo(ds, 0);
    let (chart, apts) = plot::albedo_chart(&ts.label(), &ts.model_for(0), &measured);
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/albedo"))?;
    doc.figure(
        &png,
        Some(&svg),
        "Directional albedo of the Torrance–Sparrow fit",
    );
    if let Some(p) = apts.iter().find(|p| p.1 > 1.0) {
        doc.p(&format!(
            "⚠ The fitted model creates energy: albedo {:.3} at θi = {}°.",
            p.1, p.0
        ));
    } else if let (Some(a), Some(b)) = (apts.first(), apts.last()) {
        doc.p(&format!(
            "Takeaway: the fit reflects {} of the light at normal incidence and {} at θi = {}°, \
             within the energy limit. {}",
            crate::model::significant(a.1, 3),
            crate::model::significant(b.1, 3),
            b.0,
            albedo_agreement(&apts, &measured)
        ));
    }

    Ok(())
}

/// Figure 7 renders of the fitted Torrance–Sparrow material and its equal-β Phong.
fn renders(doc: &mut Doc, set: &DataSet, ts: &FitResult) -> Result<()> {
    let (name, root, dir, opts) = (&set.name, set.root, &set.name, set.opts);
    doc.h(
        3,
        "Renders of the fitted material",
        &format!("{name}-renders"),
    );
    let m = ts.model_for(0);
    let phong = crate::model::equal_beta_phong(&m);
    doc.p(&format!(
        "Blinn's Figure 7 sphere with this data set's fit: {m}; and Phong with the same \
         half-angle β: {phong}."
    ));
    let mut names = Vec::new();
    for (lname, l) in [
        ("front", render::scene::Lighting::Front),
        ("edge", render::scene::Lighting::Edge),
    ] {
        for (mname, mm) in [("phong", crate::model::equal_beta_phong(&m)), ("ts", m)] {
            let img = render::scene::fig7_scene(mm, l, opts.render_res).render(&|| {});
            let base = root.join(dir).join(format!("render-{lname}-{mname}"));
            render::save(&img, &base)?;
            names.push(format!("{dir}/render-{lname}-{mname}.png"));
        }
    }
    let _ = writeln!(doc.html, "<div class=\"row\">");
    for (n, cap) in names.iter().zip([
        "front lit, Phong (equal β)",
        "front lit, Torrance–Sparrow",
        "edge lit, Phong (equal β)",
        "edge lit, Torrance–Sparrow",
    ]) {
        let _ = writeln!(
            doc.html,
            "<figure class=\"small\"><img src=\"{n}\" alt=\"{cap}\"><figcaption>{cap} (<a href=\"{}\">EXR</a>)</figcaption></figure>",
            n.replace(".png", ".exr")
        );
        let _ = writeln!(doc.md, "![{cap}]({n})");
    }
    let _ = writeln!(doc.html, "</div>");
    doc.md.push('\n');

    Ok(())
}

/// What each scene needs: `brdfit choose` on Blinn's Figure 7 cases at 512², its sheet and
/// chart per case; the model comparison's `fits` are its global fits.
fn scene_needs(doc: &mut Doc, set: &DataSet, fits: &[FitResult]) -> Result<Vec<String>> {
    let (name, root, dir) = (&set.name, set.root, &set.name);
    doc.h(3, "What each scene needs", &format!("{name}-choose"));
    let cases = crate::choose::fig7_cases(CHOOSE_RES);
    let watch = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let opts = crate::choose::ChooseOptions {
        watch: Some(watch.clone()),
        ..Default::default()
    };
    // One progress line per step (`choose::progress_steps`), and every 0.25 s the fits'
    // passes over the data so far beside the step last done.
    let steps = crate::choose::progress_steps(&set.ds, &cases, &opts);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let last = std::sync::Mutex::new(String::from("global fits of every model"));
    let share = || done.load(std::sync::atomic::Ordering::Relaxed) as f64 / steps as f64;
    let tick = |k: usize| {
        let last = last.lock().expect("no progress hook panics");
        step_at(set, 4, share(), &fit::with_count(&last, k));
    };
    let chosen = fit::ticking(&watch, &tick, || {
        crate::choose::choose_with(&set.ds, &cases, &opts, fits, &|m| {
            let mut last = last.lock().expect("no progress hook panics");
            *last = m.to_string();
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            step_at(set, 4, share(), m)
        })
    });
    let (r, images) = chosen?;
    let out = root.join(dir).join("choose");
    crate::choose::write(&out, &r, &images)?;
    doc.p(&format!(
        "The measurement itself is rendered as the reference (resampled onto a half/difference \
         table, {:.0} % of its cells filled from the {} fit) on Blinn's Figure 7 sphere at \
         {CHOOSE_RES}², and each model is fitted to the configurations the scene's lit pixels \
         show (`brdfit choose`, threshold {} ≤ {}). The simplest model under the threshold is \
         enough for that scene.",
        100.0 * r.fill_share,
        r.fill_model,
        r.threshold.metric,
        r.threshold.value
    ));
    for c in &r.cases {
        let answer = format!("{} lit: {}.", c.case, c.answer());
        doc.p(&answer);
        doc.p(&format!("Verdict: {}: {}.", c.verdict.name(), c.reason));
        let sheet = format!("{dir}/choose/{}/sheet.png", c.case);
        doc.figure(
            &sheet,
            None,
            &format!(
                "{answer} Top: the reference and each model's render; below: ꟻLIP error maps."
            ),
        );
        let chart = format!("{dir}/choose/{}/chart", c.case);
        doc.figure(
            &format!("{chart}.png"),
            Some(&format!("{chart}.svg")),
            "Image error against fit + render time (times measured in this run; the other \
             numbers are the same on every run); the ringed point is the choice.",
        );
        let md = crate::choose::case_table(c, false);
        doc.md.push_str(&md);
        doc.md.push('\n');
        doc.html.push_str(&md_table_to_html(&md));
    }
    doc.link(
        &format!("{dir}/choose/choose.json"),
        "the choice as JSON (choose.json)",
    );
    Ok(r.cases
        .iter()
        .map(|c| match &c.chosen {
            Some(m) => m.clone(),
            None if c.verdict == crate::choose::Verdict::Undetermined => {
                format!("undetermined (closest {})", c.closest)
            }
            None => format!("none (closest {})", c.closest),
        })
        .collect())
}

/// Speed against accuracy and stability from random starts.
fn studies(
    doc: &mut Doc,
    set: &DataSet,
    ts: &FitResult,
    tm: &mut serde_json::Map<String, Value>,
) -> Result<()> {
    let (ds, name, root, dir, opts) = (&set.ds, &set.name, set.root, &set.name, set.opts);
    let m = ts.model_for(0);
    doc.h(3, "Speed against accuracy", &format!("{name}-speed"));
    let truth = study::parse_truth(ds);
    step(set, 5, "studies: speed against accuracy");
    // The speed study about half of the stage, the stability study the rest.
    let rows = study::speed_accuracy_with_progress(ds, truth.as_ref(), 1, &|i, n, what| {
        step_at(
            set,
            5,
            0.5 * i as f64 / n as f64,
            &format!("studies: speed against accuracy: {what}"),
        )
    });
    let chart = study::speed_chart(
        &format!("{name}: cost against fit time, every method × model"),
        &rows,
    );
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/speed-accuracy"))?;
    doc.figure(&png, Some(&svg), "Fit time (measured in this run) against the cost above the best found, for the solvers on Torrance–Sparrow (D3) and for each model with its best solver, and, where the file carries its truth, against each solver's largest parameter error; ringed points and the step line mark the Pareto front (no point is both faster and better)");
    {
        // Deterministic (no times): which solvers reach the lowest cost found on
        // Torrance–Sparrow (D3), which do not, and the best model.
        let ts_rows: Vec<&study::SpeedRow> = rows
            .iter()
            .filter(|r| r.model == "torrance-sparrow (d3)")
            .collect();
        let best = ts_rows.iter().map(|r| r.cost).fold(f64::INFINITY, f64::min);
        let (reach, miss): (Vec<&study::SpeedRow>, Vec<&study::SpeedRow>) =
            ts_rows.iter().partition(|r| r.cost <= best * (1.0 + 1e-6));
        let names = |v: &[&study::SpeedRow]| {
            v.iter()
                .map(|r| r.method.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let lowest = rows
            .iter()
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
            .map_or(String::new(), |r| r.model.clone());
        doc.p(&format!(
            "Takeaway: the lowest cost of all is {lowest}'s. On Torrance–Sparrow (D3) {} reach \
             the lowest cost found for it{}.",
            names(&reach),
            if miss.is_empty() {
                String::new()
            } else {
                format!(
                    "; {} {} not (see why each stopped in the table)",
                    names(&miss),
                    if miss.len() == 1 { "does" } else { "do" }
                )
            }
        ));
    }
    let (md, csv) = study::speed_tables(&rows, false);
    write_bytes_atomic(&root.join(dir).join("speed-accuracy.csv"), csv.as_bytes())?;
    doc.md.push_str(&md);
    doc.md.push('\n');
    doc.html.push_str(&md_table_to_html(&md));
    tm.insert(
        "speed_accuracy_fit_seconds".into(),
        json!(
            rows.iter()
                .map(|r| json!({"method": r.method, "model": r.model, "seconds": r.seconds}))
                .collect::<Vec<_>>()
        ),
    );
    doc.h(
        3,
        "Stability from random starts",
        &format!("{name}-stability"),
    );
    let reference = truth
        .filter(|m| m.kind == ModelKind::TorranceSparrow)
        .unwrap_or(m);
    // The stability study is the second half of the stage (the speed study's steps end at 0.5).
    step_at(set, 5, 0.5, "studies: stability from random starts");
    let configurations = std::sync::atomic::AtomicUsize::new(0);
    let srows = study::stability_with_progress(&reference, opts.stability_starts, 600, 1, &|| {
        let k = configurations.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        step_at(
            set,
            5,
            0.5 + 0.5 * k as f64 / study::STABILITY_CONFIGURATIONS as f64,
            &format!(
                "studies: stability from random starts: {k} of {} configurations",
                study::STABILITY_CONFIGURATIONS
            ),
        )
    });
    let chart = study::stability_chart(
        &format!(
            "{name}: share of {} random starts reaching the global minimum",
            opts.stability_starts
        ),
        &srows,
    );
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/stability"))?;
    doc.figure(&png, Some(&svg), "Stability as a heatmap: configurations (noise × sampling) against methods, each cell the share of seeded random starts reaching the global minimum, failures classified");
    doc.p(&stability_takeaway(&srows));
    let (md, csv) = study::stability_tables(&srows);
    doc.p(study::STABILITY_CELLS);
    write_bytes_atomic(&root.join(dir).join("stability.csv"), csv.as_bytes())?;
    doc.md.push_str(&md);
    doc.md.push('\n');
    doc.html.push_str(&md_table_to_html(&md));
    Ok(())
}

/// How the fit's albedo compares with the estimate from the samples, in one sentence.
fn albedo_agreement(fit: &[(f64, f64)], measured: &[(f64, f64)]) -> String {
    let worst = measured
        .iter()
        .filter_map(|(t, m)| {
            let f = fit.iter().find(|p| p.0 == *t)?.1;
            Some((*t, (f - m) / m))
        })
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    match worst {
        None => "The samples do not cover and resolve the outgoing hemisphere at any θi, so \
                 the albedo cannot be estimated from them."
            .into(),
        Some((t, d)) => format!(
            "The estimate from the samples ({} incidence angle{}) differs from the fit by at \
             most {} % (θi = {t}°).",
            measured.len(),
            if measured.len() == 1 { "" } else { "s" },
            crate::model::significant(100.0 * d.abs(), 2)
        ),
    }
}

/// The takeaway under the stability heatmap: per method, in how many configurations every
/// start reached the minimum, with the global initialisation and from the random start alone.
fn stability_takeaway(rows: &[study::StabilityRow]) -> String {
    use crate::fit::lsq::Method;
    let configs = rows.len() / (2 * Method::ALL.len());
    let all_reached = |m: Method, g: bool| {
        rows.iter()
            .filter(|r| r.method == m && r.global == g && r.hits == r.starts)
            .count()
    };
    let list = |g: bool| {
        Method::ALL
            .iter()
            .map(|&m| format!("{} {}", m.name(), all_reached(m, g)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "Takeaway: configurations (of {configs}) in which every start reached the minimum, \
         with the global initialisation: {}; from the random start alone: {}.",
        list(true),
        list(false)
    )
}

/// index.html, report.md, results.json and timings.json.
fn assemble(
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

/// One line under the lobe chart: where each panel's first fitted curve peaks relative to
/// the mirror direction, and how many measured samples lie near the plane.
fn lobe_takeaway(chart: &plot::LobeChart) -> String {
    let parts: Vec<String> = chart
        .panels
        .iter()
        .map(|p| {
            let peak = p.series.first().and_then(|s| {
                s.points
                    .iter()
                    .filter(|q| q.1.is_finite())
                    .max_by(|a, b| a.1.total_cmp(&b.1))
            });
            let measured = p
                .series
                .iter()
                .filter(|s| s.markers)
                .map(|s| s.points.len())
                .sum::<usize>();
            // Signed θo < 0 is the mirror side; the mirror direction is at −θi.
            match peak {
                Some(q) => format!(
                    "at θi = {}° the fit peaks {}° from the mirror direction{} ({measured} \
                     measured sample{} near the plane)",
                    p.theta_i_deg,
                    crate::model::significant((q.0 + p.theta_i_deg).abs(), 2),
                    if q.0 < -p.theta_i_deg - 0.5 {
                        ", toward grazing"
                    } else {
                        ""
                    },
                    if measured == 1 { "" } else { "s" }
                ),
                None => format!("at θi = {}° nothing to show", p.theta_i_deg),
            }
        })
        .collect();
    format!("Takeaway: {}.", parts.join("; "))
}

/// One line under a residual chart: the largest binned median and where it is.
fn residual_takeaway(chart: &plot::XyChart) -> String {
    let median = chart.series.iter().find(|s| s.label == "binned median");
    let worst = median.and_then(|s| {
        s.points
            .iter()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    });
    match worst {
        Some(w) => format!(
            "Takeaway: the binned median residual stays within ±{} (loss units); its largest \
             departure is at {} = {}°.",
            crate::model::significant(w.1.abs(), 2),
            chart.x_label.split(' ').next().unwrap_or("x"),
            crate::model::significant(w.0, 3)
        ),
        None => "Takeaway: too few samples for a binned median.".into(),
    }
}

/// Incidence angles for the lobe plots: the two measured θi closest to 30° and 60° that have
/// in-plane samples, else 30° and 60°.
fn lobe_angles(ds: &Dataset) -> Vec<f64> {
    let mut tis: Vec<f64> = ds
        .theta_i
        .iter()
        .map(|t| (t.to_degrees() * 10.0).round() / 10.0)
        .collect();
    tis.sort_by(f64::total_cmp);
    tis.dedup();
    if tis.len() > 30 || tis.is_empty() {
        return vec![30.0, 60.0];
    }
    let pick = |want: f64| {
        tis.iter()
            .cloned()
            .min_by(|a, b| (a - want).abs().total_cmp(&(b - want).abs()))
            .unwrap_or(want)
    };
    let (a, b) = (pick(30.0), pick(60.0));
    if a == b { vec![a] } else { vec![a, b] }
}

/// A Markdown pipe table as an HTML table (for the study tables, built once as Markdown).
fn md_table_to_html(md: &str) -> String {
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

/// Random starts the report's verification runs for every fit it shows.
const REPORT_VERIFY: usize = 8;

/// Resolution of the report's `choose` renders (the CLI's default).
const CHOOSE_RES: u32 = 512;

/// The Torrance–Sparrow D3 fit among the fits of [`fit::all_models`].
fn ts_index(fits: &[FitResult]) -> usize {
    fits.iter()
        .position(|f| {
            f.model == ModelKind::TorranceSparrow && f.dist == crate::model::Distribution::D3
        })
        .expect("all_models has d3")
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

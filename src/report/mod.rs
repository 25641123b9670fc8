//! `brdfit report`: from measured files to one shareable folder — per data set the summary,
//! the model comparison, the fitted parameters with uncertainty and warnings, lobe plots with
//! the in-plane data, residual and albedo plots, renders of the fitted material and the two
//! studies; plus Blinn's Figures 5–7. Written as `index.html` (self-contained, relative links,
//! no script), `report.md`, `results.json` (every fit) and `timings.json` (the only file that
//! changes between runs of the same inputs).

mod doc;
mod figures;
mod fits;
mod page;
mod progress;
mod scene_needs;
mod studies;

use crate::data::{self, Dataset, LoadOptions};
use crate::fit::FitResult;
use crate::model::ModelKind;
use crate::study;
use anyhow::{Context, Result};
use doc::Doc;
use figures::{blinn_figures, plots, renders};
use fits::{model_comparison, parameters, summary_row};
use page::assemble;
use progress::{UNITS, say, stage};
use scene_needs::scene_needs;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;
use studies::studies;

pub use doc::{folded_summary, inline_html};

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

/// Each file's section id and folder: its file stem, with `-2`, `-3`, … after a stem an
/// earlier file already has (compared without case, for case-blind file systems), so that
/// `a/sample.csv` and `b/sample.csv` get sections and folders of their own.
pub fn section_names(files: &[PathBuf]) -> Vec<String> {
    let mut taken = std::collections::HashSet::new();
    files
        .iter()
        .map(|f| {
            let stem = f
                .file_stem()
                .map_or("data".into(), |s| s.to_string_lossy().into_owned());
            let mut name = stem.clone();
            let mut k = 2;
            while !taken.insert(name.to_lowercase()) {
                name = format!("{stem}-{k}");
                k += 1;
            }
            name
        })
        .collect()
}

/// Write the report for `files` into `opts.out`: index.html, report.md, results.json,
/// timings.json, and one folder per data set. The steps are the functions below, in order.
pub fn report(files: &[PathBuf], opts: &ReportOptions) -> Result<()> {
    let root = &opts.out;
    crate::support::output::create_dir(root)
        .with_context(|| format!("creating {}", root.display()))?;
    let t_all = Instant::now();
    let mut doc = Doc::default();
    let mut results = Vec::new();
    let mut timings = serde_json::Map::new();
    let mut toc = Vec::new();
    let mut summary = Vec::new();
    let names = section_names(files);
    for (fi, file) in files.iter().enumerate() {
        let t0 = Instant::now();
        let name = names[fi].clone();
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

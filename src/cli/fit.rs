//! `brdfit fit`: parse, call the library, print the table and write the JSON and summary.

use super::*;
use anyhow::{Result, anyhow, bail};
use brdfit::model::{Distribution, ModelKind};
use std::path::Path;

/// Read a fit JSON strictly (one fit, or several under `fits`); the error names the file.
pub(crate) fn read_fits(path: &Path) -> Result<Vec<brdfit::fit::FitResult>> {
    let text = brdfit::support::input::read_to_string_limited(
        path,
        brdfit::support::input::Input::FitJson,
    )?;
    brdfit::fit::read_fit_file(&text).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Say on stderr what was picked for the user from `path`.
fn say_notes(path: &Path, p: &brdfit::fit::Picked) {
    if !quiet() {
        for n in &p.notes {
            eprintln!("note: {}: {n}", path.display());
        }
    }
}

/// The fits of `path` that `want` asks for, one model, every channel asked (see
/// [`brdfit::fit::pick`]); the notes go to stderr.
pub(crate) fn pick_fits(path: &Path, want: &brdfit::fit::Want) -> Result<brdfit::fit::Picked> {
    let p = brdfit::fit::pick(&read_fits(path)?, want)
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    say_notes(path, &p);
    Ok(p)
}

/// One fit of `path` for a consumer of one channel (the data's, when given; see
/// [`brdfit::fit::pick_one`]); the notes go to stderr.
pub(crate) fn pick_fit(
    path: &Path,
    want: &brdfit::fit::Want,
    data_channel: Option<&str>,
) -> Result<brdfit::fit::PickedChannel> {
    pick_fit_from(path, &read_fits(path)?, want, data_channel)
}

/// As [`pick_fit`], from the fits already read from `path` (named in messages).
pub(crate) fn pick_fit_from(
    path: &Path,
    fits: &[brdfit::fit::FitResult],
    want: &brdfit::fit::Want,
    data_channel: Option<&str>,
) -> Result<brdfit::fit::PickedChannel> {
    let mut p = brdfit::fit::pick_one(fits, want, data_channel)
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    say_notes(path, &p);
    Ok(p.channels.remove(0))
}

pub(crate) fn run_fit(a: &FitArgs, load: &LoadArgs) -> Result<()> {
    use rayon::prelude::*;
    // An output that is an input is refused before any fit is run or printed.
    let inputs: Vec<&Path> = a.files.iter().map(PathBuf::as_path).collect();
    for out in [&a.json, &a.summary, &a.residuals].into_iter().flatten() {
        refuse_input(out, &inputs)?;
    }
    check_residuals_target(a)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.jobs as usize)
        .build()
        .map_err(|e| anyhow!("cannot start {} jobs: {e}", a.jobs))?;
    let results: Vec<Result<Fitted>> = if a.merge {
        vec![fit_merged(a, load)]
    } else if a.files.len() == 1 {
        vec![fit_one(a, load, &a.files[0])]
    } else {
        let bar = progress_bar(a.files.len() as u64, "files");
        let r = pool.install(|| {
            a.files
                .par_iter()
                .map(|f| {
                    let r = fit_one(a, load, f);
                    bar.inc(1);
                    r
                })
                .collect()
        });
        bar.finish_and_clear();
        r
    };
    let mut all = Vec::new();
    let mut first_err = None;
    for (f, r) in a.files.iter().zip(results) {
        match r {
            Ok((text, fits, residuals)) => {
                if a.files.len() > 1 && !a.merge {
                    print(&format!("== {}\n", f.display()))?;
                }
                print(&text)?;
                if let (Some(path), Some(csv)) = (&a.residuals, residuals) {
                    write_file(path, csv.as_bytes())?;
                }
                all.push((f.clone(), fits));
            }
            Err(e) => {
                // One file: main reports the error; a batch reports each and goes on.
                if a.files.len() > 1 && !a.merge {
                    report_error(&e);
                }
                first_err.get_or_insert(e);
            }
        }
    }
    // Nothing fitted: no output file (an empty `fits` list would only fail its consumer).
    if all.is_empty()
        && let Some(e) = first_err
    {
        return Err(e);
    }
    if let Some(path) = &a.json {
        refuse_input(
            path,
            &a.files.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
        )?;
        let flat: Vec<&brdfit::fit::FitResult> = all.iter().flat_map(|(_, f)| f).collect();
        let v = brdfit::fit::fits_json(&flat);
        let s = serde_json::to_string_pretty(&v)? + "\n";
        write_file(path, s.as_bytes())?;
        if flat.len() > 1 && !quiet() {
            eprintln!("note: {}", holds(path, &flat));
        }
    }
    if let Some(path) = &a.summary {
        refuse_input(
            path,
            &a.files.iter().map(PathBuf::as_path).collect::<Vec<_>>(),
        )?;
        let text = if path.extension().is_some_and(|e| e == "json") {
            let rows: Vec<serde_json::Value> = all
                .iter()
                .flat_map(|(f, fits)| {
                    fits.iter().map(move |r| {
                        let mut v = r.to_json();
                        v["file"] = serde_json::json!(f.display().to_string());
                        v
                    })
                })
                .collect();
            serde_json::to_string_pretty(&rows)? + "\n"
        } else {
            // One column per parameter name (in order of first appearance), empty where a
            // row's model has no such parameter.
            let mut pnames: Vec<&str> = Vec::new();
            for (_, fits) in &all {
                for r in fits {
                    for (n, _) in &r.params {
                        if !pnames.contains(&n.as_str()) {
                            pnames.push(n);
                        }
                    }
                }
            }
            let mut w = csv::Writer::from_writer(Vec::new());
            let mut head = vec!["file", "channel", "model"];
            head.extend(&pnames);
            head.extend([
                "cost",
                "rmse",
                "bic",
                "samples_used",
                "warnings",
                "unusable",
                "recommended",
                "interval_level",
            ]);
            // Each parameter's confidence interval, two columns a parameter.
            let ends: Vec<String> = pnames
                .iter()
                .flat_map(|n| [format!("{n}_lo"), format!("{n}_hi")])
                .collect();
            head.extend(ends.iter().map(String::as_str));
            w.write_record(&head)?;
            for (f, fits) in &all {
                let recommended = summary_recommended(fits);
                for (i, r) in fits.iter().enumerate() {
                    let mut row = vec![f.display().to_string(), r.channel.clone(), r.label()];
                    row.extend(
                        pnames
                            .iter()
                            .map(|n| r.get(n).map_or(String::new(), |v| v.to_string())),
                    );
                    row.extend([
                        r.cost.to_string(),
                        r.rmse.to_string(),
                        r.bic.to_string(),
                        r.samples_used.to_string(),
                        r.warnings.len().to_string(),
                        r.unusable.join("; "),
                        recommended[i].to_string(),
                        r.interval_level.to_string(),
                    ]);
                    for n in &pnames {
                        let iv = r.ranges.iter().find(|x| x.0 == *n);
                        row.extend([
                            iv.map_or(String::new(), |x| x.1.to_string()),
                            iv.map_or(String::new(), |x| x.2.to_string()),
                        ]);
                    }
                    w.write_record(&row)?;
                }
            }
            String::from_utf8(w.into_inner().map_err(|e| anyhow!("{e}"))?)?
        };
        write_file(path, text.as_bytes())?;
    }
    match first_err {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Most fits (channels × models) one `fit` of a file runs: 1,024 (about a minute at the
/// slowest models' 50 ms a fit); a file of more channels is refused before any fit, with the
/// fix.
pub(crate) const MAX_FITS: usize = 1024;

/// Refuse a file whose channels × models exceed [`MAX_FITS`].
fn check_fit_count(file: &Path, channels: usize, models: usize) -> Result<()> {
    if channels * models > MAX_FITS {
        bail!(
            "{}: {channels} channels × {models} model(s) would be {} fits, above the limit of {MAX_FITS} for one run\n  fix: pick channels with --channel NAME|INDEX|<λ>nm|cie-y{}",
            file.display(),
            channels * models,
            if models > 1 {
                ", or fit one model (--model NAME) instead of --model all"
            } else {
                ""
            }
        );
    }
    Ok(())
}

/// Warn (even with --quiet, like the loaders' warnings) when samples repeat an earlier
/// sample's angles: each copy counts as an independent measurement, so the standard errors
/// shrink by about √(copies) although no information was added.
fn duplicates_warning(file: &Path, ds: &brdfit::data::Dataset) {
    let dup = ds.duplicates();
    if dup > 0 {
        eprintln!(
            "warning: {}: {dup} of {} samples repeat an earlier sample's angles; each counts as a new measurement, so the standard errors are smaller than the data support (about √{:.1} too small if every sample repeats equally)\n  fix: average the repeated rows into one (with a weights column giving their count if they are independent measurements)",
            file.display(),
            ds.len(),
            ds.len() as f64 / (ds.len() - dup).max(1) as f64
        );
    }
}

/// For each of one file's fits, whether it is the recommendation of its channel (the BIC
/// ranking of `fit --model all`, [`brdfit::fit::rank`]).
fn summary_recommended(fits: &[brdfit::FitResult]) -> Vec<bool> {
    let mut out = vec![false; fits.len()];
    let mut channels: Vec<&str> = fits.iter().map(|f| f.channel.as_str()).collect();
    channels.dedup();
    channels.sort();
    channels.dedup();
    for c in channels {
        let idx: Vec<usize> = (0..fits.len()).filter(|&i| fits[i].channel == c).collect();
        let subset: Vec<brdfit::FitResult> = idx.iter().map(|&i| fits[i].clone()).collect();
        if let (_, Some(k)) = brdfit::fit::rank(&subset) {
            out[idx[k]] = true;
        }
    }
    out
}

/// Samples from which a single file's fits show a progress bar on a terminal.
const BAR_SAMPLES: usize = 100_000;

/// One file fitted: the terminal text, the fits and (with `--residuals`) the residuals' CSV.
type Fitted = (String, Vec<brdfit::fit::FitResult>, Option<String>);

/// `--residuals` takes one data file and an output no other output names, checked before any
/// fit.
fn check_residuals_target(a: &FitArgs) -> Result<()> {
    let Some(r) = &a.residuals else {
        return Ok(());
    };
    if a.files.len() > 1 && !a.merge {
        bail!(
            "--residuals {}: {} data files given; the residuals are written for one\n  fix: fit each file on its own with --residuals",
            r.display(),
            a.files.len()
        );
    }
    for (flag, other) in [("--json", &a.json), ("--summary", &a.summary)] {
        if other.as_ref().is_some_and(|o| o == r || same_file(o, r)) {
            bail!(
                "--residuals {} is also the {flag} output\n  fix: give the residuals another file name",
                r.display()
            );
        }
    }
    Ok(())
}

/// The CSV of `--residuals`: every sample each fit of `fits` used (see
/// [`brdfit::fit::residuals`]).
fn residuals_csv(
    file: &Path,
    ds: &brdfit::data::Dataset,
    fits: &[brdfit::fit::FitResult],
    max_theta: Option<f64>,
) -> Result<String> {
    let mut rows = Vec::with_capacity(fits.len());
    for f in fits {
        let r = brdfit::fit::residuals(ds, f, max_theta)
            .map_err(|e| anyhow!("{}: {}: {e}", file.display(), f.label()))?;
        rows.push((f.label(), r));
    }
    let mut losses: Vec<brdfit::fit::Loss> = Vec::new();
    for f in fits {
        if !losses.contains(&f.loss) {
            losses.push(f.loss);
        }
    }
    let mut comments = vec![format!(
        "residuals of brdfit fit {}: one row per sample and channel each fit used",
        file.display()
    )];
    comments.extend(
        losses
            .iter()
            .map(|l| brdfit::fit::residual_definition(*l).to_string()),
    );
    comments.push(
        "angles in degrees; brdf in 1/sr; each fit's cost = 1/2 sum(weight residual^2)".into(),
    );
    let models = fits.iter().any(|f| f.label() != fits[0].label());
    let mut buf = Vec::new();
    brdfit::fit::write_residuals_csv(&mut buf, &comments, &rows, models)?;
    Ok(String::from_utf8(buf)?)
}

/// Fit one file as the flags say: the terminal text, the fits and the residuals asked for.
pub(crate) fn fit_one(a: &FitArgs, load: &LoadArgs, file: &Path) -> Result<Fitted> {
    let t = std::time::Instant::now();
    let ds = load.load(file)?;
    if VERBOSE.load(std::sync::atomic::Ordering::Relaxed) {
        eprintln!(
            "{}: {} samples, {} channel(s) read in {:.3} s",
            file.display(),
            ds.len(),
            ds.channels.len(),
            t.elapsed().as_secs_f64()
        );
    }
    fit_loaded(a, file, ds)
}

/// `--merge`: every file of the command line as one measurement, fitted once under the
/// first file's name.
fn fit_merged(a: &FitArgs, load: &LoadArgs) -> Result<Fitted> {
    let sets = a
        .files
        .iter()
        .map(|f| load.load(f))
        .collect::<Result<Vec<_>>>()?;
    let ds = data::Dataset::merge(&sets).map_err(|e| anyhow!("{e}"))?;
    fit_loaded(a, &a.files[0], ds)
}

/// Fit the loaded data of `file` as the arguments say.
fn fit_loaded(a: &FitArgs, file: &Path, ds: data::Dataset) -> Result<Fitted> {
    use brdfit::fit::{self, FitOptions};
    let dist = a.distribution;
    // clap has checked the name: `all` or a model.
    let kinds: Vec<(ModelKind, Distribution)> = match ModelKind::parse(&a.model) {
        Some(kind) => vec![(kind, dist)],
        None => fit::all_models(),
    };
    check_fit_count(file, ds.channels.len(), kinds.len())?;
    duplicates_warning(file, &ds);
    let (method, loss, robust) = (a.method, a.loss, a.robust);
    let fix = parse_assignments("--fix", &a.fix)?;
    // A held value outside the fitter's box would be written to a fit JSON that reading
    // refuses: the same bounds as the fit-file loader (ParamSpec::in_fit_box).
    for (k, v) in &fix {
        for (kind, dist) in &kinds {
            if let Some(spec) = kind.params(*dist).iter().find(|s| s.name == k)
                && !spec.in_fit_box(*v)
            {
                bail!(
                    "on the command line: --fix {k}={} is outside the range a fit can return ({}: {})\n  fix: give --fix {k}=VALUE with {}",
                    brdfit::model::exact(*v),
                    kind.label(*dist),
                    spec.fit_box_text(),
                    spec.fit_box_text()
                );
            }
        }
    }
    let start = parse_assignments("--start", &a.start)?;
    check_flag_params(&kinds, &fix, &start)?;
    let mut o = FitOptions::new(kinds[0].0);
    o.method = method;
    o.loss = loss;
    o.robust = robust;
    o.max_theta_deg = a.max_theta;
    o.weights = a.weights;
    (o.fix, o.start, o.shared) = (fix, start, a.shared.clone());
    o.local_only = a.local_only;
    o.resolution = a.resolution;
    o.fast_pow = a.fast_pow;
    o.verify = a.verify;
    o.seed = a.verify_seed;
    let opts = fit::options_per_model(&o, &kinds);
    // The models in parallel, each channel's geometry computed once for them all. A bar (on a
    // terminal, one file) from a tenth of a million samples on, where the fits take seconds (a
    // full MERL table: about 20 s for --model all); a batch of files has its own bar.
    let bar = if (a.files.len() == 1 || a.merge) && ds.len() >= BAR_SAMPLES {
        progress_bar(1, "fitting")
    } else {
        indicatif::ProgressBar::hidden()
    };
    let shown = |done: u64, total: u64, running: &str| {
        bar.set_length(total);
        bar.set_position(done);
        bar.set_message(format!("fitting {running}"));
    };
    let fitted = fit::fit_models_with_progress(&ds, &opts, a.repeat as usize, &shown);
    bar.finish_and_clear();
    let (all, wall) = fitted.with_context(|| file.display().to_string())?;
    if a.repeat > 1 && kinds.len() > 1 {
        eprintln!(
            "{}: {} models fitted in {:.1} ms ({} channel(s); wall, median of {} runs)",
            file.display(),
            kinds.len(),
            1e3 * wall,
            all[0].len(),
            a.repeat
        );
    }
    let mut text = String::new();
    let nch = all[0].len();
    if nch > 1 && !VERBOSE.load(std::sync::atomic::Ordering::Relaxed) {
        // A multi-channel file: one table per model, a row per channel (--verbose: each fit
        // in full), then the recommendation per channel.
        for fits in &all {
            text.push_str(&fit::format_channels(fits));
        }
        if all.len() > 1 {
            text.push_str(
                "BIC ranking per channel: ΔBIC from the best usable fit; ← recommended (fewest parameters within 2 BIC of the best):\n",
            );
            for c in 0..nch {
                let row: Vec<fit::FitResult> = all.iter().map(|f| f[c].clone()).collect();
                text.push_str(&format!(
                    "  {:<10} {}\n",
                    row[0].channel,
                    fit::format_ranking_line(&row)
                ));
            }
        }
        text.push_str("(each fit in full: --verbose or --json)\n");
    } else {
        for c in 0..nch {
            for fits in &all {
                text.push_str(&fit::format_fit(&fits[c]));
            }
            if all.len() > 1 {
                let row: Vec<fit::FitResult> = all.iter().map(|f| f[c].clone()).collect();
                text.push_str(&format!("model comparison, channel {}:\n", row[0].channel));
                text.push_str(&fit::format_ranking(&row));
            }
        }
    }
    let fits: Vec<brdfit::fit::FitResult> = all.into_iter().flatten().collect();
    let residuals = match &a.residuals {
        Some(_) => Some(residuals_csv(file, &ds, &fits, a.max_theta)?),
        None => None,
    };
    Ok((text, fits, residuals))
}

/// What a fit file holds, e.g. `fits.json holds 7 models of channel y; consumers (export,
/// plot, render) use the recommended one unless given --model`.
fn holds(path: &Path, fits: &[&brdfit::fit::FitResult]) -> String {
    let mut models: Vec<String> = Vec::new();
    let mut channels: Vec<&str> = Vec::new();
    for f in fits {
        if !models.contains(&f.label()) {
            models.push(f.label());
        }
        for c in f.channel.split(',') {
            if !channels.contains(&c) {
                channels.push(c);
            }
        }
    }
    let m = match models.len() {
        1 => format!("1 model ({})", models[0]),
        n => format!("{n} models"),
    };
    let c = match channels.len() {
        1 => format!("channel {}", channels[0]),
        n if n <= 4 => format!("channels {}", channels.join(", ")),
        n => format!("{n} channels ({} … {})", channels[0], channels[n - 1]),
    };
    let tail = if models.len() > 1 {
        "; consumers (export, plot, render) use the recommended model unless given --model"
    } else {
        "; consumers take every channel (export, scenes: as colour) or pick one with --channel"
    };
    format!("{} holds {m} of {c}{tail}", path.display())
}

/// `--fix` and `--start` checked on the command line, before any fit: every name must be a
/// parameter of a model being fitted, and every value within that parameter's bounds. The
/// library checks the same per fit, but its error is then reported against the data file.
fn check_flag_params(
    kinds: &[(ModelKind, Distribution)],
    fix: &[(String, f64)],
    start: &[(String, f64)],
) -> Result<()> {
    for (flag, list) in [("--fix", fix), ("--start", start)] {
        for (k, v) in list {
            let mut found = false;
            for (kind, dist) in kinds {
                let Some(spec) = kind.params(*dist).iter().find(|s| s.name == k) else {
                    continue;
                };
                found = true;
                if !spec.admits(*v) {
                    let bounds = spec.bounds_text();
                    bail!(
                        "on the command line: {flag} {k}={} is outside its bounds ({}: {bounds})\n  fix: give {flag} {k}=VALUE with {bounds}",
                        brdfit::model::exact(*v),
                        kind.label(*dist)
                    );
                }
            }
            if !found {
                let mut names: Vec<&str> = Vec::new();
                for (kind, dist) in kinds {
                    for n in kind.param_names(*dist) {
                        if !names.contains(&n) {
                            names.push(n);
                        }
                    }
                }
                let which = match kinds {
                    [(kind, dist)] => format!("{} has", kind.label(*dist)),
                    _ => "none of the models fitted has".to_string(),
                };
                bail!(
                    "on the command line: {flag} {k}={}: {which} no parameter {k}\n  fix: name one of its parameters: {}",
                    brdfit::model::exact(*v),
                    names.join(", ")
                );
            }
        }
    }
    Ok(())
}

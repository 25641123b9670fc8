//! `brdfit report`: the library's report over the given files (the bundled data by default).

use super::*;
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

pub(crate) fn run_report(
    files: Vec<PathBuf>,
    output: &Path,
    stability_starts: u16,
    render_res: u32,
) -> Result<()> {
    let quiet = quiet();
    let files = if files.is_empty() {
        let f = brdfit::report::bundled_files(Path::new("data"));
        if f.is_empty() {
            bail!(
                "no data files given and none found in data/\n  fix: run from the brdfit checkout, or name the files: brdfit report FILE..."
            );
        }
        f
    } else {
        files
    };
    // The output folder is checked before the work: a file in its place is refused now.
    if output.exists() && !output.is_dir() {
        bail!(
            "-o {}: is a file, and report writes a folder\n  fix: give a folder name, e.g. -o {}",
            output.display(),
            output.with_extension("").display().to_string() + "-report"
        );
    }
    let t = std::time::Instant::now();
    let started = std::time::SystemTime::now();
    // A bar with the stage running and the time left, on a terminal only (else the stages are
    // named line by line, or not at all with --quiet).
    let bar = progress_bar(1, "report");
    let progress = (!bar.is_hidden()).then(|| {
        let bar = bar.clone();
        // Steps run in parallel report as they end, not always in order: the bar never moves
        // back (the furthest position so far, under a lock).
        let furthest = std::sync::Mutex::new(0u64);
        brdfit::report::Progress(std::sync::Arc::new(move |done, total, what: &str| {
            let mut at = furthest.lock().expect("no progress hook panics");
            *at = (*at).max(done);
            bar.set_length(total);
            bar.set_position(*at);
            bar.set_message(what.to_string());
        }))
    });
    brdfit::report::report(
        &files,
        &brdfit::report::ReportOptions {
            out: output.to_path_buf(),
            stability_starts: stability_starts as usize,
            render_res,
            verbose: !quiet,
            progress,
        },
    )?;
    bar.finish_and_clear();
    // The output folder if it was created; its sub-folders are counted with the files.
    announce_created(Some(output));
    // The four files a reader opens; the rest (charts, renders, CSV) are counted.
    let main = ["index.html", "report.md", "results.json", "timings.json"];
    for f in main {
        wrote(&output.join(f));
    }
    if !quiet {
        eprintln!(
            "wrote {} more files under {} (charts, renders, tables); report in {:.1} s",
            count_files(output, started).saturating_sub(main.len()),
            output.display(),
            t.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// Files under `dir`, recursively, written since `since` (files of an earlier report left in
/// the folder are not this run's).
fn count_files(dir: &Path, since: std::time::SystemTime) -> usize {
    std::fs::read_dir(dir).map_or(0, |rd| {
        rd.flatten()
            .map(|e| {
                let p = e.path();
                if p.is_dir() {
                    count_files(&p, since)
                } else {
                    let fresh = e
                        .metadata()
                        .and_then(|m| m.modified())
                        .is_ok_and(|m| m >= since);
                    usize::from(fresh)
                }
            })
            .sum()
    })
}

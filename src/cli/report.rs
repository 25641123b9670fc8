//! `brdfit report`: the library's report over the given files (the bundled data by default).

use super::*;
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

pub(crate) fn run_report(
    files: Vec<PathBuf>,
    output: &Path,
    stability_starts: usize,
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
    let t = std::time::Instant::now();
    brdfit::report::report(
        &files,
        &brdfit::report::ReportOptions {
            out: output.to_path_buf(),
            stability_starts: stability_starts.clamp(1, 100),
            render_res: render_res.clamp(16, 4096),
            verbose: !quiet,
        },
    )?;
    if !quiet {
        eprintln!(
            "report written to {}/index.html in {:.1} s",
            output.display(),
            t.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

//! `brdfit study …`: arguments and printing around the library's studies.

use super::*;
use anyhow::{Result, anyhow};
use brdfit::data::{self, Dataset};
use brdfit::model::ModelKind;
use clap::Subcommand;
use std::path::{Path, PathBuf};

#[derive(Subcommand, Debug)]
pub(crate) enum StudyCommand {
    /// Every method (LM, Gauss–Newton, Nelder–Mead, scipy when available) × model: time and
    /// work against final cost (and parameter error when the data carry their truth).
    #[command(
        after_help = "Example:\n  brdfit study speed-accuracy data/blinn-mgo.csv -o reports/study"
    )]
    SpeedAccuracy {
        /// The data set (channel 0, or --channel).
        data: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
        /// Timed runs per fit (the median is reported).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u16).range(1..=100))]
        repeats: u16,
        /// Python with numpy and scipy, to run the scipy peer side by side.
        #[arg(long, env = "BRDFIT_PEER_PYTHON")]
        peer_python: Option<String>,
        /// The peer script: a scipy program that fits the file's samples and prints one JSON
        /// line (params, cost, seconds); the peer runs only when this and --peer-python are given.
        #[arg(long)]
        peer_script: Option<PathBuf>,
        /// Output directory (speed-accuracy.svg/png/csv/md).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Image error (RMSE against a 16×16-supersampled reference) against time and rays per
    /// pixel, uniform against adaptive anti-aliasing, on the Figure 7 scenes.
    #[command(after_help = "Example:\n  brdfit study render -o reports/study")]
    Render {
        /// Resolution of the study images (8–2048).
        #[arg(long, default_value_t = 192, value_parser = clap::value_parser!(u32).range(8..=2048))]
        res: u32,
        /// Study this scene file (at its own resolution) instead of the Figure 7 scenes.
        #[arg(long)]
        scene: Option<PathBuf>,
        /// Output directory (render-study.svg/png/csv/md).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Share of seeded random starts reaching the global minimum, per method, with and without
    /// the global initialisation, across noise levels and sampling patterns.
    #[command(
        after_help = "Example:\n  brdfit study stability data/blinn-aluminium.csv --starts 8 -o reports/study"
    )]
    Stability {
        /// The data set: its truth (synthetic files) or its Torrance–Sparrow fit is the reference.
        data: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
        /// Random starts per method and configuration (1–1000).
        #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u16).range(1..=1000))]
        starts: u16,
        /// Seed of the synthetic data and the starts.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output directory (stability.svg/png/csv/md).
        #[arg(short, long)]
        output: PathBuf,
    },
}

/// Write a study's tables as OUTPUT/NAME.md (with its title) and OUTPUT/NAME.csv.
pub(crate) fn write_study_tables(
    output: &Path,
    name: &str,
    title: &str,
    md: &str,
    csv: &str,
) -> Result<()> {
    write_file(
        &output.join(format!("{name}.md")),
        format!("# {title}\n\n{md}").as_bytes(),
    )?;
    write_file(&output.join(format!("{name}.csv")), csv.as_bytes())?;
    Ok(())
}

pub(crate) fn study_input(data: &Path, load: &LoadArgs) -> Result<Dataset> {
    let ds = load.load(data)?;
    Ok(if load.channel.is_none() {
        data::representative_channel(&ds)
            .map_err(|m| anyhow!("{m}"))?
            .0
    } else {
        ds
    })
}

pub(crate) fn run_study(cmd: StudyCommand) -> Result<()> {
    use brdfit::study;
    match cmd {
        StudyCommand::SpeedAccuracy {
            data,
            load,
            repeats,
            peer_python,
            peer_script,
            output,
        } => {
            let ds = study_input(&data, &load)?;
            let truth = study::parse_truth(&ds);
            // A bar with the method and model running (a few seconds on a MERL CSV, minutes
            // on a full table).
            let bar = progress_bar(1, "speed against accuracy");
            let mut rows = study::speed_accuracy_with_progress(
                &ds,
                truth.as_ref(),
                repeats as usize,
                &|done, total, what| {
                    bar.set_length(total as u64);
                    bar.set_position(done as u64);
                    bar.set_message(what.to_string());
                },
            );
            bar.finish_and_clear();
            match peer_python
                .as_deref()
                .zip(peer_script.as_deref())
                .and_then(|(py, script)| study::scipy_peer(&ds, py, script))
            {
                Some(r) => rows.push(r),
                None if !quiet() => eprintln!(
                    "note: scipy peer not run (give --peer-python with numpy and scipy, and --peer-script)"
                ),
                None => {}
            }
            let title = format!("Speed against accuracy: {}", data.display());
            save_chart(
                &study::speed_chart(&title, &rows),
                &output.join("speed-accuracy"),
            )?;
            let (md, csv) = study::speed_tables(&rows, true);
            write_study_tables(&output, "speed-accuracy", &title, &md, &csv)?;
            print(&md)
        }
        StudyCommand::Render { res, scene, output } => {
            // A bar with the render under way (1.8 s at the default 192 × 192, minutes at
            // 1024 × 1024 or on a large scene), moving as each image row is done.
            let bar = progress_bar(1, "render study");
            let progress = |done: usize, total: usize, what: &str| {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
                bar.set_message(what.to_string());
            };
            let rows = match &scene {
                Some(p) => study::render_study_scenes_with_progress(&[load_scene(p)?], &progress),
                None => study::render_study_with_progress(res, &progress),
            };
            bar.finish_and_clear();
            let what = match &scene {
                Some(p) => p.display().to_string(),
                None => format!("Figure 7 scenes, {res}×{res}"),
            };
            let title = format!("Anti-aliasing: image error against rays per pixel ({what})");
            save_chart(
                &study::render_chart(&title, &rows, false),
                &output.join("render-study"),
            )?;
            save_chart(
                &study::render_chart(&title, &rows, true),
                &output.join("render-study-time"),
            )?;
            let (md, csv) = study::render_tables(&rows, true);
            write_study_tables(&output, "render-study", &title, &md, &csv)?;
            print(&md)
        }
        StudyCommand::Stability {
            data,
            load,
            starts,
            seed,
            output,
        } => {
            let ds = study_input(&data, &load)?;
            let reference = match study::parse_truth(&ds) {
                Some(m) if m.kind == ModelKind::TorranceSparrow => m,
                _ => {
                    let mut o = brdfit::fit::FitOptions::new(ModelKind::TorranceSparrow);
                    o.profile = false;
                    brdfit::fit::fit(&ds, &o).map_err(|e| anyhow!("{}: {e}", data.display()))?[0]
                        .model_for(0)
                }
            };
            let bar = progress_bar(16, "stability configurations");
            let rows =
                study::stability_with_progress(&reference, starts as usize, 1500, seed, &|| {
                    bar.inc(1)
                });
            bar.finish_and_clear();
            let title = format!("Stability from {starts} random starts around {reference}");
            save_chart(
                &study::stability_chart(&title, &rows),
                &output.join("stability"),
            )?;
            let (md, csv) = study::stability_tables(&rows);
            let md = format!("{}\n\n{md}", study::STABILITY_CELLS);
            write_study_tables(&output, "stability", &title, &md, &csv)?;
            print(&md)
        }
    }
}

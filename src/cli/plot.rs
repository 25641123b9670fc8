//! `brdfit plot …`: arguments and printing around the library's charts.

use super::*;
use anyhow::{Result, bail};
use clap::Subcommand;
use std::path::{Path, PathBuf};

#[derive(Subcommand, Debug)]
pub(crate) enum PlotCommand {
    /// Polar plot of the reflected intensity in the plane of incidence, models against data.
    #[command(
        after_help = "Example:\n  brdfit plot lobe --fit fit.json --data data/blinn-mgo.csv --theta-i 30,70 -o lobe"
    )]
    Lobe {
        /// Fit JSON files whose models are drawn (repeat for several).
        #[arg(long)]
        fit: Vec<PathBuf>,
        #[command(flatten)]
        model: OptModelArgs,
        /// Measured data whose in-plane samples are overlaid.
        #[arg(long)]
        data: Option<PathBuf>,
        /// Incidence angles in degrees, one panel each.
        #[arg(long, value_delimiter = ',', default_value = "30,70")]
        theta_i: Vec<f64>,
        /// Radius: intensity (Blinn's i = π f_r cosθi) or brdf (f_r).
        #[arg(long, default_value = "intensity")]
        quantity: String,
        /// Logarithmic radius (4 decades), for sharp measured peaks.
        #[arg(long)]
        log: bool,
        /// Which samples are drawn in a panel (degrees): θi within DEG of the panel's and
        /// azimuth within DEG of the plane of incidence; the legend states it and the count.
        /// 2.5° finds a few samples per panel in a scattered hemisphere of 10,000 (Blinn's MgO);
        /// narrow it for dense gridded data.
        #[arg(long, value_name = "DEG", default_value_t = 2.5)]
        tolerance: f64,
        #[command(flatten)]
        load: LoadArgs,
        /// Output base name: writes BASE.svg and BASE.png.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Blinn's Figures 5 and 6: Phong against Torrance–Sparrow with equal β, at 30° and 70°.
    #[command(after_help = "Example:\n  brdfit plot blinn-figures -o reports/figures")]
    BlinnFigures {
        /// Output directory (figure5.svg/png, figure6.svg/png).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Residuals of a fit against θh, θd and θi, to show where a model fails.
    #[command(
        after_help = "Example:\n  brdfit plot residuals --fit fit.json data/blinn-mgo.csv -o reports/residuals"
    )]
    Residuals {
        /// The fit JSON.
        #[arg(long)]
        fit: PathBuf,
        /// The data it was fitted to.
        data: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
        /// Output directory.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// θh × θd image of data and fit side by side (BRDF Explorer's image slice).
    #[command(
        after_help = "Example:\n  brdfit plot slice --fit fit.json data/merl-aluminium.csv --channel r -o slice"
    )]
    Slice {
        /// The fit JSON.
        #[arg(long)]
        fit: PathBuf,
        /// The data.
        data: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
        /// Bins per axis.
        #[arg(long, default_value_t = 45)]
        bins: usize,
        /// Output base name.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Directional albedo against θi by integration over the hemisphere (energy check), with
    /// an estimate from the samples where they cover the hemisphere.
    #[command(
        after_help = "Example:\n  brdfit plot albedo --fit fit.json --data data/blinn-mgo.csv -o albedo"
    )]
    Albedo {
        /// The fit JSON.
        #[arg(long)]
        fit: Option<PathBuf>,
        #[command(flatten)]
        model: OptModelArgs,
        /// Measured data: its albedo is estimated at each θi where its samples cover and
        /// resolve the outgoing hemisphere (see the README).
        #[arg(long)]
        data: Option<PathBuf>,
        #[command(flatten)]
        load: LoadArgs,
        /// Output base name.
        #[arg(short, long)]
        output: PathBuf,
    },
}

/// The output base name without extension.
pub(crate) fn base(p: &Path) -> PathBuf {
    match p.extension().and_then(|e| e.to_str()) {
        Some("svg" | "png") => p.with_extension(""),
        _ => p.to_path_buf(),
    }
}

pub(crate) fn run_plot(cmd: PlotCommand) -> Result<()> {
    use brdfit::plot;
    match cmd {
        PlotCommand::Lobe {
            fit,
            model,
            data,
            theta_i,
            quantity,
            log,
            tolerance,
            load,
            output,
        } => {
            let q = match quantity.as_str() {
                "intensity" => plot::LobeQuantity::Intensity,
                "brdf" => plot::LobeQuantity::Brdf,
                _ => {
                    bail!("unknown quantity '{quantity}'\n  fix: use --quantity intensity or brdf")
                }
            };
            if !(0.0..=90.0).contains(&tolerance) {
                bail!(
                    "--tolerance {tolerance}: not an angle in [0°, 90°]\n  fix: e.g. --tolerance 2.5"
                );
            }
            let ds = data.as_ref().map(|d| load.load(d)).transpose()?;
            // The plotted channel: the data's first (after --channel), whose fit is drawn from
            // a fit file of several channels (else that file's first).
            let plotted = ds.as_ref().map(|d| d.channels[0].name.clone());
            let mut models = Vec::new();
            for f in &fit {
                let fits = read_fits(f)?;
                let pick = fits
                    .iter()
                    .position(|r| Some(&r.channel) == plotted.as_ref())
                    .unwrap_or(0);
                if let Some(r) = fits.get(pick) {
                    let channel = match r.channel.as_str() {
                        "" | "value" | "brdf" | "brdf_cos" | "rfactor" => String::new(),
                        c => format!(" ({c})"),
                    };
                    models.push((format!("{} fit{channel}", r.label()), r.model_for(0)));
                }
                if fits.len() > 1 && !quiet() {
                    eprintln!(
                        "note: {} holds fits of {} channels; drawing the one of channel {} ({}); \
                         choose another with --channel",
                        f.display(),
                        fits.len(),
                        fits[pick].channel,
                        if plotted.as_ref() == Some(&fits[pick].channel) {
                            "the data's channel"
                        } else {
                            "the file's first"
                        }
                    );
                }
            }
            if let Some(m) = model.build()? {
                models.push((format!("{m}"), m));
            }
            if models.is_empty() && data.is_none() {
                bail!(
                    "nothing to plot\n  fix: give --fit FILE, --model with --set, or --data FILE"
                );
            }
            let title = match &data {
                Some(d) => format!("Reflection in the plane of incidence: {}", d.display()),
                None => "Reflection in the plane of incidence".to_string(),
            };
            let chart = plot::lobe_chart(
                &title,
                &models,
                ds.as_ref().map(|d| (d, 0)),
                &theta_i,
                q,
                log,
                plot::InPlane::both(tolerance),
            );
            save_chart(&chart, &base(&output))?;
            Ok(())
        }
        PlotCommand::BlinnFigures { output } => {
            save_chart(&plot::blinn_figure(30.0, 5), &output.join("figure5"))?;
            save_chart(&plot::blinn_figure(70.0, 6), &output.join("figure6"))?;
            Ok(())
        }
        PlotCommand::Residuals {
            fit,
            data,
            load,
            output,
        } => {
            let r = read_fits(&fit)?.remove(0);
            let ds = load.load(&data)?;
            let pts = plot::residual_points(
                &ds,
                0,
                &r.model_for(0),
                r.loss == brdfit::fit::problem::Loss::Log,
            );
            for (name, chart) in plot::residual_charts(&r.label(), &pts) {
                save_chart(&chart, &output.join(name))?;
            }
            Ok(())
        }
        PlotCommand::Slice {
            fit,
            data,
            load,
            bins,
            output,
        } => {
            let r = read_fits(&fit)?.remove(0);
            let ds = load.load(&data)?;
            let (d, f) = plot::slice_grids(&ds, 0, &r.model_for(0), bins.clamp(2, 360));
            let chart = plot::SliceChart {
                title: format!("θh × θd slice: {} against {}", data.display(), r.label()),
                n: bins.clamp(2, 360),
                images: [d, f],
            };
            save_chart(&chart, &base(&output))?;
            Ok(())
        }
        PlotCommand::Albedo {
            fit,
            model,
            data,
            load,
            output,
        } => {
            let (label, m) = match (fit, model.build()?) {
                (Some(f), _) => {
                    let r = read_fits(&f)?.remove(0);
                    (r.label(), r.model_for(0))
                }
                (None, Some(m)) => (m.kind.to_string(), m),
                (None, None) => bail!("no model\n  fix: give --fit FILE or --model with --set"),
            };
            let measured = match &data {
                Some(d) => {
                    let est = plot::measured_albedo(&load.load(d)?, 0);
                    if est.is_empty() {
                        eprintln!(
                            "note: the samples of {} do not cover and resolve the outgoing hemisphere at any θi (6 × 16 cells of equal projected solid angle, each with two samples or more, none outweighing the rest of its cell, and the same value with the cells turned by half a sector): no albedo estimate from them",
                            d.display()
                        );
                    }
                    est
                }
                None => vec![],
            };
            let (chart, pts) = plot::albedo_chart(&label, &m, &measured);
            save_chart(&chart, &base(&output))?;
            let worst = pts
                .iter()
                .cloned()
                .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
            if worst.1 > 1.0 {
                eprintln!(
                    "warning: the albedo exceeds 1 (energy is created): ρ = {:.3} at θi = {}°",
                    worst.1, worst.0
                );
            }
            Ok(())
        }
    }
}

//! `brdfit plot …`: arguments and printing around the library's charts.

use super::*;
use anyhow::{Result, bail};
use clap::Subcommand;
use std::path::{Path, PathBuf};

/// The data a fit is drawn against, one channel: `--channel` if given; else, for data of several
/// channels, the fits' channel where they share one the data has (a `y` fit takes CIE Y), and
/// otherwise the representative one (green of RGB, CIE Y of spectral data), said on stderr.
fn data_for_fits(load: &LoadArgs, data: &Path, fits: &[PathBuf]) -> Result<brdfit::Dataset> {
    let ds = load.load(data)?;
    if load.channel.is_some() || ds.channels.len() <= 1 {
        return Ok(ds);
    }
    let mut held: Vec<String> = Vec::new();
    for f in fits {
        for r in read_fits(f)? {
            for c in r.channel.split(',') {
                if !held.iter().any(|h| h == c) {
                    held.push(c.to_string());
                }
            }
        }
    }
    let names = ds
        .channels
        .iter()
        .map(|c| c.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    if let [c] = held.as_slice() {
        let sel = if c == "y" { "cie-y" } else { c.as_str() };
        if let Ok(one) = ds.select(&brdfit::data::ChannelSelect::parse(sel)) {
            if !quiet() {
                eprintln!(
                    "note: {} has channels {names}; using channel {sel}, the fit's (choose another with --channel)",
                    data.display()
                );
            }
            return Ok(one);
        }
    }
    let (one, what) = brdfit::data::representative_channel(&ds).map_err(anyhow::Error::msg)?;
    if !quiet() {
        eprintln!(
            "note: {} has channels {names}; using {what} (choose another with --channel)",
            data.display()
        );
    }
    Ok(one)
}

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
        /// Draw a fit marked not usable anyway.
        #[arg(long)]
        allow_unusable: bool,
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
        pick: PickArgs,
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
        pick: PickArgs,
        #[command(flatten)]
        load: LoadArgs,
        /// Bins per axis (2–360).
        #[arg(long, default_value_t = 45, value_parser = clap::value_parser!(u16).range(2..=360))]
        bins: u16,
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
        /// Draw a fit marked not usable anyway.
        #[arg(long)]
        allow_unusable: bool,
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

/// The output base name without extension ([`output_base`]: svg and png).
pub(crate) fn base(p: &Path) -> Result<PathBuf> {
    output_base(p, &["svg", "png"])
}

/// Refuse, before any work, a chart's output that is a folder, a device or one of `inputs`:
/// the SVG and PNG of each base in `bases` ([`refuse_input`]). A folder of charts (`dir`) that
/// exists as something else than a folder is refused too.
fn check_chart_outputs(dir: Option<&Path>, bases: &[PathBuf], inputs: &[&Path]) -> Result<()> {
    if let Some(d) = dir.filter(|d| d.exists() && !d.is_dir()) {
        bail!(
            "-o {}: is not a folder; this command writes its charts into a folder
  fix: give a new name or a folder",
            d.display()
        );
    }
    for b in bases {
        for ext in ["svg", "png"] {
            refuse_input(&b.with_extension(ext), inputs)?;
        }
    }
    Ok(())
}

/// The inputs of a plot: the fit files and the data file, if any.
fn inputs<'a>(fits: &'a [PathBuf], data: Option<&'a PathBuf>) -> Vec<&'a Path> {
    fits.iter().chain(data).map(PathBuf::as_path).collect()
}

pub(crate) fn run_plot(cmd: PlotCommand) -> Result<()> {
    use brdfit::plot;
    match cmd {
        PlotCommand::Lobe {
            fit,
            model,
            allow_unusable,
            data,
            theta_i,
            quantity,
            log,
            tolerance,
            load,
            output,
        } => {
            let out = base(&output)?;
            check_chart_outputs(
                None,
                std::slice::from_ref(&out),
                &inputs(&fit, data.as_ref()),
            )?;
            let q = lobe_quantity(&quantity, tolerance, &theta_i)?;
            let ds = data
                .as_ref()
                .map(|d| data_for_fits(&load, d, &fit))
                .transpose()?;
            // With --fit and no --set, --model picks the fit file's model.
            let want = fit_want(&model, &fit, &load, ds.is_some(), allow_unusable);
            let plotted = ds.as_ref().map(|d| d.channels[0].name.clone());
            let mut models = fitted_models(&fit, &want, plotted.as_deref(), ds.as_ref())?;
            if let Some(m) = analytic(&model, &fit)? {
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
            save_chart(&chart, &out)?;
            Ok(())
        }
        PlotCommand::BlinnFigures { output } => {
            let names = ["figure5", "figure6"].map(|n| output.join(n));
            check_chart_outputs(Some(&output), &names, &[])?;
            save_chart(&plot::blinn_figure(30.0, 5), &output.join("figure5"))?;
            save_chart(&plot::blinn_figure(70.0, 6), &output.join("figure6"))?;
            Ok(())
        }
        PlotCommand::Residuals {
            fit,
            data,
            pick,
            load,
            output,
        } => {
            let names = plot::RESIDUAL_FILES.map(|n| output.join(n));
            let fits = std::slice::from_ref(&fit);
            check_chart_outputs(Some(&output), &names, &inputs(fits, Some(&data)))?;
            let ds = data_for_fits(&load, &data, fits)?;
            let r = pick_fit(&fit, &pick.want(None), Some(&ds.channels[0].name))?;
            let pts = plot::residual_points(
                &ds,
                0,
                &r.model,
                r.fit.loss == brdfit::fit::problem::Loss::Log,
            );
            let label = format!("{}, channel {}", r.fit.label(), ds.channels[0].name);
            for (name, chart) in plot::residual_charts(&label, &pts) {
                save_chart(&chart, &output.join(name))?;
            }
            Ok(())
        }
        PlotCommand::Slice {
            fit,
            data,
            pick,
            load,
            bins,
            output,
        } => {
            let out = base(&output)?;
            let fits = std::slice::from_ref(&fit);
            check_chart_outputs(None, std::slice::from_ref(&out), &inputs(fits, Some(&data)))?;
            let ds = data_for_fits(&load, &data, fits)?;
            let r = pick_fit(&fit, &pick.want(None), Some(&ds.channels[0].name))?;
            let (d, f) = plot::slice_grids(&ds, 0, &r.model, bins as usize);
            let chart = plot::SliceChart {
                title: format!(
                    "θh × θd slice: {} against {}, channel {}",
                    data.display(),
                    r.fit.label(),
                    ds.channels[0].name
                ),
                n: bins as usize,
                images: [d, f],
            };
            save_chart(&chart, &out)?;
            Ok(())
        }
        PlotCommand::Albedo {
            fit,
            model,
            allow_unusable,
            data,
            load,
            output,
        } => {
            let fits: Vec<PathBuf> = fit.into_iter().collect();
            let out = base(&output)?;
            check_chart_outputs(
                None,
                std::slice::from_ref(&out),
                &inputs(&fits, data.as_ref()),
            )?;
            let ds = data
                .as_ref()
                .map(|d| data_for_fits(&load, d, &fits))
                .transpose()?;
            let want = fit_want(&model, &fits, &load, ds.is_some(), allow_unusable);
            let (label, m) = match (fits.first(), analytic(&model, &fits)?) {
                (Some(f), _) => {
                    let plotted = ds.as_ref().map(|d| d.channels[0].name.clone());
                    let r = pick_fit(f, &want, plotted.as_deref())?;
                    (format!("{}, channel {}", r.fit.label(), r.channel), r.model)
                }
                (None, Some(m)) => (m.kind.to_string(), m),
                (None, None) => bail!("no model\n  fix: give --fit FILE or --model with --set"),
            };
            let measured = match (&data, &ds) {
                (Some(d), Some(ds)) => measured_albedo(d, ds),
                _ => vec![],
            };
            let (chart, pts) = plot::albedo_chart(&label, &m, &measured);
            save_chart(&chart, &out)?;
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

/// `plot lobe`'s quantity, with its tolerance and angles of incidence checked.
fn lobe_quantity(
    quantity: &str,
    tolerance: f64,
    theta_i: &[f64],
) -> Result<brdfit::plot::LobeQuantity> {
    use brdfit::plot::LobeQuantity;
    let q = match quantity {
        "intensity" => LobeQuantity::Intensity,
        "brdf" => LobeQuantity::Brdf,
        _ => bail!("unknown quantity '{quantity}'\n  fix: use --quantity intensity or brdf"),
    };
    if !(0.0..=90.0).contains(&tolerance) {
        bail!("--tolerance {tolerance}: not an angle in [0°, 90°]\n  fix: e.g. --tolerance 2.5");
    }
    if let Some(t) = theta_i.iter().find(|t| !(0.0..90.0).contains(*t)) {
        bail!("--theta-i {t}: not an angle of incidence in [0°, 90°)\n  fix: e.g. --theta-i 30,70");
    }
    Ok(q)
}

/// Each fit file's picked model, labelled with its fit and channel, for a chart's legend. A
/// file of several models (`fit --model all`) without `--model` gives every usable one, the
/// recommended one first and so labelled. With data, a fit that cannot have been made from
/// them is refused, and one whose cost on them is not the one it reports is drawn with a
/// warning ([`brdfit::fit::check_fitted_to`]).
fn fitted_models(
    fits: &[PathBuf],
    want: &brdfit::fit::Want,
    plotted: Option<&str>,
    ds: Option<&brdfit::Dataset>,
) -> Result<Vec<(String, brdfit::Model)>> {
    let label = |r: &brdfit::fit::PickedChannel| {
        let channel = if brdfit::fit::is_unnamed_channel(&r.channel) {
            String::new()
        } else {
            format!(" ({})", r.channel)
        };
        let usable = if r.fit.usable() { "" } else { ", not usable" };
        format!("{} fit{channel}{usable}", r.fit.label())
    };
    let check = |path: &Path, r: &brdfit::fit::PickedChannel| -> Result<()> {
        if let Some(ds) = ds {
            let note = brdfit::fit::check_fitted_to(ds, &r.fit).map_err(|e| {
                anyhow::anyhow!(
                    "{}: {e}: the fit is of another data set, or of these data loaded otherwise\n  fix: plot the fit with the data it was fitted to (and the same --negative and --channel), or fit these data: brdfit fit DATA --json OUT",
                    path.display()
                )
            })?;
            if let Some(n) = note {
                // Warnings even with --quiet, like the loaders'.
                eprintln!(
                    "warning: {}: {n}: the fit is of other values at these angles, or its parameters were edited",
                    path.display()
                );
            }
        }
        Ok(())
    };
    let mut models = Vec::new();
    for f in fits {
        let all = read_fits(f)?;
        let mut picked = brdfit::fit::pick_one(&all, want, plotted)
            .map_err(|e| anyhow::anyhow!("{}: {e}", f.display()))?;
        let first = picked.channels.remove(0);
        check(f, &first)?;
        let mut kinds: Vec<(brdfit::ModelKind, brdfit::Distribution)> = Vec::new();
        for r in all.iter().filter(|r| {
            r.channel
                .split(',')
                .any(|c| brdfit::fit::same_channel(c, &first.channel))
        }) {
            if !kinds.contains(&(r.model, r.dist)) {
                kinds.push((r.model, r.dist));
            }
        }
        if want.model.is_some() || kinds.len() < 2 {
            if !quiet() {
                for n in &picked.notes {
                    eprintln!("note: {}: {n}", f.display());
                }
            }
            models.push((label(&first), first.model));
            continue;
        }
        let start = models.len();
        // Every model of the file on the same channel: the recommended one first.
        let recommended = (first.fit.model, first.fit.dist);
        models.push((format!("{}, recommended", label(&first)), first.model));
        let mut skipped = Vec::new();
        for (k, d) in kinds.into_iter().filter(|m| *m != recommended) {
            let one = brdfit::fit::Want {
                model: Some(k),
                dist: Some(d),
                channel: Some(first.channel.clone()),
                allow_unusable: want.allow_unusable,
            };
            match brdfit::fit::pick(&all, &one) {
                Ok(mut p) => {
                    let r = p.channels.remove(0);
                    check(f, &r)?;
                    models.push((label(&r), r.model));
                }
                Err(_) => skipped.push(k.label(d)),
            }
        }
        if !quiet() {
            let skipped = if skipped.is_empty() {
                String::new()
            } else {
                format!(
                    "; not drawn, marked not usable: {} (--allow-unusable draws them)",
                    skipped.join(", ")
                )
            };
            eprintln!(
                "note: {}: drawing the file's {} {}models of channel {} (the recommended {} first){skipped}; one model: --model NAME",
                f.display(),
                models.len() - start,
                if want.allow_unusable { "" } else { "usable " },
                first.channel,
                first.fit.label()
            );
        }
    }
    Ok(models)
}

/// The albedo estimated from the samples of `ds` (read from `path`), said on stderr when the
/// samples do not allow one.
fn measured_albedo(path: &Path, ds: &brdfit::Dataset) -> Vec<(f64, f64)> {
    let est = brdfit::plot::measured_albedo(ds, 0);
    if est.is_empty() {
        eprintln!(
            "note: the samples of {} do not cover and resolve the outgoing hemisphere at any θi (6 × 16 cells of equal projected solid angle, each with two samples or more, none outweighing the rest of its cell, and the same value with the cells turned by half a sector): no albedo estimate from them",
            path.display()
        );
    }
    est
}

/// What `plot lobe|albedo` ask of their fit files: `--model` (and `--distribution`) pick the
/// file's model when no `--set` makes them an analytic model; `--channel` picks the channel
/// when no data file takes it.
fn fit_want(
    model: &OptModelArgs,
    fit: &[PathBuf],
    load: &LoadArgs,
    with_data: bool,
    allow_unusable: bool,
) -> brdfit::fit::Want {
    let picks = !fit.is_empty() && model.set.is_empty();
    brdfit::fit::Want {
        model: model.model.filter(|_| picks),
        dist: model.model.filter(|_| picks).map(|_| model.distribution),
        channel: if with_data {
            None
        } else {
            load.channel.clone()
        },
        allow_unusable,
    }
}

/// The analytic model of `--model … --set …`, unless `--model` picks a fit file's model.
fn analytic(model: &OptModelArgs, fit: &[PathBuf]) -> Result<Option<brdfit::model::Model>> {
    if !fit.is_empty() && model.set.is_empty() {
        return Ok(None);
    }
    model.build()
}

//! `brdfit`: the command-line interface, a thin layer over the library.

use anyhow::{Context, Result, anyhow, bail};
use brdfit::data::{self, ChannelSelect, Dataset, Format, LoadOptions, NegativePolicy, Quantity};
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use brdfit::simulate::{Grid, simulate};
use clap::{Args, Parser, Subcommand};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// mimalloc keeps freed pages for reuse: repeated fits (several channels, `--model all`,
/// `--repeat`) do not fault fresh pages in on every pass as glibc malloc does after trimming.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Fit reflection models (Phong, Blinn's Torrance–Sparrow) to measured reflectance.
#[derive(Parser, Debug)]
#[command(name = "brdfit", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Replace existing output files (directories such as reports/ are always regenerated).
    #[arg(long, global = true)]
    force: bool,
    /// No progress bars or notes on stderr.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// More detail on stderr (timings).
    #[arg(long, short, global = true)]
    verbose: bool,
}

static FORCE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
static VERBOSE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Refuse to replace an existing output file unless --force was given.
fn guard(path: &Path) -> Result<()> {
    if path.exists() && !FORCE.load(std::sync::atomic::Ordering::Relaxed) {
        if path.is_dir() {
            bail!(
                "{}: is a directory\n  fix: give a file name",
                path.display()
            );
        }
        bail!(
            "{}: the output exists\n  fix: choose another name, or add --force to replace it",
            path.display()
        );
    }
    Ok(())
}

/// A progress bar on stderr, drawn only on a terminal and never with --quiet.
fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if quiet() || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_message(what.to_string());
    bar
}

fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

#[derive(Subcommand, Debug)]
enum Command {
    /// One command from measurements to a report: fits, model comparison, plots, renders and
    /// studies for each file (the bundled data/ when no file is given), as index.html, report.md
    /// and results.json.
    #[command(
        after_help = "Examples:\n  brdfit report\n  brdfit report my-sample.csv -o my-report"
    )]
    Report {
        /// Data files (default: every data file in data/).
        files: Vec<PathBuf>,
        /// Output directory (regenerated).
        #[arg(short, long, default_value = "reports")]
        output: PathBuf,
        /// Random starts per configuration in each stability study.
        #[arg(long, default_value_t = 3)]
        stability_starts: usize,
        /// Resolution of the material renders.
        #[arg(long, default_value_t = 256)]
        render_res: u32,
    },
    /// Summarise a data file: format, samples, channels, quantity, angle coverage, value range.
    #[command(after_help = "Example:\n  brdfit info data/cayman.astm")]
    Info {
        /// The data file (.csv, .astm, .brdf or MERL .binary).
        file: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Evaluate a model's BRDF at the directions of a CSV (its four angle columns).
    #[command(
        after_help = "Example:\n  brdfit eval --model torrance-sparrow --set n=1.8,c3=0.35,ps=0.667,pd=0.333 dirs.csv -o out.csv"
    )]
    Eval {
        #[command(flatten)]
        model: ModelArgs,
        /// CSV whose theta_i/phi_i/theta_o/phi_o columns (with _deg or _rad) give the directions.
        directions: PathBuf,
        /// Output CSV (standard output when omitted).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Write synthetic samples of a model, with seeded multiplicative Gaussian noise.
    #[command(
        after_help = "Example:\n  brdfit simulate --model torrance-sparrow --set n=1.8,c3=0.35,ps=0.667,pd=0.333 \\\n    --grid hemisphere:10000 --noise 0.01 --seed 1 -o mgo.csv"
    )]
    Simulate {
        #[command(flatten)]
        model: ModelArgs,
        /// Sampling: hemisphere:N (N seeded random directions) or plane:θ1,θ2,… (degrees).
        #[arg(long, default_value = "hemisphere:10000")]
        grid: String,
        /// Relative noise σ: each value is multiplied by (1 + σ ε), ε ~ N(0, 1).
        #[arg(long, default_value_t = 0.0)]
        noise: f64,
        /// Seed of the random stream (directions and noise).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output CSV.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Fit a model (or all of them, ranked by BIC) to a data file by nonlinear least squares.
    #[command(
        after_help = "Examples:\n  brdfit fit data/blinn-mgo.csv\n  brdfit fit data/merl-aluminium.csv --model all --json fits.json\n  brdfit fit data/cayman.astm --channel cie-y --model phong --max-theta 80"
    )]
    Fit {
        #[command(flatten)]
        fit: FitArgs,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Plots: polar lobes (Blinn's Figures 5–6), residuals, θh×θd slices, albedo.
    #[command(subcommand)]
    Plot(PlotCommand),
    /// Studies: speed against accuracy of every method × model, and stability from random starts.
    #[command(subcommand)]
    Study(StudyCommand),
    /// Render a scene (TOML) with Whitted's ray tracer, or Blinn's Figure 7 with `fig7`.
    #[command(
        after_help = "Examples:\n  brdfit render data/scenes/mitsuba-front.toml -o out.png\n  brdfit render fig7 --aluminium al.json --mgo mgo.json -o reports/fig7"
    )]
    Render {
        /// The scene file, or `fig7` for Blinn's Figure 7 matrix.
        scene: String,
        /// Output: an image path for a scene (PNG; the EXR is written beside it), a directory for fig7.
        #[arg(short, long)]
        output: PathBuf,
        /// fig7: fit JSON for the aluminium object (default: Blinn's ps .4 pd .6 n 200 c3 .5).
        #[arg(long)]
        aluminium: Option<PathBuf>,
        /// fig7: fit JSON for the magnesium-oxide object (default: Blinn's ps .667 pd .333 n 1.8 c3 .35).
        #[arg(long)]
        mgo: Option<PathBuf>,
        /// fig7: image resolution (square).
        #[arg(long, default_value_t = 512)]
        res: u32,
    },
    /// Export a fit to another renderer or format: mitsuba, pbrt, brdf-explorer, merl, csv.
    #[command(
        after_help = "Examples:\n  brdfit export fit.json --to mitsuba\n  brdfit export fit.json --to merl -o fitted.binary"
    )]
    Export {
        /// The fit JSON (from brdfit fit --json or brdfit report).
        fit: PathBuf,
        /// Target: mitsuba (BSDF XML), pbrt (pbrt-v4 material), brdf-explorer (.brdf analytic),
        /// merl (.binary table), csv (the model on a 5°/15° grid).
        #[arg(long, value_enum)]
        to: brdfit::export::ExportFormat,
        /// Output file (text formats go to standard output when omitted).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    #[command(after_help = "Example:\n  brdfit completions bash > /etc/bash_completion.d/brdfit")]
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
    /// Inverse Phong: normals and a height profile along a line of an image, from known light,
    /// ambient and diffuse constants (the cylinder case: the normal lies in the plane of the line
    /// and the view). The general case (three unknown normal components) is under-determined from
    /// one image; a second image under another light (--image2, --light2) removes the ambiguity.
    #[command(
        after_help = "Example:\n  brdfit inverse cyl.exr --row 128 --light 0.5,0.2,1 --ca 0.1 --cd 1 --pixel-size 0.01 -o profile"
    )]
    Inverse {
        /// The image (PNG is sRGB-decoded unless --linear; EXR is linear).
        image: PathBuf,
        /// The row to invert (left to right).
        #[arg(long, conflicts_with_all = ["from", "to"])]
        row: Option<u32>,
        /// Start pixel X,Y of the line.
        #[arg(long, value_delimiter = ',')]
        from: Vec<u32>,
        /// End pixel X,Y of the line.
        #[arg(long, value_delimiter = ',')]
        to: Vec<u32>,
        /// Light direction x,y,z in view coordinates (x right, y up, z toward the viewer).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        light: Vec<f64>,
        /// Ambient constant Ca (image value of a surface facing away from the light).
        #[arg(long, default_value_t = 0.0)]
        ca: f64,
        /// Diffuse constant Cd (image value added by a surface facing the light).
        #[arg(long)]
        cd: Option<f64>,
        /// Take Cd = pd·E/π and Ca = pd·A from a fit JSON with --irradiance E and --ambient A.
        #[arg(long)]
        fit: Option<PathBuf>,
        /// Light irradiance E (with --fit).
        #[arg(long, default_value_t = std::f64::consts::PI)]
        irradiance: f64,
        /// Ambient radiance A (with --fit).
        #[arg(long, default_value_t = 0.0)]
        ambient: f64,
        /// World size of one pixel, for the heights.
        #[arg(long, default_value_t = 1.0)]
        pixel_size: f64,
        /// Shape prior for the first pixel: convex or concave.
        #[arg(long, default_value = "convex")]
        prior: String,
        /// A second image of the same view under --light2 (photometric stereo along the line).
        #[arg(long)]
        image2: Option<PathBuf>,
        /// The second light direction x,y,z.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        light2: Vec<f64>,
        /// PNG values are already linear.
        #[arg(long)]
        linear: bool,
        /// A CSV with columns pixel,height: the true profile, drawn with the estimate.
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Output base: BASE.csv and the profile plot BASE.svg/png.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Convert between formats: any → brdfit CSV, CSV (or any) → MERL .binary.
    #[command(
        after_help = "Example:\n  brdfit convert data/cayman.astm --channel cie-y -o cayman.csv"
    )]
    Convert {
        /// Input data file.
        input: PathBuf,
        /// Output file; `.binary` writes MERL, anything else brdfit CSV.
        #[arg(short, long)]
        output: PathBuf,
        /// Output format (csv or merl), overriding the output's extension.
        #[arg(long)]
        to: Option<String>,
        #[command(flatten)]
        load: LoadArgs,
    },
}

#[derive(Subcommand, Debug)]
enum PlotCommand {
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
        /// Azimuth tolerance (degrees) for samples to count as in the plane of incidence.
        #[arg(long, default_value_t = 1.0)]
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
    /// Directional albedo against θi by integration over the hemisphere (energy check).
    #[command(after_help = "Example:\n  brdfit plot albedo --fit fit.json -o albedo")]
    Albedo {
        /// The fit JSON.
        #[arg(long)]
        fit: Option<PathBuf>,
        #[command(flatten)]
        model: OptModelArgs,
        /// Output base name.
        #[arg(short, long)]
        output: PathBuf,
    },
}

#[derive(Subcommand, Debug)]
enum StudyCommand {
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
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Python with numpy and scipy, to run the scipy peer side by side.
        #[arg(long, env = "BRDFIT_PEER_PYTHON")]
        peer_python: Option<String>,
        /// The peer script.
        #[arg(long, default_value = "../shared/peers/scipy_fit.py")]
        peer_script: PathBuf,
        /// Output directory (speed-accuracy.svg/png/csv/md).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Image error (RMSE against a 16×16-supersampled reference) against time and rays per
    /// pixel, uniform against adaptive anti-aliasing, on the Figure 7 scenes.
    #[command(after_help = "Example:\n  brdfit study render -o reports/study")]
    Render {
        /// Resolution of the study images.
        #[arg(long, default_value_t = 192)]
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
        /// Random starts per method and configuration.
        #[arg(long, default_value_t = 8)]
        starts: usize,
        /// Seed of the synthetic data and the starts.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output directory (stability.svg/png/csv/md).
        #[arg(short, long)]
        output: PathBuf,
    },
}

/// Write a study's tables as OUTPUT/NAME.md (with its title) and OUTPUT/NAME.csv.
fn write_study_tables(output: &Path, name: &str, title: &str, md: &str, csv: &str) -> Result<()> {
    brdfit::output::write_bytes_atomic(
        &output.join(format!("{name}.md")),
        format!("# {title}\n\n{md}").as_bytes(),
    )?;
    brdfit::output::write_bytes_atomic(&output.join(format!("{name}.csv")), csv.as_bytes())?;
    Ok(())
}

fn study_input(data: &Path, load: &LoadArgs) -> Result<Dataset> {
    let ds = load.load(data)?;
    Ok(if load.channel.is_none() {
        data::representative_channel(&ds)
            .map_err(|m| anyhow!("{m}"))?
            .0
    } else {
        ds
    })
}

fn run_study(cmd: StudyCommand) -> Result<()> {
    use brdfit::{plot, study};
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
            let mut rows = study::speed_accuracy(&ds, truth.as_ref(), repeats);
            match peer_python
                .as_deref()
                .and_then(|py| study::scipy_peer(&ds, py, &peer_script))
            {
                Some(r) => rows.push(r),
                None if !quiet() => eprintln!(
                    "note: scipy peer not run (give --peer-python with numpy and scipy, and --peer-script)"
                ),
                None => {}
            }
            let title = format!("Speed against accuracy: {}", data.display());
            plot::save(
                &study::speed_chart(&title, &rows, false),
                &output.join("speed-accuracy"),
            )?;
            let (md, csv) = study::speed_tables(&rows, true);
            write_study_tables(&output, "speed-accuracy", &title, &md, &csv)?;
            print(&md)
        }
        StudyCommand::Render { res, scene, output } => {
            let rows = match &scene {
                Some(p) => study::render_study_scenes(&[brdfit::render::scene::load_scene(p)?]),
                None => study::render_study(res.clamp(8, 2048)),
            };
            let what = match &scene {
                Some(p) => p.display().to_string(),
                None => format!("Figure 7 scenes, {res}×{res}"),
            };
            let title = format!("Anti-aliasing: image error against rays per pixel ({what})");
            plot::save(
                &study::render_chart(&title, &rows, false),
                &output.join("render-study"),
            )?;
            plot::save(
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
            let rows = study::stability_with_progress(
                &reference,
                starts.clamp(1, 1000),
                1500,
                seed,
                &|| bar.inc(1),
            );
            bar.finish_and_clear();
            let title = format!("Stability from {starts} random starts around {reference}");
            plot::save(
                &study::stability_chart(&title, &rows),
                &output.join("stability"),
            )?;
            let (md, csv) = study::stability_tables(&rows);
            write_study_tables(&output, "stability", &title, &md, &csv)?;
            print(&md)
        }
    }
}

#[derive(Args, Debug, Clone)]
struct OptModelArgs {
    /// A model (instead of or besides a fit).
    #[arg(long, value_enum)]
    model: Option<ModelKind>,
    /// Facet distribution of models that take one (torrance-sparrow).
    #[arg(long, value_enum, default_value = "d3")]
    distribution: Distribution,
    /// Parameters NAME=VALUE.
    #[arg(long = "set", value_delimiter = ',')]
    set: Vec<String>,
}

impl OptModelArgs {
    fn build(&self) -> Result<Option<Model>> {
        match &self.model {
            None => Ok(None),
            Some(m) => ModelArgs {
                model: *m,
                distribution: self.distribution,
                set: self.set.clone(),
                fast_pow: None,
            }
            .build()
            .map(Some),
        }
    }
}

/// Read a fit JSON (one fit, or the first of `fits`) into its model(s) with labels.
fn read_fits(path: &Path) -> Result<Vec<brdfit::fit::FitResult>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the fit JSON", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        anyhow!(
            "{}: not valid JSON ({e})\n  fix: give a file written by brdfit fit --json",
            path.display()
        )
    })?;
    let list: Vec<serde_json::Value> = match v.get("fits").and_then(|f| f.as_array()) {
        Some(a) => a.clone(),
        None => vec![v],
    };
    list.iter()
        .map(|f| {
            brdfit::fit::FitResult::from_json(f).map_err(|e| {
                anyhow!(
                    "{}: {e}\n  fix: give a file written by brdfit fit --json",
                    path.display()
                )
            })
        })
        .collect()
}

/// The output base name without extension.
fn base(p: &Path) -> PathBuf {
    match p.extension().and_then(|e| e.to_str()) {
        Some("svg" | "png") => p.with_extension(""),
        _ => p.to_path_buf(),
    }
}

fn run_plot(cmd: PlotCommand) -> Result<()> {
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
            let mut models = Vec::new();
            for f in &fit {
                for r in read_fits(f)? {
                    models.push((format!("{} fit ({})", r.label(), r.channel), r.model_for(0)));
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
            let ds = data.as_ref().map(|d| load.load(d)).transpose()?;
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
                tolerance,
            );
            plot::save(&chart, &base(&output))?;
            Ok(())
        }
        PlotCommand::BlinnFigures { output } => {
            plot::save(&plot::blinn_figure(30.0, 5), &output.join("figure5"))?;
            plot::save(&plot::blinn_figure(70.0, 6), &output.join("figure6"))?;
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
                plot::save(&chart, &output.join(name))?;
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
            plot::save(&chart, &base(&output))?;
            Ok(())
        }
        PlotCommand::Albedo { fit, model, output } => {
            let (label, m) = match (fit, model.build()?) {
                (Some(f), _) => {
                    let r = read_fits(&f)?.remove(0);
                    (r.label(), r.model_for(0))
                }
                (None, Some(m)) => (m.kind.to_string(), m),
                (None, None) => bail!("no model\n  fix: give --fit FILE or --model with --set"),
            };
            let (chart, pts) = plot::albedo_chart(&label, &m);
            plot::save(&chart, &base(&output))?;
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

#[derive(Args, Debug, Clone)]
struct FitArgs {
    /// The data file(s); several files are fitted in parallel (see --jobs, --summary).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Files fitted at once in a batch.
    #[arg(long, short = 'j', default_value_t = 2)]
    jobs: usize,
    /// Batch summary: one row per file, channel and model (CSV, or JSON when FILE ends in .json).
    #[arg(long, value_name = "FILE")]
    summary: Option<PathBuf>,
    /// Model, or all (every model, ranked by BIC).
    #[arg(long, default_value = "torrance-sparrow", value_parser = model_or_all())]
    model: String,
    /// Facet distribution of models that take one (torrance-sparrow): d1 (cosine power), d2
    /// (Gaussian), d3 (Trowbridge–Reitz).
    #[arg(long, value_enum, default_value = "d3")]
    distribution: Distribution,
    /// Local method: lm (Levenberg–Marquardt), gn (Gauss–Newton with line search), nm (Nelder–Mead).
    #[arg(long, value_enum, default_value = "lm")]
    method: brdfit::fit::lsq::Method,
    /// Loss: log (ln(1 + cosθi f) differences) or linear (f differences).
    #[arg(long, value_enum, default_value = "log")]
    loss: brdfit::fit::problem::Loss,
    /// Robust loss on top of it.
    #[arg(long, value_enum)]
    robust: Option<brdfit::fit::RobustKind>,
    /// Drop samples with θi or θo beyond this angle (degrees).
    #[arg(long, value_name = "DEG")]
    max_theta: Option<f64>,
    /// Hold parameters fixed, NAME=VALUE (repeat or separate with commas).
    #[arg(long, value_delimiter = ',')]
    fix: Vec<String>,
    /// Start point NAME=VALUE (one more candidate after the global initialisation).
    #[arg(long, value_delimiter = ',')]
    start: Vec<String>,
    /// Fit these parameters jointly across channels (the others per channel), e.g. n,c3.
    #[arg(long, value_delimiter = ',')]
    shared: Vec<String>,
    /// Skip the global initialisation (local method from --start or the default start only).
    #[arg(long)]
    local_only: bool,
    /// Certificate: after the fit, refine K seeded random starts and report whether any ended
    /// lower (JSON `verified`, `verify_best_cost`); a fit one of them beats is marked not usable.
    #[arg(long, value_name = "K", default_value_t = 0)]
    verify: usize,
    /// Seed of the --verify starts.
    #[arg(long, value_name = "S", default_value_t = 1)]
    verify_seed: u64,
    /// Phong only: fast power approximation with γ = 2^K.
    #[arg(long, value_name = "K")]
    fast_pow: Option<u32>,
    /// Benchmarking: run each fit N times in this process and report the median time in
    /// `seconds` and `geometry_seconds` (the results are identical every time; the peer scripts
    /// time the same way).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeat: u32,
    /// Write the fit(s) as JSON to this file.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

#[derive(Args, Debug, Clone)]
struct LoadArgs {
    /// Input format (csv, astm, cornell, merl) instead of detecting it from extension and content.
    #[arg(long, value_enum)]
    format: Option<Format>,
    /// What to do with negative values: mask (treat as missing), clamp (to 0) or error.
    #[arg(long, value_enum, default_value = "mask")]
    negative: NegativePolicy,
    /// Reduce to one channel: a name (r, g, b, 550nm), an index, a wavelength (555nm,
    /// interpolated) or cie-y (CIE 1931 luminance of spectral data).
    #[arg(long)]
    channel: Option<String>,
}

#[derive(Args, Debug, Clone)]
struct ModelArgs {
    /// Model.
    #[arg(long, value_enum)]
    model: ModelKind,
    /// Facet distribution of models that take one (torrance-sparrow): d1 (cosine power), d2
    /// (Gaussian), d3 (Trowbridge–Reitz).
    #[arg(long, value_enum, default_value = "d3")]
    distribution: Distribution,
    /// Parameter values NAME=VALUE (repeat or separate with commas), e.g. n=1.8,c3=0.35,ps=0.667,pd=0.333.
    #[arg(long = "set", value_delimiter = ',')]
    set: Vec<String>,
    /// Phong only: use the fast power approximation (1 − βλ)^γ with γ = 2^K.
    #[arg(long, value_name = "K")]
    fast_pow: Option<u32>,
}

impl ModelArgs {
    fn build(&self) -> Result<Model> {
        let (kind, dist) = (self.model, self.distribution);
        let set = parse_assignments("--set", &self.set)?;
        let mut m = Model::from_named(kind, dist, &set).map_err(|e| anyhow!("{e}"))?;
        m.fast_pow = self.fast_pow;
        Ok(m)
    }
}

/// Parse `NAME=VALUE` items of a flag.
fn parse_assignments(flag: &str, items: &[String]) -> Result<Vec<(String, f64)>> {
    items
        .iter()
        .map(|kv| {
            let (k, v) = kv.split_once('=').ok_or_else(|| {
                anyhow!("{flag} '{kv}' is not NAME=VALUE\n  fix: write e.g. {flag} c3=0.35")
            })?;
            let v: f64 = v.trim().parse().map_err(|_| {
                anyhow!("{flag} {kv}: '{v}' is not a number\n  fix: write e.g. {flag} c3=0.35")
            })?;
            Ok((k.trim().to_string(), v))
        })
        .collect()
}

impl LoadArgs {
    fn load(&self, path: &Path) -> Result<Dataset> {
        let (format, negative) = (self.format, self.negative);
        let ds = data::load(path, &LoadOptions { format, negative })?;
        match &self.channel {
            None => Ok(ds),
            Some(c) => ds.select(&ChannelSelect::parse(c)).map_err(|m| {
                anyhow!(
                    "{}: {m}\n  fix: pick a channel the file has",
                    path.display()
                )
            }),
        }
    }
}

/// Write to stdout; a closed pipe ends the program quietly.
fn print(s: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(s.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        r => r.context("writing to standard output"),
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { file, load } => {
            let ds = load.load(&file)?;
            print(&data::summary(&ds))
        }
        Command::Eval {
            model,
            directions,
            output,
        } => {
            let m = model.build()?;
            let dirs = data::load_directions(&directions)?;
            let mut out = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
            for k in 0..dirs.len() {
                let a = dirs.angles(k);
                out.push(a, &[m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]))]);
            }
            out.meta.comments = vec![format!("brdfit eval: {m}")];
            match output {
                Some(p) => {
                    guard(&p)?;
                    if same_file(&directions, &p) {
                        bail!(
                            "{}: the output would overwrite the input\n  fix: choose another output path",
                            p.display()
                        );
                    }
                    Ok(data::write_csv(&out, &p)?)
                }
                None => {
                    let mut buf = Vec::new();
                    data::write_csv_to(&out, &mut buf)?;
                    print(&String::from_utf8_lossy(&buf))
                }
            }
        }
        Command::Simulate {
            model,
            grid,
            noise,
            seed,
            output,
        } => {
            let m = model.build()?;
            let g = Grid::parse(&grid).map_err(|e| anyhow!("{e}"))?;
            if !(noise.is_finite() && noise >= 0.0) {
                bail!(
                    "--noise {noise} must be a finite number ≥ 0\n  fix: e.g. --noise 0.01 for 1 %"
                );
            }
            let mut ds = simulate(&m, &g.directions(seed), noise, seed);
            ds.meta.comments = vec![
                format!(
                    "generated by: brdfit simulate --model {} --distribution {} --set {} --grid {grid} --noise {noise} --seed {seed}",
                    m.kind,
                    m.dist.name(),
                    m.param_names()
                        .iter()
                        .zip(m.params())
                        .map(|(n, v)| format!("{n}={v}"))
                        .collect::<Vec<_>>()
                        .join(",")
                ),
                format!("truth: {m}"),
                "angles in degrees; f_r in 1/sr; mirror direction is phi_o = phi_i + 180".into(),
            ];
            data::write_csv(&ds, &output)?;
            Ok(())
        }
        Command::Fit { fit, load } => run_fit(&fit, &load),
        Command::Inverse {
            image,
            row,
            from,
            to,
            light,
            ca,
            cd,
            fit,
            irradiance,
            ambient,
            pixel_size,
            prior,
            image2,
            light2,
            linear,
            truth,
            output,
        } => {
            use brdfit::inverse;
            let read = |p: &Path| -> Result<(u32, u32, Vec<f64>)> {
                let img = image::open(p).map_err(|e| {
                    anyhow!(
                        "{}: cannot read the image: {e}\n  fix: give a PNG or EXR",
                        p.display()
                    )
                })?;
                let is_exr = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
                let rgb = img.to_rgb32f();
                let dec = |v: f32| -> f64 {
                    let v = v as f64;
                    if is_exr || linear {
                        v
                    } else if v <= 0.04045 {
                        v / 12.92
                    } else {
                        ((v + 0.055) / 1.055).powf(2.4)
                    }
                };
                let lum = rgb
                    .pixels()
                    .map(|px| (dec(px.0[0]) + dec(px.0[1]) + dec(px.0[2])) / 3.0)
                    .collect();
                Ok((rgb.width(), rgb.height(), lum))
            };
            let (w, h, lum) = read(&image)?;
            let (a, b) = match (row, from.as_slice(), to.as_slice()) {
                (Some(r), _, _) if r < h => ((0, r), (w - 1, r)),
                (Some(r), _, _) => bail!("--row {r} is outside the image (height {h})"),
                (None, [x0, y0], [x1, y1]) => ((*x0, *y0), (*x1, *y1)),
                _ => bail!("no line given\n  fix: give --row Y, or --from X,Y --to X,Y"),
            };
            let (cd, ca) = match (cd, &fit) {
                (Some(cd), _) => (cd, ca),
                (None, Some(f)) => {
                    let m = read_fits(f)?.remove(0).model_for(0);
                    let pd = m.pd();
                    (pd * irradiance / std::f64::consts::PI, pd * ambient)
                }
                (None, None) => bail!(
                    "no diffuse constant\n  fix: give --cd VALUE, or --fit FILE (with --irradiance and --ambient)"
                ),
            };
            if light.len() != 3 {
                bail!("--light needs x,y,z");
            }
            let (dx, dy) = (b.0 as f64 - a.0 as f64, -(b.1 as f64 - a.1 as f64));
            let len = (dx * dx + dy * dy).sqrt().max(1e-12);
            let proj = |l: &[f64]| {
                let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt().max(1e-12);
                [(l[0] * dx + l[1] * dy) / len / n, l[2] / n]
            };
            let samples = inverse::sample_line(w, h, &lum, a, b);
            let pos: Vec<(u32, u32)> = samples.iter().map(|s| s.0).collect();
            let vals: Vec<f64> = samples.iter().map(|s| s.1).collect();
            let px = match image2 {
                Some(p2) => {
                    if light2.len() != 3 {
                        bail!("--image2 needs --light2 x,y,z");
                    }
                    let (w2, h2, lum2) = read(&p2)?;
                    if (w2, h2) != (w, h) {
                        bail!(
                            "{}: the second image is {w2}×{h2}, the first {w}×{h}",
                            p2.display()
                        );
                    }
                    let v2: Vec<f64> = inverse::sample_line(w, h, &lum2, a, b)
                        .iter()
                        .map(|s| s.1)
                        .collect();
                    inverse::invert_line_two_lights(
                        &vals,
                        &v2,
                        proj(&light),
                        proj(&light2),
                        ca,
                        cd,
                        pixel_size,
                    )
                }
                None => {
                    let prior = match prior.as_str() {
                        "convex" => inverse::Prior::Convex,
                        "concave" => inverse::Prior::Concave,
                        p => bail!("unknown prior '{p}'\n  fix: use --prior convex or concave"),
                    };
                    inverse::invert_line(&vals, proj(&light), ca, cd, pixel_size, prior)
                }
            };
            let base = output.with_extension("");
            brdfit::output::write_bytes_atomic(
                &base.with_extension("csv"),
                inverse::to_csv(&px, &pos).as_bytes(),
            )?;
            let mut series = vec![brdfit::plot::LobeSeries {
                label: "estimated height".into(),
                points: px
                    .iter()
                    .filter(|p| p.height.is_finite())
                    .map(|p| (p.t, p.height))
                    .collect(),
                markers: false,
            }];
            if let Some(t) = truth {
                let d = std::fs::read_to_string(&t)
                    .with_context(|| format!("{}: cannot read", t.display()))?;
                let pts: Vec<(f64, f64)> = d
                    .lines()
                    .skip(1)
                    .filter_map(|l| {
                        let mut it = l.split(',');
                        Some((
                            it.next()?.trim().parse().ok()?,
                            it.next()?.trim().parse().ok()?,
                        ))
                    })
                    .collect();
                series.push(brdfit::plot::LobeSeries {
                    label: "true height".into(),
                    points: pts,
                    markers: false,
                });
            }
            let chart = brdfit::plot::XyChart {
                title: format!("Height profile by inverse Phong: {}", image.display()),
                x_label: "pixel along the line".into(),
                y_label: "relative height (world units)".into(),
                series,
                log_x: false,
                log_y: false,
                hline: None,
            };
            brdfit::plot::save(&chart, &base)?;
            let flagged = px.iter().filter(|p| p.flagged).count();
            if flagged > 0 {
                eprintln!(
                    "note: {flagged} of {} pixels have no solution (value outside the model's range) and are flagged",
                    px.len()
                );
            }
            Ok(())
        }
        Command::Completions { shell } => {
            use clap::CommandFactory;
            let mut buf = Vec::new();
            clap_complete::generate(shell, &mut Cli::command(), "brdfit", &mut buf);
            print(&String::from_utf8_lossy(&buf))
        }
        Command::Export { fit, to, output } => {
            use brdfit::export::{self, ExportFormat};
            use clap::ValueEnum;
            let fmt = to;
            let to = to
                .to_possible_value()
                .map_or(String::new(), |v| v.get_name().to_string());
            let r = read_fits(&fit)?.remove(0);
            let m = r.model_for(0);
            let id = fit
                .file_stem()
                .map_or("brdfit".into(), |s| s.to_string_lossy().into_owned());
            let text = match fmt {
                ExportFormat::Mitsuba => Some(export::mitsuba(&m, &id)),
                ExportFormat::Pbrt => Some(export::pbrt(&m)),
                ExportFormat::BrdfExplorer => Some(export::brdf_explorer(&m)),
                ExportFormat::Merl | ExportFormat::Csv => None,
            };
            match (text, output) {
                (Some(t), None) => print(&t),
                (Some(t), Some(o)) => {
                    guard(&o)?;
                    Ok(brdfit::output::write_bytes_atomic(&o, t.as_bytes())?)
                }
                (None, None) => bail!("--to {to} writes a file\n  fix: add -o OUT"),
                (None, Some(o)) => {
                    guard(&o)?;
                    if same_file(&fit, &o) {
                        bail!(
                            "{}: the output would overwrite the input\n  fix: choose another output path",
                            o.display()
                        );
                    }
                    if fmt == ExportFormat::Merl {
                        data::merl::write_merl(&export::merl_dataset(&m), &o)?;
                    } else {
                        data::write_csv(&export::grid_dataset(&m), &o)?;
                    }
                    Ok(())
                }
            }
        }
        Command::Report {
            files,
            output,
            stability_starts,
            render_res,
        } => {
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
                    out: output.clone(),
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
        Command::Render {
            scene,
            output,
            aluminium,
            mgo,
            res,
        } => run_render(
            &scene,
            &output,
            aluminium.as_deref(),
            mgo.as_deref(),
            res,
            quiet(),
        ),
        Command::Plot(cmd) => run_plot(cmd),
        Command::Study(cmd) => run_study(cmd),
        Command::Convert {
            input,
            output,
            to,
            load,
        } => {
            let ds = load.load(&input)?;
            let to_merl = match to.as_deref() {
                Some("merl") => true,
                Some("csv") => false,
                Some(t) => bail!("unknown output format '{t}'\n  fix: use --to csv or --to merl"),
                None => Format::from_extension(&output) == Some(Format::Merl),
            };
            if same_file(&input, &output) {
                bail!(
                    "{}: the output would overwrite the input\n  fix: choose another output path",
                    output.display()
                );
            }
            guard(&output)?;
            if to_merl {
                data::merl::write_merl(&ds, &output)?;
            } else {
                data::write_csv(&ds, &output)?;
            }
            Ok(())
        }
    }
}

fn run_fit(a: &FitArgs, load: &LoadArgs) -> Result<()> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.jobs.clamp(1, 64))
        .build()
        .map_err(|e| anyhow!("cannot start {} jobs: {e}", a.jobs))?;
    let results: Vec<Result<(String, Vec<brdfit::fit::FitResult>)>> = if a.files.len() == 1 {
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
            Ok((text, fits)) => {
                if a.files.len() > 1 {
                    print(&format!("== {}\n", f.display()))?;
                }
                print(&text)?;
                all.push((f.clone(), fits));
            }
            Err(e) => {
                eprintln!("error: {e:#}");
                first_err.get_or_insert(e);
            }
        }
    }
    if let Some(path) = &a.json {
        guard(path)?;
        if a.files.iter().any(|f| same_file(f, path)) {
            bail!(
                "{}: the output would overwrite an input\n  fix: choose another output path",
                path.display()
            );
        }
        let flat: Vec<&brdfit::fit::FitResult> = all.iter().flat_map(|(_, f)| f).collect();
        let v = if flat.len() == 1 {
            flat[0].to_json()
        } else {
            serde_json::json!({ "fits": flat.iter().map(|f| f.to_json()).collect::<Vec<_>>() })
        };
        let s = serde_json::to_string_pretty(&v)? + "\n";
        brdfit::output::write_bytes_atomic(path, s.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &a.summary {
        guard(path)?;
        if a.files.iter().any(|f| same_file(f, path)) {
            bail!(
                "{}: the output would overwrite an input\n  fix: choose another output path",
                path.display()
            );
        }
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
            let mut w = csv::Writer::from_writer(Vec::new());
            w.write_record([
                "file",
                "channel",
                "model",
                "params",
                "cost",
                "rmse",
                "samples_used",
                "warnings",
                "unusable",
            ])?;
            for (f, fits) in &all {
                for r in fits {
                    let params: Vec<String> =
                        r.params.iter().map(|(n, v)| format!("{n}={v}")).collect();
                    w.write_record([
                        f.display().to_string(),
                        r.channel.clone(),
                        r.label(),
                        params.join(" "),
                        r.cost.to_string(),
                        r.rmse.to_string(),
                        r.samples_used.to_string(),
                        r.warnings.len().to_string(),
                        r.unusable.join("; "),
                    ])?;
                }
            }
            String::from_utf8(w.into_inner().map_err(|e| anyhow!("{e}"))?)?
        };
        brdfit::output::write_bytes_atomic(path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    match first_err {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Fit one file as the flags say: the terminal text and the fits.
fn fit_one(
    a: &FitArgs,
    load: &LoadArgs,
    file: &Path,
) -> Result<(String, Vec<brdfit::fit::FitResult>)> {
    use brdfit::fit::{self, FitOptions};
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
    let dist = a.distribution;
    // clap has checked the name: `all` or a model.
    let kinds: Vec<(ModelKind, Distribution)> = match ModelKind::parse(&a.model) {
        Some(kind) => vec![(kind, dist)],
        None => fit::all_models(),
    };
    let (method, loss, robust) = (a.method, a.loss, a.robust);
    let fix = parse_assignments("--fix", &a.fix)?;
    let start = parse_assignments("--start", &a.start)?;
    let mut all = Vec::new();
    for (kind, dist) in &kinds {
        let mut o = FitOptions::new(*kind);
        o.dist = *dist;
        o.method = method;
        o.loss = loss;
        o.robust = robust;
        o.max_theta_deg = a.max_theta;
        // With --model all, parameters a model lacks are skipped for that model.
        let names = kind.param_names(*dist);
        let keep = |v: &Vec<(String, f64)>| -> Vec<(String, f64)> {
            v.iter()
                .filter(|(k, _)| kinds.len() == 1 || names.contains(&k.as_str()))
                .cloned()
                .collect()
        };
        o.fix = keep(&fix);
        o.start = keep(&start);
        o.shared = a
            .shared
            .iter()
            .filter(|s| kinds.len() == 1 || names.contains(&s.as_str()))
            .cloned()
            .collect();
        o.local_only = a.local_only;
        o.fast_pow = a.fast_pow;
        o.verify = a.verify;
        o.seed = a.verify_seed;
        let mut fits = fit::fit(&ds, &o).map_err(|e| anyhow!("{}: {e}", file.display()))?;
        if a.repeat > 1 {
            let both = |f: &fit::FitResult| [f.seconds, f.geometry_seconds];
            let mut times: Vec<Vec<[f64; 2]>> = fits.iter().map(|f| vec![both(f)]).collect();
            for _ in 1..a.repeat {
                let again = fit::fit(&ds, &o).map_err(|e| anyhow!("{}: {e}", file.display()))?;
                for (t, f) in times.iter_mut().zip(&again) {
                    t.push(both(f));
                }
            }
            // Each time is the median of its own column.
            let median = |t: &[[f64; 2]], k: usize| {
                let mut v: Vec<f64> = t.iter().map(|x| x[k]).collect();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            for (f, t) in fits.iter_mut().zip(&times) {
                (f.seconds, f.geometry_seconds) = (median(t, 0), median(t, 1));
            }
        }
        all.push(fits);
    }
    let mut text = String::new();
    let nch = all[0].len();
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
    Ok((text, all.into_iter().flatten().collect()))
}

fn ts_model_from(fit: Option<&Path>, default: Model) -> Result<Model> {
    match fit {
        None => Ok(default),
        Some(p) => {
            let r = read_fits(p)?.remove(0);
            if r.model != ModelKind::TorranceSparrow {
                bail!(
                    "{}: fig7 needs a torrance-sparrow fit, this is {}\n  fix: fit with --model torrance-sparrow",
                    p.display(),
                    r.model
                );
            }
            Ok(r.model_for(0))
        }
    }
}

fn run_render(
    scene: &str,
    output: &Path,
    al: Option<&Path>,
    mgo: Option<&Path>,
    res: u32,
    quiet: bool,
) -> Result<()> {
    use brdfit::render;
    if !(1..=8192).contains(&res) {
        bail!("--res {res} is out of range\n  fix: give a resolution between 1 and 8192");
    }
    if scene == "fig7" {
        let al = ts_model_from(al, Model::blinn_aluminium())?;
        let mgo = ts_model_from(mgo, Model::blinn_mgo())?;
        let t = std::time::Instant::now();
        let imgs = render::fig7_images(
            &al,
            &mgo,
            res,
            render::AntiAlias::Adaptive {
                threshold: 0.02,
                max_level: 3,
                block: 1,
                jitter: false,
            },
        );
        for (name, img) in &imgs {
            render::save(img, &output.join(name))?;
        }
        brdfit::output::write_bytes_atomic(
            &output.join("fig7.png"),
            &render::contact_sheet(&imgs)?,
        )?;
        if !quiet {
            eprintln!(
                "rendered 8 images {res}×{res} in {:.2} s",
                t.elapsed().as_secs_f64()
            );
        }
        return Ok(());
    }
    let s = render::scene::load_scene(Path::new(scene))?;
    let bar = if quiet {
        indicatif::ProgressBar::hidden()
    } else {
        progress_bar(s.camera.height as u64, "rows")
    };
    let t = std::time::Instant::now();
    let img = s.render(&|| bar.inc(1));
    let seconds = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if !quiet {
        eprintln!(
            "rendered {}×{} in {seconds:.4} s: {:.2} primary rays per pixel, {} rays in all",
            img.width,
            img.height,
            img.primary_per_pixel(),
            img.total_rays()
        );
    }
    let base = match output.extension().and_then(|e| e.to_str()) {
        Some("png" | "exr") => output.with_extension(""),
        _ => output.to_path_buf(),
    };
    guard(&base.with_extension("png"))?;
    render::save(&img, &base)?;
    Ok(())
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

fn main() -> ExitCode {
    // Start rayon's worker threads now, while the arguments are parsed and the input is read,
    // rather than inside the first timed parallel pass.
    let _ = rayon::current_num_threads();
    let cli = match Cli::try_parse() {
        Ok(c) => {
            FORCE.store(c.force, std::sync::atomic::Ordering::Relaxed);
            QUIET.store(c.quiet, std::sync::atomic::Ordering::Relaxed);
            VERBOSE.store(c.verbose && !c.quiet, std::sync::atomic::Ordering::Relaxed);
            c
        }
        Err(e) => {
            let _ = e.print();
            return match e.kind() {
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion => {
                    ExitCode::SUCCESS
                }
                _ => ExitCode::from(2),
            };
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

/// `--model` of `fit`: a model's name (or alias) or `all`; clap rejects anything else with a
/// suggestion and exit code 2.
fn model_or_all() -> clap::builder::PossibleValuesParser {
    use clap::ValueEnum;
    clap::builder::PossibleValuesParser::new(
        ModelKind::value_variants()
            .iter()
            .filter_map(|k| k.to_possible_value())
            .chain([clap::builder::PossibleValue::new("all")]),
    )
}

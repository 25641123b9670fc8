//! The command-line interface: argument parsing (clap) and printing; the work is done by the
//! library. One file per command group.

mod args;
mod choose;
mod fit;
mod inverse;
mod io;
mod plan;
mod plot;
mod prior;
mod render;
mod report;
mod study;

pub(crate) use args::*;
pub(crate) use choose::*;
pub(crate) use fit::*;
pub(crate) use inverse::*;
pub(crate) use io::*;
pub(crate) use plan::*;
pub(crate) use plot::*;
pub(crate) use prior::*;
pub(crate) use render::*;
pub(crate) use report::*;
pub(crate) use study::*;

use anyhow::{Context, Result, bail};
use brdfit::data::{self};
use clap::{Parser, Subcommand};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Fit reflection models (Phong, Blinn's Torrance–Sparrow) to measured reflectance.
#[derive(Parser, Debug)]
#[command(name = "brdfit", version, about, long_about = None)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
    /// No progress bars or notes on stderr.
    #[arg(long, short, global = true)]
    pub(crate) quiet: bool,
    /// More detail on stderr (timings).
    #[arg(long, short, global = true)]
    pub(crate) verbose: bool,
    /// Size limit of every input file in MB (default: 64 for data files, 4 for fit JSON,
    /// 1 for scene files, 64 for OBJ meshes).
    #[arg(long, global = true, value_name = "MB", value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub(crate) max_input_mb: Option<u64>,
}

pub(crate) static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

pub(crate) static VERBOSE: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// Announce a file the command wrote, on stderr (`wrote PATH`), after any folder created
/// for it (`created DIR/`), unless --quiet. The one rule for outputs: an existing file is
/// replaced (atomically) only if it is a regular file, an output that is one of the inputs
/// is refused, and missing parent folders are created and named.
pub(crate) fn wrote(path: &Path) {
    announce_created(None);
    if !quiet() {
        eprintln!("wrote {}", path.display());
    }
}

/// Announce the folders created since the last announcement (`created DIR/`), leaving out
/// those inside `within` (a report's own sub-folders, counted with its files).
pub(crate) fn announce_created(within: Option<&Path>) {
    for d in brdfit::support::output::take_created() {
        if !quiet() && within.is_none_or(|w| !d.starts_with(w) || d == w) {
            eprintln!("created {}/", d.display());
        }
    }
}

/// Refuse an output path that is one of the inputs (brdfit never modifies an input), or that
/// exists and is not a regular file ([`brdfit::support::output::check_target`]: a device such as
/// `/dev/null`, a named pipe, a folder). Called before the command's work.
pub(crate) fn refuse_input(output: &Path, inputs: &[&Path]) -> Result<()> {
    brdfit::support::output::check_target(output)?;
    if inputs.iter().any(|i| same_file(i, output)) {
        bail!(
            "{}: the output would overwrite an input\n  fix: choose another output path",
            output.display()
        );
    }
    Ok(())
}

/// [`wrote`] for each path.
pub(crate) fn wrote_all<'a>(paths: impl IntoIterator<Item = &'a PathBuf>) {
    for p in paths {
        wrote(p);
    }
}

/// A list for a message: "a", "a and b", "a, b and c".
fn words<S: AsRef<str>>(items: &[S]) -> String {
    let items: Vec<&str> = items.iter().map(AsRef::as_ref).collect();
    match items.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => items.concat(),
    }
}

/// The base name of an output written as BASE.EXT for each extension of `exts` (e.g. png and
/// exr): `-o NAME` without an extension, or with one of `exts` (any case), is that base; any
/// other extension is refused with the fix, where it used to be replaced silently (`-o x.jpg`
/// wrote x.png). So is an existing folder, whose name used to become the base (`-o renders`
/// wrote renders.png beside the folder, not in it).
pub(crate) fn output_base(output: &Path, exts: &[&str]) -> Result<PathBuf> {
    if output.is_dir() {
        let name = match exts[0] {
            "png" => "image",
            "csv" => "profile",
            _ => "chart",
        };
        bail!(
            "-o {}: is a folder; this command writes {} files named by -o\n  fix: give a file \
             name, e.g. -o {}",
            output.display(),
            words(exts),
            output.join(format!("{name}.{}", exts[0])).display()
        );
    }
    match output.extension().map(|e| e.to_string_lossy()) {
        None => Ok(output.to_path_buf()),
        Some(e) if exts.iter().any(|x| x.eq_ignore_ascii_case(&e)) => Ok(output.with_extension("")),
        Some(e) => {
            let files: Vec<String> = exts
                .iter()
                .map(|x| output.with_extension(x).display().to_string())
                .collect();
            bail!(
                "-o {}: this command writes {} files, not .{e}\n  fix: give -o {} (it writes {})",
                output.display(),
                words(exts),
                output.with_extension(exts[0]).display(),
                words(&files)
            )
        }
    }
}

/// Save a chart as `base.svg` and `base.png` and announce both.
pub(crate) fn save_chart(chart: &impl brdfit::plot::Chart, base: &Path) -> Result<()> {
    let (svg, png) = brdfit::plot::save(chart, base)?;
    wrote_all([&svg, &png]);
    Ok(())
}

/// Save an image as `base.png` and `base.exr` and announce both.
pub(crate) fn save_image(img: &brdfit::render::Image, base: &Path) -> Result<()> {
    wrote_all(&brdfit::render::save(img, base)?);
    Ok(())
}

/// Write bytes atomically and announce the file.
pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    // The error names the path and the fix.
    brdfit::support::output::write_bytes_atomic(path, bytes)?;
    wrote(path);
    Ok(())
}

/// A progress bar on stderr, drawn only on a terminal and never with --quiet.
pub(crate) fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if quiet() || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{elapsed:>4} [{wide_bar}] {percent:>3} % · {eta} left · {msg}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    // Ticks keep the clock moving through a long step.
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    bar
}

pub(crate) fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// Read a scene file and say on stderr (unless --quiet) what was chosen for the user in it,
/// and its warnings (always).
pub(crate) fn load_scene(path: &std::path::Path) -> anyhow::Result<brdfit::render::Scene> {
    let (scene, notes) = brdfit::scene::load_scene_noted(path)?;
    for n in notes {
        // Warnings (already FILE:LINE) even with --quiet, like the loaders' warnings.
        let n = printable(&n);
        if n.starts_with("warning: ") {
            eprintln!("{n}");
        } else if !quiet() {
            eprintln!("note: {}: {n}", path.display());
        }
    }
    Ok(scene)
}

#[derive(Subcommand, Debug)]
pub(crate) enum Command {
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
        /// Random starts per configuration in each stability study (1–100).
        #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u16).range(1..=100))]
        stability_starts: u16,
        /// Resolution of the material renders (16–2048; 4096 took 1.8 GB).
        #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=2048))]
        render_res: u32,
    },
    /// Which model a scene needs: render the measurement itself and each model fitted where the
    /// scene looks, and name the simplest whose image a viewer cannot tell apart.
    #[command(
        after_help = "Examples:\n  brdfit choose data/blinn-mgo.csv\n  brdfit choose data/merl-alumina-oxide.csv --scene fig7 --threshold delta_e_itp_p99=2 -o choose-alumina"
    )]
    Choose(ChooseArgs),
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
    Eval(EvalArgs),
    /// Write synthetic samples of a model, with seeded multiplicative Gaussian noise.
    #[command(
        after_help = "Example:\n  brdfit simulate --model torrance-sparrow --set n=1.8,c3=0.35,ps=0.667,pd=0.333 \\\n    --grid hemisphere:10000 --noise 0.01 --seed 1 -o mgo.csv"
    )]
    Simulate(SimulateArgs),
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
    /// Priors: what real materials are like (principal components of measured materials).
    #[command(subcommand)]
    Prior(PriorCmd),
    /// Where to measure next: the configurations that would most reduce what a scene's
    /// pixels leave uncertain under the prior, best first.
    #[command(
        after_help = "Examples:\n  brdfit plan data/merl-alumina-oxide.csv --scene fig7 --budget 100 -o plan.csv\n  brdfit plan --budget 20 -o first.csv"
    )]
    Plan(PlanArgs),
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
        /// Render an image larger than 8192 on a side or 16 M pixels (memory: about 35 bytes a
        /// pixel), or fig7 above --res 2048 (about 110 bytes a pixel).
        #[arg(long)]
        allow_large_image: bool,
        #[command(flatten)]
        pick: PickArgs,
        /// fig7: the channel to take from fit files of several.
        #[arg(long)]
        channel: Option<String>,
    },
    /// Export a fit to another renderer or format: mitsuba, pbrt, brdf-explorer, merl, csv.
    #[command(
        after_help = "Examples:\n  brdfit export fit.json --to mitsuba\n  brdfit export fit.json --to merl -o fitted.binary"
    )]
    Export(ExportArgs),
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
    Inverse(InverseArgs),
    /// Convert between formats: any → brdfit CSV, CSV (or any) → MERL .binary.
    #[command(
        after_help = "Example:\n  brdfit convert data/cayman.astm --channel cie-y -o cayman.csv"
    )]
    Convert(ConvertArgs),
}

/// Write to stdout; a closed pipe ends the program quietly.
pub(crate) fn print(s: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(s.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        r => r.context("writing to standard output"),
    }
}

/// Whether the command running takes `fit`'s flags (--fix, --start, --max-theta), so that an
/// error's fix names only flags the command has.
static FIT_FLAGS: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);

pub(crate) fn run(cli: Cli) -> Result<()> {
    FIT_FLAGS.store(
        matches!(cli.command, Command::Fit { .. }),
        std::sync::atomic::Ordering::Relaxed,
    );
    match cli.command {
        Command::Info { file, load } => {
            let ds = load.load(&file)?;
            print(&data::summary(&ds))
        }
        Command::Eval(args) => run_eval(args),
        Command::Simulate(args) => run_simulate(args),
        Command::Fit { fit, load } => run_fit(&fit, &load),
        Command::Inverse(args) => run_inverse(args),
        Command::Completions { shell } => {
            use clap::CommandFactory;
            let mut buf = Vec::new();
            clap_complete::generate(shell, &mut Cli::command(), "brdfit", &mut buf);
            print(&String::from_utf8_lossy(&buf))
        }
        Command::Export(args) => run_export(args),
        Command::Report {
            files,
            output,
            stability_starts,
            render_res,
        } => run_report(files, &output, stability_starts, render_res),
        Command::Render {
            scene,
            output,
            aluminium,
            mgo,
            res,
            allow_large_image,
            pick,
            channel,
        } => run_render(
            &scene,
            &output,
            aluminium.as_deref(),
            mgo.as_deref(),
            (&pick, channel.as_deref()),
            (res, allow_large_image),
            quiet(),
        ),
        Command::Choose(args) => run_choose(args),
        Command::Plot(cmd) => run_plot(cmd),
        Command::Study(cmd) => run_study(cmd),
        Command::Prior(cmd) => run_prior(cmd),
        Command::Plan(args) => run_plan(args),
        Command::Convert(args) => run_convert(args),
    }
}

pub(crate) fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

pub(crate) fn main() -> ExitCode {
    // Start rayon's worker threads now, while the arguments are parsed and the input is read,
    // rather than inside the first timed parallel pass.
    let _ = rayon::current_num_threads();
    let cli = match Cli::try_parse() {
        Ok(c) => {
            QUIET.store(c.quiet, std::sync::atomic::Ordering::Relaxed);
            VERBOSE.store(c.verbose && !c.quiet, std::sync::atomic::Ordering::Relaxed);
            brdfit::support::input::set_max_input_bytes(c.max_input_mb.map(|mb| mb << 20));
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
            report_error(&e);
            ExitCode::from(1)
        }
    }
}

/// Print an error, and the flag that changes the setting a library error names (library
/// errors say what to change, not how to spell it on this command line).
pub(crate) fn report_error(e: &anyhow::Error) {
    eprintln!("error: {}", printable(&format!("{e:#}")));
    if let Some(flag) = e.chain().find_map(setting_of).map(|s| flag(&s)) {
        eprintln!("  on the command line: {flag}");
    }
}

/// `s` with its control characters (ESC, CR, …; not the line breaks of the message itself)
/// escaped (`\u{1b}`), so that bytes from a file never drive the terminal.
pub(crate) fn printable(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_control() && c != '\n' {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// The setting a library error names, if any.
fn setting_of(e: &(dyn std::error::Error + 'static)) -> Option<brdfit::support::setting::Setting> {
    use brdfit::{data::DataError, fit::FitError, model::ModelError};
    if let Some(d) = e.downcast_ref::<DataError>() {
        return d.setting.clone();
    }
    if let Some(f) = e.downcast_ref::<FitError>() {
        return f.setting.clone();
    }
    e.downcast_ref::<ModelError>().and_then(ModelError::setting)
}

/// The command-line spelling of a setting.
pub(crate) fn flag(s: &brdfit::support::setting::Setting) -> String {
    use brdfit::support::setting::Setting;
    if !FIT_FLAGS.load(std::sync::atomic::Ordering::Relaxed) {
        // This command has no --fix, --start or --max-theta: name what it has, and `fit`.
        match s {
            Setting::Hold(p) => {
                return format!(
                    "this command fits with no held values; fit the data with `brdfit fit DATA --fix {p}=VALUE`"
                );
            }
            Setting::Start => {
                return "this command has no start values; fit the data with `brdfit fit DATA --start NAME=VALUE,…`".into();
            }
            Setting::MaxTheta => {
                return "--negative mask|clamp, or fit the data with `brdfit fit DATA --max-theta DEG`".into();
            }
            _ => {}
        }
    }
    match s {
        Setting::NegativePolicy => {
            "--negative mask (treat as missing) or --negative clamp (set to 0)".into()
        }
        Setting::Format => "--format csv|astm|cornell|merl".into(),
        Setting::Channel => "--channel NAME|INDEX|<λ>nm|cie-y".into(),
        Setting::Hold(p) => format!("--fix {p}=VALUE"),
        Setting::Start => "--start NAME=VALUE,…".into(),
        Setting::Value(p) => format!("--set {p}=VALUE"),
        Setting::MaxTheta => "--max-theta DEG, --negative, or --fix NAME=VALUE".into(),
        Setting::MaxInputSize => "--max-input-mb N (a limit for every input file)".into(),
    }
}

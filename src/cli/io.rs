//! `brdfit eval`, `simulate`, `export` and `convert`: model values and data files in and out.

use super::*;
use anyhow::{Result, anyhow, bail};
use brdfit::data::{self, Dataset, Format, Quantity};
use brdfit::model::{Geometry, Model};
use brdfit::simulate::{Grid, simulate};
use clap::Args;
use std::path::{Path, PathBuf};

/// Arguments of `brdfit eval`.
#[derive(Args, Debug)]
pub(crate) struct EvalArgs {
    /// Model (with --set), or with --fit the fit file's model to take.
    #[arg(long, value_enum, required_unless_present = "fit")]
    pub(crate) model: Option<brdfit::ModelKind>,
    /// Facet distribution of models that take one (torrance-sparrow): d1, d2, d3 (default),
    /// abc; with --fit, the fit's.
    #[arg(long, value_enum)]
    pub(crate) distribution: Option<brdfit::Distribution>,
    /// Parameter values NAME=VALUE (repeat or separate with commas), e.g. n=1.8,c3=0.35,ps=0.667,pd=0.333.
    #[arg(long = "set", value_delimiter = ',', conflicts_with = "fit")]
    pub(crate) set: Vec<String>,
    /// Phong only: use the fast power approximation (1 − βλ)^γ with γ = 2^K.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(0..=30))]
    pub(crate) fast_pow: Option<u32>,
    /// A fit JSON (brdfit fit --json) whose fitted model is evaluated; a file of several fits
    /// needs --model (and --distribution) and --channel to name one.
    #[arg(long, value_name = "FIT.json")]
    pub(crate) fit: Option<PathBuf>,
    /// With --fit: the channel whose fit is evaluated.
    #[arg(long, requires = "fit")]
    pub(crate) channel: Option<String>,
    /// With --fit: evaluate a fit marked not usable anyway.
    #[arg(long, requires = "fit")]
    pub(crate) allow_unusable: bool,
    /// CSV whose theta_i/phi_i/theta_o/phi_o columns (with _deg or _rad) give the directions.
    pub(crate) directions: PathBuf,
    /// Output CSV (standard output when omitted).
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
}

/// `brdfit eval` (see its help).
pub(crate) fn run_eval(args: EvalArgs) -> Result<()> {
    let EvalArgs {
        model,
        distribution,
        set,
        fast_pow,
        fit,
        channel,
        allow_unusable,
        directions,
        output,
    } = args;
    if let Some(p) = &output {
        let mut inputs = vec![directions.as_path()];
        inputs.extend(fit.as_deref());
        refuse_input(p, &inputs)?;
    }
    let (m, from) = match &fit {
        Some(path) => {
            let want = brdfit::fit::Want {
                model,
                dist: distribution,
                channel,
                allow_unusable,
            };
            let p = pick_for_eval(path, &want)?;
            let mut m = p.model;
            m.fast_pow = fast_pow;
            let channel = if brdfit::fit::is_unnamed_channel(&p.channel) {
                String::new()
            } else {
                format!(", channel {}", p.channel)
            };
            (m, format!(" (from {}{channel})", path.display()))
        }
        None => {
            let m = ModelArgs {
                model: model.expect("clap requires --model without --fit"),
                distribution: distribution.unwrap_or_default(),
                set,
                fast_pow,
            }
            .build()?;
            (m, String::new())
        }
    };
    let dirs = data::load_directions(&directions)?;
    let mut out = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
    for k in 0..dirs.len() {
        let a = dirs.angles(k);
        out.push(a, &[m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]))]);
    }
    refuse_overflow(&out, &m)?;
    out.meta.comments = vec![format!("brdfit eval: {m}{from}")];
    match output {
        Some(p) => {
            data::write_csv(&out, &p)?;
            wrote(&p);
            Ok(())
        }
        None => {
            let mut buf = Vec::new();
            data::write_csv_to(&out, &mut buf)?;
            print(&String::from_utf8_lossy(&buf))
        }
    }
}

/// The one fit of `path` that `eval --fit` evaluates: a file of several models or channels is
/// refused unless `want` names one, with the choices and the flags that pick each.
fn pick_for_eval(path: &Path, want: &brdfit::fit::Want) -> Result<brdfit::fit::PickedChannel> {
    use brdfit::fit::same_channel;
    let fits = read_fits(path)?;
    let ambiguous = |what: &str, choices: Vec<String>| {
        anyhow!(
            "{}: the file holds fits of {} {what}s and eval evaluates one\n  fix: pick one with {}",
            path.display(),
            choices.len(),
            choices.join(" | ")
        )
    };
    // The models on offer (those of the channel asked, if any), in file order.
    let of_channel = |f: &&brdfit::FitResult| {
        want.channel
            .as_deref()
            .is_none_or(|c| f.channel.split(',').any(|h| same_channel(h, c)))
    };
    let mut models: Vec<(brdfit::ModelKind, brdfit::Distribution)> = Vec::new();
    for f in fits.iter().filter(of_channel) {
        if !models.contains(&(f.model, f.dist)) {
            models.push((f.model, f.dist));
        }
    }
    let flag = |(k, d): &(brdfit::ModelKind, brdfit::Distribution)| {
        let kinds = models.iter().filter(|(x, _)| x == k).count();
        if kinds > 1 {
            format!("--model {k} --distribution {}", d.name())
        } else {
            format!("--model {k}")
        }
    };
    let chosen: Vec<_> = models
        .iter()
        .filter(|(k, d)| want.model.is_none_or(|w| w == *k) && want.dist.is_none_or(|w| w == *d))
        .collect();
    if chosen.len() > 1 {
        return Err(ambiguous("model", chosen.iter().map(|m| flag(m)).collect()));
    }
    let mut want = want.clone();
    if let Some((k, d)) = chosen.first() {
        (want.model, want.dist) = (Some(*k), Some(*d));
    }
    if want.channel.is_none() {
        let mut channels: Vec<&str> = Vec::new();
        for f in fits
            .iter()
            .filter(|f| Some(f.model) == want.model && Some(f.dist) == want.dist)
        {
            for c in f.channel.split(',') {
                if !channels.contains(&c) {
                    channels.push(c);
                }
            }
        }
        if channels.len() > 1 {
            return Err(ambiguous(
                "channel",
                channels.iter().map(|c| format!("--channel {c}")).collect(),
            ));
        }
        // The model's only channel, though other models of the file may have others.
        want.channel = channels.first().map(|c| c.to_string());
    }
    // What is left names one fit, or none (the library's message says which exist).
    pick_fit_from(path, &fits, &want, None)
}

/// Refuse a table where `m` overflowed (f_r infinite or NaN at some direction): nothing is
/// written, and the error names the first such direction.
fn refuse_overflow(ds: &Dataset, m: &Model) -> Result<()> {
    let values = ds.channels.first().map(|c| &c.values[..]).unwrap_or(&[]);
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        let a = ds.angles(k);
        bail!(
            "{m} gives f_r = {} at direction {} (theta_i {}, phi_i {}, theta_o {}, phi_o {}); nothing written\n  fix: give parameter values whose f_r is finite (a scale such as ps near the largest double overflows)",
            values[k],
            k + 1,
            a[0],
            a[1],
            a[2],
            a[3]
        );
    }
    Ok(())
}

/// Arguments of `brdfit simulate`.
#[derive(Args, Debug)]
pub(crate) struct SimulateArgs {
    /// Model to sample (or --nbrdf for a Neural-BRDF network).
    #[arg(
        long,
        value_enum,
        required_unless_present = "nbrdf",
        conflicts_with = "nbrdf"
    )]
    pub(crate) model: Option<brdfit::ModelKind>,
    /// Facet distribution of models that take one (torrance-sparrow): d1, d2, d3, abc.
    #[arg(long, value_enum, default_value = "d3")]
    pub(crate) distribution: brdfit::Distribution,
    /// Parameter values NAME=VALUE (repeat or separate with commas), e.g. n=1.8,c3=0.35,ps=0.667,pd=0.333.
    #[arg(long = "set", value_delimiter = ',')]
    pub(crate) set: Vec<String>,
    /// Phong only: use the fast power approximation (1 − βλ)^γ with γ = 2^K.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(0..=30))]
    pub(crate) fast_pow: Option<u32>,
    /// Neural-BRDF weights file (nbrdf_weights.json, Sztrajman et al. 2021): sample the
    /// network of --material instead of a model (RGB).
    #[arg(long, requires = "material")]
    pub(crate) nbrdf: Option<PathBuf>,
    /// The network's name in the weights file (merl/steel, or steel when unambiguous).
    #[arg(long)]
    pub(crate) material: Option<String>,
    /// With --nbrdf: the network made reciprocal and mirror-symmetric (the mean of f(L, E),
    /// f(E, L) and their mirror images in the plane of incidence), the truth for an
    /// isotropic model or table.
    #[arg(long, requires = "nbrdf")]
    pub(crate) symmetric: bool,
    /// Sampling: hemisphere:N (N seeded random directions), plane:θ1,θ2,… (degrees),
    /// goniometer (θi 10–80° step 10, θo 0–85° step 1, φo every 15°) or merl (the cells of a
    /// 90×90×180 MERL table; write it with an output ending in .binary), or a CSV file whose
    /// angle columns list the configurations (a plan of `brdfit plan`).
    #[arg(long, default_value = "hemisphere:10000")]
    pub(crate) grid: String,
    /// Relative noise σ: each value is multiplied by (1 + σ ε), ε ~ N(0, 1).
    #[arg(long, default_value_t = 0.0)]
    pub(crate) noise: f64,
    /// Seed of the random stream (directions and noise).
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Output: a CSV, or a MERL .binary (by the extension).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
}

/// `brdfit simulate` (see its help).
pub(crate) fn run_simulate(args: SimulateArgs) -> Result<()> {
    // A file's configurations (a plan), else a named grid.
    let listed = Path::new(&args.grid);
    let g = if listed.is_file() || args.grid.ends_with(".csv") {
        refuse_input(&args.output, &[listed])?;
        let d = data::load_directions(listed)?;
        Grid::Listed((0..d.len()).map(|k| d.angles(k)).collect())
    } else {
        Grid::parse(&args.grid).map_err(|e| anyhow!("--grid {e}"))?
    };
    let grid = &args.grid;
    let (noise, seed) = (args.noise, args.seed);
    if !(noise.is_finite() && noise >= 0.0) {
        bail!("--noise {noise} must be a finite number ≥ 0\n  fix: e.g. --noise 0.01 for 1 %");
    }
    let output = &args.output;
    let binary = output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("binary"));
    let mut ds = if let Some(file) = &args.nbrdf {
        if noise != 0.0 {
            bail!(
                "--noise {noise} with --nbrdf: a network is sampled without noise\n  fix: drop --noise"
            );
        }
        let name = args.material.as_deref().unwrap_or_default();
        let net = brdfit::data::nbrdf::Nbrdf::load(file, name)?;
        refuse_input(output, &[file])?;
        let mut ds = brdfit::simulate::simulate_nbrdf(&net, &g.directions(seed), args.symmetric);
        ds.meta.comments = vec![
            format!(
                "generated by: brdfit simulate --nbrdf {} --material {}{} --grid {grid}",
                file.display(),
                net.name,
                if args.symmetric { " --symmetric" } else { "" }
            ),
            format!(
                "NBRDF network evaluation (NOT raw measurement): {}{}",
                net.name,
                if args.symmetric {
                    ", symmetrised: mean of f(L,E), f(E,L) and their mirror images in the plane of incidence"
                } else {
                    ""
                }
            ),
            "weights: asztr/Neural-BRDF (MIT; Sztrajman et al. 2021); underlying data: MERL/RGL".into(),
            "angles in degrees; f_r in 1/sr per RGB channel; mirror direction is phi_o = phi_i + 180".into(),
        ];
        ds
    } else {
        let model = ModelArgs {
            model: args.model.expect("clap requires --model without --nbrdf"),
            distribution: args.distribution,
            set: args.set.clone(),
            fast_pow: args.fast_pow,
        };
        let m = model.build()?;
        let mut ds = simulate(&m, &g.directions(seed), noise, seed);
        refuse_overflow(&ds, &m)?;
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
        ds
    };
    if binary {
        ds.meta.source = "brdfit simulate".into();
        data::merl::write_merl(&ds, output)?;
    } else {
        data::write_csv(&ds, output)?;
    }
    wrote(output);
    Ok(())
}

/// Arguments of `brdfit export`.
#[derive(Args, Debug)]
pub(crate) struct ExportArgs {
    /// The fit JSON (from brdfit fit --json or brdfit report).
    pub(crate) fit: PathBuf,
    /// Target: mitsuba (BSDF XML), pbrt (pbrt-v4 material), brdf-explorer (.brdf analytic),
    /// merl (.binary table), csv (the model on a 5°/15° grid).
    #[arg(long, value_enum)]
    pub(crate) to: brdfit::export::ExportFormat,
    /// Output file (text formats go to standard output when omitted).
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) pick: PickArgs,
    /// The channel to export from a fit file of several (default: all of an RGB file as
    /// colour; the recommended channel otherwise).
    #[arg(long)]
    pub(crate) channel: Option<String>,
}

/// `--channel C` for one of `picked`'s channels, as the fix of a command that takes one: g of
/// RGB, else the middle one (550nm of 400–700nm), with the list.
fn channel_example(picked: &brdfit::fit::Picked) -> String {
    let names: Vec<&str> = picked.channels.iter().map(|c| c.channel.as_str()).collect();
    let one = if names.contains(&"g") {
        "g"
    } else {
        names.get(names.len() / 2).copied().unwrap_or("")
    };
    format!(
        "--channel {one} (the file's channels: {})",
        names.join(", ")
    )
}

/// `brdfit export` (see its help).
pub(crate) fn run_export(args: ExportArgs) -> Result<()> {
    let ExportArgs {
        fit,
        to,
        output,
        pick,
        channel,
    } = args;
    use brdfit::export::{self, ExportFormat};
    use clap::ValueEnum;
    let fmt = to;
    let to = to
        .to_possible_value()
        .map_or(String::new(), |v| v.get_name().to_string());
    let picked = pick_fits(&fit, &pick.want(channel.as_deref()))?;
    let c = picked
        .colour()
        .map_err(|e| anyhow!("{}: {e}", fit.display()))?;
    if !quiet() {
        for n in &c.notes {
            eprintln!("note: {}: {n}", fit.display());
        }
    }
    let id = fit
        .file_stem()
        .map_or("brdfit".into(), |s| s.to_string_lossy().into_owned());
    let fail = |e: String| anyhow!("{}: {e}", fit.display());
    let text = match fmt {
        ExportFormat::Mitsuba => Some(export::mitsuba(&c, &id).map_err(fail)?),
        ExportFormat::Pbrt => Some(export::pbrt(&c)),
        ExportFormat::BrdfExplorer => Some(
            export::brdf_explorer(&c)
                .map_err(|e| fail(e.replace("--channel NAME", &channel_example(&picked))))?,
        ),
        ExportFormat::Merl | ExportFormat::Csv | ExportFormat::RglBsdf => None,
    };
    // The refit's error is a note, or a warning (even with --quiet) where it is not faithful.
    if let Some(t) = &text
        && let Some(line) = t.lines().find(|l| l.trim_start().starts_with("refitted:"))
    {
        match line.split_once(" warning: ") {
            Some((_, w)) => eprintln!("warning: {}: {w}", fit.display()),
            None if !quiet() => eprintln!("note: {}: {}", fit.display(), line.trim()),
            None => {}
        }
    }
    match (text, output) {
        (Some(t), None) => print(&t),
        (Some(t), Some(o)) => {
            refuse_input(&o, &[&fit])?;
            write_file(&o, t.as_bytes())?;
            Ok(())
        }
        (None, None) => bail!("--to {to} writes a file\n  fix: add -o OUT"),
        (None, Some(o)) => {
            refuse_input(&o, &[&fit])?;
            if fmt == ExportFormat::RglBsdf {
                return write_file(&o, &export::rgl_bsdf(&c));
            }
            if fmt == ExportFormat::Merl {
                data::merl::write_merl(&export::merl_dataset(&c), &o)?;
            } else {
                data::write_csv(&export::grid_dataset(&c), &o)?;
            }
            wrote(&o);
            Ok(())
        }
    }
}

/// Arguments of `brdfit convert`.
#[derive(Args, Debug)]
pub(crate) struct ConvertArgs {
    /// Input data file.
    pub(crate) input: PathBuf,
    /// Output file; `.binary` writes MERL, anything else brdfit CSV.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Output format (csv or merl), overriding the output's extension.
    #[arg(long)]
    pub(crate) to: Option<String>,
    #[command(flatten)]
    pub(crate) load: LoadArgs,
}

/// `brdfit convert` (see its help).
pub(crate) fn run_convert(args: ConvertArgs) -> Result<()> {
    let ConvertArgs {
        input,
        output,
        to,
        load,
    } = args;
    refuse_input(&output, &[&input])?;
    let ds = load.load(&input)?;
    let to_merl = match to.as_deref() {
        Some("merl") => true,
        Some("csv") => false,
        Some(t) => bail!("unknown output format '{t}'\n  fix: use --to csv or --to merl"),
        None => Format::from_extension(&output) == Some(Format::Merl),
    };
    if to_merl {
        data::merl::write_merl(&ds, &output)?;
    } else {
        data::write_csv(&ds, &output)?;
    }
    wrote(&output);
    if to_merl && let Ok(cells) = data::merl::tabulate(&ds) {
        // A goniometer's samples fill a sliver of MERL's cells: say so.
        let filled = cells.iter().filter(|c| c.iter().any(|&v| v >= 0.0)).count();
        if filled * 2 < cells.len() {
            eprintln!(
                "warning: the samples fill {filled} of the table's {} cells ({} %); the others \
                 hold -1, which MERL readers take as missing (a renderer reads them as black)\n  \
                 fix: to render the material, fit a model and export it (fit --json, then \
                 export --to merl), which fills every cell",
                cells.len(),
                brdfit::model::significant(100.0 * filled as f64 / cells.len() as f64, 2)
            );
        }
    }
    Ok(())
}

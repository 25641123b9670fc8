//! Arguments shared by several commands: loading, models, fitting.

use anyhow::{Result, anyhow, bail};
use brdfit::data::{self, ChannelSelect, Dataset, Format, LoadOptions, NegativePolicy};
use brdfit::model::{Distribution, Model, ModelKind};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub(crate) struct OptModelArgs {
    /// A model (instead of or besides a fit).
    #[arg(long, value_enum)]
    pub(crate) model: Option<ModelKind>,
    /// Facet distribution of models that take one (torrance-sparrow).
    #[arg(long, value_enum, default_value = "d3")]
    pub(crate) distribution: Distribution,
    /// Parameters NAME=VALUE.
    #[arg(long = "set", value_delimiter = ',')]
    pub(crate) set: Vec<String>,
}

impl OptModelArgs {
    pub(crate) fn build(&self) -> Result<Option<Model>> {
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

#[derive(Args, Debug, Clone)]
pub(crate) struct FitArgs {
    /// The data file(s); several files are fitted in parallel (see --jobs, --summary).
    #[arg(required = true)]
    pub(crate) files: Vec<PathBuf>,
    /// The files are measurements of one material: merge them (samples at the same angles
    /// averaged, the same channels required) and fit once, instead of fitting each.
    #[arg(long)]
    pub(crate) merge: bool,
    /// Files fitted at once in a batch (1–64).
    #[arg(long, short = 'j', default_value_t = 2, value_parser = clap::value_parser!(u16).range(1..=64))]
    pub(crate) jobs: u16,
    /// Batch summary: one row per file, channel and model (CSV, or JSON when FILE ends in .json).
    #[arg(long, value_name = "FILE")]
    pub(crate) summary: Option<PathBuf>,
    /// Model, or all (every model, ranked by BIC).
    #[arg(long, default_value = "torrance-sparrow", value_parser = model_or_all())]
    pub(crate) model: String,
    /// Facet distribution of models that take one (torrance-sparrow): d1 (cosine power), d2
    /// (Gaussian), d3 (Trowbridge–Reitz), abc (Löw et al. 2012).
    #[arg(long, value_enum, default_value = "d3")]
    pub(crate) distribution: Distribution,
    /// Local method: brdfit's lm (Levenberg–Marquardt), gn (Gauss–Newton with line search) or
    /// nm (Nelder–Mead), or one of argmin's solvers run on the same problem, for comparison
    /// (bounds are brdfit's: argmin's own solvers are unconstrained).
    #[arg(long, value_enum, default_value = "lm")]
    pub(crate) method: brdfit::fit::lsq::Method,
    /// Loss: log (ln(1 + cosθi f) differences) or linear (f differences).
    #[arg(long, value_enum, default_value = "log")]
    pub(crate) loss: brdfit::fit::problem::Loss,
    /// Robust loss on top of it.
    #[arg(long, value_enum)]
    pub(crate) robust: Option<brdfit::fit::RobustKind>,
    /// Drop samples with θi or θo beyond this angle (degrees).
    #[arg(long, value_name = "DEG", value_parser = parse_max_theta)]
    pub(crate) max_theta: Option<f64>,
    /// Each sample's weight in the loss: file (the file's weights column, or 1) or solid-angle
    /// (that times the solid angle of the sample's cell on the data's own grid, so that a
    /// goniometer's dense θo axis and its samples near the pole do not outweigh the rest).
    #[arg(long, value_enum, default_value = "file")]
    pub(crate) weights: brdfit::fit::Weighting,
    /// Hold parameters fixed, NAME=VALUE (repeat or separate with commas).
    #[arg(long, value_delimiter = ',')]
    pub(crate) fix: Vec<String>,
    /// Start point NAME=VALUE (one more candidate after the global initialisation).
    #[arg(long, value_delimiter = ',')]
    pub(crate) start: Vec<String>,
    /// Fit these parameters jointly across channels (the others per channel), e.g. n,c3.
    #[arg(long, value_delimiter = ',')]
    pub(crate) shared: Vec<String>,
    /// Skip the global initialisation (local method from --start or the default start only).
    #[arg(long)]
    pub(crate) local_only: bool,
    /// Where the final refinement on all samples stops (--method lm, the default, only): once
    /// its last three steps together lowered the cost by less than F times the rise that one
    /// standard error brings, so that the parameters end within about √F standard errors of the
    /// minimum. 0 runs it on to a relative cost change of 1e-14, for comparisons with other
    /// fitters to the last digits.
    #[arg(long, value_name = "F", default_value = "1e-6", value_parser = parse_resolution, allow_negative_numbers = true)]
    pub(crate) resolution: f64,
    /// Certificate: after the fit, refine K seeded random starts and report whether any ended
    /// lower (JSON `verified`, `verify_best_cost`); a fit one of them beats is marked not usable.
    #[arg(long, value_name = "K", default_value_t = 0, value_parser = parse_verify)]
    pub(crate) verify: usize,
    /// Seed of the --verify starts.
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub(crate) verify_seed: u64,
    /// Phong only: fast power approximation with γ = 2^K.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(0..=30))]
    pub(crate) fast_pow: Option<u32>,
    /// Benchmarking: run each fit N times in this process and report the median time in
    /// `seconds` and `geometry_seconds` (the results are identical every time; the peer scripts
    /// time the same way).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub(crate) repeat: u32,
    /// Write the fit(s) as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub(crate) json: Option<PathBuf>,
    /// Write every sample each fit used to this CSV: its angles, channel, measured and model
    /// f_r, residual in the fit's loss and weight (with a `model` column for several models).
    #[arg(long, value_name = "FILE")]
    pub(crate) residuals: Option<PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub(crate) struct LoadArgs {
    /// Input format (csv, astm, cornell, merl) instead of detecting it from extension and content.
    #[arg(long, value_enum)]
    pub(crate) format: Option<Format>,
    /// What to do with negative values: mask (treat as missing), clamp (to 0) or error.
    #[arg(long, value_enum, default_value = "mask")]
    pub(crate) negative: NegativePolicy,
    /// Reduce to one channel: a name (r, g, b, 550nm), an index, a wavelength (555nm,
    /// interpolated) or cie-y (CIE 1931 luminance of spectral data).
    #[arg(long)]
    pub(crate) channel: Option<String>,
    /// Take the angle columns' declared units as they are: silences the warning for a `_deg`
    /// file whose every θ lies within [0, π/2] and φ within [−2π, 2π] (radians under `_deg`).
    #[arg(long)]
    pub(crate) trust_units: bool,
}

/// Which fit of a fit file a consumer uses (`export`, `plot residuals|slice`, `inverse`,
/// `render fig7`).
#[derive(Args, Debug, Clone, Default)]
pub(crate) struct PickArgs {
    /// The model to take from the fit file (default: its only model, or the recommended one of
    /// a `fit --model all` file).
    #[arg(long, value_enum)]
    pub(crate) model: Option<ModelKind>,
    /// Facet distribution of that model (default: d3 where the file holds several).
    #[arg(long, value_enum)]
    pub(crate) distribution: Option<Distribution>,
    /// Use a fit marked not usable (failed verification, KKT check, pd > 1, …) anyway.
    #[arg(long)]
    pub(crate) allow_unusable: bool,
}

impl PickArgs {
    /// What to ask of the fit file, with the channel from the command's `--channel`.
    pub(crate) fn want(&self, channel: Option<&str>) -> brdfit::fit::Want {
        brdfit::fit::Want {
            model: self.model,
            dist: self.distribution,
            channel: channel.map(str::to_string),
            allow_unusable: self.allow_unusable,
        }
    }
}

#[derive(Args, Debug, Clone)]
pub(crate) struct ModelArgs {
    /// Model.
    #[arg(long, value_enum)]
    pub(crate) model: ModelKind,
    /// Facet distribution of models that take one (torrance-sparrow): d1 (cosine power), d2
    /// (Gaussian), d3 (Trowbridge–Reitz), abc (Löw et al. 2012).
    #[arg(long, value_enum, default_value = "d3")]
    pub(crate) distribution: Distribution,
    /// Parameter values NAME=VALUE (repeat or separate with commas), e.g. n=1.8,c3=0.35,ps=0.667,pd=0.333.
    #[arg(long = "set", value_delimiter = ',')]
    pub(crate) set: Vec<String>,
    /// Phong only: use the fast power approximation (1 − βλ)^γ with γ = 2^K.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(0..=30))]
    pub(crate) fast_pow: Option<u32>,
}

impl ModelArgs {
    pub(crate) fn build(&self) -> Result<Model> {
        let (kind, dist) = (self.model, self.distribution);
        let set = parse_assignments("--set", &self.set)?;
        let mut m = Model::from_named(kind, dist, &set)?;
        m.fast_pow = self.fast_pow;
        Ok(m)
    }
}

/// `--resolution F`: a fraction, 0 ≤ F ≤ 1.
fn parse_resolution(s: &str) -> std::result::Result<f64, String> {
    let why = match s.trim().parse::<f64>() {
        Ok(f) if (0.0..=1.0).contains(&f) => return Ok(f),
        Ok(_) => format!("{s} is not a fraction from 0 to 1"),
        Err(_) => format!("'{s}' is not a number"),
    };
    Err(format!(
        "{why}\n  fix: e.g. --resolution 1e-6 (the default), or 0 to polish to the last digits"
    ))
}

/// Most random starts `--verify` takes: each is a full local fit, so 1,000 take about as
/// long as 1,000 fits.
pub(crate) const MAX_VERIFY: usize = 1000;

/// `--verify K`: a count from 0 to [`MAX_VERIFY`].
pub(crate) fn parse_verify(s: &str) -> std::result::Result<usize, String> {
    match s.trim().parse::<u64>() {
        Ok(k) if k <= MAX_VERIFY as u64 => Ok(k as usize),
        Ok(_) => Err(format!(
            "{s} random starts is above the limit of {MAX_VERIFY}\n  fix: give --verify K with K from 0 to {MAX_VERIFY} (e.g. 64)"
        )),
        Err(_) => Err(format!(
            "'{s}' is not a count\n  fix: give --verify K with K from 0 to {MAX_VERIFY} (e.g. 64)"
        )),
    }
}

/// `--max-theta DEG`: an angle in degrees, 0 < DEG ≤ 90 (NaN and infinities are refused).
fn parse_max_theta(s: &str) -> std::result::Result<f64, String> {
    let why = match s.trim().parse::<f64>() {
        Ok(d) if d > 0.0 && d <= 90.0 => return Ok(d),
        Ok(_) => format!("{s} is not an angle above 0° and at most 90°"),
        Err(_) => format!("'{s}' is not a number"),
    };
    Err(format!("{why}\n  fix: e.g. --max-theta 80"))
}

/// Parse `NAME=VALUE` items of a flag.
/// A name given twice is refused (the last one used to win silently).
pub(crate) fn parse_assignments(flag: &str, items: &[String]) -> Result<Vec<(String, f64)>> {
    let mut out: Vec<(String, f64)> = Vec::with_capacity(items.len());
    for kv in items {
        let (k, v) = kv.split_once('=').ok_or_else(|| {
            anyhow!("{flag} '{kv}' is not NAME=VALUE\n  fix: write e.g. {flag} c3=0.35")
        })?;
        let v: f64 = v.trim().parse().map_err(|_| {
            anyhow!("{flag} {kv}: '{v}' is not a number\n  fix: write e.g. {flag} c3=0.35")
        })?;
        let k = k.trim().to_string();
        if let Some((_, first)) = out.iter().find(|(name, _)| *name == k) {
            bail!(
                "{flag} gives {k} twice ({k}={first} and {k}={v})\n  fix: give each parameter once"
            );
        }
        out.push((k, v));
    }
    Ok(out)
}

impl LoadArgs {
    pub(crate) fn load(&self, path: &Path) -> Result<Dataset> {
        let (format, negative) = (self.format, self.negative);
        let ds = data::load(path, &LoadOptions { format, negative })?;
        if !self.trust_units {
            for w in &ds.meta.warnings {
                eprintln!("warning: {}", super::printable(w));
            }
        }
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

/// `--model` of `fit`: a model's name (or alias) or `all`; clap rejects anything else with a
/// suggestion and exit code 2.
pub(crate) fn model_or_all() -> clap::builder::PossibleValuesParser {
    use clap::ValueEnum;
    clap::builder::PossibleValuesParser::new(
        ModelKind::value_variants()
            .iter()
            .filter_map(|k| k.to_possible_value())
            .chain([clap::builder::PossibleValue::new("all")]),
    )
}

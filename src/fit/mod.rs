//! Fitting reflection models to samples by nonlinear least squares.
//!
//! The pipeline for one data set (and one channel, or several with `shared` parameters),
//! [`fit`] here calling one file a stage, in order:
//! 1. `setup`: samples are converted to f_r and filtered (finite values, `max_theta`); the
//!    geometry of each sample is computed once ([`problem::Rows`]); the solver variables are
//!    laid out and the data checked;
//! 2. `init`: **global initialisation** (variable projection): the linear parameters (each
//!    lobe's ps, and pd) enter the model linearly, so a grid over the nonlinear parameters with
//!    a weighted non-negative linear solve at each point finds the basin; on a subsample;
//! 3. `solve`: the local method (Levenberg–Marquardt by default) from the best grid points and
//!    the user's `start`, first on a subsample of at most 2,000 rows per channel, then on all
//!    rows;
//! 4. `checks`: first-order conditions, absurd values, random-start verification (and
//!    [`physical`]: only physical fits in use);
//! 5. `stats`: statistics in natural parameters from JᵀJ at the solution: standard errors,
//!    correlations, and honest warnings (with a profiled range) for parameters the data do not
//!    determine;
//! 6. `format`: ranking by BIC and the terminal tables.

mod argmin_peer;
mod checks;
mod dispatch;
mod fitfile;
mod format;
mod init;
mod json;
pub mod physical;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod lsq;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod problem;
mod setup;
mod solve;
mod stats;

use crate::data::Dataset;
use crate::lanes::{self, LANES};
use crate::model::Geometry;
use crate::model::{Distribution, Model, ModelKind, ParamSpec, Role, Scale, readable};
use crate::setting::Setting;
pub use fitfile::{
    Colour, FitFileError, Picked, PickedChannel, Want, is_unnamed_channel, parse_strict, pick,
    pick_one, read_fit_file, same_channel,
};
pub use lsq::{Limits, Method};
use lsq::{Problem, Robust, Solution};
pub use problem::Loss;
use problem::{BrdfProblem, RowWriter, Rows, Slot, Transform};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use checks::certify;
pub use format::{
    all_models, format_channels, format_fit, format_ranking, format_ranking_line, rank,
};
pub use setup::solid_angle_weights;
use setup::{ChannelRows, channel_rows, check_data, layout, problem};
use solve::search;
pub use solve::{RESOLUTION, random_start};
pub use stats::describe_range;
use stats::{reported, uncertainty};

/// A fit that cannot be run, with the fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}\n  fix: {fix}")]
pub struct FitError {
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub fix: String,
    /// The setting that fix changes, if it is one.
    pub setting: Option<Setting>,
}

fn fit_error(message: impl Into<String>, fix: impl Into<String>) -> FitError {
    FitError {
        message: message.into(),
        fix: fix.into(),
        setting: None,
    }
}

impl FitError {
    /// The same error, naming the setting its fix changes.
    fn with(mut self, s: Setting) -> Self {
        self.setting = Some(s);
        self
    }
}

/// Robust loss choice (the threshold is set from the residuals, see [`FitOptions::robust`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RobustKind {
    /// Huber.
    Huber,
    /// Cauchy.
    Cauchy,
}

/// How each sample is weighted in the loss (`weights` in the fit JSON).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Weighting {
    /// The file's weights column, or every sample 1 (default).
    #[default]
    File,
    /// The file's weights times each sample's solid angle on the data's own grid (see
    /// solid_angle_weights): the loss approximates an integral over (θi, θo, |φo − φi|).
    SolidAngle,
}

/// Options of a fit; [`FitOptions::new`] gives the defaults.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Model to fit.
    pub kind: ModelKind,
    /// Facet distribution for torrance-sparrow.
    pub dist: Distribution,
    /// Local method.
    pub method: Method,
    /// Loss.
    pub loss: Loss,
    /// Optional robust loss; its threshold is 1.345 × 1.4826 × the median |residual| at the
    /// best start (Huber's 95 %-efficiency constant on a MAD scale).
    pub robust: Option<RobustKind>,
    /// Drop samples with θi or θo beyond this (degrees).
    pub max_theta_deg: Option<f64>,
    /// Each sample's weight in the loss (default: the file's weights column, if any).
    pub weights: Weighting,
    /// Parameters held fixed.
    pub fix: Vec<(String, f64)>,
    /// A start point (one more candidate; the only one with `local_only`).
    pub start: Vec<(String, f64)>,
    /// Parameters shared across channels (the others are per channel); empty = each channel
    /// fitted on its own.
    pub shared: Vec<String>,
    /// Skip the global initialisation.
    pub local_only: bool,
    /// Phong fast power (γ = 2^k).
    pub fast_pow: Option<u32>,
    /// Solver limits.
    pub limits: Limits,
    /// Where the polish on every row stops: once its last steps lowered the cost by less than
    /// this fraction of the rise one standard error brings (see [`RESOLUTION`]); 0 runs it to
    /// `limits.ftol`.
    pub resolution: f64,
    /// Profile undetermined parameters to report the range that fits.
    pub profile: bool,
    /// Random local starts run after the fit as a certificate (0 = none); see [`Verification`].
    pub verify: usize,
    /// Seed of the verification starts.
    pub seed: u64,
    /// Counts the fit's passes over the data as they start (every solver's, the statistics'
    /// too), for a progress display to read while a long fit goes on.
    pub watch: Option<Watch>,
}

impl FitOptions {
    /// Defaults: LM, log loss, global initialisation on, D3.
    pub fn new(kind: ModelKind) -> Self {
        FitOptions {
            kind,
            dist: Distribution::D3,
            method: Method::Lm,
            loss: Loss::Log,
            robust: None,
            max_theta_deg: None,
            weights: Weighting::File,
            fix: vec![],
            start: vec![],
            shared: vec![],
            local_only: false,
            fast_pow: None,
            limits: Limits::default(),
            resolution: RESOLUTION,
            profile: true,
            verify: 0,
            seed: 1,
            watch: None,
        }
    }
}

/// The outcome of `--verify K`: K seeded random starts, each refined by the local method (on
/// the same subsample as the pipeline's candidates, the best one then on every sample).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Verification {
    /// Number of random starts.
    #[serde(rename = "verify_starts")]
    pub starts: usize,
    /// The lowest cost any of them reached (on every sample), in the loss the fit minimised:
    /// with a robust loss Σ ρ(r), not the declared ½ Σ r² of `cost`.
    #[serde(rename = "verify_best_cost")]
    pub best_cost: f64,
    /// The robust loss `best_cost` is measured in (`huber`, `cauchy`), or empty.
    #[serde(
        rename = "verify_loss",
        default,
        skip_serializing_if = "String::is_empty"
    )]
    pub robust: String,
    /// True when none ended lower than the fit (by more than 1e-6 relative).
    pub verified: bool,
}

/// Relative cost difference below which two fits count as the same minimum.
pub const SAME_MINIMUM: f64 = 1e-6;

/// Largest scaled projected gradient accepted as a first-order (KKT) point: for each free
/// parameter |∂cost/∂u| / (‖∂r/∂u‖ ‖r‖), with only the inward part counted at a bound.
pub const KKT_TOLERANCE: f64 = 1e-3;

/// The outcome of one fit (one channel, or a joint fit of several); its JSON form (serde) is
/// the fit JSON the README documents.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitResult {
    /// Model fitted.
    pub model: ModelKind,
    /// Facet distribution (of models that take one; `d3` otherwise).
    #[serde(rename = "distribution")]
    pub dist: Distribution,
    /// Loss.
    pub loss: Loss,
    /// Method.
    pub method: Method,
    /// Channel name(s).
    pub channel: String,
    /// Parameter names and values, model order (per-channel names carry `_<channel>`).
    #[serde(with = "json::pairs")]
    pub params: Vec<(String, f64)>,
    /// Standard errors in `params` order (0 for fixed parameters).
    #[serde(with = "json::floats")]
    pub stderr: Vec<f64>,
    /// Correlation matrix in `params` order.
    #[serde(default, with = "json::matrix")]
    pub correlation: Vec<Vec<f64>>,
    /// Which parameters were free.
    #[serde(default)]
    pub free: Vec<bool>,
    /// How the samples were weighted (`--weights`: `file`, the file's weight column or 1;
    /// `solid-angle`, that times each sample's solid angle). Fit files of earlier versions,
    /// which do not say, read as `file`.
    #[serde(default)]
    pub weights: Weighting,
    /// True when the samples' weights were not all 1 (a weight column, or `solid-angle`):
    /// `cost` and `rmse` are then the weighted ones.
    #[serde(default)]
    pub weighted: bool,
    /// ½ Σ w r² with the declared loss at the returned parameters, on the samples used (w = 1
    /// unless `weighted`).
    pub cost: f64,
    /// √(2 cost / samples_used) (weighted when `weighted`).
    pub rmse: f64,
    /// Rows used (samples × channels).
    pub samples_used: usize,
    /// Iterations of the local method, all stages.
    #[serde(default)]
    pub iterations: usize,
    /// Cost and Jacobian evaluations, all stages.
    #[serde(default)]
    pub evaluations: usize,
    /// Why the final stage stopped.
    #[serde(default)]
    pub termination: String,
    /// Wall time of the fit: geometry pass, solve and statistics (no file reading):
    /// `geometry_seconds` + `solve_seconds` + `statistics_seconds`.
    #[serde(default)]
    pub seconds: f64,
    /// The part of `seconds` spent on the per-sample geometry pass (N·L, N·H, E·H, G and the
    /// targets), which depends on no parameter and is done once per fit.
    #[serde(default)]
    pub geometry_seconds: f64,
    /// The part of `seconds` that reaches the minimum: the problem set up from the geometry,
    /// the global initialisation, the candidates' local fits and the polish on every row (the
    /// work scipy's `least_squares` clock covers).
    #[serde(default)]
    pub solve_seconds: f64,
    /// The part of `seconds` after the minimum is reached: the checks at return (first-order
    /// conditions, `--verify`'s random starts), standard errors, correlations, the 1 %
    /// ranges (profiled refits where the quadratic model does not hold) and the physical
    /// check (pd, directional albedo, index; [`physical`]).
    #[serde(default)]
    pub statistics_seconds: f64,
    /// Honest warnings: undetermined parameters with the range that fits, limits reached.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// Bayesian information criterion m ln(2 cost/m) + k ln m.
    pub bic: f64,
    /// Akaike information criterion m ln(2 cost/m) + 2k.
    pub aic: f64,
    /// Number of free parameters.
    pub n_free: usize,
    /// Profiled ranges of the nonlinear parameters: values within 1 % of the minimum cost
    /// (upper bound ∞ when the range is open).
    #[serde(default, with = "json::ranges")]
    pub ranges: Vec<(String, f64, f64)>,
    /// Parameters that ended on a bound of their admissible range, with the side (`lower` or
    /// `upper`).
    #[serde(with = "json::pairs")]
    #[serde(default)]
    pub at_bound: Vec<(String, String)>,
    /// First-order optimality at the returned point: the largest scaled projected gradient
    /// over the free parameters (see [`KKT_TOLERANCE`]).
    #[serde(default, with = "json::float")]
    pub kkt_violation: f64,
    /// The random-start certificate, when one was run (its keys `verified`, `verify_starts`,
    /// `verify_best_cost` sit in the fit's object).
    #[serde(flatten)]
    pub verification: Option<Verification>,
    /// Why the fit is not usable as a result; empty when it is.
    #[serde(default)]
    pub unusable: Vec<String>,
}

impl FitResult {
    /// True when nothing marks the fit as not usable (verification, KKT, absurd values).
    pub fn usable(&self) -> bool {
        self.unusable.is_empty()
    }

    /// Fitted model of channel `c` (for a single-channel fit, `c = 0`).
    pub fn model_for(&self, c: usize) -> Model {
        let names = self.model.param_names(self.dist);
        let chans: Vec<&str> = self.channel.split(',').collect();
        let suffix = if chans.len() > 1 {
            format!("_{}", chans[c.min(chans.len() - 1)])
        } else {
            String::new()
        };
        let vals: Vec<f64> = names
            .iter()
            .map(|n| {
                self.params
                    .iter()
                    .find(|(k, _)| *k == *n || *k == format!("{n}{suffix}"))
                    .map(|(_, v)| *v)
                    .unwrap_or(0.0)
            })
            .collect();
        let mut m = Model {
            kind: self.model,
            dist: self.dist,
            p: [0.0; crate::model::MAX_PARAMS],
            fast_pow: None,
        };
        m.p[..vals.len()].copy_from_slice(&vals);
        m
    }

    /// Short flags: `unconverged` for a fit whose solver stopped at a limit before converging
    /// (its warning says which), `bound:NAME` for a parameter on a bound, `weak:NAME` for one
    /// the data determine only weakly (its range within 1 % of the minimum cost is wide).
    pub fn flags(&self) -> Vec<String> {
        let mut flags = Vec::new();
        if self.warnings.iter().any(|w| w.starts_with(UNCONVERGED)) {
            flags.push("unconverged".to_string());
        }
        flags.extend(self.at_bound.iter().map(|(n, _)| format!("bound:{n}")));
        flags.extend(
            self.ranges
                .iter()
                .filter(|r| {
                    self.warnings
                        .iter()
                        .any(|w| w.starts_with(&format!("{} ", r.0)))
                })
                .map(|r| format!("weak:{}", r.0)),
        );
        flags
    }

    /// Value of parameter `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.params.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }

    /// Model label, e.g. `torrance-sparrow (d3)`.
    pub fn label(&self) -> String {
        self.model.label(self.dist)
    }

    /// The JSON object of the fit (schema in the README).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("a fit serialises")
    }

    /// Read a fit back from its JSON object, checked first: only known keys, a known model and
    /// distribution, and every parameter of the model present once, finite and within its
    /// declared bounds ([`ParamSpec::admits`]); the error names the key and the fix. The JSON
    /// of earlier versions (standard errors as an object, no certificate) is read as far as it
    /// goes. Duplicate keys are lost in a `Value`: read text with [`read_fit_file`].
    pub fn from_json(v: &serde_json::Value) -> Result<FitResult, FitFileError> {
        fitfile::check_fit_object(v)?;
        match serde_json::from_value::<FitResult>(v.clone()) {
            Ok(f) => Ok(f),
            Err(e) => Self::from_lenient_json(v).map_err(|m| FitFileError {
                message: format!("{m} ({e})"),
                fix: "give a file written by brdfit fit --json".into(),
            }),
        }
    }

    /// The reader of earlier versions' fit JSON: the model, its parameters and the figures;
    /// what it lacks is left empty.
    fn from_lenient_json(v: &serde_json::Value) -> Result<FitResult, String> {
        let s = |k: &str| v.get(k).and_then(|x| x.as_str()).map(str::to_string);
        let model = s("model")
            .and_then(|m| ModelKind::parse(&m))
            .ok_or("the fit JSON has no known 'model'")?;
        let dist = s("distribution")
            .and_then(|d| Distribution::parse(&d))
            .unwrap_or_default();
        let obj = v
            .get("params")
            .and_then(|p| p.as_object())
            .ok_or("the fit JSON has no 'params' object")?;
        let params: Vec<(String, f64)> = obj
            .iter()
            .map(|(k, x)| (k.clone(), x.as_f64().unwrap_or(f64::NAN)))
            .collect();
        if params.iter().any(|(_, x)| !x.is_finite()) {
            return Err("a parameter in the fit JSON is not a number".into());
        }
        let n = params.len();
        let f = |k: &str| v.get(k).and_then(|x| x.as_f64()).unwrap_or(f64::NAN);
        Ok(FitResult {
            model,
            dist,
            loss: s("loss").and_then(|l| Loss::parse(&l)).unwrap_or_default(),
            method: s("method")
                .and_then(|m| Method::parse(&m))
                .unwrap_or_default(),
            channel: s("channel").unwrap_or_default(),
            weights: Weighting::default(),
            weighted: v.get("weighted").and_then(|x| x.as_bool()).unwrap_or(false),
            stderr: vec![0.0; n],
            correlation: vec![],
            free: vec![true; n],
            params,
            cost: f("cost"),
            rmse: f("rmse"),
            samples_used: f("samples_used") as usize,
            iterations: 0,
            evaluations: 0,
            termination: s("termination").unwrap_or_default(),
            seconds: f("seconds"),
            geometry_seconds: f("geometry_seconds"),
            solve_seconds: f("solve_seconds"),
            statistics_seconds: f("statistics_seconds"),
            warnings: vec![],
            bic: f("bic"),
            aic: f("aic"),
            n_free: n,
            ranges: vec![],
            at_bound: v
                .get("at_bound")
                .and_then(|x| x.as_object())
                .map(|o| {
                    o.iter()
                        .map(|(k, x)| (k.clone(), x.as_str().unwrap_or("").to_string()))
                        .collect()
                })
                .unwrap_or_default(),
            kkt_violation: f("kkt_violation"),
            verification: v.get("verified").and_then(|x| x.as_bool()).map(|verified| {
                Verification {
                    starts: f("verify_starts") as usize,
                    best_cost: f("verify_best_cost"),
                    robust: v
                        .get("verify_loss")
                        .and_then(|x| x.as_str())
                        .unwrap_or("")
                        .to_string(),
                    verified,
                }
            }),
            unusable: v
                .get("unusable")
                .and_then(|x| x.as_array())
                .map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_str().map(str::to_string))
                        .collect()
                })
                .unwrap_or_default(),
        })
    }
}

/// Fit `opts.kind` to every channel of `ds` (or jointly with `opts.shared`).
pub fn fit(ds: &Dataset, opts: &FitOptions) -> Result<Vec<FitResult>, FitError> {
    // Each channel's geometry pass is timed with its fit. On a thread of rayon's pool (called
    // from outside it, the work is handed to the pool once): each parallel stage then wakes
    // the other core only, instead of putting this thread to sleep and waking it again.
    rayon::scope(|_| fit_with(ds, opts, |c| timed_rows(ds, c, opts), &|_, _| {}))
}

/// [`fit`] with each channel's rows (and their geometry seconds) from `timed`; `step(c, true)`
/// as the fit of channel `c` starts and `step(c, false)` as it ends (`None`: the joint fit of
/// every channel).
fn fit_with(
    ds: &Dataset,
    opts: &FitOptions,
    timed: impl Fn(usize) -> (ChannelRows, f64),
    step: &dyn Fn(Option<usize>, bool),
) -> Result<Vec<FitResult>, FitError> {
    let names = opts.kind.param_names(opts.dist);
    for (k, v) in opts.fix.iter().chain(&opts.start) {
        let Some(spec) = opts.kind.params(opts.dist).iter().find(|s| s.name == k) else {
            return Err(fit_error(
                format!("model {} has no parameter {k}", opts.kind),
                format!("its parameters are {}", names.join(", ")),
            ));
        };
        let bounds = spec.bounds_text();
        if !spec.admits(*v) {
            return Err(fit_error(
                format!("{k} = {v} is outside its bounds ({bounds})"),
                format!("choose a value with {bounds}"),
            ));
        }
    }
    for s in &opts.shared {
        if !names.contains(&s.as_str()) {
            return Err(fit_error(
                format!(
                    "shared parameter {s}: model {} has no parameter {s}",
                    opts.kind
                ),
                format!("its parameters are {}", names.join(", ")),
            ));
        }
    }
    if opts.shared.is_empty() || ds.channels.len() == 1 {
        (0..ds.channels.len())
            .map(|c| {
                step(Some(c), true);
                let (rows, t) = timed(c);
                let f = fit_group(vec![rows], opts, t);
                step(Some(c), false);
                f
            })
            .collect()
    } else {
        step(None, true);
        let (chans, times): (Vec<ChannelRows>, Vec<f64>) =
            (0..ds.channels.len()).map(timed).unzip();
        let f = fit_group(chans, opts, times.iter().sum());
        step(None, false);
        Ok(vec![f?])
    }
}

/// Channel `c`'s rows for `opts` and the seconds their geometry pass took.
fn timed_rows(ds: &Dataset, c: usize, opts: &FitOptions) -> (ChannelRows, f64) {
    let t = Instant::now();
    let rows = channel_rows(ds, c, opts);
    (rows, t.elapsed().as_secs_f64())
}

/// [`fit`] run `repeat` times in this process (for benchmarks): the results of the first run
/// with `seconds` and each stage's seconds the median of its own column over the runs
/// (every run gives the same parameters; only the clock differs).
pub fn fit_timed(
    ds: &Dataset,
    opts: &FitOptions,
    repeat: usize,
) -> Result<Vec<FitResult>, FitError> {
    let runs = (0..repeat.max(1))
        .map(|_| fit(ds, opts))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(median_times(runs))
}

/// The first of several runs of the same fits, with `seconds` and each stage's seconds the
/// median of its own column over the runs.
fn median_times(mut runs: Vec<Vec<FitResult>>) -> Vec<FitResult> {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let seconds: Vec<[f64; 4]> = (0..runs[0].len())
        .map(|i| {
            let col = |g: fn(&FitResult) -> f64| median(runs.iter().map(|r| g(&r[i])).collect());
            [
                col(|f| f.seconds),
                col(|f| f.geometry_seconds),
                col(|f| f.solve_seconds),
                col(|f| f.statistics_seconds),
            ]
        })
        .collect();
    let mut fits = runs.swap_remove(0);
    for (f, [s, g, v, t]) in fits.iter_mut().zip(seconds) {
        (f.seconds, f.geometry_seconds) = (s, g);
        (f.solve_seconds, f.statistics_seconds) = (v, t);
    }
    fits
}

/// Several fits of one dataset, e.g. `fit --model all`: each entry of `opts` as [`fit`] gives
/// it (the same results), with the models fitted in parallel and each channel's geometry
/// computed once for all the fits that share its loss, `--max-theta` and weighting (its time
/// is counted in each fit's `geometry_seconds`). Run `repeat` times (benchmarks), it returns
/// the first run's fits with their median times, as [`fit_timed`] does, and the median wall
/// time of one run of them all (geometry included). The first error in `opts` order, if any.
pub fn fit_models(
    ds: &Dataset,
    opts: &[FitOptions],
    repeat: usize,
) -> Result<(Vec<Vec<FitResult>>, f64), FitError> {
    fit_models_with_progress(ds, opts, repeat, &|_, _, _| {})
}

/// How often [`ticking`] reports a count while work goes on.
pub const TICK: std::time::Duration = std::time::Duration::from_millis(250);

/// A count of passes over the data, shared by the fits that add to it and the display that
/// reads it ([`FitOptions::watch`], [`ticking`]).
pub type Watch = std::sync::Arc<AtomicUsize>;

/// `what` and the passes over the data so far, as a progress message: `what · K evaluations in
/// all`, or the count alone where nothing is named.
pub fn with_count(what: &str, k: usize) -> String {
    if what.is_empty() {
        format!("{k} evaluations in all")
    } else {
        format!("{what} · {k} evaluations in all")
    }
}

/// Run `work`, calling `tick(count)` from another thread every [`TICK`] with `count`'s value
/// while it runs, once it is above 0 (a fit's passes over the data: [`FitOptions::watch`]).
/// The ticker stops as `work` ends, also by a panic.
pub fn ticking<T>(
    count: &AtomicUsize,
    tick: &(dyn Fn(usize) + Sync),
    work: impl FnOnce() -> T,
) -> T {
    /// Stops the ticker when dropped.
    struct Stop<'a>(&'a AtomicBool, std::thread::Thread);
    impl Drop for Stop<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Release);
            self.1.unpark();
        }
    }
    let done = AtomicBool::new(false);
    std::thread::scope(|s| {
        let ticker = s.spawn(|| {
            loop {
                std::thread::park_timeout(TICK);
                if done.load(Ordering::Acquire) {
                    break;
                }
                let k = count.load(Ordering::Relaxed);
                if k > 0 {
                    tick(k);
                }
            }
        });
        let _stop = Stop(&done, ticker.thread().clone());
        work()
    })
}

/// [`fit_models`], calling `progress(done, total, running)` as each channel's fit of a model
/// starts and ends: `done` of `total` units of work (each fit weighs `work_weight`, its
/// relative cost, so a bar's estimate of the time left holds while one dear fit runs for
/// seconds: a full MERL table's ggx-smith-2), `running` the fits under way, e.g.
/// `ggx-smith-2 (r), torrance-sparrow (abc) (g)`, and every [`TICK`] while fits run, with the
/// passes over the data so far (`… · 1234 evaluations in all`). The fits count in a watch of
/// their own: a `watch` set in `opts` is not used.
pub fn fit_models_with_progress(
    ds: &Dataset,
    opts: &[FitOptions],
    repeat: usize,
    progress: &(dyn Fn(u64, u64, &str) + Sync),
) -> Result<(Vec<Vec<FitResult>>, f64), FitError> {
    let nch = ds.channels.len() as u64;
    let total = repeat.max(1) as u64 * nch * opts.iter().map(work_weight).sum::<u64>();
    let done = std::sync::atomic::AtomicU64::new(0);
    let running: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    // The hook of one entry's fits (see `fit_with`): the fit named in `running` while it runs,
    // its weight added when it ends.
    let step = |o: &FitOptions, c: Option<usize>, started: bool| {
        let label = match c {
            Some(c) if nch > 1 => format!("{} ({})", o.kind.label(o.dist), ds.channel_label(c)),
            _ => o.kind.label(o.dist),
        };
        let mut run = running.lock().expect("no progress hook panics");
        let now = if started {
            run.push(label);
            done.load(std::sync::atomic::Ordering::Relaxed)
        } else {
            if let Some(at) = run.iter().position(|r| *r == label) {
                run.remove(at);
            }
            let units = work_weight(o) * if c.is_some() { 1 } else { nch };
            done.fetch_add(units, std::sync::atomic::Ordering::Relaxed) + units
        };
        progress(now, total, &run.join(", "));
    };
    // Every fit counts its passes over the data in one watch, shown beside the fits running
    // every [`TICK`]: the message moves while one dear fit runs for seconds.
    let watch = std::sync::Arc::new(AtomicUsize::new(0));
    let owned: Vec<FitOptions> = opts
        .iter()
        .map(|o| FitOptions {
            watch: Some(watch.clone()),
            ..o.clone()
        })
        .collect();
    let opts = &owned[..];
    let tick = |k: usize| {
        let run = running.lock().expect("no progress hook panics");
        let now = done.load(std::sync::atomic::Ordering::Relaxed);
        progress(now, total, &with_count(&run.join(", "), k));
    };
    let mut runs: Vec<Vec<Vec<FitResult>>> = vec![Vec::new(); opts.len()];
    let mut walls = Vec::new();
    ticking(&watch, &tick, || {
        fit_runs(ds, opts, repeat, &step, &mut runs, &mut walls)
    })?;
    walls.sort_by(f64::total_cmp);
    let fits = runs.into_iter().map(median_times).collect();
    Ok((fits, walls[walls.len() / 2]))
}

/// The runs of [`fit_models_with_progress`]: each run's fits appended to `runs` (one list per
/// entry of `opts`) and its wall time to `walls`; `step` as each channel's fit starts and ends.
fn fit_runs(
    ds: &Dataset,
    opts: &[FitOptions],
    repeat: usize,
    step: &(dyn Fn(&FitOptions, Option<usize>, bool) + Sync),
    runs: &mut [Vec<Vec<FitResult>>],
    walls: &mut Vec<f64>,
) -> Result<(), FitError> {
    let key = |o: &FitOptions| (o.loss, o.max_theta_deg.map(f64::to_bits), o.weights);
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        // Each distinct geometry once per channel: (its key, each channel's rows and time).
        // On a thread of rayon's pool, as in [`fit`]: each parallel stage of the geometry
        // pass then wakes the other core only, not this thread as well.
        let mut shared: Vec<(_, Vec<(ChannelRows, f64)>)> = rayon::scope(|_| {
            let mut shared: Vec<(_, Vec<(ChannelRows, f64)>)> = Vec::new();
            for o in opts {
                if !shared.iter().any(|(k, _)| *k == key(o)) {
                    let rows = (0..ds.channels.len())
                        .map(|c| timed_rows(ds, c, o))
                        .collect();
                    shared.push((key(o), rows));
                }
            }
            shared
        });
        // A geometry only one entry uses is moved into its fit, not copied (a million rows:
        // 56 MB copied and faulted in for nothing).
        let alone: Vec<std::sync::Mutex<Option<ChannelGeometries>>> = opts
            .iter()
            .map(|o| {
                let users = opts.iter().filter(|p| key(p) == key(o)).count();
                let rows = (users == 1).then(|| {
                    let at = shared.iter().position(|(k, _)| *k == key(o));
                    shared
                        .swap_remove(at.expect("every geometry computed above"))
                        .1
                });
                std::sync::Mutex::new(rows)
            })
            .collect();
        // Longest first, each model taken by the next free thread as it finishes one (a
        // FIFO scope: the calling thread runs the first, a thief takes the oldest left), so
        // no core idles at the end behind the dearest fit.
        let mut order: Vec<usize> = (0..opts.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(work_weight(&opts[i])));
        let slots: Vec<std::sync::Mutex<Option<FitsOrError>>> =
            opts.iter().map(|_| std::sync::Mutex::new(None)).collect();
        rayon::scope_fifo(|s| {
            for &i in &order {
                let (o, slot, shared, alone) = (&opts[i], &slots[i], &shared, &alone[i]);
                s.spawn_fifo(move |_| {
                    let own = alone.lock().expect("no fit panics").take();
                    let f = match own {
                        Some(rows) => {
                            // Each channel's rows are asked for once.
                            let rows: Vec<std::cell::Cell<Option<(ChannelRows, f64)>>> =
                                rows.into_iter().map(|r| Some(r).into()).collect();
                            fit_with(
                                ds,
                                o,
                                |c| rows[c].take().expect("each channel taken once"),
                                &|c, started| step(o, c, started),
                            )
                        }
                        None => {
                            let (_, rows) = shared
                                .iter()
                                .find(|(k, _)| *k == key(o))
                                .expect("every geometry computed above");
                            fit_with(ds, o, |c| rows[c].clone(), &|c, started| {
                                step(o, c, started)
                            })
                        }
                    };
                    *slot.lock().expect("no fit panics") = Some(f);
                });
            }
        });
        let fits: Vec<FitsOrError> = slots
            .into_iter()
            .map(|m| {
                m.into_inner()
                    .expect("no fit panics")
                    .expect("every fit ran")
            })
            .collect();
        walls.push(t.elapsed().as_secs_f64());
        for (run, f) in runs.iter_mut().zip(fits) {
            run.push(f?);
        }
    }
    Ok(())
}

/// Each channel's rows and the seconds of their geometry pass.
type ChannelGeometries = Vec<(ChannelRows, f64)>;

/// One entry's fits of [`fit_models`], or its error.
type FitsOrError = Result<Vec<FitResult>, FitError>;

/// The start of the warning of a fit whose solver stopped before converging (the flag
/// `unconverged` of [`FitResult::flags`]).
const UNCONVERGED: &str = "the solver stopped before converging";

/// The relative cost of a fit of `o` on real data, larger is dearer: [`fit_models`] starts
/// the dearest first and counts a fit's progress in these units. Seconds per channel of a full
/// MERL table (steel, 1,096,216 rows, `fit --model all`, the tenth round's binary: lambert
/// 0.18, phong 0.35, blinn-phong 0.31, Torrance–Sparrow d3 0.85, d2 1.3, d1 1.5, abc 2.1,
/// ggx-smith 0.78, ggx-smith-2 4.1–12.6) over lambert's, rounded, with the order measured on
/// MERL alumina-oxide's 16,512 rows where the two differ (phong and blinn-phong dearer than
/// d3 and ggx-smith there).
pub(crate) fn work_weight(o: &FitOptions) -> u64 {
    match (o.kind, o.dist) {
        (ModelKind::GgxSmith2, _) => 40,
        (ModelKind::TorranceSparrow, Distribution::Abc) => 12,
        (ModelKind::TorranceSparrow, Distribution::D1) => 8,
        (ModelKind::TorranceSparrow, Distribution::D2) => 7,
        (ModelKind::Phong | ModelKind::BlinnPhong, _) => 4,
        (ModelKind::TorranceSparrow, Distribution::D3) => 3,
        (ModelKind::GgxSmith, _) => 2,
        (ModelKind::Lambert, _) => 1,
    }
}

/// One fit of one channel, or a joint fit of several, in the steps above.
fn fit_group(
    chans: Vec<ChannelRows>,
    opts: &FitOptions,
    geometry_seconds: f64,
) -> Result<FitResult, FitError> {
    let t0 = Instant::now();
    let channel_names: Vec<String> = chans.iter().map(|c| c.name.clone()).collect();
    let channel_label = channel_names.join(",");
    let lay = layout(&channel_names, opts);
    check_data(&chans, &lay, opts, &channel_label)?;
    let m: usize = chans.iter().map(|c| c.rows.len()).sum();
    let weighted = chans.iter().any(|c| c.rows.weighted());
    let nfree = lay.transforms.len();
    let full = problem(chans, &lay, opts);
    let mut found = search(&full, &lay, opts);
    if !found.sol.cost.is_finite() {
        return Err(fit_error(
            format!("channel {channel_label}: the fit found no point with a finite cost"),
            "check the data for extreme values, or give a start point",
        )
        .with(Setting::Start));
    }
    // The same f_r in canonical order (ggx-smith-2: alpha1 ≤ alpha2), before any statistic
    // (the normal equations cached at the solution are in the old order: made again).
    let x = solve::canonical(&full, &found.sol.x);
    if x != found.sol.x {
        found.sol.x = x;
        found.sol.normal = None;
    }
    let solve_seconds = t0.elapsed().as_secs_f64();
    // Statistics in natural parameters, on the declared (not the robust) loss.
    let cost = if found.robust == Robust::None {
        found.sol.cost
    } else {
        lsq::cost(&full, &found.sol.x, Robust::None).unwrap_or(f64::INFINITY)
    };
    let theta: Vec<f64> = (0..nfree)
        .map(|k| full.transforms[k].apply(found.sol.x[k]).0)
        .collect();
    let mut warnings = Vec::new();
    if full
        .models(&found.sol.x)
        .iter()
        .any(|m| m.canonical() != *m)
    {
        warnings.push(
            "the lobes end out of order (alpha1 > alpha2) and a held parameter keeps them from \
             being swapped: hold the other lobe's parameters instead (--fix)"
                .to_string(),
        );
    }
    if !found.sol.converged {
        warnings.push(format!("{UNCONVERGED}: {}", found.sol.termination));
    }
    let checks = certify(&full, &mut found, &lay, &theta, opts);
    let u = uncertainty(&full, &found.sol, &theta, cost, &lay, opts, &mut warnings);
    let (params, stderr, free, correlation) = reported(&lay, &theta, &u);
    let rss = 2.0 * cost;
    let mf = m as f64;
    let kf = nfree as f64;
    let loglike_term = mf * (rss / mf).max(1e-300).ln();
    let mut result = FitResult {
        model: opts.kind,
        dist: opts.dist,
        loss: opts.loss,
        method: opts.method,
        channel: channel_label,
        weights: opts.weights,
        weighted,
        params,
        stderr,
        correlation,
        free,
        cost,
        rmse: (rss / mf).sqrt(),
        samples_used: m,
        iterations: found.iterations,
        evaluations: found.evaluations,
        termination: found.sol.termination,
        // Set below, once the physical check is done.
        seconds: 0.0,
        geometry_seconds,
        solve_seconds,
        statistics_seconds: 0.0,
        warnings,
        bic: loglike_term + kf * mf.ln(),
        aic: loglike_term + 2.0 * kf,
        n_free: nfree,
        ranges: u.ranges,
        at_bound: u.at_bound,
        kkt_violation: checks.kkt_violation,
        verification: checks.verification,
        unusable: checks.unusable,
    };
    // Step 8: only physical fits in use (pd ≤ 1, albedo ≤ 1, no lobe held down by F ≈ 0).
    let unphysical = physical::problems(&result);
    result.unusable.extend(unphysical);
    let fit_seconds = t0.elapsed().as_secs_f64();
    result.seconds = geometry_seconds + fit_seconds;
    result.statistics_seconds = fit_seconds - solve_seconds;
    Ok(result)
}

//! Fitting reflection models to samples by nonlinear least squares.
//!
//! The pipeline for one data set (and one channel, or several with `shared` parameters):
//! 1. samples are converted to f_r and filtered (finite values, `max_theta`); the geometry of
//!    each sample is computed once ([`problem::Rows`]);
//! 2. **global initialisation** (variable projection): ps and pd enter the model linearly, so a
//!    small grid over the nonlinear parameters (F0 = ((n−1)/(n+1))² and c3, or c1/c2) with a
//!    weighted linear solve for (ps, pd) at each point finds the basin; it runs on a subsample;
//! 3. the local method (Levenberg–Marquardt by default) from the best grid points and the
//!    user's `start`, first on a subsample of at most 2,000 rows per channel, then on all rows;
//! 4. statistics in natural parameters from JᵀJ at the solution: standard errors,
//!    correlations, and honest warnings (with a profiled range) for parameters the data do not
//!    determine.

mod argmin_peer;
mod fitfile;
mod json;
pub mod physical;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod lsq;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod problem;

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
use problem::{BrdfProblem, Rows, Slot, Transform};
use std::time::Instant;

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
    /// Profile undetermined parameters to report the range that fits.
    pub profile: bool,
    /// Random local starts run after the fit as a certificate (0 = none); see [`Verification`].
    pub verify: usize,
    /// Seed of the verification starts.
    pub seed: u64,
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
            fix: vec![],
            start: vec![],
            shared: vec![],
            local_only: false,
            fast_pow: None,
            limits: Limits::default(),
            profile: true,
            verify: 0,
            seed: 1,
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
    /// ½ Σ r² with the declared loss at the returned parameters, on the samples used.
    pub cost: f64,
    /// √(2 cost / samples_used).
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
    /// Wall time of the fit: geometry pass, solve and statistics (no file reading).
    #[serde(default)]
    pub seconds: f64,
    /// The part of `seconds` spent on the per-sample geometry pass (N·L, N·H, E·H, G and the
    /// targets), which depends on no parameter and is done once per fit.
    #[serde(default)]
    pub geometry_seconds: f64,
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

    /// Short flags: `bound:NAME` for a parameter on a bound, `weak:NAME` for one the data
    /// determine only weakly (its range within 1 % of the minimum cost is wide).
    pub fn flags(&self) -> Vec<String> {
        let mut flags: Vec<String> = self
            .at_bound
            .iter()
            .map(|(n, _)| format!("bound:{n}"))
            .collect();
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

/// One channel's usable samples, converted to f_r.
struct ChannelRows {
    name: String,
    rows: Rows,
    /// θi when every row has the same incidence angle.
    one_incidence: Option<f64>,
    all_zero: bool,
}

fn channel_rows(ds: &Dataset, c: usize, opts: &FitOptions) -> ChannelRows {
    let vals = &ds.channels[c].values;
    let max = opts.max_theta_deg.map(f64::to_radians);
    let weighted = ds
        .weights
        .as_ref()
        .is_some_and(|w| w.iter().any(|&v| v != 1.0));
    // Geometry of every sample, in parallel over fixed chunks joined in sample order.
    let rows = Rows::par_fill(ds.len(), weighted, |range, cols| {
        fill_rows(ds, vals, max, opts.loss, range, cols)
    });
    // ln(1 + 0) = 0 and f = 0: a zero target is a zero value under either loss.
    let all_zero = rows.target.iter().all(|&t| t == 0.0);
    let first = rows.nl.first().copied();
    let one_incidence = first.is_some_and(|c0| rows.nl.iter().all(|c| (c - c0).abs() < 1e-12));
    ChannelRows {
        name: ds.channel_label(c),
        rows,
        one_incidence: one_incidence.then(|| first.unwrap_or(1.0).acos()),
        all_zero,
    }
}

/// Rows of samples `range` of channel values `vals` written to the front of `cols` (the
/// layout of [`Rows::write`]); returns how many were kept. [`LANES`] samples at a time, so
/// the trigonometry and logarithms vectorise; compiled for AVX-512 and AVX2 as well and picked
/// at run time.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn fill_rows(
    ds: &Dataset,
    vals: &[f64],
    max: Option<f64>,
    loss: Loss,
    range: std::ops::Range<usize>,
    mut cols: [&mut [f64]; 8],
) -> usize {
    let q = ds.quantity;
    let mut kept = 0;
    // LANES samples at a time, so the trigonometry and logarithms vectorise.
    let mut k = range.start;
    while k < range.end {
        let n = (range.end - k).min(LANES);
        let (mut ti, mut to, mut dphi) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for l in 0..n {
            let a = ds.angles(k + l);
            (ti[l], to[l], dphi[l]) = (a[0], a[2], a[3] - a[1]);
        }
        let (si, ci) = lanes::sin_cos(&ti);
        let (so, co) = lanes::sin_cos(&to);
        let (_, cp) = lanes::sin_cos(&dphi);
        let mut v = [0.0; LANES];
        let mut y = [0.0; LANES];
        for l in 0..n {
            v[l] = match q {
                crate::data::Quantity::Brdf => vals[k + l],
                _ => vals[k + l] * q.to_brdf_factor(ci[l]),
            };
            y[l] = ci[l] * v[l];
        }
        let target = match loss {
            Loss::Log => lanes::ln_1p(&y).0,
            Loss::Linear => v,
            Loss::Pixel => y.map(|x| problem::pixel(x).0),
        };
        // L·E = sinθi sinθo cos(φo − φi) + cosθi cosθo. Columns in the order of [`Rows::write`].
        let mut col = [[0.0; LANES]; 8];
        let mut keep = [false; LANES];
        let mut w = [1.0; LANES];
        if let Some(ws) = &ds.weights {
            w[..n].copy_from_slice(&ws[k..k + n]);
        }
        let m = max.unwrap_or(f64::INFINITY);
        for l in 0..LANES {
            let g = Geometry::from_cosines(ci[l], co[l], si[l] * so[l] * cp[l] + ci[l] * co[l]);
            let inside = !(ti[l] > m) & !(to[l] > m);
            keep[l] = (l < n) & v[l].is_finite() & inside & (w[l] > 0.0) & g.visible();
            [
                col[0][l], col[1][l], col[2][l], col[3][l], col[4][l], col[5][l],
            ] = [g.nl, g.ne, g.nh, g.eh, g.re, g.g_ne];
            (col[6][l], col[7][l]) = (target[l], w[l].sqrt());
        }
        if keep.iter().all(|&x| x) {
            // The usual case: the whole block is kept, written a lane vector at a time.
            for (c, x) in cols.iter_mut().zip(&col) {
                c[kept..kept + LANES].copy_from_slice(x);
            }
            kept += LANES;
        } else {
            for l in 0..n {
                if keep[l] {
                    for (c, x) in cols.iter_mut().zip(&col) {
                        c[kept] = x[l];
                    }
                    kept += 1;
                }
            }
        }
        k += n;
    }
    kept
}

/// Fit `opts.kind` to every channel of `ds` (or jointly with `opts.shared`).
pub fn fit(ds: &Dataset, opts: &FitOptions) -> Result<Vec<FitResult>, FitError> {
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
    // Each channel's geometry pass is timed with its fit.
    let timed = |c: usize| {
        let t = Instant::now();
        let rows = channel_rows(ds, c, opts);
        (rows, t.elapsed().as_secs_f64())
    };
    if opts.shared.is_empty() || ds.channels.len() == 1 {
        (0..ds.channels.len())
            .map(|c| {
                let (rows, t) = timed(c);
                fit_group(vec![rows], opts, t)
            })
            .collect()
    } else {
        let (chans, times): (Vec<ChannelRows>, Vec<f64>) =
            (0..ds.channels.len()).map(timed).unzip();
        Ok(vec![fit_group(chans, opts, times.iter().sum())?])
    }
}

/// [`fit`] run `repeat` times in this process (for benchmarks): the results of the first run
/// with `seconds` and `geometry_seconds` each the median of its own column over the runs
/// (every run gives the same parameters; only the clock differs).
pub fn fit_timed(
    ds: &Dataset,
    opts: &FitOptions,
    repeat: usize,
) -> Result<Vec<FitResult>, FitError> {
    let mut fits = fit(ds, opts)?;
    let mut times: Vec<Vec<[f64; 2]>> = fits
        .iter()
        .map(|f| vec![[f.seconds, f.geometry_seconds]])
        .collect();
    for _ in 1..repeat.max(1) {
        for (t, f) in times.iter_mut().zip(fit(ds, opts)?) {
            t.push([f.seconds, f.geometry_seconds]);
        }
    }
    let median = |t: &[[f64; 2]], k: usize| {
        let mut v: Vec<f64> = t.iter().map(|x| x[k]).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    for (f, t) in fits.iter_mut().zip(&times) {
        (f.seconds, f.geometry_seconds) = (median(t, 0), median(t, 1));
    }
    Ok(fits)
}

/// A reported parameter: its name (with `_<channel>` when per channel) and its slot.
#[derive(Clone, Debug)]
struct Entry {
    name: String,
    slot: Slot,
}

/// The solver variables of a fit: which model parameters are held, shared or per channel.
struct Layout {
    transforms: Vec<Transform>,
    names: Vec<String>,
    specs: Vec<&'static ParamSpec>,
    slots: Vec<[Slot; crate::model::MAX_PARAMS]>,
    entries: Vec<Entry>,
}

/// Step 1: lay out the solver variables. A held parameter is fixed in every channel; with one
/// channel (or `shared`) a parameter is one variable, otherwise one per channel.
fn layout(channels: &[String], opts: &FitOptions) -> Layout {
    let specs = opts.kind.params(opts.dist);
    let multi = channels.len() > 1;
    let mut lay = Layout {
        transforms: Vec::new(),
        names: Vec::new(),
        specs: Vec::new(),
        slots: vec![[Slot::Fixed(0.0); crate::model::MAX_PARAMS]; channels.len()],
        entries: Vec::new(),
    };
    let held = |name: &str| opts.fix.iter().rev().find(|(k, _)| k == name).map(|f| f.1);
    let shared = |name: &str| opts.shared.iter().any(|s| s == name);
    let add = |lay: &mut Layout, j: usize, name: String, chans: std::ops::Range<usize>| {
        let k = lay.transforms.len();
        lay.transforms.push(Transform::of(&specs[j]));
        lay.specs.push(&specs[j]);
        lay.names.push(name.clone());
        for c in chans {
            lay.slots[c][j] = Slot::Free(k);
        }
        lay.entries.push(Entry {
            name,
            slot: Slot::Free(k),
        });
    };
    for (j, spec) in specs.iter().enumerate() {
        if let Some(v) = held(spec.name) {
            for l in lay.slots.iter_mut() {
                l[j] = Slot::Fixed(v);
            }
            lay.entries.push(Entry {
                name: spec.name.to_string(),
                slot: Slot::Fixed(v),
            });
        } else if !multi || shared(spec.name) {
            add(&mut lay, j, spec.name.to_string(), 0..channels.len());
        }
    }
    for (c, ch) in channels.iter().enumerate() {
        for (j, spec) in specs.iter().enumerate() {
            if multi && !shared(spec.name) && held(spec.name).is_none() {
                add(&mut lay, j, format!("{}_{ch}", spec.name), c..c + 1);
            }
        }
    }
    lay
}

/// Step 2: refuse data that cannot determine the free parameters.
fn check_data(
    chans: &[ChannelRows],
    lay: &Layout,
    opts: &FitOptions,
    label: &str,
) -> Result<(), FitError> {
    let m: usize = chans.iter().map(|c| c.rows.len()).sum();
    let nfree = lay.transforms.len();
    if m <= nfree {
        return Err(fit_error(
            format!("channel {label}: {m} usable samples for {nfree} free parameters"),
            "a fit needs more samples than free parameters: check the largest angle used, the negative policy, or hold some parameters",
        )
        .with(Setting::MaxTheta));
    }
    if chans.iter().all(|c| c.all_zero) {
        return Err(fit_error(
            format!("channel {label}: every value is zero"),
            "there is no reflectance to fit; check the channel and the file",
        ));
    }
    let index = opts
        .kind
        .index_of(opts.dist, Role::Index)
        .filter(|&i| matches!(lay.slots[0][i], Slot::Free(_)));
    if let Some(index) = index
        && let Some(t) = chans[0].one_incidence
        && chans
            .iter()
            .all(|c| c.one_incidence.is_some_and(|x| (x - t).abs() < 1e-9))
    {
        return Err(fit_error(
            format!(
                "channel {label}: every sample has θi = {:.2}°; the Fresnel index n cannot be separated from ps at one incidence angle",
                t.to_degrees()
            ),
            "add samples at other incidence angles, or hold the index at a value",
        )
        .with(Setting::Hold(
            opts.kind.params(opts.dist)[index].name.into(),
        )));
    }
    Ok(())
}

/// Step 3: the least-squares problem over every channel's rows.
fn problem(chans: Vec<ChannelRows>, lay: &Layout, opts: &FitOptions) -> BrdfProblem {
    let mut starts = vec![0];
    let mut rows = Rows::default();
    for c in chans {
        if rows.is_empty() {
            rows = c.rows;
        } else {
            rows.extend(&c.rows);
        }
        starts.push(rows.len());
    }
    // The template's values are placeholders: each parameter's declared start.
    let declared: Vec<f64> = opts
        .kind
        .params(opts.dist)
        .iter()
        .map(|s| s.start)
        .collect();
    let mut template =
        Model::new(opts.kind, opts.dist, &declared).expect("declared starts are valid");
    template.fast_pow = opts.fast_pow;
    BrdfProblem {
        template,
        rows: std::sync::Arc::new(rows),
        starts,
        layout: lay.slots.clone(),
        transforms: lay.transforms.clone(),
        loss: opts.loss,
    }
}

/// What the search found and what it cost.
struct Search {
    sol: Solution,
    robust: Robust,
    /// The ≤ 2,000-rows-per-channel subsample the candidates were refined on, if any.
    sub: Option<BrdfProblem>,
    refine_limits: Limits,
    iterations: usize,
    evaluations: usize,
}

/// Step 4: global initialisation, candidates refined on a subsample, the distinct basins near
/// the best polished on every row (robust loss, if any, on that last stage).
fn search(full: &BrdfProblem, lay: &Layout, opts: &FitOptions) -> Search {
    use rayon::prelude::*;
    let sub = (full.rows.len() > 2_000 * full.layout.len()).then(|| full.subsample(2_000));
    let work = sub.as_ref().unwrap_or(full);
    let mut candidates: Vec<Vec<f64>> = Vec::new();
    if !opts.local_only {
        candidates.extend(global_init(full, &lay.specs, opts));
    }
    if !opts.start.is_empty() || candidates.is_empty() {
        candidates.push(start_vector(full, &lay.specs, &lay.names, &opts.start));
    }
    // On a subsample only the basin matters: the polish on every row sets the final accuracy.
    let refine_limits = if sub.is_some() {
        Limits {
            ftol: opts.limits.ftol.max(1e-8),
            ..opts.limits
        }
    } else {
        opts.limits
    };
    let mut sols: Vec<Solution> = candidates
        .par_iter()
        .map(|x0| lsq::solve(work, x0, opts.method, Robust::None, &refine_limits))
        .collect();
    let mut iterations: usize = sols.iter().map(|s| s.iterations).sum();
    let mut evaluations: usize = sols.iter().map(|s| s.evaluations).sum();
    sols.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let robust = match opts.robust {
        None => Robust::None,
        Some(kind) => {
            let delta = robust_scale(full, &sols[0].x);
            match kind {
                RobustKind::Huber => Robust::Huber(delta),
                RobustKind::Cauchy => Robust::Cauchy(delta),
            }
        }
    };
    let sol = if sub.is_some() || robust != Robust::None {
        // A subsample's cost tells basins apart only to within its sampling noise: every
        // distinct basin whose subsample cost is near the best is polished on every row.
        let polished: Vec<Solution> = distinct_basins(&sols)
            .par_iter()
            .map(|s| lsq::solve(full, &s.x, opts.method, robust, &opts.limits))
            .collect();
        iterations += polished.iter().map(|s| s.iterations).sum::<usize>();
        evaluations += polished.iter().map(|s| s.evaluations).sum::<usize>();
        polished
            .into_iter()
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
            .expect("at least one candidate")
    } else {
        sols.swap_remove(0)
    };
    Search {
        sol,
        robust,
        sub,
        refine_limits,
        iterations,
        evaluations,
    }
}

/// What the checks at return found.
struct Checks {
    kkt_violation: f64,
    verification: Option<Verification>,
    unusable: Vec<String>,
}

/// Step 5: the first-order conditions, absurd values and (with `verify`) the random starts.
fn certify(
    full: &BrdfProblem,
    found: &mut Search,
    lay: &Layout,
    theta: &[f64],
    opts: &FitOptions,
) -> Checks {
    let mut unusable = Vec::new();
    let (kkt_violation, why) = first_order(full, &found.sol, found.robust, &lay.names);
    unusable.extend(why);
    for k in 0..theta.len() {
        if theta[k] >= lay.specs[k].absurd_above {
            unusable.push(format!(
                "{} = {} is not a physical value (≥ {})",
                lay.names[k],
                readable(theta[k]),
                readable(lay.specs[k].absurd_above)
            ));
        }
    }
    let verification = (opts.verify > 0).then(|| {
        let work = found.sub.as_ref().unwrap_or(full);
        let (v, evaluations) = verify(
            full,
            work,
            &lay.specs,
            opts,
            found.robust,
            &found.refine_limits,
            found.sol.cost,
        );
        found.evaluations += evaluations;
        v
    });
    if let Some(v) = &verification
        && !v.verified
    {
        unusable.push(format!(
            "verification: a random start reached cost {}, below this fit's {}",
            readable(v.best_cost),
            readable(found.sol.cost)
        ));
    }
    Checks {
        kkt_violation,
        verification,
        unusable,
    }
}

/// What the data say about each free parameter.
struct Uncertainty {
    se: Vec<f64>,
    corr: Vec<Vec<f64>>,
    ranges: Vec<(String, f64, f64)>,
    at_bound: Vec<(String, String)>,
}

/// Step 6: standard errors and correlations, 1 % ranges (quadratic or profiled), parameters on
/// a bound, and the honest warnings (appended to `warnings`).
fn uncertainty(
    full: &BrdfProblem,
    sol: &Solution,
    theta: &[f64],
    cost: f64,
    lay: &Layout,
    opts: &FitOptions,
    warnings: &mut Vec<String>,
) -> Uncertainty {
    let m = full.rows.len();
    let nfree = theta.len();
    let (se, corr, singular) = statistics(full, sol, theta, cost, m);
    let prof = full.subsample(1000);
    let mut ranges = Vec::new();
    let mut at_bound = Vec::new();
    for k in 0..nfree {
        let name = &lay.names[k];
        // The quadratic model of the cost gives the 1 % range in solver space,
        // Δu = (σ_θ/|dθ/du|)·√(0.01 (m − p)); where it is narrow (a factor ≤ 1.2, inside the
        // bounds) it stands, otherwise the cost is profiled for real.
        let t = full.transforms[k];
        let (ulo, uhi) = t.bounds();
        let du = se[k] / t.apply(sol.x[k]).1.abs().max(1e-300)
            * (0.01 * (m.saturating_sub(nfree)) as f64).sqrt();
        let quadratic = (du.is_finite() && sol.x[k] - du > ulo && sol.x[k] + du < uhi)
            .then(|| {
                let (a, b) = (t.apply(sol.x[k] - du).0, t.apply(sol.x[k] + du).0);
                (a.min(b), a.max(b))
            })
            .filter(|(a, b)| *a > 0.0 && b / a <= 1.2);
        let range = if !opts.profile {
            None
        } else if quadratic.is_some() {
            quadratic
        } else {
            profile_range(&prof, &sol.x, k, opts)
        };
        let side = lsq::bound_side(sol.x[k], t.bounds());
        if side != 0 {
            let which = if side < 0 { "lower" } else { "upper" };
            at_bound.push((name.clone(), which.to_string()));
        }
        // A shape parameter at the end of its box has run off (a linear one at 0 is an answer).
        let ran_off = side != 0 && matches!(t.scale, Scale::Log { .. });
        let rel = se[k] / theta[k].abs().max(1e-300);
        // Weak: the 1 % range spans more than a factor 1.25, or reaches a bound.
        let wide = range.is_some_and(|(a, b)| !(b / a <= 1.25) || a == f64::NEG_INFINITY);
        if let Some((a, b)) = range {
            ranges.push((name.clone(), a, b));
        }
        if side != 0 && !ran_off {
            warnings.push(format!(
                "{name} = {} is at its {} bound",
                readable(theta[k]),
                if side < 0 { "lower" } else { "upper" }
            ));
        } else if !(rel <= 0.5) || singular[k] || ran_off || wide {
            let why = if ran_off {
                format!(
                    "{name} ran to the edge of its range ({})",
                    readable(theta[k])
                )
            } else if singular[k] {
                format!("{name} is not determined by the data (JᵀJ is near-singular in it)")
            } else if !(rel <= 10.0) {
                format!("{name} is not determined by the data (standard error over 10× the value)")
            } else if !(rel <= 0.5) {
                format!(
                    "{name} is not determined by the data (relative standard error {} %)",
                    readable((100.0 * rel).round())
                )
            } else {
                format!("{name} is only weakly determined by the data")
            };
            warnings.push(match range {
                Some(r) => format!("{why}: {}", describe_range(name, r)),
                None => why,
            });
        }
    }
    Uncertainty {
        se,
        corr,
        ranges,
        at_bound,
    }
}

/// Every model parameter as reported, fixed ones included: (params, stderr, free,
/// correlation), in model order.
type Reported = (Vec<(String, f64)>, Vec<f64>, Vec<bool>, Vec<Vec<f64>>);

/// Step 7: the reported parameters from the solver variables.
fn reported(lay: &Layout, theta: &[f64], u: &Uncertainty) -> Reported {
    let order: Vec<Option<usize>> = lay
        .entries
        .iter()
        .map(|e| match e.slot {
            Slot::Free(k) => Some(k),
            Slot::Fixed(_) => None,
        })
        .collect();
    let params = lay
        .entries
        .iter()
        .map(|e| match e.slot {
            Slot::Free(k) => (e.name.clone(), theta[k]),
            Slot::Fixed(v) => (e.name.clone(), v),
        })
        .collect();
    let stderr = order.iter().map(|o| o.map_or(0.0, |k| u.se[k])).collect();
    let free = order.iter().map(Option::is_some).collect();
    let correlation = (0..order.len())
        .map(|a| {
            (0..order.len())
                .map(|b| match (order[a], order[b]) {
                    (Some(i), Some(j)) => u.corr[i][j],
                    _ if a == b => 1.0,
                    _ => 0.0,
                })
                .collect()
        })
        .collect();
    (params, stderr, free, correlation)
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
    if !found.sol.converged {
        warnings.push(format!(
            "the solver stopped before converging: {}",
            found.sol.termination
        ));
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
        seconds: geometry_seconds + t0.elapsed().as_secs_f64(),
        geometry_seconds,
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
    Ok(result)
}

/// Solutions of distinct basins (apart by more than 1e-3 in some solver variable, relative to
/// its magnitude or 1) whose cost on `work` is within [`CONTENDER_RATIO`] of the
/// best, best first, at most 3. `sols` is sorted by cost.
fn distinct_basins(sols: &[Solution]) -> Vec<&Solution> {
    let best = sols[0].cost;
    let mut out: Vec<&Solution> = Vec::new();
    for s in sols {
        if out.len() == 3 || !(s.cost <= best * CONTENDER_RATIO) {
            break;
        }
        let same = out.iter().any(|o| {
            o.x.iter()
                .zip(&s.x)
                .all(|(a, b)| (a - b).abs() <= 1e-3 * a.abs().max(b.abs()).max(1.0))
        });
        if !same {
            out.push(s);
        }
    }
    out
}

/// Candidates whose subsample cost is within this factor of the best are polished on every
/// row (a subsample ranks basins only to within its sampling noise).
const CONTENDER_RATIO: f64 = 1.5;

/// The first-order (KKT) conditions of the box-constrained problem at the solution, in solver
/// variables: an interior variable has a scaled gradient |g_k| / (√(JᵀJ)_kk ‖r‖) near 0; one at
/// a bound has its gradient pointing out of the box (only an inward part counts). Returns the
/// largest violation and, when it exceeds [`KKT_TOLERANCE`], why.
fn first_order(
    p: &BrdfProblem,
    sol: &Solution,
    robust: Robust,
    names: &[String],
) -> (f64, Option<String>) {
    let ne = match &sol.normal {
        Some(n) => n.clone(),
        None => match lsq::normal_equations(p, &sol.x, robust) {
            Some(n) => n,
            None => {
                return (
                    f64::INFINITY,
                    Some("the cost is not finite at the fit".into()),
                );
            }
        },
    };
    let dim = p.dim();
    let norm = (2.0 * ne.cost).sqrt();
    // An exact fit (rms residual below 1e-9) is optimal whatever its rounding-level gradient.
    if norm <= 1e-9 * (p.n_residuals() as f64).sqrt() || dim == 0 {
        return (0.0, None);
    }
    let bounds = p.bounds();
    let mut worst = (0.0f64, None);
    for k in 0..dim {
        let d = ne.jtj[k * dim + k].sqrt();
        if d == 0.0 {
            continue;
        }
        let g = ne.jtr[k] / (d * norm);
        let side = lsq::bound_side(sol.x[k], bounds[k]);
        let v = match side {
            -1 => (-g).max(0.0),
            1 => g.max(0.0),
            _ => g.abs(),
        };
        if v > worst.0 {
            worst = (v, Some((k, side)));
        }
    }
    let why = worst.1.filter(|_| worst.0 > KKT_TOLERANCE).map(|(k, side)| {
        let at = match side {
            -1 => " at its lower bound, pointing into the range",
            1 => " at its upper bound, pointing into the range",
            _ => "",
        };
        format!(
            "first-order conditions fail: the cost gradient in {}{at} is {} (scaled; tolerance {})",
            names[k],
            readable(worst.0),
            readable(KKT_TOLERANCE)
        )
    });
    (worst.0, why)
}

/// `opts.verify` seeded random starts ([`random_start`]), each refined by the local method on
/// `work` (the pipeline's subsample, or every row), the best three then polished on every row
/// of `full`. Returns the certificate and the evaluations spent.
fn verify(
    full: &BrdfProblem,
    work: &BrdfProblem,
    specs: &[&ParamSpec],
    opts: &FitOptions,
    robust: Robust,
    limits: &Limits,
    cost: f64,
) -> (Verification, usize) {
    use rand::SeedableRng;
    use rayon::prelude::*;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    let starts: Vec<Vec<f64>> = (0..opts.verify)
        .map(|_| random_start(full, specs, &mut rng))
        .collect();
    let mut sols: Vec<Solution> = starts
        .par_iter()
        .map(|x0| lsq::solve(work, x0, opts.method, Robust::None, limits))
        .collect();
    let mut evaluations: usize = sols.iter().map(|s| s.evaluations).sum();
    sols.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let same_rows = std::ptr::eq(full, work);
    let polished: Vec<Solution> = if same_rows && robust == Robust::None {
        sols.into_iter().take(1).collect()
    } else {
        sols.iter()
            .take(3)
            .collect::<Vec<_>>()
            .par_iter()
            .map(|s| lsq::solve(full, &s.x, opts.method, robust, &opts.limits))
            .collect()
    };
    evaluations += polished.iter().map(|s| s.evaluations).sum::<usize>();
    let best_cost = polished
        .iter()
        .map(|s| s.cost)
        .fold(f64::INFINITY, f64::min);
    (
        Verification {
            starts: opts.verify,
            best_cost,
            robust: match robust {
                Robust::None => String::new(),
                Robust::Huber(_) => "huber".into(),
                Robust::Cauchy(_) => "cauchy".into(),
            },
            verified: !(best_cost < cost * (1.0 - SAME_MINIMUM)),
        },
        evaluations,
    )
}

/// Robust threshold from the residuals at `x`: 1.345 · 1.4826 · median |r|.
fn robust_scale(p: &BrdfProblem, x: &[f64]) -> f64 {
    let Some(prep) = p.prepare(x) else {
        return 1.0;
    };
    let mut r: Vec<f64> = (0..p.n_residuals())
        .map(|i| p.residual(&prep, i).abs())
        .collect();
    let mid = r.len() / 2;
    let med = *r.select_nth_unstable_by(mid, f64::total_cmp).1;
    (1.345 * 1.4826 * med).max(1e-12)
}

/// The default or user start as solver variables (a per-channel variable `ps_r` takes a
/// start given for `ps_r` or for `ps`).
fn start_vector(
    p: &BrdfProblem,
    specs: &[&ParamSpec],
    var_names: &[String],
    start: &[(String, f64)],
) -> Vec<f64> {
    (0..specs.len())
        .map(|k| {
            let v = start
                .iter()
                .rev()
                .find(|(n, _)| n == specs[k].name || *n == var_names[k])
                .map_or(specs[k].start, |(_, v)| *v);
            p.transforms[k].invert(v)
        })
        .collect()
}

/// A random start in solver variables: each parameter drawn from its declared
/// [`ParamSpec::random`] range, log-uniformly when both ends are positive.
pub fn random_start(p: &BrdfProblem, specs: &[&ParamSpec], rng: &mut impl rand::Rng) -> Vec<f64> {
    specs
        .iter()
        .enumerate()
        .map(|(k, s)| p.transforms[k].invert(s.random_value(rng)))
        .collect()
}

/// The weighted sums of the two-parameter linear problem y ≈ ps s + pd/π of the global
/// initialisation, y = f_data − ps_fixed s − pd_fixed/π: [Σws², Σws/π, Σw/π², Σwsy, Σwy/π,
/// Σwy²], from the basis sums [Σws², Σws, Σ(wf)s] of [`basis_sums`] (or
/// [`ts_grid_sums`]), the basis-free sums k and the fixed (ps, pd).
fn combine_sums([ss, s1, sf]: [f64; 3], k: [f64; 3], fixed: (f64, f64)) -> [f64; 6] {
    let [w1, f1, ff] = k;
    let d = std::f64::consts::FRAC_1_PI;
    let (a, b) = (fixed.0, fixed.1 * d);
    // y = f − a s − b, expanded.
    let sy = sf - a * ss - b * s1;
    let y1 = f1 - a * s1 - b * w1;
    let yy = ff + a * a * ss + b * b * w1 - 2.0 * a * sf - 2.0 * b * f1 + 2.0 * a * b * s1;
    [ss, s1 * d, w1 * d * d, sy, y1 * d, yy]
}

/// Torrance–Sparrow's specular basis s = D(c)·F(n)·G/(π N·L N·E) at every point of a grid of
/// n (`ns`) and the distribution's c (`cs`) is a term in n alone times a term in c alone:
/// rows of `a` (F(n)·G/(π N·L N·E), one per n) times rows of `b` (D(c), one per c).
struct TsFactors {
    /// F(n)·G/(π N·L N·E), one row of m per n, row-major.
    a: Vec<f64>,
    /// D(c), one row of m per c, row-major.
    b: Vec<f64>,
    m: usize,
}

impl TsFactors {
    fn new(rows: &Rows, dist: Distribution, ns: &[f64], cs: &[f64]) -> Self {
        let m = rows.len();
        let pi = std::f64::consts::FRAC_1_PI;
        let geo: Vec<f64> = (0..m).map(|r| rows.g_ne[r] * pi / rows.nl[r]).collect();
        let a = ns
            .iter()
            .flat_map(|&n| (0..m).map(move |r| crate::model::fresnel(n, rows.eh[r])))
            .zip(geo.iter().cycle())
            .map(|(f, g)| f * g)
            .collect();
        let b = cs
            .iter()
            .flat_map(|&c| (0..m).map(move |r| dist.eval(rows.nh[r], c)))
            .collect();
        TsFactors { a, b, m }
    }

    /// [`basis_sums`] at every grid point, n-major: three matrix products (17 × m by m × 19
    /// for the default grids) instead of a pass over the rows per grid point.
    fn grid_sums(&self, w: &[f64], wf: &[f64]) -> Vec<[f64; 3]> {
        use nalgebra::DMatrix;
        let m = self.m;
        let (ni, nc) = (self.a.len() / m, self.b.len() / m);
        let rowm = |n: usize, f: &dyn Fn(usize) -> f64| DMatrix::from_fn(n, m, |i, r| f(i * m + r));
        let a = &self.a;
        let wa2 = rowm(ni, &|k| w[k % m] * a[k] * a[k]);
        let wa = rowm(ni, &|k| w[k % m] * a[k]);
        let wfa = rowm(ni, &|k| wf[k % m] * a[k]);
        let bt = DMatrix::from_fn(m, nc, |r, j| self.b[j * m + r]);
        let b2t = bt.map(|x| x * x);
        let ss = wa2 * b2t;
        let s1 = wa * &bt;
        let sf = wfa * &bt;
        (0..ni)
            .flat_map(|i| (0..nc).map(move |j| (i, j)))
            .map(|(i, j)| [ss[(i, j)], s1[(i, j)], sf[(i, j)]])
            .collect()
    }

    /// The basis at grid point `index` (n-major), row by row.
    fn basis(&self, index: usize) -> Basis<'_> {
        let (m, nc) = (self.m, self.b.len() / self.m);
        let (i, j) = (index / nc, index % nc);
        Basis {
            a: &self.a[i * m..(i + 1) * m],
            b: &self.b[j * m..(j + 1) * m],
        }
    }
}

/// [Σw, Σwf, Σwf²] of rows with weights w and data f.
fn basis_free_sums(w: &[f64], f: &[f64]) -> [f64; 3] {
    let mut k = [0.0; 3];
    for (w, f) in w.iter().zip(f) {
        k[0] += w;
        k[1] += w * f;
        k[2] += w * f * f;
    }
    k
}

/// [Σws², Σws, Σ(wf)s] over the rows. [`LANES`] rows at a time with per-lane sums added in
/// lane order, so it vectorises (and gives the same sums on every instruction set it is
/// compiled for).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn basis_sums(s: &[f64], w: &[f64], wf: &[f64]) -> [f64; 3] {
    basis_sums_body(s, w, wf)
}

/// The body of [`basis_sums`] (no closures: in a multiversioned function they are not always
/// inlined, and then do not vectorise).
#[inline(always)]
fn basis_sums_body(s: &[f64], w: &[f64], wf: &[f64]) -> [f64; 3] {
    let n = s.len().min(w.len()).min(wf.len());
    let (s, w, wf) = (&s[..n], &w[..n], &wf[..n]);
    let (mut a0, mut a1, mut a2) = ([0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES]);
    let (sc, wc, fc) = (
        s.chunks_exact(LANES),
        w.chunks_exact(LANES),
        wf.chunks_exact(LANES),
    );
    // The last block: lanes past the end have weight 0.
    let mut tail = [[0.0f64; LANES]; 3];
    tail[0][..sc.remainder().len()].copy_from_slice(sc.remainder());
    tail[1][..wc.remainder().len()].copy_from_slice(wc.remainder());
    tail[2][..fc.remainder().len()].copy_from_slice(fc.remainder());
    let [ts, tw, tf] = &tail;
    for ((s, w), f) in sc
        .zip(wc)
        .zip(fc)
        .chain(std::iter::once(((&ts[..], &tw[..]), &tf[..])))
    {
        // One loop per sum: LLVM then packs lanes, not the sums of one lane.
        let ws: [f64; LANES] = std::array::from_fn(|l| w[l] * s[l]);
        for l in 0..LANES {
            a0[l] += ws[l] * s[l];
        }
        for l in 0..LANES {
            a1[l] += ws[l];
        }
        for l in 0..LANES {
            a2[l] += f[l] * s[l];
        }
    }
    [a0, a1, a2].map(|a| a.iter().sum())
}

/// A specular basis s row by row, as the product of two factors (Torrance–Sparrow's term in
/// n times its term in c, or the basis times ones), so no grid point allocates its basis.
#[derive(Clone, Copy)]
struct Basis<'a> {
    a: &'a [f64],
    b: &'a [f64],
}

/// The √weights of rows `range`, or an empty slice for unweighted rows.
fn weights(rows: &Rows, range: std::ops::Range<usize>) -> &[f64] {
    if rows.weighted() {
        &rows.sw[range]
    } else {
        &[]
    }
}

/// One pass of the declared loss over rows `range` for model values f = a·s + b (s the
/// basis): ½ Σ r² with r = sw (ℓ(f) − target), and the normal equations of (a, b):
/// [JᵀJ_aa, JᵀJ_ab, JᵀJ_bb] and [Jᵀr_a, Jᵀr_b].
fn linear_pass(
    rows: &Rows,
    range: std::ops::Range<usize>,
    s: Basis,
    ab: (f64, f64),
    loss: Loss,
) -> (f64, [f64; 3], [f64; 2]) {
    let sw = weights(rows, range.clone());
    let t = match loss {
        Loss::Log => linear_pass_log(
            &rows.nl[range.clone()],
            &rows.target[range.clone()],
            sw,
            s,
            ab,
        ),
        Loss::Linear => linear_pass_linear(&rows.target[range], sw, s, ab),
        Loss::Pixel => {
            // Row by row (the pixel loss serves small scene-weighted sets).
            let mut t = [0.0; 6];
            for (k, i) in range.enumerate() {
                let w = sw.get(k).copied().unwrap_or(1.0);
                let (v, d) = loss.term(ab.0 * s.a[k] + ab.1 * s.b[k], rows.nl[i]);
                let r = w * (v - rows.target[i]);
                let (ja, jb) = (w * d * s.a[k], w * d * s.b[k]);
                t[0] += 0.5 * r * r;
                t[1] += ja * ja;
                t[2] += ja * jb;
                t[3] += jb * jb;
                t[4] += ja * r;
                t[5] += jb * r;
            }
            t
        }
    };
    (t[0], [t[1], t[2], t[3]], [t[4], t[5]])
}

/// [`linear_pass`] for the log loss, eight rows at a time with the lane logarithm (`sw` empty =
/// unweighted); the sums are added per lane, then in lane order.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn linear_pass_log(nl: &[f64], tg: &[f64], sw: &[f64], s: Basis, ab: (f64, f64)) -> [f64; 6] {
    linear_pass_log_body::<true>(nl, tg, sw, s, ab)
}

/// The cost alone of [`linear_pass_log`] (no Jacobian: no division per row).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn linear_cost_log(nl: &[f64], tg: &[f64], sw: &[f64], s: Basis, ab: (f64, f64)) -> f64 {
    linear_pass_log_body::<false>(nl, tg, sw, s, ab)[0]
}

#[inline(always)]
fn linear_pass_log_body<const JAC: bool>(
    nl: &[f64],
    tg: &[f64],
    sw: &[f64],
    s: Basis,
    ab: (f64, f64),
) -> [f64; 6] {
    let m = nl.len();
    let mut acc = [[0.0f64; LANES]; 6];
    let full = m / LANES * LANES;
    let ones = [1.0f64; LANES];
    let mut i = 0;
    while i < full {
        let get = |v: &[f64]| -> [f64; LANES] { v[i..i + LANES].try_into().expect("lane block") };
        let w = if sw.is_empty() { ones } else { get(sw) };
        let (sa, sb) = (get(s.a), get(s.b));
        let sv = std::array::from_fn(|l| sa[l] * sb[l]);
        linear_block::<JAC>(&get(nl), &get(tg), &w, &sv, ab, &mut acc);
        i += LANES;
    }
    if i < m {
        // The last block: lanes past the end have weight 0.
        let len = m - i;
        let pad = |v: &[f64]| -> [f64; LANES] { std::array::from_fn(|l| v[i + l.min(len - 1)]) };
        let w: [f64; LANES] = std::array::from_fn(|l| match (l < len, sw.is_empty()) {
            (false, _) => 0.0,
            (true, true) => 1.0,
            (true, false) => sw[i + l],
        });
        let (sa, sb) = (pad(s.a), pad(s.b));
        let sv = std::array::from_fn(|l| sa[l] * sb[l]);
        linear_block::<JAC>(&pad(nl), &pad(tg), &w, &sv, ab, &mut acc);
    }
    acc.map(|a| a.iter().sum::<f64>())
}

/// One block of [`LANES`] rows of [`linear_pass_log_body`].
#[inline(always)]
fn linear_block<const JAC: bool>(
    c: &[f64; LANES],
    t: &[f64; LANES],
    w: &[f64; LANES],
    sv: &[f64; LANES],
    (a, b): (f64, f64),
    acc: &mut [[f64; LANES]; 6],
) {
    let y: [f64; LANES] = std::array::from_fn(|l| c[l] * (a * sv[l] + b));
    if !JAC {
        let u: [f64; LANES] = std::array::from_fn(|l| 1.0 + y[l]);
        let v = lanes::ln(&u);
        for l in 0..LANES {
            // fdlibm log1p's correction for the rounding of u, without its division by u
            // (a change below 2⁻⁵³ relative, enough for ranking grid points).
            let r = w[l] * (v[l] + (y[l] - (u[l] - 1.0)) - t[l]);
            acc[0][l] += 0.5 * r * r;
        }
        return;
    }
    let (v, iu) = lanes::ln_1p(&y);
    for l in 0..LANES {
        let r = w[l] * (v[l] - t[l]);
        let jb = w[l] * c[l] * iu[l];
        let ja = jb * sv[l];
        acc[0][l] += 0.5 * r * r;
        acc[1][l] += ja * ja;
        acc[2][l] += ja * jb;
        acc[3][l] += jb * jb;
        acc[4][l] += ja * r;
        acc[5][l] += jb * r;
    }
}

/// [`linear_pass`] for the linear loss.
fn linear_pass_linear(tg: &[f64], sw: &[f64], s: Basis, (a, b): (f64, f64)) -> [f64; 6] {
    let mut t = [0.0f64; 6];
    for i in 0..tg.len() {
        let w = sw.get(i).copied().unwrap_or(1.0);
        let si = s.a[i] * s.b[i];
        let r = w * (a * si + b - tg[i]);
        let (ja, jb) = (w * si, w);
        t[0] += 0.5 * r * r;
        t[1] += ja * ja;
        t[2] += ja * jb;
        t[3] += jb * jb;
        t[4] += ja * r;
        t[5] += jb * r;
    }
    t
}

/// Minimise the declared loss over the linear coefficients (a, b) of f = a·s + b from a
/// start, by `steps` projected Gauss–Newton steps; `lo` holds each one's lower bound, or
/// `None` for one that is held. Returns the cost and (a, b).
fn refine_linear(
    rows: &Rows,
    range: std::ops::Range<usize>,
    s: Basis,
    start: (f64, f64),
    lo: (Option<f64>, Option<f64>),
    loss: Loss,
    steps: usize,
) -> (f64, (f64, f64)) {
    let free = (lo.0.is_some(), lo.1.is_some());
    let lo = (lo.0.unwrap_or(f64::MIN), lo.1.unwrap_or(f64::MIN));
    let mut x = start;
    if steps == 0 && loss == Loss::Log {
        let sw = weights(rows, range.clone());
        let cost = linear_cost_log(
            &rows.nl[range.clone()],
            &rows.target[range.clone()],
            sw,
            s,
            x,
        );
        return (cost, x);
    }
    let (mut cost, mut jtj, mut jtr) = linear_pass(rows, range.clone(), s, x, loss);
    if loss == Loss::Linear {
        return (cost, x);
    }
    for _ in 0..steps {
        let ridge = 1e-9;
        let (da, db) = match free {
            (true, true) => {
                let (p, q, r) = (jtj[0] * (1.0 + ridge), jtj[1], jtj[2] * (1.0 + ridge));
                let det = p * r - q * q;
                if !(det > 0.0) {
                    break;
                }
                (
                    -(r * jtr[0] - q * jtr[1]) / det,
                    -(p * jtr[1] - q * jtr[0]) / det,
                )
            }
            (true, false) if jtj[0] > 0.0 => (-jtr[0] / jtj[0], 0.0),
            (false, true) if jtj[2] > 0.0 => (0.0, -jtr[1] / jtj[2]),
            _ => break,
        };
        let mut step = 1.0;
        let mut accepted = false;
        for _ in 0..3 {
            let xn = ((x.0 + step * da).max(lo.0), (x.1 + step * db).max(lo.1));
            let (cn, jn, gn) = linear_pass(rows, range.clone(), s, xn, loss);
            if cn < cost {
                (x, cost, jtj, jtr) = (xn, cn, jn, gn);
                accepted = true;
                break;
            }
            step *= 0.25;
        }
        if !accepted {
            break;
        }
    }
    (cost, x)
}

/// Gauss–Newton steps on the linear coefficients at the grid points that are refined.
const LINEAR_STEPS: usize = 3;

/// Grid points whose (ps, pd) are refined in the declared loss: the best this many by the
/// first score, and as many of the grid's local minima.
const REFINED_POINTS: usize = 8;

/// Rows per channel the global initialisation scores its grid on.
const INIT_ROWS: usize = 500;

/// How many candidates of distinct basins the global initialisation hands to the local method.
const CANDIDATES: usize = 4;

/// Variable projection over a grid of the nonlinear parameters that spans each one's whole
/// admissible range ([`crate::model::ParamSpec::grid`]): at each grid point the free ps and pd
/// of each channel come from a weighted linear least-squares solve (weights that linearise
/// the loss at the data), clipped to ≥ 0; each point is then scored on the *declared* loss at
/// those (ps, pd), so a basin ranks by the cost the fit minimises, not by its linearisation.
/// The grid's local minima (distinct basins) are returned best first, at most [`CANDIDATES`],
/// as solver variables.
fn global_init(full: &BrdfProblem, specs: &[&ParamSpec], opts: &FitOptions) -> Vec<Vec<f64>> {
    let p = full.subsample(INIT_ROWS);
    let nfree = p.transforms.len();
    let kind = opts.kind;
    let names = kind.param_names(opts.dist);
    let ips = kind.index_of(opts.dist, Role::Specular);
    let ipd = kind
        .index_of(opts.dist, Role::Diffuse)
        .expect("every model has pd");
    let (nonlinear, dims, points) = grid_points(specs, nfree);
    let (fdata, wdata) = linearised_data(&p, opts.loss);
    let wf: Vec<f64> = wdata.iter().zip(&fdata).map(|(w, f)| w * f).collect();
    // Per channel, the sums that do not depend on the grid point.
    let free_sums: Vec<[f64; 3]> = (0..p.layout.len())
        .map(|c| {
            let rows = p.starts[c]..p.starts[c + 1];
            basis_free_sums(&wdata[rows.clone()], &fdata[rows])
        })
        .collect();
    // Torrance–Sparrow on one channel with n and c free: every point's sums at once.
    let separable = (kind == ModelKind::TorranceSparrow
        && p.layout.len() == 1
        && ips.is_some()
        && nonlinear.len() == 2
        && specs[nonlinear[0].0].role == Role::Index
        && specs[nonlinear[1].0].role == Role::Shape)
        .then(|| {
            let f = TsFactors::new(&p.rows, opts.dist, &nonlinear[0].1, &nonlinear[1].1);
            let table = f.grid_sums(&wdata, &wf);
            (f, table)
        });
    let (ones, zeros) = (vec![1.0; p.rows.len()], vec![0.0; p.rows.len()]);
    let score_point = |index: usize, steps: usize| {
        let pt = &points[index];
        // Natural values of all free variables at this grid point (linear ones solved).
        let mut theta = vec![f64::NAN; nfree];
        let mut score = 0.0;
        for ((k, _), v) in nonlinear.iter().zip(pt) {
            theta[*k] = *v;
        }
        for c in 0..p.layout.len() {
            let slots = p.layout[c];
            let rows = p.starts[c]..p.starts[c + 1];
            // Model with ps = 1, pd = 0 gives the specular basis; pd's basis is 1/π.
            let mut vals = [0.0; crate::model::MAX_PARAMS];
            for j in 0..names.len() {
                vals[j] = match slots[j] {
                    Slot::Fixed(v) => v,
                    Slot::Free(k) => theta[k],
                };
            }
            if let Some(i) = ips {
                vals[i] = 1.0;
            }
            vals[ipd] = 0.0;
            let spec_model = full.template.with_params(&vals);
            let fixed_ps = ips.and_then(|i| match slots[i] {
                Slot::Fixed(v) => Some(v),
                _ => None,
            });
            let fixed_pd = match slots[ipd] {
                Slot::Fixed(v) => Some(v),
                _ => None,
            };
            let owned: Vec<f64>;
            let basis = match (&separable, ips) {
                (Some((f, _)), _) => f.basis(index),
                (None, Some(_)) => {
                    owned = problem::brdf_values(&spec_model, &p.rows, rows.clone());
                    Basis {
                        a: &owned,
                        b: &ones[..rows.len()],
                    }
                }
                (None, None) => Basis {
                    a: &zeros[..rows.len()],
                    b: &ones[..rows.len()],
                },
            };
            let raw = match &separable {
                Some((_, table)) => table[index],
                // Here the basis is its first factor (the second is ones).
                None => basis_sums(basis.a, &wdata[rows.clone()], &wf[rows.clone()]),
            };
            let [a11, a12, a22, b1, b2, _] = combine_sums(
                raw,
                free_sums[c],
                (fixed_ps.unwrap_or(0.0), fixed_pd.unwrap_or(0.0)),
            );
            let free_ps = ips.is_some() && fixed_ps.is_none();
            let free_pd = fixed_pd.is_none();
            let (ps, pd) = nonnegative_2x2([a11, a12, a22, b1, b2], (free_ps, free_pd));
            // The declared loss, minimised over (ps, pd) from the linear solve.
            let pi = std::f64::consts::FRAC_1_PI;
            let (fps, fpd) = (fixed_ps.unwrap_or(0.0), fixed_pd.unwrap_or(0.0) * pi);
            let (cost, (a, b)) = refine_linear(
                &p.rows,
                rows,
                basis,
                (ps + fps, pd * pi + fpd),
                (free_ps.then_some(fps), free_pd.then_some(fpd)),
                opts.loss,
                steps,
            );
            score += cost;
            let (ps, pd) = (a - fps, (b - fpd) / pi);
            if let (Some(i), true) = (ips, free_ps)
                && let Slot::Free(k) = slots[i]
            {
                theta[k] = ps;
            }
            if free_pd && let Slot::Free(k) = slots[ipd] {
                theta[k] = pd;
            }
        }
        let x: Vec<f64> = (0..nfree)
            .map(|k| p.transforms[k].invert(theta[k]))
            .collect();
        let score = if score.is_finite() {
            score
        } else {
            f64::INFINITY
        };
        (score, x)
    };
    // Every point scored at the linear solve's (ps, pd) (an upper bound of its best score),
    // then the promising ones with (ps, pd) minimising the declared loss.
    use rayon::prelude::*;
    let mut scored: Vec<(f64, Vec<f64>)> = (0..points.len())
        .into_par_iter()
        .map(|i| score_point(i, 0))
        .collect();
    let first: Vec<f64> = scored.iter().map(|s| s.0).collect();
    let mut refine = grid_minima(&first, &dims, REFINED_POINTS);
    let mut order: Vec<usize> = (0..first.len()).collect();
    order.sort_by(|&a, &b| first[a].total_cmp(&first[b]).then(a.cmp(&b)));
    refine.extend(order.into_iter().take(REFINED_POINTS));
    refine.sort_unstable();
    refine.dedup();
    let better: Vec<(usize, (f64, Vec<f64>))> = refine
        .par_iter()
        .map(|&i| (i, score_point(i, LINEAR_STEPS)))
        .collect();
    for (i, s) in better {
        if s.0 <= scored[i].0 {
            scored[i] = s;
        }
    }
    let scores: Vec<f64> = scored.iter().map(|s| s.0).collect();
    grid_minima(&scores, &dims, CANDIDATES)
        .into_iter()
        .map(|i| scored[i].1.clone())
        .collect()
}

/// The starting grid of the nonlinear free variables: which variables have a grid, the grid
/// sizes, and every grid point (row-major). Grids are thinned while the product of their
/// sizes exceeds 4,096 (a joint fit with per-channel shape parameters).
fn grid_points(specs: &[&ParamSpec], nfree: usize) -> GridPoints {
    let mut nonlinear: Vec<(usize, Vec<f64>)> = (0..nfree)
        .filter_map(|k| {
            let g = specs[k].grid_values();
            (!g.is_empty()).then_some((k, g))
        })
        .collect();
    while nonlinear.iter().map(|(_, g)| g.len()).product::<usize>() > 4096 {
        for (_, g) in nonlinear.iter_mut() {
            *g = g.iter().step_by(2).copied().collect();
        }
    }
    let dims: Vec<usize> = nonlinear.iter().map(|(_, g)| g.len()).collect();
    let mut points: Vec<Vec<f64>> = vec![vec![]];
    for (_, g) in &nonlinear {
        points = points
            .iter()
            .flat_map(|pt| {
                g.iter().map(move |v| {
                    let mut q = pt.clone();
                    q.push(*v);
                    q
                })
            })
            .collect();
    }
    (nonlinear, dims, points)
}

/// Gridded variables with their values, the grid sizes, and the grid points.
type GridPoints = (Vec<(usize, Vec<f64>)>, Vec<usize>, Vec<Vec<f64>>);

/// Per row, the data f_r and the weight that linearises the loss around it (parameter-free):
/// for the log loss r ≈ cosθi Δf / (1 + cosθi f), so w = (cosθi / (1 + cosθi f))².
fn linearised_data(p: &BrdfProblem, loss: Loss) -> (Vec<f64>, Vec<f64>) {
    (0..p.rows.len())
        .map(|i| {
            let r = p.rows.get(i);
            let fd = match loss {
                Loss::Log => r.target.exp_m1() / r.cos_i,
                Loss::Linear => r.target,
                // The sRGB encoding inverted (the smooth clip taken as none).
                Loss::Pixel => {
                    let v = r.target.max(0.0);
                    let c = if v <= 12.92 * 0.003_130_8 {
                        v / 12.92
                    } else {
                        ((v + 0.055) / 1.055).powf(2.4)
                    };
                    c / r.cos_i
                }
            };
            let w = match loss {
                Loss::Log => (r.cos_i / (1.0 + r.cos_i * fd)).powi(2),
                Loss::Linear => 1.0,
                Loss::Pixel => loss.term(fd, r.cos_i).1.powi(2),
            } * r.sw
                * r.sw;
            (fd, w)
        })
        .unzip()
}

/// Non-negative least squares with two unknowns from the normal equations
/// [a11 a12; a12 a22] x = [b1; b2]: the unconstrained solution if it is non-negative, else
/// the better of the two faces. An unknown that is not free stays 0.
fn nonnegative_2x2([a11, a12, a22, b1, b2]: [f64; 5], free: (bool, bool)) -> (f64, f64) {
    let solve1 = |a: f64, b: f64| if a > 0.0 { (b / a).max(0.0) } else { 0.0 };
    match free {
        (true, true) => {
            let det = a11 * a22 - a12 * a12;
            let (x1, x2) = if det > 1e-300 {
                ((b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det)
            } else {
                (-1.0, -1.0)
            };
            if x1 >= 0.0 && x2 >= 0.0 && x1.is_finite() && x2.is_finite() {
                return (x1, x2);
            }
            let c1 = (solve1(a11, b1), 0.0);
            let c2 = (0.0, solve1(a22, b2));
            let q = |(u, v): (f64, f64)| {
                a11 * u * u + 2.0 * a12 * u * v + a22 * v * v - 2.0 * (b1 * u + b2 * v)
            };
            if q(c1) <= q(c2) { c1 } else { c2 }
        }
        (true, false) => (solve1(a11, b1), 0.0),
        (false, true) => (0.0, solve1(a22, b2)),
        (false, false) => (0.0, 0.0),
    }
}

/// The local minima of a score tabulated on a grid (row-major over `dims`; a point is a
/// minimum when no neighbour along any axis scores lower), best first, at most `limit`; if
/// there are fewer than two, the best other point not next to a kept one is added.
fn grid_minima(scores: &[f64], dims: &[usize], limit: usize) -> Vec<usize> {
    let strides: Vec<usize> = (0..dims.len())
        .map(|d| dims[d + 1..].iter().product())
        .collect();
    let coord = |i: usize, d: usize| (i / strides[d]) % dims[d];
    let neighbours = |i: usize| {
        let mut v = Vec::new();
        for d in 0..dims.len() {
            let c = coord(i, d);
            if c > 0 {
                v.push(i - strides[d]);
            }
            if c + 1 < dims[d] {
                v.push(i + strides[d]);
            }
        }
        v
    };
    let mut order: Vec<usize> = (0..scores.len())
        .filter(|&i| scores[i].is_finite())
        .collect();
    order.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]).then(a.cmp(&b)));
    let is_min = |i: usize| neighbours(i).iter().all(|&j| scores[i] <= scores[j]);
    let mut kept: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&i| is_min(i))
        .take(limit)
        .collect();
    for &i in &order {
        if kept.len() >= limit.min(2) {
            break;
        }
        let near = kept
            .iter()
            .any(|&k| (0..dims.len()).all(|d| coord(i, d).abs_diff(coord(k, d)) <= 1));
        if !near {
            kept.push(i);
        }
    }
    kept
}

/// Standard errors, correlations and per-parameter near-singularity flags from JᵀJ in natural
/// parameters (σ̂² = 2 cost/(m − p)).
fn statistics(
    full: &BrdfProblem,
    sol: &Solution,
    theta: &[f64],
    cost: f64,
    m: usize,
) -> (Vec<f64>, Vec<Vec<f64>>, Vec<bool>) {
    let p = theta.len();
    if p == 0 {
        // Every parameter held: nothing to estimate.
        return (vec![], vec![], vec![]);
    }
    // JᵀJ in natural parameters: from the solver's last pass by the chain rule
    // (J_θ = J_u / (dθ/du)) when every dθ/du is non-zero, else from one more pass.
    let chain: Vec<f64> = (0..p)
        .map(|k| full.transforms[k].apply(sol.x[k]).1)
        .collect();
    let reuse = sol
        .normal
        .as_ref()
        .filter(|_| chain.iter().all(|d| d.abs() > 1e-12))
        .map(|n| lsq::Normal {
            cost: n.cost,
            jtj: (0..p * p)
                .map(|i| n.jtj[i] / (chain[i / p] * chain[i % p]))
                .collect(),
            jtr: (0..p).map(|i| n.jtr[i] / chain[i]).collect(),
        });
    let Some(ne) = reuse.or_else(|| lsq::normal_equations(&full.natural(), theta, Robust::None))
    else {
        return (
            vec![f64::INFINITY; p],
            vec![vec![f64::NAN; p]; p],
            vec![true; p],
        );
    };
    let a = nalgebra::DMatrix::from_row_slice(p, p, &ne.jtj);
    let d: Vec<f64> = (0..p).map(|i| a[(i, i)].max(1e-300).sqrt()).collect();
    let scaled = nalgebra::DMatrix::from_fn(p, p, |i, j| a[(i, j)] / (d[i] * d[j]));
    let eig = scaled.clone().symmetric_eigen();
    let (imin, lmin) =
        eig.eigenvalues
            .iter()
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |acc, (i, &l)| if l < acc.1 { (i, l) } else { acc },
            );
    let lmax = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let near_singular = !(lmin > 1e-12 * lmax);
    let singular: Vec<bool> = (0..p)
        .map(|i| near_singular && eig.eigenvectors[(i, imin)].abs() > 0.3)
        .collect();
    let sigma2 = 2.0 * cost / (m.saturating_sub(p)).max(1) as f64;
    // Pseudo-inverse in the scaled space, dropping directions below 1e-14 of the largest.
    let mut inv = nalgebra::DMatrix::<f64>::zeros(p, p);
    for k in 0..p {
        let l = eig.eigenvalues[k];
        let v = eig.eigenvectors.column(k);
        let il = if l > 1e-14 * lmax {
            1.0 / l
        } else {
            1e14 / lmax.max(1e-300)
        };
        inv += v * v.transpose() * il;
    }
    let cov = nalgebra::DMatrix::from_fn(p, p, |i, j| sigma2 * inv[(i, j)] / (d[i] * d[j]));
    let se: Vec<f64> = (0..p).map(|i| cov[(i, i)].max(0.0).sqrt()).collect();
    let corr = (0..p)
        .map(|i| {
            (0..p)
                .map(|j| {
                    let c = cov[(i, j)] / (se[i] * se[j]);
                    if c.is_finite() {
                        c.clamp(-1.0, 1.0)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    (se, corr, singular)
}

/// Human-readable form of a profiled range (∞ upper bound = open).
pub fn describe_range(name: &str, (lo, hi): (f64, f64)) -> String {
    let what = match (lo == f64::NEG_INFINITY, hi == f64::INFINITY) {
        (true, true) => format!("any {name}"),
        (true, false) => format!("{name} ≤ {}", readable(hi)),
        (false, true) => format!("{name} ≥ {}", readable(lo)),
        (false, false) => format!("{name} in [{}, {}]", readable(lo), readable(hi)),
    };
    format!("{what} fits within 1 % of the minimum cost")
}

/// Profile a free variable on problem `p`: hold it at grid values, refit the rest from the
/// optimum `x`, and return the range of values whose cost is within 1 % of the minimum. The
/// bounds are the nearest grid values that do *not* fit, so the range contains every value
/// that does; an end that reaches the parameter's own bound is ∓∞ (open).
fn profile_range(p: &BrdfProblem, x: &[f64], k: usize, opts: &FitOptions) -> Option<(f64, f64)> {
    let t = p.transforms[k];
    let (ulo, uhi) = t.bounds();
    // The 1 % test needs the profiled cost to a few digits only.
    let limits = Limits {
        max_iter: 40,
        ftol: 1e-8,
        ..opts.limits
    };
    // Cost of the problem with variable k held at solver value u, the rest refitted from x.
    let held = |u: f64| -> f64 {
        let mut q = p.clone();
        let v = t.apply(u).0;
        for slots in q.layout.iter_mut() {
            for s in slots.iter_mut() {
                *s = match *s {
                    Slot::Free(j) if j == k => Slot::Fixed(v),
                    Slot::Free(j) if j > k => Slot::Free(j - 1),
                    other => other,
                };
            }
        }
        q.transforms.remove(k);
        let mut x0 = x.to_vec();
        x0.remove(k);
        let s = lsq::levenberg_marquardt(&q, &x0, Robust::None, &limits);
        if s.cost.is_finite() {
            s.cost
        } else {
            f64::INFINITY
        }
    };
    let c0 = lsq::cost(p, x, Robust::None)?;
    let limit = 1.01 * c0;
    // Walk outward in solver space with doubling steps until the cost exceeds the limit, then
    // bisect; the bound returned is the failing end of the last bracket.
    let side = |dir: f64| -> Option<f64> {
        let edge = if dir > 0.0 { uhi } else { ulo };
        let mut inside = x[k];
        let mut step = 0.05;
        let outside = loop {
            let u = (inside + dir * step).clamp(ulo, uhi);
            if held(u) > limit {
                break u;
            }
            if u == edge {
                return None;
            }
            inside = u;
            step *= 2.0;
        };
        let (mut a, mut b) = (inside, outside);
        for _ in 0..4 {
            let mid = 0.5 * (a + b);
            if held(mid) > limit {
                b = mid;
            } else {
                a = mid;
            }
        }
        Some(b)
    };
    let (lo, hi) = rayon::join(|| side(-1.0), || side(1.0));
    let lo = lo.map_or(f64::NEG_INFINITY, |u| t.apply(u).0);
    let hi = hi.map_or(f64::INFINITY, |u| t.apply(u).0);
    Some((lo, hi))
}

/// The models compared by `--model all`: (kind, distribution), simplest first.
pub fn all_models() -> Vec<(ModelKind, Distribution)> {
    crate::model::catalogue()
}

/// Rank fits of one channel by BIC, usable fits first (a fit marked not usable is never
/// recommended); returns the order and the index of the recommended model: the usable one with
/// the fewest free parameters within 2 BIC of the best usable one (`None` if none is usable).
pub fn rank(fits: &[FitResult]) -> (Vec<usize>, Option<usize>) {
    let mut order: Vec<usize> = (0..fits.len()).collect();
    order.sort_by(|&a, &b| {
        (!fits[a].usable())
            .cmp(&!fits[b].usable())
            .then(fits[a].bic.total_cmp(&fits[b].bic))
    });
    let usable: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&i| fits[i].usable())
        .collect();
    let rec = usable.first().and_then(|&b| {
        let best = fits[b].bic;
        usable
            .iter()
            .copied()
            .filter(|&i| fits[i].bic <= best + 2.0)
            .min_by(|&a, &b| {
                fits[a]
                    .n_free
                    .cmp(&fits[b].n_free)
                    .then(fits[a].bic.total_cmp(&fits[b].bic))
            })
    });
    (order, rec)
}

/// The terminal table of one fit.
pub fn format_fit(f: &FitResult) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} on channel {}: {} loss, {} ({} samples)",
        f.label(),
        f.channel,
        f.loss.name(),
        f.method.name(),
        f.samples_used
    );
    let _ = writeln!(s, "  {:<8} {:>14} {:>14}", "param", "value", "std. error");
    for (((n, v), se), free) in f.params.iter().zip(&f.stderr).zip(&f.free) {
        let value = readable(*v);
        if *free {
            let se = if se.is_finite() && (*se <= 10.0 * v.abs() || *v == 0.0) {
                format!("{se:.3e}")
            } else {
                "not determined".into()
            };
            let _ = writeln!(s, "  {n:<8} {value:>14} {se:>14}");
        } else {
            let _ = writeln!(s, "  {n:<8} {value:>14} {:>14}", "(fixed)");
        }
    }
    let _ = writeln!(
        s,
        "  cost {:.6e}  rmse {:.4e}  iterations {}  evaluations {}  {:.3} s",
        f.cost, f.rmse, f.iterations, f.evaluations, f.seconds
    );
    let _ = writeln!(s, "  termination: {}", f.termination);
    for (n, lo, hi) in &f.ranges {
        let _ = writeln!(s, "  range: {}", describe_range(n, (*lo, *hi)));
    }
    for w in &f.warnings {
        let _ = writeln!(s, "  warning: {w}");
    }
    if let Some(v) = &f.verification {
        let _ = writeln!(
            s,
            "  verification: {} random starts, best cost {:.6e}{}: {}",
            v.starts,
            v.best_cost,
            if v.robust.is_empty() {
                String::new()
            } else {
                format!(
                    " (of the {} loss the fit minimised, not the cost above)",
                    v.robust
                )
            },
            if v.verified {
                "none ended lower"
            } else {
                "one ended lower"
            }
        );
    }
    for why in &f.unusable {
        let _ = writeln!(s, "  NOT USABLE: {why}");
    }
    s
}

/// One model's fits to the channels of a file as one table, a row per channel: the
/// parameters (4 significant digits), cost, rmse and short flags (`bound:NAME`,
/// `weak:NAME` for a parameter only weakly determined, `NOT USABLE`). `format_fit` gives the
/// full detail of one channel.
pub fn format_channels(fits: &[FitResult]) -> String {
    use std::fmt::Write;
    let Some(first) = fits.first() else {
        return String::new();
    };
    let names = first.model.param_names(first.dist);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} loss, {}, {} channels ({} samples each)",
        first.label(),
        first.loss.name(),
        first.method.name(),
        fits.len(),
        first.samples_used
    );
    let _ = write!(s, "  {:<10}", "channel");
    for n in &names {
        let _ = write!(s, " {n:>10}");
    }
    let _ = writeln!(s, " {:>12} {:>10}  flags", "cost", "rmse");
    for f in fits {
        let _ = write!(s, "  {:<10}", f.channel);
        for (_, v) in f.params.iter().take(names.len()) {
            let _ = write!(s, " {:>10}", crate::model::readable(*v));
        }
        let mut flags = f.flags();
        if let Some(v) = &f.verification {
            flags.push(if v.verified {
                format!("verified({})", v.starts)
            } else {
                format!("NOT-VERIFIED({})", v.starts)
            });
        }
        if !f.usable() {
            flags.push("NOT USABLE".into());
        }
        let _ = writeln!(
            s,
            " {:>12.6e} {:>10.4e}  {}",
            f.cost,
            f.rmse,
            flags.join(" ")
        );
    }
    for f in fits.iter().filter(|f| !f.usable()) {
        let _ = writeln!(s, "  not usable, {}: {}", f.channel, f.unusable.join("; "));
    }
    s
}

/// One line of a channel's BIC ranking: each model with its ΔBIC from the best usable fit,
/// best first, the recommended one marked `←`, fits not usable last as `not usable`.
pub fn format_ranking_line(fits: &[FitResult]) -> String {
    let (order, rec) = rank(fits);
    let best = order.first().map_or(0.0, |&i| fits[i].bic);
    order
        .iter()
        .map(|&i| {
            let f = &fits[i];
            if !f.usable() {
                format!("{} not usable", f.label())
            } else if Some(i) == rec {
                format!("{} {:+.1} ←", f.label(), f.bic - best)
            } else {
                format!("{} {:+.1}", f.label(), f.bic - best)
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The model-comparison table of one channel.
pub fn format_ranking(fits: &[FitResult]) -> String {
    use std::fmt::Write;
    let (order, rec) = rank(fits);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "  {:<26} {:>3} {:>13} {:>12} {:>12} {:>9}",
        "model", "k", "cost", "AIC", "BIC", "ΔBIC"
    );
    let best = fits[order[0]].bic;
    for &i in &order {
        let f = &fits[i];
        let mark = if Some(i) == rec {
            "  ← simplest the data support".to_string()
        } else if !f.usable() {
            format!("  not usable: {}", f.unusable.join("; "))
        } else {
            String::new()
        };
        let dbic = if f.usable() {
            format!("{:>9.1}", f.bic - best)
        } else {
            format!("{:>9}", "—")
        };
        let _ = writeln!(
            s,
            "  {:<26} {:>3} {:>13.6e} {:>12.1} {:>12.1} {dbic}{mark}",
            f.label(),
            f.n_free,
            f.cost,
            f.aic,
            f.bic,
        );
    }
    if rec.is_none() {
        let _ = writeln!(s, "  no fit is usable, so no model is recommended");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The weighted sums of the two-parameter linear problem y ≈ ps s + pd/π of the global
    /// initialisation, y = f_data − ps_fixed s − pd_fixed/π: [Σws², Σws/π, Σw/π², Σwsy, Σwy/π,
    /// Σwy²] of a basis s; `wf` holds w·f_data and `k` the sums free of s ([`basis_free_sums`]).
    fn linear_sums(s: &[f64], w: &[f64], wf: &[f64], k: [f64; 3], fixed: (f64, f64)) -> [f64; 6] {
        combine_sums(basis_sums(s, w, wf), k, fixed)
    }

    /// The lane sums of the global initialisation equal plain sums written out here, for
    /// lengths with and without a partial last block and with fixed ps and pd.
    #[test]
    fn linear_sums_match_plain_sums() {
        let d = std::f64::consts::FRAC_1_PI;
        for m in [0, 1, 7, 8, 9, 500, 1003] {
            let s: Vec<f64> = (0..m)
                .map(|i| (0.37 * i as f64).sin().abs() * 3.0)
                .collect();
            let fd: Vec<f64> = (0..m)
                .map(|i| 0.1 + (0.11 * i as f64).cos().powi(2))
                .collect();
            let w: Vec<f64> = (0..m).map(|i| 1.0 / (1.0 + i as f64 % 5.0)).collect();
            for (ps, pd) in [(0.0, 0.0), (0.4, 0.0), (0.0, 0.6), (0.4, 0.6)] {
                let mut want = [0.0; 6];
                for i in 0..m {
                    let y = fd[i] - ps * s[i] - pd * d;
                    let t = [s[i] * s[i], s[i] * d, d * d, s[i] * y, d * y, y * y];
                    for k in 0..6 {
                        want[k] += w[i] * t[k];
                    }
                }
                let wf: Vec<f64> = w.iter().zip(&fd).map(|(w, f)| w * f).collect();
                let k = basis_free_sums(&w, &fd);
                let got = linear_sums(&s, &w, &wf, k, (ps, pd));
                for k in 0..6 {
                    let tol = 1e-13 * want[k].abs().max(1e-300);
                    assert!(
                        (got[k] - want[k]).abs() <= tol,
                        "m={m} k={k}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    /// The tabulated sums of Torrance–Sparrow's separable basis equal, point by point, the
    /// sums of the basis evaluated through the model (problem::brdf_values), for D3 and D1.
    #[test]
    fn separable_grid_sums_match_the_model_point_by_point() {
        use crate::model::Geometry;
        use problem::Row;
        let mut rows = Vec::new();
        for k in 0..300 {
            let x = k as f64;
            let g = Geometry::from_angles(
                (0.37 * x).sin().abs() * 1.4,
                0.0,
                (0.71 * x).cos().abs() * 1.4,
                2.0 * (0.13 * x).sin() * std::f64::consts::PI,
            );
            if g.visible() {
                rows.push(Row {
                    g,
                    cos_i: g.nl,
                    target: 0.0,
                    sw: 1.0,
                });
            }
        }
        let rows = Rows::from(rows);
        let m = rows.len();
        let w: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 / 7.0).collect();
        let wf: Vec<f64> = (0..m).map(|i| w[i] * (0.2 + (i % 5) as f64)).collect();
        for dist in [Distribution::D3, Distribution::D1] {
            let specs = ModelKind::TorranceSparrow.params(dist);
            let (ns, cs) = (specs[0].grid_values(), specs[1].grid_values());
            let factors = TsFactors::new(&rows, dist, &ns, &cs);
            let table = factors.grid_sums(&w, &wf);
            assert_eq!(table.len(), ns.len() * cs.len());
            for (i, n) in ns.iter().enumerate() {
                for (j, c) in cs.iter().enumerate() {
                    let model =
                        Model::new(ModelKind::TorranceSparrow, dist, &[*n, *c, 1.0, 0.0]).unwrap();
                    let basis = problem::brdf_values(&model, &rows, 0..m);
                    let want = basis_sums(&basis, &w, &wf);
                    let index = i * cs.len() + j;
                    let got = table[index];
                    let fb = factors.basis(index);
                    let got_basis = fb.a.iter().zip(fb.b).map(|(x, y)| x * y);
                    for (r, (a, b)) in got_basis.zip(&basis).enumerate() {
                        assert!(
                            (a - b).abs() <= 1e-12 * b.abs().max(1e-300),
                            "row {r}: {a} vs {b}"
                        );
                    }
                    for k in 0..3 {
                        let tol = 1e-10 * want[k].abs().max(1e-300);
                        assert!(
                            (got[k] - want[k]).abs() <= tol,
                            "{dist:?} n={n} c={c} sum {k}: {} vs {}",
                            got[k],
                            want[k]
                        );
                    }
                }
            }
        }
    }
}

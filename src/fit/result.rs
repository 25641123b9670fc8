//! What a fit returns: the [`FitResult`] (the fit JSON's schema), its certificate and the
//! thresholds its checks use.

use super::json;
use super::lsq::Method;
use super::options::Weighting;
use super::problem::Loss;
use crate::model::{Distribution, Model, ModelKind};

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
    /// check (pd, directional albedo, index; [`physical`](crate::fit::physical)).
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
    /// Each free parameter's confidence interval at `interval_level`, by profile likelihood
    /// (the JSON key `intervals`; ∓∞ where it is open on that side). Fit files of earlier
    /// versions held the values within 1 % of the minimum cost under `ranges`: read here, with
    /// `interval_level` 0.
    #[serde(default, rename = "intervals", alias = "ranges", with = "json::ranges")]
    pub ranges: Vec<(String, f64, f64)>,
    /// The confidence level of `ranges` (0.95); 0 for a fit file of an earlier version.
    #[serde(default)]
    pub interval_level: f64,
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
    /// the data determine only weakly (its confidence interval is wide).
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
}

/// The fit JSON of several fits as `fit --json` writes it: one fit as its object, several
/// under `fits` in order.
pub fn fits_json(fits: &[&FitResult]) -> serde_json::Value {
    match fits {
        [one] => one.to_json(),
        _ => serde_json::json!({ "fits": fits.iter().map(|f| f.to_json()).collect::<Vec<_>>() }),
    }
}

/// The start of the warning of a fit whose solver stopped before converging (the flag
/// `unconverged` of [`FitResult::flags`]).
pub(super) const UNCONVERGED: &str = "the solver stopped before converging";

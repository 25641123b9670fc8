//! What a fit is asked: the [`FitOptions`], their choices, and the [`FitError`] of a fit that
//! cannot be run.

use super::lsq::{Limits, Method};
use super::problem::Loss;
use super::progress::Watch;
use crate::model::{Distribution, ModelKind};
use crate::support::setting::Setting;

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

/// A [`FitError`] with no setting named.
pub(super) fn fit_error(message: impl Into<String>, fix: impl Into<String>) -> FitError {
    FitError {
        message: message.into(),
        fix: fix.into(),
        setting: None,
    }
}

impl FitError {
    /// The same error, naming the setting its fix changes.
    pub(super) fn with(mut self, s: Setting) -> Self {
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
    /// Hold energy conservation (directional albedo ≤ 1 at every θi the physical check
    /// looks at) as a constraint of the fit: where the least-squares minimum breaks it, the
    /// fit is solved again on the feasible set ([`crate::fit::conserve`]).
    pub conserve: bool,
    /// Random local starts run after the fit as a certificate (0 = none); see
    /// [`Verification`](crate::fit::Verification).
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
            conserve: true,
            verify: 0,
            seed: 1,
            watch: None,
        }
    }
}

/// The fraction of one standard error's rise in the cost (σ̂²/2 = S/(m − p) for the cost S = ½ Σ r²
/// over m rows and p free variables) by which the polish's last
/// [`crate::fit::lsq::RESOLUTION_STEPS`] steps together must lower the cost for it to go on: below
/// that the steps move the parameters by a small fraction of a standard error (a cost ε·S/(m − p)
/// above the minimum is √ε standard errors from it). On the 1,854 fits of `--model all` over the
/// bundled and test files the parameters ended within 0.005 standard errors (those of the full
/// polish) of where a polish to ftol = 1e-14 ends, their cost within a relative 1e-8 of that
/// polish's, but for one: blinn-aluminium's GGX–Smith-2, whose two lobes the data do not tell
/// apart, ended at the same cost at another point of its flat valley. The fits took 2.5 % fewer
/// evaluations in all and 11 % fewer on MERL aluminium, a metal whose weakly determined index n
/// makes the last steps crawl (on its green channel TS-d3's polish took 29 steps, not 37; TS-D2's
/// 22, not 36).
pub const RESOLUTION: f64 = 1e-6;

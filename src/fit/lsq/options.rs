//! The run's choices: which [`Method`] solves, and the [`Limits`] that bound it.

/// Solver choice.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
pub enum Method {
    /// Levenberg–Marquardt (default).
    #[default]
    #[serde(rename = "lm")]
    #[value(alias = "levenberg-marquardt")]
    Lm,
    /// Gauss–Newton with line search.
    #[value(name = "gn", alias = "gauss-newton")]
    #[serde(rename = "gn")]
    GaussNewton,
    /// Nelder–Mead simplex.
    #[value(name = "nm", alias = "nelder-mead")]
    #[serde(rename = "nm")]
    NelderMead,
    /// argmin's L-BFGS (memory 7, More–Thuente line search) on the cost and its gradient
    /// Jᵀr; unconstrained: a step out of the box ends the run.
    #[value(name = "argmin-lbfgs")]
    #[serde(rename = "argmin-lbfgs")]
    ArgminLbfgs,
    /// argmin's trust region (Steihaug's CG subproblem) with the Gauss–Newton Hessian JᵀJ;
    /// a trial step out of the box costs +∞ and is rejected; argmin gives it no convergence
    /// test, so it runs to the iteration limit.
    #[value(name = "argmin-trust-region")]
    #[serde(rename = "argmin-trust-region")]
    ArgminTrustRegion,
    /// argmin's Gauss–Newton (full steps, no line search) on the residuals and the m×p
    /// Jacobian; unconstrained: a step out of the box ends the run.
    #[value(name = "argmin-gauss-newton")]
    #[serde(rename = "argmin-gauss-newton")]
    ArgminGaussNewton,
    /// argmin's Nelder–Mead on the cost, +∞ outside the box.
    #[value(name = "argmin-nm")]
    #[serde(rename = "argmin-nm")]
    ArgminNm,
    /// argmin's particle swarm (40 particles, seeded) in the box, on the cost.
    #[value(name = "argmin-pso")]
    #[serde(rename = "argmin-pso")]
    ArgminPso,
}

impl Method {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Method::Lm => "lm",
            Method::GaussNewton => "gn",
            Method::NelderMead => "nm",
            Method::ArgminLbfgs => "argmin-lbfgs",
            Method::ArgminTrustRegion => "argmin-trust-region",
            Method::ArgminGaussNewton => "argmin-gauss-newton",
            Method::ArgminNm => "argmin-nm",
            Method::ArgminPso => "argmin-pso",
        }
    }

    /// brdfit's own methods, then argmin's, in the order the studies show them.
    pub const ALL: [Method; 8] = [
        Method::Lm,
        Method::GaussNewton,
        Method::NelderMead,
        Method::ArgminLbfgs,
        Method::ArgminTrustRegion,
        Method::ArgminGaussNewton,
        Method::ArgminNm,
        Method::ArgminPso,
    ];

    /// True for the methods run through argmin (the in-Rust peers).
    pub fn is_argmin(self) -> bool {
        !matches!(self, Method::Lm | Method::GaussNewton | Method::NelderMead)
    }

    /// Parse a command-line name (`lm`, `gn`, `nm`, `argmin-lbfgs`, …; also long names).
    pub fn parse(s: &str) -> Option<Self> {
        <Self as clap::ValueEnum>::from_str(s, true).ok()
    }
}

/// Stopping rules; every one is a bound, none can be switched off.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Maximum iterations.
    pub max_iter: usize,
    /// Maximum cost evaluations (a Jacobian pass counts as one).
    pub max_eval: usize,
    /// Stop when a step lowers the cost by less than `ftol` relative.
    pub ftol: f64,
    /// Stop when the scaled step is below `xtol` relative to the parameters.
    pub xtol: f64,
    /// Stop when the largest scaled gradient component is below `gtol`.
    pub gtol: f64,
    /// Levenberg–Marquardt only: stop when the cost fell by less than `stall.1` relative over
    /// the last `stall.0` accepted steps (a slide along a plateau that every step still
    /// lowers a little); `stall.0 = 0` (the default) turns it off.
    pub stall: (usize, f64),
    /// Levenberg–Marquardt only: stop, converged, when the last [`RESOLUTION_STEPS`] accepted
    /// steps together lowered the cost by at most this fraction of it (the data's resolution:
    /// see `fit::RESOLUTION`); 0 (the default) turns it off. Summed over steps, not
    /// judged per step, so a slow slide along a valley, where each step gains little but the
    /// steps add up, is not mistaken for convergence.
    pub resolution: f64,
}

/// Accepted steps whose summed cost reduction [`Limits::resolution`] judges.
pub const RESOLUTION_STEPS: usize = 3;

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_iter: 500,
            max_eval: 2000,
            ftol: 1e-14,
            xtol: 1e-15,
            gtol: 1e-14,
            stall: (0, 0.0),
            resolution: 0.0,
        }
    }
}

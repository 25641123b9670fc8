//! A generic nonlinear least-squares core. A [`Problem`] supplies residuals and their analytic
//! gradient row by row; the solvers never know what model they fit.
//!
//! The normal equations JᵀJ and Jᵀr are accumulated in one streaming pass over the residuals,
//! in parallel over fixed chunks whose partial sums are added in chunk order, so the result is
//! the same bytes whatever the thread count and no m×p Jacobian is ever stored.
//!
//! Methods:
//! - [`Method::Lm`]: Levenberg–Marquardt with Marquardt's diagonal scaling and Nielsen's damping
//!   update (K. Madsen, H. B. Nielsen, O. Tingleff, "Methods for non-linear least squares
//!   problems", 2004, Algorithm 3.16), bound-constrained as a projected LM with an active set:
//!   each iteration fixes the variables at a bound whose gradient points out of the box
//!   (Bertsekas, "Projected Newton methods for optimization problems with simple constraints",
//!   SIAM J. Control Optim. 20, 1982), solves the damped system on the others and projects the
//!   step onto the box (Kanzow, Yamashita, Fukushima, "Levenberg–Marquardt methods with strong
//!   local convergence properties for solving nonlinear equations with convex constraints",
//!   J. Comput. Appl. Math. 172, 2004). A variable at a bound whose gradient points inward is
//!   free, so it leaves the bound; the gain ratio is taken on the projected step.
//!   Where the residuals are large the Gauss–Newton step can overshoot, the steps alternating
//!   in sign at a linear rate; once two accepted steps point opposite ways, each step is scaled
//!   by the minimum of the parabola through the last step's slope and cost change.
//! - [`Method::GaussNewton`]: Gauss–Newton with a bounded, NaN-safe Armijo backtracking line
//!   search (Nocedal & Wright, "Numerical Optimization", 2006, Algorithm 3.1), with the same
//!   active set and projection as LM.
//! - [`Method::NelderMead`]: the derivative-free simplex method (Nelder & Mead 1965) with the
//!   standard coefficients (1, 2, ½, ½), on the cost only.
//!
//! Every loop is bounded in iterations and evaluations, and a trial point whose cost is not
//! finite is rejected, never accepted.

use rayon::prelude::*;

/// A least-squares problem: minimise ½ Σ ρ(r_i(x)) over a box.
pub trait Problem: Sync {
    /// Per-evaluation data derived from the parameters (e.g. the model and chain factors).
    type Prepared: Sync;
    /// Number of parameters.
    fn dim(&self) -> usize;
    /// Number of residuals.
    fn n_residuals(&self) -> usize;
    /// Derive the per-evaluation data from `x`, or `None` if `x` is not admissible.
    fn prepare(&self, x: &[f64]) -> Option<Self::Prepared>;
    /// Residual `i` and its gradient with respect to the parameters (written to `row`).
    fn residual_grad(&self, prep: &Self::Prepared, i: usize, row: &mut [f64]) -> f64;
    /// Residual `i` alone (defaults to [`Problem::residual_grad`]).
    fn residual(&self, prep: &Self::Prepared, i: usize) -> f64 {
        let mut row = vec![0.0; self.dim()];
        self.residual_grad(prep, i, &mut row)
    }
    /// Add residuals `range` to `acc`: Σ ρ(r) to the cost, JᵀWJ to the upper triangle of
    /// `acc.jtj` and JᵀWr to `acc.jtr`, with IRLS weights W = ρ'(r)/r. The default goes row
    /// by row through [`Problem::residual_grad`]; a problem may override it with a kernel.
    fn accumulate(
        &self,
        prep: &Self::Prepared,
        range: std::ops::Range<usize>,
        robust: Robust,
        acc: &mut Normal,
    ) {
        let n = self.dim();
        let mut row = vec![0.0; n];
        for i in range {
            let r = self.residual_grad(prep, i, &mut row);
            acc.cost += robust.rho(r);
            let w = robust.weight(r);
            for a in 0..n {
                let wa = w * row[a];
                acc.jtr[a] += wa * r;
                for b in a..n {
                    acc.jtj[a * n + b] += wa * row[b];
                }
            }
        }
    }
    /// Σ ρ(r) over residuals `range` (defaults to [`Problem::residual`] row by row).
    fn cost_range(
        &self,
        prep: &Self::Prepared,
        range: std::ops::Range<usize>,
        robust: Robust,
    ) -> f64 {
        range.map(|i| robust.rho(self.residual(prep, i))).sum()
    }
    /// Lower and upper bound of each parameter (defaults to unbounded).
    fn bounds(&self) -> Vec<(f64, f64)> {
        vec![(f64::NEG_INFINITY, f64::INFINITY); self.dim()]
    }
    /// Variable `k` at the value `u`, in words for a message (defaults to `variable k = u`).
    fn describe(&self, k: usize, u: f64) -> String {
        format!("variable {k} = {u:.4e}")
    }
    /// A step each parameter may always take in one Levenberg–Marquardt iteration, whatever
    /// its magnitude (like `x_scale` in scipy's `least_squares`); defaults to 0, a purely
    /// relative bound.
    fn step_scale(&self) -> Vec<f64> {
        vec![0.0; self.dim()]
    }
}

/// Robust loss ρ applied to each residual (the cost is Σ ρ(r)/…, see [`Robust::rho`]).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Robust {
    /// ρ(r) = ½ r² (ordinary least squares).
    #[default]
    None,
    /// Huber with threshold δ: quadratic within δ, linear beyond.
    Huber(f64),
    /// Cauchy (Lorentzian) with scale δ: ½ δ² ln(1 + (r/δ)²).
    Cauchy(f64),
}

impl Robust {
    /// ρ(r), with ρ(r) = ½ r² for small r.
    #[inline]
    pub fn rho(self, r: f64) -> f64 {
        match self {
            Robust::None => 0.5 * r * r,
            Robust::Huber(d) => {
                if r.abs() <= d {
                    0.5 * r * r
                } else {
                    d * (r.abs() - 0.5 * d)
                }
            }
            Robust::Cauchy(d) => 0.5 * d * d * (r / d).powi(2).ln_1p(),
        }
    }

    /// IRLS weight ρ'(r)/r.
    #[inline]
    pub fn weight(self, r: f64) -> f64 {
        match self {
            Robust::None => 1.0,
            Robust::Huber(d) => {
                if r.abs() <= d {
                    1.0
                } else {
                    d / r.abs()
                }
            }
            Robust::Cauchy(d) => 1.0 / (1.0 + (r / d).powi(2)),
        }
    }
}

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

/// What a solver returns.
#[derive(Clone, Debug)]
pub struct Solution {
    /// Parameters at the end.
    pub x: Vec<f64>,
    /// Cost Σ ρ(r) at `x` (½ Σ r² without a robust loss).
    pub cost: f64,
    /// Iterations taken: steps tried (Levenberg–Marquardt's damping increases that need no
    /// evaluation are not counted), so never more than the evaluations.
    pub iterations: usize,
    /// Cost or Jacobian evaluations.
    pub evaluations: usize,
    /// Why it stopped.
    pub termination: String,
    /// True when a convergence test (not a limit or failure) stopped it.
    pub converged: bool,
    /// Normal equations at `x`, where the method computed them (LM and Gauss–Newton).
    pub normal: Option<Normal>,
}

/// Normal equations at a point: cost, JᵀWJ (row-major p×p) and JᵀWr.
#[derive(Clone, Debug)]
pub struct Normal {
    /// Σ ρ(r).
    pub cost: f64,
    /// JᵀWJ, row-major.
    pub jtj: Vec<f64>,
    /// JᵀWr.
    pub jtr: Vec<f64>,
}

/// The most residuals in a chunk of a pass.
const CHUNK: usize = 4096;

/// The fewest chunks run in parallel: a MERL table's 16,512 rows and a 10k synthetic set are,
/// a 2,000-row subsample is not (its pass is too short to repay waking the other core).
const PARALLEL_CHUNKS: usize = 2;

/// `f` of every chunk of `m` residuals, in chunk order: in parallel when there are enough
/// chunks to repay waking the thread pool, else on this thread (the same values either way).
/// The chunks are equal (to a residual) and, when several, an even number: rayon halves the
/// list, so two cores take the same share (10,000 rows in four chunks of 2,500, not 4,096,
/// 4,096 and 1,808, of which one core took two). They depend on `m` alone, so every result
/// is the same on any number of threads.
fn map_chunks<T: Send>(m: usize, f: impl Fn(std::ops::Range<usize>) -> T + Sync) -> Vec<T> {
    let n = m.div_ceil(CHUNK);
    let n = if n >= PARALLEL_CHUNKS {
        n.next_multiple_of(2)
    } else {
        n
    };
    let range = |c: usize| c * m / n..(c + 1) * m / n;
    if n < PARALLEL_CHUNKS {
        (0..n).map(range).map(f).collect()
    } else {
        (0..n).into_par_iter().map(|c| f(range(c))).collect()
    }
}

/// Cost Σ ρ(r_i) at `x`; `None` where `x` is inadmissible or the cost is not finite.
pub fn cost<P: Problem>(p: &P, x: &[f64], robust: Robust) -> Option<f64> {
    let prep = p.prepare(x)?;
    let m = p.n_residuals();
    let parts: Vec<f64> = map_chunks(m, |r| p.cost_range(&prep, r, robust));
    let s: f64 = parts.iter().sum();
    s.is_finite().then_some(s)
}

/// Normal equations at `x` in one streaming pass; `None` if anything is not finite.
pub fn normal_equations<P: Problem>(p: &P, x: &[f64], robust: Robust) -> Option<Normal> {
    let prep = p.prepare(x)?;
    let n = p.dim();
    let m = p.n_residuals();
    let parts: Vec<Normal> = map_chunks(m, |r| {
        let mut acc = Normal {
            cost: 0.0,
            jtj: vec![0.0; n * n],
            jtr: vec![0.0; n],
        };
        p.accumulate(&prep, r, robust, &mut acc);
        acc
    });
    let mut out = Normal {
        cost: 0.0,
        jtj: vec![0.0; n * n],
        jtr: vec![0.0; n],
    };
    for part in &parts {
        out.cost += part.cost;
        for k in 0..n * n {
            out.jtj[k] += part.jtj[k];
        }
        for k in 0..n {
            out.jtr[k] += part.jtr[k];
        }
    }
    for a in 0..n {
        for b in 0..a {
            out.jtj[a * n + b] = out.jtj[b * n + a];
        }
    }
    let finite = out.cost.is_finite()
        && out.jtj.iter().all(|v| v.is_finite())
        && out.jtr.iter().all(|v| v.is_finite());
    finite.then_some(out)
}

/// Solve (A + μ diag(D)) h = −g by Cholesky with Jacobi scaling on the variables not in the
/// active set (whose step is 0); `None` if not positive definite. The factorisation is
/// Cholesky–Banachiewicz in one buffer (Golub & Van Loan, Matrix Computations, 4th ed.,
/// Algorithm 4.2.1), the matrices being a few parameters wide.
pub(crate) fn damped_solve(
    a: &[f64],
    g: &[f64],
    d: &[f64],
    mu: f64,
    active: &[bool],
) -> Option<Vec<f64>> {
    let n = g.len();
    debug_assert!(a.len() == n * n && d.len() == n && active.len() == n);
    // The work space: L (n × n), then h and s; on the stack for a few parameters (the
    // initialisation solves hundreds of small systems per fit), else on the heap.
    let mut small = [0.0; SMALL * SMALL + 2 * SMALL];
    let mut large = Vec::new();
    let work: &mut [f64] = if n <= SMALL {
        &mut small[..n * n + 2 * n]
    } else {
        large.resize(n * n + 2 * n, 0.0);
        &mut large
    };
    let (l, hs) = work.split_at_mut(n * n);
    let (h, s) = hs.split_at_mut(n);
    // Scale by s_i = 1/√d_i so the scaled matrix has a unit-ish diagonal: better conditioned.
    for ((hi, si), v) in h.iter_mut().zip(s.iter_mut()).zip(d) {
        *hi = 1.0 / v.sqrt();
        *si = *hi;
    }
    // The scaled, damped matrix, then its factor L in place (lower triangle, row-major).
    for i in 0..n {
        for j in 0..=i {
            let mut v = if active[i] || active[j] {
                if i == j { 1.0 } else { 0.0 }
            } else {
                a[i * n + j] * s[i] * s[j]
            };
            if i == j {
                v += mu;
            }
            for k in 0..j {
                v -= l[i * n + k] * l[j * n + k];
            }
            l[i * n + j] = if i == j {
                if !(v > 0.0) {
                    return None;
                }
                v.sqrt()
            } else {
                v / l[j * n + j]
            };
        }
    }
    // L y = rhs, then Lᵀ z = y, in place in `h`; the step is s ∘ z.
    for i in 0..n {
        let mut v = if active[i] { 0.0 } else { -g[i] * s[i] };
        for k in 0..i {
            v -= l[i * n + k] * h[k];
        }
        h[i] = v / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut v = h[i];
        for k in i + 1..n {
            v -= l[k * n + i] * h[k];
        }
        h[i] = v / l[i * n + i];
    }
    for (v, si) in h.iter_mut().zip(&*s) {
        *v *= si;
    }
    h.iter().all(|v| v.is_finite()).then(|| h.to_vec())
}

/// Systems of at most this many unknowns are solved by [`damped_solve`] without a heap work
/// space.
const SMALL: usize = crate::model::MAX_PARAMS;

/// Where `x` sits on its box: −1 at the lower bound, +1 at the upper, 0 inside.
pub fn bound_side(x: f64, (lo, hi): (f64, f64)) -> i8 {
    let tol = |b: f64| 1e-12 * (1.0 + b.abs());
    if x <= lo + tol(lo) {
        -1
    } else if x >= hi - tol(hi) {
        1
    } else {
        0
    }
}

/// The active set of Bertsekas' projected Newton method (SIAM J. Control Optim. 20, 1982):
/// the variables at a bound whose cost gradient `g` points out of the box, so that no descent
/// step can move them. A variable at a bound whose gradient points inward is free and leaves it.
pub fn active_set(x: &[f64], g: &[f64], bounds: &[(f64, f64)]) -> Vec<bool> {
    (0..x.len())
        .map(|i| match bound_side(x[i], bounds[i]) {
            -1 => g[i] >= 0.0,
            1 => g[i] <= 0.0,
            _ => false,
        })
        .collect()
}

/// Clamp `x` onto the box.
pub(crate) fn project(x: &mut [f64], bounds: &[(f64, f64)]) {
    for (v, (lo, hi)) in x.iter_mut().zip(bounds) {
        *v = v.clamp(*lo, *hi);
    }
}

fn scale_diag(n: &Normal, dim: usize) -> Vec<f64> {
    let maxd = (0..dim)
        .map(|i| n.jtj[i * dim + i])
        .fold(0.0f64, f64::max)
        .max(1e-300);
    (0..dim)
        .map(|i| n.jtj[i * dim + i].max(1e-12 * maxd))
        .collect()
}

/// The scaled-gradient convergence test on the free variables (the projected gradient):
/// max |(Jᵀr)_i|/√d_i ≤ gtol·√(2 cost), or a zero cost.
fn gradient_small(ne: &Normal, d: &[f64], gtol: f64, active: &[bool]) -> bool {
    let gmax = d
        .iter()
        .zip(&ne.jtr)
        .zip(active)
        .filter(|(_, a)| !**a)
        .map(|((di, g), _)| g.abs() / di.sqrt())
        .fold(0.0f64, f64::max);
    gmax <= gtol * (2.0 * ne.cost).sqrt().max(1e-300) || ne.cost == 0.0
}

/// Minimise with the chosen method from `x0` (projected onto the bounds first).
pub fn solve<P: Problem>(
    p: &P,
    x0: &[f64],
    method: Method,
    robust: Robust,
    limits: &Limits,
) -> Solution {
    match method {
        Method::Lm => levenberg_marquardt(p, x0, robust, limits),
        Method::GaussNewton => gauss_newton(p, x0, robust, limits),
        Method::NelderMead => nelder_mead(p, x0, robust, limits),
        _ => super::argmin_peer::solve(p, x0, method, robust, limits),
    }
}

fn failed(x: Vec<f64>, why: &str, evaluations: usize) -> Solution {
    Solution {
        x,
        cost: f64::INFINITY,
        iterations: 0,
        evaluations,
        termination: why.to_string(),
        converged: false,
        normal: None,
    }
}

/// Levenberg–Marquardt (see the module documentation).
pub fn levenberg_marquardt<P: Problem>(
    p: &P,
    x0: &[f64],
    robust: Robust,
    limits: &Limits,
) -> Solution {
    let dim = p.dim();
    let bounds = p.bounds();
    let mut x = x0.to_vec();
    project(&mut x, &bounds);
    let mut evals = 1;
    let Some(mut ne) = normal_equations(p, &x, robust) else {
        return failed(x, "the start point gives a non-finite cost", evals);
    };
    let mut d = scale_diag(&ne, dim);
    let scale = p.step_scale();
    let mut mu = 1e-3;
    let mut nu = 2.0;
    let mut iter = 0;
    // Steps tried (each costs one evaluation): what `iterations` reports. `iter` also counts
    // the passes that only raise the damping, and bounds the loop.
    let mut steps = 0;
    let mut termination = "iteration limit reached".to_string();
    let mut converged = false;
    // The cost at the start and after each accepted step (for `limits.stall` and
    // `limits.resolution`).
    let mut accepted = vec![ne.cost];
    // Where the cost curves more than JᵀJ says along the step (a large residual), the
    // Gauss–Newton step overshoots and the steps alternate in sign, each a fixed fraction of
    // the last; where it curves less (the residuals' own curvature against JᵀJ), the step
    // undershoots and the steps keep one direction, each again a fixed fraction of the last,
    // the cost falling by more than predicted (gain ratio ρ > 1). Either is a linear rate.
    // Once two accepted steps point opposite ways, every step is scaled by `gain` ≤ 1, the
    // minimum of the cost along the last step (see [`line_minimum`]). Once two point the same
    // way (cosine > ½), the second with ρ > UNDERSHOT, lightly damped (μ < 0.1) and not cut
    // by a bound, every step is extended likewise to that minimum (gain in [1, MAX_GAIN]),
    // for as long as the steps keep their direction. An extended step is judged against the
    // model's prediction for its own step times the gain (what the parabola along the line
    // gives at its minimum); one rejected, or too long for the step bound, ends the
    // extension. On the bundled and test files (1,854 fits) this took 6.6 % fewer passes
    // over the data, a fifth fewer for Phong and Torrance–Sparrow D1/D2.
    const MAX_GAIN: f64 = 4.0;
    const UNDERSHOT: f64 = 1.2;
    let mut gain = 1.0;
    let mut last_step: Option<Vec<f64>> = None;
    while iter < limits.max_iter {
        if evals >= limits.max_eval {
            termination = "evaluation limit reached".into();
            break;
        }
        // Scaled gradient test on the free variables.
        let active = active_set(&x, &ne.jtr, &bounds);
        if gradient_small(&ne, &d, limits.gtol, &active) {
            termination = "gradient below tolerance".into();
            converged = true;
            break;
        }
        iter += 1;
        // Marquardt's scaling: keep the largest diagonal seen (Moré 1978).
        for i in 0..dim {
            d[i] = d[i].max(ne.jtj[i * dim + i]);
        }
        let Some(mut h) = damped_solve(&ne.jtj, &ne.jtr, &d, mu, &active) else {
            mu *= nu;
            nu *= 2.0;
            if mu > 1e20 {
                termination = "damping limit reached (singular system)".into();
                break;
            }
            continue;
        };
        // Relative step bound: no parameter moves by more than its own magnitude in one step
        // (floored at 1e-3 of the largest and at the problem's step scale). This stops "parameter evaporation", where a long
        // first step lands on a plateau (an exponential saturated, F ≈ 1) that is a false
        // minimum at infinity; the damping grows until the step fits, without evaluations.
        h.iter_mut().for_each(|v| *v *= gain);
        let xmax = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let too_long =
            (0..dim).any(|i| h[i].abs() > x[i].abs().max(1e-3 * xmax).max(scale[i]).max(1e-6));
        if too_long && gain > 1.0 {
            // The extension, not the model's step, went too far: the model's step instead.
            gain = 1.0;
            continue;
        }
        if too_long && mu < 1e20 {
            mu *= 2.0;
            continue;
        }
        let mut xn: Vec<f64> = x.iter().zip(&h).map(|(a, b)| a + b).collect();
        project(&mut xn, &bounds);
        let step: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        // A step cut short by a bound leaves the line the extension measures.
        let clipped = xn.iter().zip(&x).zip(&h).any(|((n, a), b)| *n != a + b);
        let snorm = step
            .iter()
            .zip(&d)
            .map(|(s, di)| (s * di.sqrt()).powi(2))
            .sum::<f64>()
            .sqrt();
        let xnorm = x
            .iter()
            .zip(&d)
            .map(|(s, di)| (s * di.sqrt()).powi(2))
            .sum::<f64>()
            .sqrt();
        if snorm <= limits.xtol * (xnorm + limits.xtol) {
            termination = "step below tolerance".into();
            converged = true;
            break;
        }
        // Predicted reduction of the linear model for t times the projected step.
        let pred_at = |t: f64| {
            let mut pred = 0.0;
            for a in 0..dim {
                let mut jh = 0.0;
                for b in 0..dim {
                    jh += ne.jtj[a * dim + b] * step[b];
                }
                pred -= t * step[a] * (ne.jtr[a] + 0.5 * t * jh);
            }
            pred
        };
        let pred = if gain > 1.0 {
            gain * pred_at(1.0 / gain)
        } else {
            pred_at(1.0)
        };
        if pred >= 0.0 && pred <= limits.ftol * ne.cost && mu < 1.0 {
            // Even the full step would change the cost by less than ftol: converged without
            // spending another pass over the data.
            termination = "predicted reduction below tolerance".into();
            converged = true;
            break;
        }
        // One pass gives the cost and, if the step is accepted, the next normal equations.
        evals += 1;
        steps += 1;
        let trial = normal_equations(p, &xn, robust);
        let cn = trial.as_ref().map_or(f64::INFINITY, |t| t.cost);
        let actual = ne.cost - cn;
        let rho = if pred > 0.0 { actual / pred } else { -1.0 };
        if cn.is_finite() && actual > 0.0 && rho > 0.0 {
            let small = actual <= limits.ftol * ne.cost;
            // This step against the last, in the scaled norm: opposite, or the same way.
            let (dot, norms) = last_step.as_ref().map_or((0.0, 0.0), |l| {
                let (dot, ll, ss) = (0..dim).fold((0.0, 0.0, 0.0), |(a, b, c), i| {
                    (
                        a + l[i] * step[i] * d[i],
                        b + l[i] * l[i] * d[i],
                        c + step[i] * step[i] * d[i],
                    )
                });
                (dot, (ll * ss).sqrt())
            });
            let slope: f64 = (0..dim).map(|i| ne.jtr[i] * step[i]).sum();
            let along = dot > 0.5 * norms;
            if dot < -0.5 * norms || gain < 1.0 {
                gain = (gain * line_minimum(slope, -actual)).clamp(0.1, 1.0);
            } else if along && !clipped && (gain > 1.0 || (rho > UNDERSHOT && mu < 0.1)) {
                gain = (gain * line_minimum(slope, -actual)).clamp(1.0, MAX_GAIN);
            } else {
                gain = 1.0;
            }
            last_step = Some(step);
            x = xn;
            ne = trial.expect("finite trial");
            mu *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
            nu = 2.0;
            if small {
                termination = "cost reduction below tolerance".into();
                converged = true;
                break;
            }
            accepted.push(ne.cost);
            let k = RESOLUTION_STEPS;
            if limits.resolution > 0.0
                && accepted.len() > k
                && accepted[accepted.len() - 1 - k] - ne.cost <= limits.resolution * ne.cost
            {
                termination = format!(
                    "cost within the data's resolution: {k} steps lowered it by less than {:.1e} \
                     relative",
                    limits.resolution
                );
                converged = true;
                break;
            }
            let (window, tol) = limits.stall;
            if window > 0 {
                let before = accepted[accepted.len().saturating_sub(window + 1)];
                if accepted.len() > window && ne.cost >= before * (1.0 - tol) {
                    termination = format!(
                        "stalled: the cost fell by less than {tol:e} relative over {window} steps"
                    );
                    break;
                }
            }
        } else {
            gain = gain.min(1.0);
            mu *= nu;
            nu *= 2.0;
            if mu > 1e20 {
                termination = "no further reduction possible".into();
                converged = true;
                break;
            }
        }
    }
    Solution {
        cost: ne.cost,
        x,
        iterations: steps,
        evaluations: evals,
        termination,
        converged,
        normal: Some(ne),
    }
}

/// The multiple of a step at the minimum of the parabola along it through the cost's slope
/// `slope` at the start and its change `rise` at the full step: −slope / (2 (rise − slope)),
/// or 1 where that parabola has no minimum.
pub(crate) fn line_minimum(slope: f64, rise: f64) -> f64 {
    let curvature = 2.0 * (rise - slope);
    if slope < 0.0 && curvature > 0.0 {
        -slope / curvature
    } else {
        1.0
    }
}

/// Gauss–Newton with a bounded Armijo line search (see the module documentation).
pub fn gauss_newton<P: Problem>(p: &P, x0: &[f64], robust: Robust, limits: &Limits) -> Solution {
    let dim = p.dim();
    let bounds = p.bounds();
    let mut x = x0.to_vec();
    project(&mut x, &bounds);
    let mut evals = 1;
    let Some(mut ne) = normal_equations(p, &x, robust) else {
        return failed(x, "the start point gives a non-finite cost", evals);
    };
    let mut iter = 0;
    let mut termination = "iteration limit reached".to_string();
    let mut converged = false;
    while iter < limits.max_iter && evals < limits.max_eval {
        let d = scale_diag(&ne, dim);
        let active = active_set(&x, &ne.jtr, &bounds);
        if gradient_small(&ne, &d, limits.gtol, &active) {
            termination = "gradient below tolerance".into();
            converged = true;
            break;
        }
        iter += 1;
        // A pure Gauss–Newton step; a tiny ridge only where JᵀJ is numerically singular.
        let Some(h) = damped_solve(&ne.jtj, &ne.jtr, &d, 1e-12, &active)
            .or_else(|| damped_solve(&ne.jtj, &ne.jtr, &d, 1e-6, &active))
        else {
            termination = "singular normal equations".into();
            break;
        };
        let slope: f64 = h.iter().zip(&ne.jtr).map(|(a, b)| a * b).sum();
        if slope >= 0.0 {
            termination = "not a descent direction".into();
            break;
        }
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..40 {
            if evals >= limits.max_eval {
                break;
            }
            let mut xn: Vec<f64> = x.iter().zip(&h).map(|(a, b)| a + alpha * b).collect();
            project(&mut xn, &bounds);
            evals += 1;
            if let Some(cn) = cost(p, &xn, robust)
                && cn <= ne.cost + 1e-4 * alpha * slope
            {
                accepted = Some((xn, cn));
                break;
            }
            alpha *= 0.5;
        }
        let Some((xn, cn)) = accepted else {
            termination = "line search found no decrease".into();
            converged = true;
            break;
        };
        let small = ne.cost - cn <= limits.ftol * ne.cost;
        x = xn;
        evals += 1;
        match normal_equations(p, &x, robust) {
            Some(n2) => ne = n2,
            None => {
                termination = "non-finite Jacobian at an accepted point".into();
                break;
            }
        }
        if small {
            termination = "cost reduction below tolerance".into();
            converged = true;
            break;
        }
    }
    if evals >= limits.max_eval && !converged {
        termination = "evaluation limit reached".into();
    }
    Solution {
        cost: ne.cost,
        x,
        iterations: iter,
        evaluations: evals,
        termination,
        converged,
        normal: Some(ne),
    }
}

/// Nelder–Mead on the cost (see the module documentation).
pub fn nelder_mead<P: Problem>(p: &P, x0: &[f64], robust: Robust, limits: &Limits) -> Solution {
    let n = p.dim();
    let bounds = p.bounds();
    let mut evals = 0;
    let f = |x: &mut Vec<f64>, evals: &mut usize| {
        project(x, &bounds);
        *evals += 1;
        cost(p, x, robust).unwrap_or(f64::INFINITY)
    };
    let mut start = x0.to_vec();
    let f0 = f(&mut start, &mut evals);
    let mut simplex: Vec<(Vec<f64>, f64)> = vec![(start.clone(), f0)];
    for i in 0..n {
        let mut v = start.clone();
        v[i] += if v[i].abs() > 1e-3 { 0.1 * v[i] } else { 0.1 };
        let fv = f(&mut v, &mut evals);
        simplex.push((v, fv));
    }
    let mut iter = 0;
    let mut termination = "iteration limit reached".to_string();
    let mut converged = false;
    let max_iter = limits.max_iter * 4;
    while iter < max_iter {
        if evals >= limits.max_eval * 2 {
            termination = "evaluation limit reached".into();
            break;
        }
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        let spread = simplex
            .iter()
            .flat_map(|(v, _)| v.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
            .fold(0.0f64, f64::max);
        if best.is_finite()
            && (worst - best).abs() <= 1e-15 * best.abs().max(1e-300)
            && spread < 1e-10
        {
            termination = "simplex collapsed".into();
            converged = true;
            break;
        }
        iter += 1;
        let centroid: Vec<f64> = (0..n)
            .map(|k| simplex[..n].iter().map(|(v, _)| v[k]).sum::<f64>() / n as f64)
            .collect();
        let towards = |t: f64| -> Vec<f64> {
            centroid
                .iter()
                .zip(&simplex[n].0)
                .map(|(c, w)| c + t * (w - c))
                .collect()
        };
        let mut xr = towards(-1.0);
        let fr = f(&mut xr, &mut evals);
        if fr < simplex[0].1 {
            let mut xe = towards(-2.0);
            let fe = f(&mut xe, &mut evals);
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (mut xc, fc) = if fr < simplex[n].1 {
                let mut xc = towards(-0.5);
                let fc = f(&mut xc, &mut evals);
                (xc, fc)
            } else {
                let mut xc = towards(0.5);
                let fc = f(&mut xc, &mut evals);
                (xc, fc)
            };
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (std::mem::take(&mut xc), fc);
            } else {
                let b = simplex[0].0.clone();
                for item in simplex.iter_mut().skip(1) {
                    let mut v: Vec<f64> = b
                        .iter()
                        .zip(&item.0)
                        .map(|(a, c)| a + 0.5 * (c - a))
                        .collect();
                    let fv = f(&mut v, &mut evals);
                    *item = (v, fv);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, c) = simplex.swap_remove(0);
    Solution {
        x,
        cost: c,
        iterations: iter,
        evaluations: evals,
        termination,
        converged,
        normal: None,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// `damped_solve` on symmetric positive definite systems of 2 to 12 unknowns (the stack
    /// work space up to 8, the heap beyond), some variables in the active set: its step solves
    /// the free rows of A h = −g with the active variables at 0, to 1e-10 (the residual
    /// computed here, row by row).
    #[test]
    fn damped_solve_solves_the_free_rows_on_the_stack_and_the_heap() {
        for n in [2, 7, 8, 9, 12] {
            // A = BᵀB + I with B's entries spread by a sine (no two rows alike).
            let b: Vec<f64> = (0..n * n).map(|k| (1.7 * k as f64 + 0.3).sin()).collect();
            let a: Vec<f64> = (0..n * n)
                .map(|ij| {
                    let (i, j) = (ij / n, ij % n);
                    let dot: f64 = (0..n).map(|r| b[r * n + i] * b[r * n + j]).sum();
                    dot + if i == j { 1.0 } else { 0.0 }
                })
                .collect();
            let g: Vec<f64> = (0..n).map(|i| (0.9 * i as f64).cos() - 0.2).collect();
            let d: Vec<f64> = (0..n).map(|i| a[i * n + i]).collect();
            for active in [vec![false; n], (0..n).map(|i| i % 3 == 1).collect()] {
                let h = damped_solve(&a, &g, &d, 0.0, &active).expect("positive definite");
                assert_eq!(h.len(), n);
                for i in 0..n {
                    if active[i] {
                        assert_eq!(h[i], 0.0, "n {n}: active {i}");
                        continue;
                    }
                    let row: f64 = (0..n).map(|j| a[i * n + j] * h[j]).sum();
                    assert!(
                        (row + g[i]).abs() <= 1e-10,
                        "n {n} row {i}: {row} against {}",
                        -g[i]
                    );
                }
            }
        }
    }

    /// A pass's chunks tile the residuals in order, none longer than [`CHUNK`], their lengths
    /// within one of each other, an even number of them once the pass runs in parallel (so
    /// rayon's halving gives two cores equal shares), a lone chunk below two chunks' worth.
    #[test]
    fn chunks_are_equal_and_even() {
        for m in [
            0, 1, 7, 2_000, 4_096, 4_097, 8_192, 10_000, 16_512, 20_000, 1_000_000,
        ] {
            let ranges = map_chunks(m, |r| r);
            let mut next = 0;
            for r in &ranges {
                assert_eq!(r.start, next, "m {m}");
                next = r.end;
            }
            assert_eq!(next, m, "m {m}");
            let lens: Vec<usize> = ranges.iter().map(|r| r.len()).collect();
            let (lo, hi) = (lens.iter().min(), lens.iter().max());
            if let (Some(&lo), Some(&hi)) = (lo, hi) {
                assert!(hi <= CHUNK && hi - lo <= 1, "m {m}: {lens:?}");
            }
            let want = match m {
                0 => 0,
                1..=4_096 => 1,
                _ => m.div_ceil(CHUNK).next_multiple_of(2),
            };
            assert_eq!(ranges.len(), want, "m {m}");
        }
        assert_eq!(map_chunks(10_000, |r| r.len()), vec![2_500; 4]);
    }

    /// Rosenbrock as least squares, r1 = 10(x2 − x1²), r2 = 1 − x1, in a box (none:
    /// [`Rosen::free`]); also used by the argmin wrapper's tests.
    pub(crate) struct Rosen(pub Vec<(f64, f64)>);

    impl Rosen {
        /// No bounds.
        pub(crate) fn free() -> Self {
            Rosen(vec![(f64::NEG_INFINITY, f64::INFINITY); 2])
        }
    }

    impl Problem for Rosen {
        type Prepared = Vec<f64>;
        fn dim(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            2
        }
        fn prepare(&self, x: &[f64]) -> Option<Vec<f64>> {
            Some(x.to_vec())
        }
        fn residual_grad(&self, x: &Vec<f64>, i: usize, row: &mut [f64]) -> f64 {
            if i == 0 {
                row[0] = -20.0 * x[0];
                row[1] = 10.0;
                10.0 * (x[1] - x[0] * x[0])
            } else {
                row[0] = -1.0;
                row[1] = 0.0;
                1.0 - x[0]
            }
        }
        fn bounds(&self) -> Vec<(f64, f64)> {
            self.0.clone()
        }
    }

    #[test]
    fn all_methods_solve_rosenbrock() {
        for m in [Method::Lm, Method::GaussNewton, Method::NelderMead] {
            let s = solve(
                &Rosen::free(),
                &[-1.2, 1.0],
                m,
                Robust::None,
                &Limits::default(),
            );
            assert!(
                (s.x[0] - 1.0).abs() < 1e-6 && (s.x[1] - 1.0).abs() < 1e-6,
                "{m:?}: {s:?}"
            );
            assert!(s.iterations > 0 && s.iterations <= 20 * Limits::default().max_iter);
            // Iterations are steps tried, each evaluated once (LM counted damping-only passes).
            assert!(s.iterations < s.evaluations, "{m:?}: {s:?}");
        }
    }

    /// Dennis and Schnabel's large-residual example: r1 = x + 1, r2 = λx² + x − 1, minimum at
    /// x = 0 (cost 1), where JᵀJ = 2 and the cost's second derivative is 2 − 2λ. With λ < 0
    /// the Gauss–Newton step overshoots: each error is λ times the last, alternating.
    struct LargeResidual(f64);

    impl Problem for LargeResidual {
        type Prepared = f64;
        fn dim(&self) -> usize {
            1
        }
        fn n_residuals(&self) -> usize {
            2
        }
        fn prepare(&self, x: &[f64]) -> Option<f64> {
            Some(x[0])
        }
        fn residual_grad(&self, x: &f64, i: usize, row: &mut [f64]) -> f64 {
            if i == 0 {
                row[0] = 1.0;
                x + 1.0
            } else {
                row[0] = 2.0 * self.0 * x + 1.0;
                self.0 * x * x + x - 1.0
            }
        }
        fn bounds(&self) -> Vec<(f64, f64)> {
            vec![(-10.0, 10.0)]
        }
    }

    #[test]
    fn an_overshooting_step_is_shrunk_to_the_minimum() {
        // The parabola 3 (t − 0.4)²: slope −2.4 at 0, rise 0.6 at 1, minimum at 0.4.
        assert!((line_minimum(-2.4, 0.6) - 0.4).abs() < 1e-15);
        // No minimum ahead (rising at the start, or not curving up): the full step.
        assert_eq!(line_minimum(1.0, 2.0), 1.0);
        assert_eq!(line_minimum(-1.0, -2.0), 1.0);
        // Gauss–Newton alone would halve the error each step, alternating: 20 steps or more
        // to the default tolerance. Shrunk after the first reversal, a handful.
        let s = levenberg_marquardt(
            &LargeResidual(-0.5),
            &[0.5],
            Robust::None,
            &Limits::default(),
        );
        assert!(s.converged && s.x[0].abs() < 1e-7, "{s:?}");
        assert!((s.cost - 1.0).abs() < 1e-13, "{s:?}");
        assert!(s.iterations <= 8, "{s:?}");
    }

    #[test]
    fn an_undershooting_step_is_extended_to_the_minimum() {
        // The parabola (t − 2.5)²/2.5: slope −2 at 0, rise −1.6 at 1 (ρ = 1.6 against the
        // model's 1), minimum at 2.5 = 1/(2 − ρ).
        assert!((line_minimum(-2.0, -1.6) - 2.5).abs() < 1e-15);
        // With 0 < λ < 1 the cost curves less than JᵀJ (2 − 2λ against 2): Gauss–Newton
        // alone leaves λ of the error each step, the same sign, and the minimum along a step
        // lies 1/(1 − λ) of it ahead. With λ = 0.7 the steps unextended (MAX_GAIN = 1) took
        // 38 and stopped at x = 2.7e-7, the cost 2.3e-14 above its minimum; extended, 8, at
        // x = 1.8e-10.
        let s = levenberg_marquardt(
            &LargeResidual(0.7),
            &[0.5],
            Robust::None,
            &Limits::default(),
        );
        assert!(s.converged && s.x[0].abs() < 1e-8, "{s:?}");
        assert!((s.cost - 1.0).abs() < 1e-14, "{s:?}");
        assert!(s.iterations <= 10, "{s:?}");
    }

    /// r1 = 1 (no parameter reaches it), r2 = 10⁻³/x, x > 0: the cost ½ + ½·10⁻⁶/x² falls
    /// forever as x grows, by less than 10⁻⁶ relative in all once x ≥ 1.
    struct Plateau;

    impl Problem for Plateau {
        type Prepared = f64;
        fn dim(&self) -> usize {
            1
        }
        fn n_residuals(&self) -> usize {
            2
        }
        fn prepare(&self, x: &[f64]) -> Option<f64> {
            Some(x[0])
        }
        fn residual_grad(&self, x: &f64, i: usize, row: &mut [f64]) -> f64 {
            if i == 0 {
                row[0] = 0.0;
                1.0
            } else {
                row[0] = -1e-3 / (x * x);
                1e-3 / x
            }
        }
        fn bounds(&self) -> Vec<(f64, f64)> {
            vec![(1e-9, f64::INFINITY)]
        }
    }

    #[test]
    fn a_stalled_slide_stops_after_its_window() {
        let off = levenberg_marquardt(&Plateau, &[1.0], Robust::None, &Limits::default());
        let window = 3;
        let limits = Limits {
            stall: (window, 1e-6),
            ..Limits::default()
        };
        let on = levenberg_marquardt(&Plateau, &[1.0], Robust::None, &limits);
        // From x = 1 the whole remaining fall, ½·10⁻⁶, is below 10⁻⁶ of the cost ½: the first
        // full window ends the run.
        assert!(on.termination.starts_with("stalled"), "{on:?}");
        assert_eq!(on.iterations, window, "{on:?}");
        assert!(
            !off.termination.starts_with("stalled") && off.iterations > window,
            "{off:?}"
        );
        // Both within 10⁻⁶ of the infimum ½.
        assert!(
            on.cost - 0.5 <= 0.5e-6 && off.cost <= on.cost,
            "{on:?} {off:?}"
        );
        // Off by default: every other run is unchanged.
        assert_eq!(Limits::default().stall.0, 0);
    }

    /// r = 1 − x/10⁶ from x = 1: the step bound lets x at most double per step, so each step
    /// lowers the cost by about 2x·10⁻⁶ of it, a slide that speeds up until x nears 10⁶.
    struct Slide;

    impl Problem for Slide {
        type Prepared = f64;
        fn dim(&self) -> usize {
            1
        }
        fn n_residuals(&self) -> usize {
            1
        }
        fn prepare(&self, x: &[f64]) -> Option<f64> {
            Some(x[0])
        }
        fn residual_grad(&self, x: &f64, _: usize, row: &mut [f64]) -> f64 {
            row[0] = -1e-6;
            1.0 - x * 1e-6
        }
        fn bounds(&self) -> Vec<(f64, f64)> {
            vec![(1e-9, f64::INFINITY)]
        }
    }

    #[test]
    fn the_resolution_ends_a_converging_tail_not_a_slide() {
        let tol = 5e-6;
        let resolution = Limits {
            resolution: tol,
            ..Limits::default()
        };
        // The plateau's whole remaining fall from x = 1 is ½·10⁻⁶, below 5·10⁻⁶ of the cost:
        // the first three steps end it, converged.
        let tail = levenberg_marquardt(&Plateau, &[1.0], Robust::None, &resolution);
        assert!(
            tail.converged && tail.termination.contains("resolution"),
            "{tail:?}"
        );
        assert_eq!(tail.iterations, RESOLUTION_STEPS, "{tail:?}");
        // The slide's first steps each gain less than 5·10⁻⁶ of the cost (x = 1 → 2: 2·10⁻⁶),
        // three together more: it goes on to the minimum x = 10⁶, where a per-step test of
        // the same tolerance (ftol) stops at once.
        let slide = levenberg_marquardt(&Slide, &[1.0], Robust::None, &resolution);
        assert!((slide.x[0] - 1e6).abs() < 1.0, "{slide:?}");
        assert!(slide.iterations > 15, "{slide:?}");
        let per_step = Limits {
            ftol: tol,
            ..Limits::default()
        };
        let early = levenberg_marquardt(&Slide, &[1.0], Robust::None, &per_step);
        assert!(early.x[0] < 10.0, "{early:?}");
        // Off by default.
        assert_eq!(Limits::default().resolution, 0.0);
    }

    #[test]
    fn robust_weights_are_derivative_over_r() {
        for rb in [Robust::Huber(0.5), Robust::Cauchy(0.5)] {
            for &r in &[0.1, 0.7, 3.0] {
                let h = 1e-6;
                let d = (rb.rho(r + h) - rb.rho(r - h)) / (2.0 * h);
                assert!((d / r - rb.weight(r)).abs() < 1e-6, "{rb:?} at {r}");
            }
        }
    }
}

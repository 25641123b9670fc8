//! Energy conservation as a constraint of the fit: where the least-squares minimum describes a
//! material whose directional albedo ρ(θi) = ∫ f_r cosθo dω exceeds 1 at some θi of
//! [`ALBEDO_THETA_I_DEG`](crate::model::albedo::ALBEDO_THETA_I_DEG), the fit is solved again on the feasible set ρ ≤ 1.
//!
//! f_r is linear in each channel's linear parameters ℓ (each lobe's ps, and pd), so ρ(θi) is
//! too: scaling ℓ by s = 1/max ρ puts any point on the boundary ρ_max = 1 of the feasible set,
//! exactly. The constrained problem is solved as an unconstrained one through that projection
//! P: minimise S(P(x)) over the solver variables with, in each channel, the linear parameter
//! that contributes most to the albedo pinned (the projection makes every point of a ray ℓ·t
//! the same, and pinning one parameter removes that direction; every boundary point with that
//! parameter positive stays reachable). The minimum of S∘P is the minimum of S on the boundary,
//! which is the constrained minimum when the unconstrained one lies outside (a projection
//! method in the sense of Nocedal & Wright, "Numerical Optimization", 2006, §17.1, by
//! elimination of the active constraint). Residuals and their Jacobian J·dP/dx come from the
//! wrapped problem; dP/dx by central differences of the quadrature (whose error, about 1e-12,
//! stays far below the step's 1e-6).
//!
//! The albedo is held at the θi where it exceeded 1 (the worst of each channel first, then any
//! other that the constrained fit still violates, at most three rounds), each by the fine
//! quadrature of [`directional_albedo`].

use super::lsq::{self, Limits, Normal, Problem, Robust};
use super::problem::{BrdfProblem, Slot};
use crate::model::albedo::directional_albedo;
use crate::model::{Model, Role, Scale};
use std::sync::OnceLock;

/// The start of the warning of a fit held by energy conservation (the flag `held`).
pub const HELD: &str = "energy conservation holds the fit";

/// The albedo the constrained fit holds at its active angles.
pub const TARGET: f64 = 1.0;

/// Rounds of the active set of angles at most.
const ROUNDS: usize = 3;

/// A [`BrdfProblem`] seen through the projection onto ρ_max = [`TARGET`] (see the module
/// documentation): its variables are the wrapped problem's but the pinned ones.
pub(super) struct Conserved<'a> {
    inner: &'a BrdfProblem,
    /// The wrapped problem's variables, with the pinned ones at their values.
    base: Vec<f64>,
    /// The wrapped problem's index of each variable of this one.
    keep: Vec<usize>,
    /// Per channel, the wrapped problem's indices of its linear variables.
    linear: Vec<Vec<usize>>,
    /// The incidence angles (radians) at which the albedo is held.
    angles: Vec<f64>,
}

/// Per-evaluation data: the wrapped problem's at P(x), and dP/dx (made on first use: a cost
/// evaluation does not need it).
pub(super) struct Prepared<T> {
    inner: T,
    x: Vec<f64>,
    jac: OnceLock<Option<Vec<f64>>>,
}

impl<'a> Conserved<'a> {
    /// The projection of `inner` at its variables `x` holding the albedo at `angles` (radians),
    /// or `None` where it cannot be made: a linear parameter shared by channels, held at a
    /// non-zero value, or not on a linear scale, or a channel without one.
    pub(super) fn new(inner: &'a BrdfProblem, x: &[f64], angles: Vec<f64>) -> Option<Self> {
        let specs = inner.template.specs();
        let np = inner.n_model_params();
        let models = inner.models(x);
        let mut linear = Vec::new();
        let mut pinned = Vec::new();
        for (c, slots) in inner.layout.iter().enumerate() {
            let mut mine = Vec::new();
            let mut best = (f64::NEG_INFINITY, usize::MAX);
            for j in (0..np).filter(|&j| matches!(specs[j].role, Role::Specular | Role::Diffuse)) {
                match slots[j] {
                    Slot::Fixed(0.0) => continue,
                    Slot::Fixed(_) => return None,
                    Slot::Free(k) => {
                        let shared = inner
                            .layout
                            .iter()
                            .enumerate()
                            .any(|(d, s)| d != c && s[..np].contains(&Slot::Free(k)));
                        if shared || inner.transforms[k].scale != Scale::Linear {
                            return None;
                        }
                        mine.push(k);
                        // This parameter's share of the albedo at the angles.
                        let mut p = models[c].params().to_vec();
                        for (i, s) in specs.iter().enumerate() {
                            if i != j && matches!(s.role, Role::Specular | Role::Diffuse) {
                                p[i] = 0.0;
                            }
                        }
                        let one = models[c].with_params(&p);
                        let share = max_rho(&one, &angles);
                        if share > best.0 {
                            best = (share, k);
                        }
                    }
                }
            }
            if mine.is_empty() || best.1 == usize::MAX {
                return None;
            }
            linear.push(mine);
            pinned.push(best.1);
        }
        let keep = (0..inner.dim()).filter(|k| !pinned.contains(k)).collect();
        Some(Conserved {
            inner,
            base: x.to_vec(),
            keep,
            linear,
            angles,
        })
    }

    /// The wrapped problem's variables for this one's `y`.
    pub(super) fn expand(&self, y: &[f64]) -> Vec<f64> {
        let mut x = self.base.clone();
        for (&k, &v) in self.keep.iter().zip(y) {
            x[k] = v;
        }
        x
    }

    /// This problem's variables for the wrapped problem's `x`.
    pub(super) fn restrict(&self, x: &[f64]) -> Vec<f64> {
        self.keep.iter().map(|&k| x[k]).collect()
    }

    /// P(x): each channel's linear variables scaled so that its largest albedo over the angles
    /// is [`TARGET`]; `None` where an albedo is not a positive number.
    pub(super) fn project(&self, x: &[f64]) -> Option<Vec<f64>> {
        let mut y = x.to_vec();
        for (m, lin) in self.inner.models(x).iter().zip(&self.linear) {
            let rho = max_rho(m, &self.angles);
            if !(rho > 0.0 && rho.is_finite()) {
                return None;
            }
            let s = TARGET / rho;
            for &k in lin {
                y[k] = x[k] * s;
            }
        }
        Some(y)
    }

    /// dP/dx (wrapped variables × these, row-major) by central differences.
    fn jacobian(&self, y: &[f64]) -> Option<Vec<f64>> {
        use rayon::prelude::*;
        let (p, q) = (self.inner.dim(), self.keep.len());
        let bounds = self.bounds();
        let cols: Vec<Option<Vec<f64>>> = (0..q)
            .into_par_iter()
            .map(|k| {
                let h = 1e-6 * y[k].abs().max(1.0);
                let (lo, hi) = bounds[k];
                let (a, b) = ((y[k] - h).max(lo), (y[k] + h).min(hi));
                if !(b > a) {
                    return None;
                }
                let at = |v: f64| {
                    let mut z = y.to_vec();
                    z[k] = v;
                    self.project(&self.expand(&z))
                };
                let (pa, pb) = (at(a)?, at(b)?);
                Some((0..p).map(|i| (pb[i] - pa[i]) / (b - a)).collect())
            })
            .collect();
        let mut m = vec![0.0; p * q];
        for (k, col) in cols.into_iter().enumerate() {
            let col = col?;
            for i in 0..p {
                m[i * q + k] = col[i];
            }
        }
        Some(m)
    }

    /// The wrapped problem's row `inner` (length p) through dP/dx into `row` (length q).
    fn chain(&self, jac: &[f64], inner: &[f64], row: &mut [f64]) {
        let q = self.keep.len();
        for (k, out) in row.iter_mut().enumerate() {
            *out = (0..inner.len()).map(|i| inner[i] * jac[i * q + k]).sum();
        }
    }
}

/// The largest directional albedo of `m` over `angles` (radians), by the fine quadrature.
fn max_rho(m: &Model, angles: &[f64]) -> f64 {
    angles
        .iter()
        .map(|&t| directional_albedo(m, t))
        .fold(
            f64::NEG_INFINITY,
            |a, b| if b.is_nan() { b } else { a.max(b) },
        )
}

impl Problem for Conserved<'_> {
    type Prepared = Prepared<<BrdfProblem as Problem>::Prepared>;

    fn dim(&self) -> usize {
        self.keep.len()
    }

    fn n_residuals(&self) -> usize {
        self.inner.n_residuals()
    }

    fn prepare(&self, y: &[f64]) -> Option<Self::Prepared> {
        let x = self.project(&self.expand(y))?;
        Some(Prepared {
            inner: self.inner.prepare(&x)?,
            x: y.to_vec(),
            jac: OnceLock::new(),
        })
    }

    fn residual_grad(&self, prep: &Self::Prepared, i: usize, row: &mut [f64]) -> f64 {
        let mut inner = vec![0.0; self.inner.dim()];
        let r = self.inner.residual_grad(&prep.inner, i, &mut inner);
        match prep.jac.get_or_init(|| self.jacobian(&prep.x)) {
            Some(jac) => self.chain(jac, &inner, row),
            None => row.iter_mut().for_each(|v| *v = f64::NAN),
        }
        r
    }

    fn residual(&self, prep: &Self::Prepared, i: usize) -> f64 {
        self.inner.residual(&prep.inner, i)
    }

    fn accumulate(
        &self,
        prep: &Self::Prepared,
        range: std::ops::Range<usize>,
        robust: Robust,
        acc: &mut Normal,
    ) {
        let (p, q) = (self.inner.dim(), self.keep.len());
        let mut part = Normal {
            cost: 0.0,
            jtj: vec![0.0; p * p],
            jtr: vec![0.0; p],
        };
        self.inner.accumulate(&prep.inner, range, robust, &mut part);
        acc.cost += part.cost;
        let Some(jac) = prep.jac.get_or_init(|| self.jacobian(&prep.x)) else {
            acc.cost = f64::NAN;
            return;
        };
        // The wrapped pass fills the upper triangle: JᵀJ in full first.
        let a = |i: usize, j: usize| part.jtj[i.min(j) * p + i.max(j)];
        for k in 0..q {
            acc.jtr[k] += (0..p).map(|i| jac[i * q + k] * part.jtr[i]).sum::<f64>();
            for l in k..q {
                let mut s = 0.0;
                for i in 0..p {
                    for j in 0..p {
                        s += jac[i * q + k] * a(i, j) * jac[j * q + l];
                    }
                }
                acc.jtj[k * q + l] += s;
            }
        }
    }

    fn cost_range(
        &self,
        prep: &Self::Prepared,
        range: std::ops::Range<usize>,
        robust: Robust,
    ) -> f64 {
        self.inner.cost_range(&prep.inner, range, robust)
    }

    fn bounds(&self) -> Vec<(f64, f64)> {
        let all = self.inner.bounds();
        self.keep.iter().map(|&k| all[k]).collect()
    }

    fn describe(&self, k: usize, u: f64) -> String {
        self.inner.describe(self.keep[k], u)
    }

    fn step_scale(&self) -> Vec<f64> {
        let all = self.inner.step_scale();
        self.keep.iter().map(|&k| all[k]).collect()
    }
}

/// A constrained fit: the wrapped problem's variables on the boundary, the solution of the
/// projected problem (for its first-order conditions) and the angles held (degrees).
pub(super) struct Held {
    pub(super) x: Vec<f64>,
    pub(super) cost: f64,
    /// The first-order conditions of the projected problem: the largest violation and why.
    pub(super) kkt: (f64, Option<String>),
    pub(super) angles_deg: Vec<f64>,
    pub(super) iterations: usize,
    pub(super) evaluations: usize,
}

/// The θi (degrees, of [`ALBEDO_THETA_I_DEG`](crate::model::albedo::ALBEDO_THETA_I_DEG)) at which some channel of `models` has an
/// albedo above `limit` by the fine quadrature, the worst of each channel.
fn violated(models: &[Model], limit: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for m in models {
        let worst = crate::model::albedo::albedos(m)
            .into_iter()
            .filter(|&(_, a)| !(a <= limit))
            .fold(None, |b: Option<(f64, f64)>, x| match b {
                Some(b) if !(x.1 > b.1) => Some(b),
                _ => Some(x),
            });
        if let Some((t, _)) = worst
            && !out.contains(&t)
        {
            out.push(t);
        }
    }
    out
}

/// The best fit of `full` whose albedo is at most [`TARGET`] (within `margin`) at every θi of
/// [`ALBEDO_THETA_I_DEG`](crate::model::albedo::ALBEDO_THETA_I_DEG), from the unconstrained minimum `x`; `None` when `x` already holds,
/// or the projection cannot be made (see [`Conserved::new`]) or ends without a finite cost.
pub(super) fn constrain(
    full: &BrdfProblem,
    x: &[f64],
    names: &[String],
    margin: f64,
    robust: Robust,
    limits: &Limits,
) -> Option<Held> {
    let limit = TARGET * (1.0 + margin);
    let mut angles_deg = violated(&full.models(x), limit);
    if angles_deg.is_empty() {
        return None;
    }
    let mut from = x.to_vec();
    let (mut iterations, mut evaluations) = (0, 0);
    for _ in 0..ROUNDS {
        angles_deg.sort_by(f64::total_cmp);
        let angles = angles_deg.iter().map(|t| t.to_radians()).collect();
        let c = Conserved::new(full, &from, angles)?;
        let sol = lsq::levenberg_marquardt(&c, &c.restrict(&from), robust, limits);
        iterations += sol.iterations;
        evaluations += sol.evaluations;
        let y = c.project(&c.expand(&sol.x))?;
        let cost = lsq::cost(full, &y, Robust::None)?;
        let more: Vec<f64> = violated(&full.models(&y), limit)
            .into_iter()
            .filter(|t| !angles_deg.contains(t))
            .collect();
        if more.is_empty() {
            let kept: Vec<String> = c.keep.iter().map(|&k| names[k].clone()).collect();
            let kkt = super::checks::first_order(&c, &sol, robust, &kept);
            return Some(Held {
                x: y,
                cost,
                kkt,
                angles_deg,
                iterations,
                evaluations,
            });
        }
        angles_deg.extend(more);
        from = y;
    }
    None
}

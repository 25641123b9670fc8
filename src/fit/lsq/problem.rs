//! What every solver shares: the [`Problem`] it minimises, the robust loss ρ, the normal
//! equations of a pass and the [`Solution`] it returns.

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

/// The solution of a run that could not start: `x` unevaluated, an infinite cost, `why`.
pub(super) fn failed(x: Vec<f64>, why: &str, evaluations: usize) -> Solution {
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

#[cfg(test)]
mod tests {
    use super::*;

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

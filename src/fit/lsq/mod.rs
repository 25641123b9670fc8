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

mod gn;
mod lm;
mod nm;
mod options;
mod pass;
mod problem;
mod step;

pub use gn::gauss_newton;
pub use lm::levenberg_marquardt;
pub use nm::nelder_mead;
pub use options::{Limits, Method, RESOLUTION_STEPS};
pub use pass::{cost, normal_equations};
pub use problem::{Normal, Problem, Robust, Solution};
pub use step::{active_set, bound_side};
pub(crate) use step::{damped_solve, project};

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

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
}

//! Runs the chosen [`Method`]: brdfit's own methods from [`lsq`](crate::fit::lsq), argmin's through
//! [`argmin_peer`]. It sits above both, so neither solver module needs the other.

use super::argmin_peer;
use super::lsq::{
    Limits, Method, Problem, Robust, Solution, gauss_newton, levenberg_marquardt, nelder_mead,
};

/// Minimise with the chosen method from `x0` (projected onto the bounds first).
pub(crate) fn solve<P: Problem>(
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
        _ => argmin_peer::solve(p, x0, method, robust, limits),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::lsq::tests::Rosen;

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
}

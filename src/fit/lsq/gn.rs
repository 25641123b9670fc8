//! Gauss–Newton with a bounded, NaN-safe Armijo backtracking line search, with the same
//! active set and projection as Levenberg–Marquardt.

use super::options::Limits;
use super::pass::{cost, normal_equations};
use super::problem::failed;
use super::problem::{Problem, Robust, Solution};
use super::step::{active_set, damped_solve, gradient_small, project, scale_diag};

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

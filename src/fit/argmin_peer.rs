//! argmin's solvers (argmin 0.11, <https://argmin-rs.org>) on brdfit's least-squares problems,
//! so the in-Rust peers run on exactly the problem brdfit's own methods solve.
//!
//! One wrapper, [`Peer`], presents any [`Problem`] to argmin in the two forms its solvers ask
//! for:
//! - a cost function C(u) = Σ ρ(r_i(u)) with gradient Jᵀ W r and the Gauss–Newton Hessian
//!   JᵀWJ, from the same streaming pass as brdfit's own solvers (L-BFGS, trust region,
//!   Nelder–Mead, particle swarm);
//! - an operator u ↦ s(u) with its m×p Jacobian, where s_i = sgn(r_i) √(2 ρ(r_i)) so that
//!   ½ Σ s_i² is the same cost (argmin's Gauss–Newton). Without a robust loss s = r.
//!
//! argmin's solvers are unconstrained (except the swarm's box). brdfit's parameters have a
//! box (ps, pd ≥ 0, n > 1, c3 ≤ 1, …) outside which the model is not defined, so the wrapper
//! returns a cost of +∞ outside it (the extreme barrier, Audet & Dennis, "Mesh adaptive direct
//! search algorithms for constrained optimization", SIAM J. Optim. 17, 2006), and a gradient,
//! Hessian, residual or Jacobian request outside it ends the run as "left the bounds". The
//! solvers run with argmin's own defaults and tolerances, bounded by the same iteration and
//! evaluation limits as brdfit's methods; where they stall, leave the box or run to a limit,
//! the result says so. The best point any evaluation saw is returned.

use super::lsq::{
    Limits, Method, Normal, Problem, Robust, Solution, cost, normal_equations, project,
};
use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{
    CostFunction, Error, Executor, Gradient, Hessian, Jacobian, KV, Operator, State,
    TerminationReason, TerminationStatus,
};
use argmin::solver::gaussnewton::GaussNewton;
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::particleswarm::{Particle, ParticleSwarm};
use argmin::solver::quasinewton::LBFGS;
use argmin::solver::trustregion::{Steihaug, TrustRegion};
use argmin_math::ArgminRandom;
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rayon::prelude::*;
use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Particles of the swarm (argmin's documented example size).
pub const SWARM: usize = 40;

/// L-BFGS memory (argmin's examples).
const LBFGS_MEMORY: usize = 7;

/// Why the wrapper ended a run.
#[derive(Debug, thiserror::Error)]
enum Stop {
    #[error("left the bounds: {0}")]
    LeftBounds(String),
    #[error("evaluation limit reached")]
    EvaluationLimit,
    #[error("non-finite residuals or Jacobian at an admissible point")]
    NonFinite,
}

/// What the wrapper saw across one run.
#[derive(Default)]
struct Track {
    /// Lowest finite cost evaluated, and where.
    best: Option<(Vec<f64>, f64)>,
    /// Passes over the data (cost, normal equations, residuals or Jacobian each count one).
    evaluations: usize,
    /// The normal equations of the last point asked for (gradient and Hessian share them).
    normal: Option<(Vec<f64>, Normal)>,
}

/// A brdfit [`Problem`] as an argmin problem (see the module documentation).
struct Peer<'a, P: Problem> {
    p: &'a P,
    robust: Robust,
    bounds: Vec<(f64, f64)>,
    max_eval: usize,
    track: &'a RefCell<Track>,
}

impl<P: Problem> Peer<'_, P> {
    /// The first variable outside the box, as the error that ends the run.
    fn outside(&self, x: &[f64]) -> Option<Stop> {
        x.iter()
            .zip(&self.bounds)
            .enumerate()
            .find(|(_, (v, (lo, hi)))| !(**v >= *lo && **v <= *hi))
            .map(|(k, (&u, _))| Stop::LeftBounds(self.p.describe(k, u)))
    }

    /// Count one pass over the data, or refuse it past the limit.
    fn spend(&self) -> Result<(), Error> {
        let mut t = self.track.borrow_mut();
        if t.evaluations >= self.max_eval {
            return Err(Stop::EvaluationLimit.into());
        }
        t.evaluations += 1;
        Ok(())
    }

    fn note(&self, x: &[f64], c: f64) {
        let mut t = self.track.borrow_mut();
        if c.is_finite() && t.best.as_ref().is_none_or(|b| c < b.1) {
            t.best = Some((x.to_vec(), c));
        }
    }

    /// The normal equations at `x`, shared by the gradient and the Hessian.
    fn normal(&self, x: &DVector<f64>) -> Result<Normal, Error> {
        let x = x.as_slice();
        if let Some(e) = self.outside(x) {
            return Err(e.into());
        }
        if let Some((at, n)) = &self.track.borrow().normal
            && at == x
        {
            return Ok(n.clone());
        }
        self.spend()?;
        let n = normal_equations(self.p, x, self.robust).ok_or(Stop::NonFinite)?;
        self.note(x, n.cost);
        self.track.borrow_mut().normal = Some((x.to_vec(), n.clone()));
        Ok(n)
    }

    /// s_i and, with `jacobian`, the rows ∂s_i/∂u (row-major m×p).
    fn residuals(&self, x: &DVector<f64>, jacobian: bool) -> Result<(Vec<f64>, Vec<f64>), Error> {
        let x = x.as_slice();
        if let Some(e) = self.outside(x) {
            return Err(e.into());
        }
        self.spend()?;
        let prep = self.p.prepare(x).ok_or(Stop::NonFinite)?;
        let (m, n) = (self.p.n_residuals(), self.p.dim());
        let robust = self.robust;
        let mut s = vec![0.0; m];
        let mut jac = vec![0.0; if jacobian { m * n } else { 0 }];
        const ROWS: usize = 4096;
        let body = |(k, (s, jac)): (usize, (&mut [f64], &mut [f64]))| {
            let mut row = vec![0.0; n];
            for (j, sj) in s.iter_mut().enumerate() {
                let r = self.p.residual_grad(&prep, k * ROWS + j, &mut row);
                // s = sgn(r) √(2ρ(r)); ds/dr = ρ'(r)/|s| = w |r| / |s| (1 at r = 0).
                let (v, d) = match robust {
                    Robust::None => (r, 1.0),
                    _ => {
                        let v = r.signum() * (2.0 * robust.rho(r)).sqrt();
                        let d = if v == 0.0 {
                            1.0
                        } else {
                            robust.weight(r) * r.abs() / v.abs()
                        };
                        (v, d)
                    }
                };
                *sj = v;
                if !jac.is_empty() {
                    for a in 0..n {
                        jac[j * n + a] = d * row[a];
                    }
                }
            }
        };
        if jacobian {
            s.par_chunks_mut(ROWS)
                .zip(jac.par_chunks_mut(ROWS * n))
                .enumerate()
                .for_each(body);
        } else {
            s.par_chunks_mut(ROWS)
                .enumerate()
                .for_each(|(k, s)| body((k, (s, &mut []))));
        }
        let c = 0.5 * s.iter().map(|v| v * v).sum::<f64>();
        if !c.is_finite() || jac.iter().any(|v| !v.is_finite()) {
            return Err(Stop::NonFinite.into());
        }
        self.note(x, c);
        Ok((s, jac))
    }
}

impl<P: Problem> CostFunction for Peer<'_, P> {
    type Param = DVector<f64>;
    type Output = f64;

    /// Σ ρ(r), +∞ outside the box or where the model gives a non-finite cost.
    fn cost(&self, x: &DVector<f64>) -> Result<f64, Error> {
        if self.outside(x.as_slice()).is_some() {
            return Ok(f64::INFINITY);
        }
        self.spend()?;
        let c = cost(self.p, x.as_slice(), self.robust).unwrap_or(f64::INFINITY);
        self.note(x.as_slice(), c);
        Ok(c)
    }
}

impl<P: Problem> Gradient for Peer<'_, P> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;

    /// Jᵀ W r, the gradient of Σ ρ(r).
    fn gradient(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(DVector::from_vec(self.normal(x)?.jtr))
    }
}

impl<P: Problem> Hessian for Peer<'_, P> {
    type Param = DVector<f64>;
    type Hessian = DMatrix<f64>;

    /// The Gauss–Newton Hessian JᵀWJ.
    fn hessian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        let n = x.len();
        Ok(DMatrix::from_row_slice(n, n, &self.normal(x)?.jtj))
    }
}

impl<P: Problem> Operator for Peer<'_, P> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;

    /// The residuals s(u).
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(DVector::from_vec(self.residuals(x, false)?.0))
    }
}

impl<P: Problem> Jacobian for Peer<'_, P> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;

    /// ∂s/∂u, m×p.
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        let jac = self.residuals(x, true)?.1;
        Ok(DMatrix::from_row_slice(self.p.n_residuals(), x.len(), &jac))
    }
}

/// Counts the iterations argmin reports, also for a run that ends in an error.
struct Iterations(Arc<AtomicUsize>);

impl<I> Observe<I> for Iterations {
    fn observe_iter(&mut self, _state: &I, _kv: &KV) -> Result<(), Error> {
        self.0.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }
}

/// The search box of the swarm: the problem's box, with an infinite end replaced by
/// x0 ∓ 10 (1 + |x0|).
fn swarm_box(x0: &[f64], bounds: &[(f64, f64)]) -> (DVector<f64>, DVector<f64>) {
    let reach = |v: f64| 10.0 * (1.0 + v.abs());
    let lo = x0
        .iter()
        .zip(bounds)
        .map(|(v, b)| if b.0.is_finite() { b.0 } else { v - reach(*v) });
    let hi = x0
        .iter()
        .zip(bounds)
        .map(|(v, b)| if b.1.is_finite() { b.1 } else { v + reach(*v) });
    (
        DVector::from_iterator(x0.len(), lo),
        DVector::from_iterator(x0.len(), hi),
    )
}

/// A seed from the start point, so that the swarms of different starts differ and the same
/// start always gives the same swarm.
fn seed_of(x0: &[f64]) -> u64 {
    x0.iter().fold(0xcbf2_9ce4_8422_2325, |h, v| {
        (h ^ v.to_bits()).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Minimise with one of argmin's solvers from `x0` (projected onto the box first).
pub(super) fn solve<P: Problem>(
    p: &P,
    x0: &[f64],
    method: Method,
    robust: Robust,
    limits: &Limits,
) -> Solution {
    let bounds = p.bounds();
    let mut start = x0.to_vec();
    project(&mut start, &bounds);
    let track = RefCell::new(Track::default());
    let peer = Peer {
        p,
        robust,
        bounds: bounds.clone(),
        max_eval: limits.max_eval,
        track: &track,
    };
    let iterations = Arc::new(AtomicUsize::new(0));
    let x = DVector::from_vec(start.clone());
    let max_iters = limits.max_iter as u64;
    // Run one argmin solver on the wrapper, `$configure` setting its start, and return why it
    // ended (a macro: each solver's state has its own type).
    macro_rules! run {
        ($solver:expr, $configure:expr) => {
            Executor::new(peer, $solver)
                .configure($configure)
                .add_observer(Iterations(iterations.clone()), ObserverMode::Always)
                .run()
                .map(|r| match r.state().get_termination_status() {
                    TerminationStatus::Terminated(r) => r.clone(),
                    TerminationStatus::NotTerminated => {
                        TerminationReason::SolverExit("not terminated".into())
                    }
                })
        };
    }
    let ended: Result<TerminationReason, Error> = match method {
        Method::ArgminLbfgs => run!(
            LBFGS::new(MoreThuenteLineSearch::new(), LBFGS_MEMORY),
            |s| s.param(x).max_iters(max_iters)
        ),
        Method::ArgminTrustRegion => run!(TrustRegion::new(Steihaug::new()), |s| s
            .param(x)
            .max_iters(max_iters)),
        Method::ArgminGaussNewton => run!(GaussNewton::new(), |s| s.param(x).max_iters(max_iters)),
        Method::ArgminNm => {
            // The initial simplex: x0 and x0 + δ_i e_i, δ_i = 5 % of |x0_i| (0.00025 at 0),
            // as scipy's fmin builds it, turned inward where it would leave the box.
            let mut simplex = vec![x.clone()];
            for i in 0..start.len() {
                let mut v = x.clone();
                let d = if start[i] != 0.0 {
                    0.05 * start[i]
                } else {
                    0.00025
                };
                v[i] = if start[i] + d <= bounds[i].1 {
                    start[i] + d
                } else {
                    start[i] - d
                };
                simplex.push(v);
            }
            run!(NelderMead::new(simplex), |s| s.max_iters(max_iters))
        }
        Method::ArgminPso => {
            // The swarm from argmin's own initialisation (positions uniform in the box,
            // velocities uniform in ± its size), with the first particle put at the start.
            let (lo, hi) = swarm_box(&start, &bounds);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed_of(&start));
            let delta = &hi - &lo;
            let particles: Result<Vec<_>, Error> = (0..SWARM)
                .map(|k| {
                    let pos = if k == 0 {
                        x.clone()
                    } else {
                        DVector::rand_from_range(&lo, &hi, &mut rng)
                    };
                    let vel = DVector::rand_from_range(&-&delta, &delta, &mut rng);
                    let cost = peer.cost(&pos)?;
                    Ok(Particle::new(pos, cost, vel))
                })
                .collect();
            match particles {
                Err(e) => Err(e),
                Ok(particles) => run!(
                    ParticleSwarm::new((lo, hi), SWARM).with_rng_generator(rng),
                    |s| s.population(particles).max_iters(max_iters)
                ),
            }
        }
        Method::Lm | Method::GaussNewton | Method::NelderMead => {
            unreachable!("brdfit's own methods are solved in lsq")
        }
    };
    let (termination, converged) = match ended {
        Ok(TerminationReason::MaxItersReached) => {
            ("iteration limit reached (argmin)".into(), false)
        }
        Ok(r @ (TerminationReason::SolverConverged | TerminationReason::TargetCostReached)) => {
            (format!("argmin: {}", r.text().to_lowercase()), true)
        }
        Ok(r) => (format!("argmin: {}", r.text()), false),
        Err(e) => match e.downcast_ref::<Stop>() {
            Some(stop) => (format!("argmin: {stop}"), false),
            None => (format!("argmin error: {e}"), false),
        },
    };
    let track = track.into_inner();
    let (x, cost) = track.best.unwrap_or((start, f64::INFINITY));
    Solution {
        x,
        cost,
        iterations: iterations.load(Ordering::Relaxed),
        evaluations: track.evaluations,
        termination,
        converged,
        normal: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::fit::lsq::tests::Rosen;

    fn peer<'a>(p: &'a Rosen, robust: Robust, track: &'a RefCell<Track>) -> Peer<'a, Rosen> {
        Peer {
            p,
            robust,
            bounds: p.bounds(),
            max_eval: usize::MAX,
            track,
        }
    }

    #[test]
    fn gradient_and_jacobian_match_finite_differences() {
        let p = Rosen::free();
        for robust in [Robust::None, Robust::Huber(0.5), Robust::Cauchy(0.5)] {
            let track = RefCell::new(Track::default());
            let w = peer(&p, robust, &track);
            let x = DVector::from_vec(vec![-0.7, 1.3]);
            let g = w.gradient(&x).unwrap();
            let (s, jac) = w.residuals(&x, true).unwrap();
            // ½ Σ s² is the cost argmin's other solvers see.
            let c = w.cost(&x).unwrap();
            assert!((0.5 * s.iter().map(|v| v * v).sum::<f64>() - c).abs() < 1e-12 * c);
            let h = 1e-6;
            for k in 0..2 {
                let mut a = x.clone();
                let mut b = x.clone();
                a[k] += h;
                b[k] -= h;
                let fd = (w.cost(&a).unwrap() - w.cost(&b).unwrap()) / (2.0 * h);
                assert!(
                    (g[k] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                    "{robust:?} ∂C/∂x{k}"
                );
                let (sa, _) = w.residuals(&a, false).unwrap();
                let (sb, _) = w.residuals(&b, false).unwrap();
                for i in 0..2 {
                    let fd = (sa[i] - sb[i]) / (2.0 * h);
                    assert!(
                        (jac[i * 2 + k] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                        "{robust:?} ∂s{i}/∂x{k}: {} against {fd}",
                        jac[i * 2 + k]
                    );
                }
            }
        }
    }

    #[test]
    fn every_argmin_method_solves_rosenbrock() {
        let p = Rosen::free();
        for m in Method::ALL.into_iter().filter(|m| m.is_argmin()) {
            let s = solve(&p, &[-1.2, 1.0], m, Robust::None, &Limits::default());
            // The swarm is a global search with 40 particles and no local refinement.
            let tol = if m == Method::ArgminPso { 0.05 } else { 1e-5 };
            assert!(
                (s.x[0] - 1.0).abs() < tol && (s.x[1] - 1.0).abs() < 2.0 * tol,
                "{m:?}: {s:?}"
            );
            assert!(s.evaluations <= Limits::default().max_eval, "{m:?}: {s:?}");
            assert!(s.iterations > 0, "{m:?}: {s:?}");
        }
    }

    #[test]
    fn a_step_out_of_the_box_ends_the_run_inside_it() {
        // Rosenbrock's minimum (1, 1) lies outside x1 ≤ 0.5: an unconstrained solver must
        // step out, and the run ends there, returning the best point inside the box.
        let p = Rosen(vec![(-2.0, 0.5), (f64::NEG_INFINITY, f64::INFINITY)]);
        for m in [Method::ArgminLbfgs, Method::ArgminGaussNewton] {
            let s = solve(&p, &[-1.2, 1.0], m, Robust::None, &Limits::default());
            assert!(s.termination.contains("left the bounds"), "{m:?}: {s:?}");
            assert!(
                !s.converged && s.x[0] <= 0.5 && s.cost.is_finite(),
                "{m:?}: {s:?}"
            );
            assert!(s.cost < 0.5 * 24.2, "{m:?} made no progress: {s:?}");
        }
        // Methods that try the cost before asking for a derivative see +∞ outside, reject
        // the step and stay in, near the box's minimum (0.5, 0.25) with cost ⅛.
        for m in [
            Method::ArgminTrustRegion,
            Method::ArgminNm,
            Method::ArgminPso,
        ] {
            let s = solve(&p, &[-1.2, 1.0], m, Robust::None, &Limits::default());
            assert!(s.x[0] <= 0.5 && s.cost < 0.13, "{m:?}: {s:?}");
        }
    }

    #[test]
    fn the_evaluation_limit_binds_every_method() {
        let p = Rosen::free();
        let limits = Limits {
            max_eval: 4,
            ..Limits::default()
        };
        for m in Method::ALL.into_iter().filter(|m| m.is_argmin()) {
            let s = solve(&p, &[-1.2, 1.0], m, Robust::None, &limits);
            assert!(s.evaluations <= 4, "{m:?}: {s:?}");
            assert!(!s.converged, "{m:?} cannot converge in 4 passes: {s:?}");
        }
    }
}

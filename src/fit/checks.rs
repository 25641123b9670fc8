//! Stage 4 of a fit: the checks at return (first-order conditions, absurd values, random-start
//! verification).

use super::dispatch;
use super::lsq::{self, Limits, Problem, Robust, Solution};
use super::options::FitOptions;
use super::problem::BrdfProblem;
use super::result::{KKT_TOLERANCE, SAME_MINIMUM, Verification};
use super::setup::Layout;
use super::solve::{Search, random_start};
use crate::model::{ParamSpec, readable};

/// What the checks at return found.
pub(super) struct Checks {
    pub(super) kkt_violation: f64,
    pub(super) verification: Option<Verification>,
    pub(super) unusable: Vec<String>,
}

/// Step 5: the first-order conditions, absurd values and (with `verify`) the random starts.
pub(super) fn certify(
    full: &BrdfProblem,
    found: &mut Search,
    lay: &Layout,
    theta: &[f64],
    opts: &FitOptions,
) -> Checks {
    let mut unusable = Vec::new();
    let (kkt_violation, why) = first_order(full, &found.sol, found.robust, &lay.names);
    unusable.extend(why);
    for k in 0..theta.len() {
        // A Fresnel index above the limit is a metal's (F ≈ 1 at every angle): the fit is
        // usable and the statistics say n is not determined ([`super::stats::METAL`]).
        if theta[k] >= lay.specs[k].absurd_above && lay.specs[k].role != crate::model::Role::Index {
            unusable.push(format!(
                "{} = {} is not a physical value (≥ {})",
                lay.names[k],
                readable(theta[k]),
                readable(lay.specs[k].absurd_above)
            ));
        }
    }
    let verification = (opts.verify > 0).then(|| {
        let work = found.sub.as_ref().unwrap_or(full);
        let (v, evaluations) = verify(
            full,
            work,
            &lay.specs,
            opts,
            found.robust,
            &found.refine_limits,
            found.sol.cost,
        );
        found.evaluations += evaluations;
        v
    });
    if let Some(v) = &verification
        && !v.verified
    {
        unusable.push(format!(
            "verification: a random start reached cost {}, below this fit's {}",
            readable(v.best_cost),
            readable(found.sol.cost)
        ));
    }
    Checks {
        kkt_violation,
        verification,
        unusable,
    }
}
/// The start of the reason a fit fails its first-order conditions.
pub(super) const FIRST_ORDER: &str = "first-order conditions fail";

/// The first-order (KKT) conditions of the box-constrained problem at the solution, in solver
/// variables: an interior variable has a scaled gradient |g_k| / (√(JᵀJ)_kk ‖r‖) near 0; one at
/// a bound has its gradient pointing out of the box (only an inward part counts). Returns the
/// largest violation and, when it exceeds [`KKT_TOLERANCE`], why.
pub(super) fn first_order<P: Problem>(
    p: &P,
    sol: &Solution,
    robust: Robust,
    names: &[String],
) -> (f64, Option<String>) {
    let ne = match &sol.normal {
        Some(n) => n.clone(),
        None => match lsq::normal_equations(p, &sol.x, robust) {
            Some(n) => n,
            None => {
                return (
                    f64::INFINITY,
                    Some("the cost is not finite at the fit".into()),
                );
            }
        },
    };
    let dim = p.dim();
    let norm = (2.0 * ne.cost).sqrt();
    // An exact fit (rms residual below 1e-9) is optimal whatever its rounding-level gradient.
    if norm <= 1e-9 * (p.n_residuals() as f64).sqrt() || dim == 0 {
        return (0.0, None);
    }
    let bounds = p.bounds();
    let mut worst = (0.0f64, None);
    for k in 0..dim {
        let d = ne.jtj[k * dim + k].sqrt();
        if d == 0.0 {
            continue;
        }
        let g = ne.jtr[k] / (d * norm);
        let side = lsq::bound_side(sol.x[k], bounds[k]);
        let v = match side {
            -1 => (-g).max(0.0),
            1 => g.max(0.0),
            _ => g.abs(),
        };
        if v > worst.0 {
            worst = (v, Some((k, side)));
        }
    }
    let why = worst
        .1
        .filter(|_| worst.0 > KKT_TOLERANCE)
        .map(|(k, side)| {
            let at = match side {
                -1 => " at its lower bound, pointing into the range",
                1 => " at its upper bound, pointing into the range",
                _ => "",
            };
            format!(
                "{FIRST_ORDER}: the cost gradient in {}{at} is {} (scaled; tolerance {})",
                names[k],
                readable(worst.0),
                readable(KKT_TOLERANCE)
            )
        });
    (worst.0, why)
}

/// `opts.verify` seeded random starts ([`random_start`]), each refined by the local method on
/// `work` (the pipeline's subsample, or every row), the best three then polished on every row
/// of `full`. Returns the certificate and the evaluations spent.
pub(super) fn verify(
    full: &BrdfProblem,
    work: &BrdfProblem,
    specs: &[&ParamSpec],
    opts: &FitOptions,
    robust: Robust,
    limits: &Limits,
    cost: f64,
) -> (Verification, usize) {
    use rand::SeedableRng;
    use rayon::prelude::*;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    let starts: Vec<Vec<f64>> = (0..opts.verify)
        .map(|_| random_start(full, specs, &mut rng))
        .collect();
    let mut sols: Vec<Solution> = starts
        .par_iter()
        .map(|x0| dispatch::solve(work, x0, opts.method, Robust::None, limits))
        .collect();
    let mut evaluations: usize = sols.iter().map(|s| s.evaluations).sum();
    sols.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let same_rows = std::ptr::eq(full, work);
    let polished: Vec<Solution> = if same_rows && robust == Robust::None {
        sols.into_iter().take(1).collect()
    } else {
        // A converged start that costs clearly more on every row than the fit (beyond
        // CONTENDER_RATIO, the search's own margin between basins) is not polished: its cost
        // on every row stands for it.
        sols.iter()
            .take(3)
            .collect::<Vec<_>>()
            .par_iter()
            .map(|s| {
                if s.converged {
                    let here = lsq::cost(full, &s.x, robust).unwrap_or(f64::INFINITY);
                    if here > cost * super::solve::CONTENDER_RATIO {
                        return Solution {
                            cost: here,
                            evaluations: 1,
                            ..(*s).clone()
                        };
                    }
                }
                dispatch::solve(full, &s.x, opts.method, robust, &opts.limits)
            })
            .collect()
    };
    evaluations += polished.iter().map(|s| s.evaluations).sum::<usize>();
    let best_cost = polished
        .iter()
        .map(|s| s.cost)
        .fold(f64::INFINITY, f64::min);
    (
        Verification {
            starts: opts.verify,
            best_cost,
            robust: match robust {
                Robust::None => String::new(),
                Robust::Huber(_) => "huber".into(),
                Robust::Cauchy(_) => "cauchy".into(),
            },
            verified: !(best_cost < cost * (1.0 - SAME_MINIMUM)),
        },
        evaluations,
    )
}

//! Stage 3 of a fit: the local method from the initialisation's candidates, on a subsample
//! and then on every row, and the distinct basins polished.

use super::dispatch;
use super::init::global_init;
use super::lsq::{self, Limits, Problem, Robust, Solution};
use super::options::{FitOptions, RobustKind};
use super::problem::{BrdfProblem, Slot};
use super::setup::Layout;
use crate::model::ParamSpec;

/// What the search found and what it cost.
pub(super) struct Search {
    pub(super) sol: Solution,
    pub(super) robust: Robust,
    /// The ≤ 2,000-rows-per-channel subsample the candidates were refined on, if any.
    pub(super) sub: Option<BrdfProblem>,
    pub(super) refine_limits: Limits,
    pub(super) iterations: usize,
    pub(super) evaluations: usize,
}

/// Step 4: global initialisation, candidates refined on a subsample, the distinct basins near
/// the best polished on every row (robust loss, if any, on that last stage).
pub(super) fn search(full: &BrdfProblem, lay: &Layout, opts: &FitOptions) -> Search {
    use rayon::prelude::*;
    let per = super::problem::SUBSAMPLE_ROWS;
    // On many rows the polish starts on a 64th of them (below), and the local stage's
    // subsample is drawn from that one: the same largest values (the 64th holds the largest
    // tenth of its own size), the rest strided through the 64th, not a second sweep through
    // every row (a million rows: 0.1 ms, not 1.5 ms).
    let per_channel = full.rows.len() / full.layout.len();
    let mid = (per_channel >= MID_ABOVE).then(|| full.subsample(per_channel / MID_FRACTION));
    let sub = (full.rows.len() > per * full.layout.len())
        .then(|| mid.as_ref().unwrap_or(full).subsample(per));
    let work = sub.as_ref().unwrap_or(full);
    // On every row the data's resolution ends the polish (see [`super::options::RESOLUTION`]); the
    // same on a small file's candidates, which are refined on every row and not polished again. On
    // a subsample only the basin matters: the polish on every row sets the final accuracy.
    let polish_limits = polish_limits(full, opts);
    let refine_limits = if sub.is_some() {
        Limits {
            ftol: opts.limits.ftol.max(1e-8),
            ..opts.limits
        }
    } else {
        polish_limits
    };
    let refine =
        |x0: &Vec<f64>| dispatch::solve(work, x0, opts.method, Robust::None, &refine_limits);
    let start = || start_vector(full, &lay.specs, &lay.names, &opts.start);
    // The grid's subsample is drawn from the local stage's (the same largest values, no
    // second pass over every row). A start given with the global initialisation (or the start
    // of a local fit) is one more candidate, after the grid's, refined beside them: after the
    // initialisation, not during it, so the initialisation has both cores and the start's
    // refinement runs beside a candidate's (a 10,000-row fit's start took one core for as long
    // as the initialisation left the other idle).
    let mut candidates = if opts.local_only {
        Vec::new()
    } else {
        global_init(work, &lay.specs, opts)
    };
    if !opts.start.is_empty() || candidates.is_empty() {
        candidates.push(start());
    }
    let mut sols: Vec<Solution> = candidates.par_iter().map(refine).collect();
    let mut iterations: usize = sols.iter().map(|s| s.iterations).sum();
    let mut evaluations: usize = sols.iter().map(|s| s.evaluations).sum();
    sols.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let robust = match opts.robust {
        None => Robust::None,
        Some(kind) => {
            let delta = robust_scale(full, &sols[0].x);
            match kind {
                RobustKind::Huber => Robust::Huber(delta),
                RobustKind::Cauchy => Robust::Cauchy(delta),
            }
        }
    };
    let sol = if sub.is_some() || robust != Robust::None {
        // A subsample's cost tells basins apart only to within its sampling noise: every
        // distinct basin whose subsample cost is near the best is polished on every row. On
        // many rows, first on a 64th of them: the polish on every row then starts within that
        // subsample's noise of its end and needs a pass fewer.
        let mid_limits = Limits {
            ftol: opts.limits.ftol.max(MID_FTOL),
            ..opts.limits
        };
        let polished: Vec<(Solution, usize, usize)> = distinct_basins(&sols)
            .par_iter()
            .map(|s| match &mid {
                Some(mp) => {
                    let m = dispatch::solve(mp, &s.x, opts.method, robust, &mid_limits);
                    let f = dispatch::solve(full, &m.x, opts.method, robust, &polish_limits);
                    (f, m.iterations, m.evaluations)
                }
                None => (
                    dispatch::solve(full, &s.x, opts.method, robust, &polish_limits),
                    0,
                    0,
                ),
            })
            .collect();
        iterations += polished.iter().map(|s| s.1).sum::<usize>();
        evaluations += polished.iter().map(|s| s.2).sum::<usize>();
        let polished: Vec<Solution> = polished.into_iter().map(|s| s.0).collect();
        iterations += polished.iter().map(|s| s.iterations).sum::<usize>();
        evaluations += polished.iter().map(|s| s.evaluations).sum::<usize>();
        let mut best = polished
            .into_iter()
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
            .expect("at least one candidate");
        // A local fit never ends above its start: the subsample's basin can polish to a cost
        // on every row above the start's own, and then the start is polished instead (the
        // pixel-loss refit of `choose` relies on this to end no worse than the global fit).
        if opts.local_only {
            for x0 in &candidates {
                let c0 = lsq::cost(full, x0, robust).unwrap_or(f64::INFINITY);
                if c0 < best.cost {
                    let s = dispatch::solve(full, x0, opts.method, robust, &polish_limits);
                    iterations += s.iterations;
                    evaluations += s.evaluations;
                    if s.cost < best.cost {
                        best = s;
                    }
                }
            }
        }
        best
    } else {
        sols.swap_remove(0)
    };
    Search {
        sol,
        robust,
        sub,
        refine_limits,
        iterations,
        evaluations,
    }
}

/// The limits of a polish on every row of `full`: `opts.limits` with the data's resolution
/// ([`FitOptions::resolution`] of S/(m − p), relative to the cost).
pub(super) fn polish_limits(full: &BrdfProblem, opts: &FitOptions) -> Limits {
    let dof = full.n_residuals().saturating_sub(full.dim()).max(1);
    Limits {
        resolution: opts.resolution / dof as f64,
        ..opts.limits
    }
}

/// Solutions of distinct basins (apart by more than 1e-3 in some solver variable, relative to
/// its magnitude or 1) whose cost on `work` is within [`CONTENDER_RATIO`] of the
/// best, best first, at most 3. `sols` is sorted by cost.
pub(super) fn distinct_basins(sols: &[Solution]) -> Vec<&Solution> {
    let best = sols[0].cost;
    let mut out: Vec<&Solution> = Vec::new();
    for s in sols {
        if out.len() == 3 || !(s.cost <= best * CONTENDER_RATIO) {
            break;
        }
        let same = out.iter().any(|o| {
            o.x.iter()
                .zip(&s.x)
                .all(|(a, b)| (a - b).abs() <= 1e-3 * a.abs().max(b.abs()).max(1.0))
        });
        if !same {
            out.push(s);
        }
    }
    out
}

/// With at least [`MID_ABOVE`] rows per channel, the basins are polished first on this
/// fraction of the rows (a subsample of the same kind), then on every row. A 64th, not a
/// 16th: gathering a 16th of a million rows (every 18th row of seven 8 MB columns) reads
/// nearly every cache line, and on a 2-core machine cost more (about 7 ms)
/// than the pass over every row it saved; with a 64th a million-row fit's solve took 22.5 ms
/// against 28.5 ms at the median of six alternations, at the same cost to 1e-15.
pub(super) const MID_FRACTION: usize = 64;

/// Rows per channel from which the polish starts on [`MID_FRACTION`] of the rows (a 64th of
/// 512,000 is 8,000, four times the local stage's subsample).
pub(super) const MID_ABOVE: usize = 512_000;

/// The relative cost reduction that ends the polish on the intermediate subsample.
pub(super) const MID_FTOL: f64 = 1e-10;

/// Candidates whose subsample cost is within this factor of the best are polished on every
/// row (a subsample ranks basins only to within its sampling noise).
pub(super) const CONTENDER_RATIO: f64 = 1.5;

/// Robust threshold from the residuals at `x`: 1.345 · 1.4826 · median |r|.
pub(super) fn robust_scale(p: &BrdfProblem, x: &[f64]) -> f64 {
    let Some(prep) = p.prepare(x) else {
        return 1.0;
    };
    let mut r: Vec<f64> = (0..p.n_residuals())
        .map(|i| p.residual(&prep, i).abs())
        .collect();
    let largest = r.iter().copied().fold(0.0f64, f64::max);
    let mid = r.len() / 2;
    let med = *r.select_nth_unstable_by(mid, f64::total_cmp).1;
    // Floored relative to the residuals (the data may be of any scale), for an exact median.
    (1.345 * 1.4826 * med).max(1e-12 * largest).max(1e-300)
}

/// The default or user start as solver variables (a per-channel variable `ps_r` takes a
/// start given for `ps_r` or for `ps`).
pub(super) fn start_vector(
    p: &BrdfProblem,
    specs: &[&ParamSpec],
    var_names: &[String],
    start: &[(String, f64)],
) -> Vec<f64> {
    (0..specs.len())
        .map(|k| {
            let v = start
                .iter()
                .rev()
                .find(|(n, _)| n == specs[k].name || *n == var_names[k])
                .map_or(specs[k].start, |(_, v)| *v);
            p.transforms[k].invert(v)
        })
        .collect()
}

/// A random start in solver variables: each parameter drawn from its declared
/// [`ParamSpec::random`] range, log-uniformly when both ends are positive.
pub fn random_start(p: &BrdfProblem, specs: &[&ParamSpec], rng: &mut impl rand::Rng) -> Vec<f64> {
    specs
        .iter()
        .enumerate()
        .map(|(k, s)| p.transforms[k].invert(s.random_value(rng)))
        .collect()
}

/// The solver variables of the same f_r with each channel's parameters in canonical order
/// ([`Model::canonical`](crate::model::Model::canonical): ggx-smith-2's lobes with alpha1 ≤
/// alpha2). A parameter that moves takes the value of another free variable of the same transform
/// (a lobe swap exchanges variables and changes no residual). Where that cannot be done (a held
/// parameter, or a variable shared by channels that would swap differently), `x` is returned
/// unchanged.
pub(super) fn canonical(p: &BrdfProblem, x: &[f64]) -> Vec<f64> {
    let models = p.models(x);
    let n = p.n_model_params();
    let mut y = x.to_vec();
    for (slots, m) in p.layout.iter().zip(&models) {
        let c = m.canonical();
        for j in (0..n).filter(|&j| c.p[j] != m.p[j]) {
            let Slot::Free(k) = slots[j] else {
                return x.to_vec();
            };
            let source = (0..n).find_map(|i| match slots[i] {
                Slot::Free(ki) if m.p[i] == c.p[j] && p.transforms[ki] == p.transforms[k] => {
                    Some(ki)
                }
                _ => None,
            });
            let Some(ki) = source else {
                return x.to_vec();
            };
            y[k] = x[ki];
        }
    }
    let same = p
        .models(&y)
        .iter()
        .zip(&models)
        .all(|(a, b)| *a == b.canonical());
    if same { y } else { x.to_vec() }
}

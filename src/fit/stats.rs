//! Stage 5 of a fit: what the data say about each parameter (standard errors,
//! correlations, 1 % ranges, profiles) and the reported parameters.

use super::setup::Layout;
use super::*;

/// What the data say about each free parameter.
pub(super) struct Uncertainty {
    pub(super) se: Vec<f64>,
    pub(super) corr: Vec<Vec<f64>>,
    pub(super) ranges: Vec<(String, f64, f64)>,
    pub(super) at_bound: Vec<(String, String)>,
}

/// Step 6: standard errors and correlations, 1 % ranges (quadratic or profiled), parameters on
/// a bound, and the honest warnings (appended to `warnings`).
pub(super) fn uncertainty(
    full: &BrdfProblem,
    sol: &Solution,
    theta: &[f64],
    cost: f64,
    lay: &Layout,
    opts: &FitOptions,
    warnings: &mut Vec<String>,
) -> Uncertainty {
    let m = full.rows.len();
    let nfree = theta.len();
    let (se, corr, singular) = statistics(full, sol, theta, cost, m);
    let prof = full.subsample(1000);
    // Each free parameter's 1 % range, the parameters in parallel (a profile is a series of
    // refits; each range is the same on any number of threads).
    let range_of = |k: usize| -> Option<(f64, f64)> {
        // The quadratic model of the cost gives the 1 % range in solver space,
        // Δu = (σ_θ/|dθ/du|)·√(0.01 (m − p)); where it is narrow (a factor ≤ 1.2, inside the
        // bounds) it stands, otherwise the cost is profiled for real.
        let t = full.transforms[k];
        let (ulo, uhi) = t.bounds();
        let du = se[k] / t.apply(sol.x[k]).1.abs().max(1e-300)
            * (0.01 * (m.saturating_sub(nfree)) as f64).sqrt();
        let quadratic = (du.is_finite() && sol.x[k] - du > ulo && sol.x[k] + du < uhi)
            .then(|| {
                let (a, b) = (t.apply(sol.x[k] - du).0, t.apply(sol.x[k] + du).0);
                (a.min(b), a.max(b))
            })
            .filter(|(a, b)| *a > 0.0 && b / a <= 1.2);
        if !opts.profile {
            None
        } else if quadratic.is_some() {
            quadratic
        } else {
            profile_range(&prof, &sol.x, k, opts)
        }
    };
    let all_ranges: Vec<Option<(f64, f64)>> = {
        use rayon::prelude::*;
        (0..nfree).into_par_iter().map(range_of).collect()
    };
    let mut ranges = Vec::new();
    let mut at_bound = Vec::new();
    for k in 0..nfree {
        let name = &lay.names[k];
        let range = all_ranges[k];
        let t = full.transforms[k];
        let side = lsq::bound_side(sol.x[k], t.bounds());
        if side != 0 {
            let which = if side < 0 { "lower" } else { "upper" };
            at_bound.push((name.clone(), which.to_string()));
        }
        // A shape parameter at the end of its box has run off (a linear one at 0 is an answer).
        let ran_off = side != 0 && matches!(t.scale, Scale::Log { .. });
        let rel = se[k] / theta[k].abs().max(1e-300);
        // Weak: the 1 % range spans more than a factor 1.25, or reaches a bound.
        let wide = range.is_some_and(|(a, b)| !(b / a <= 1.25) || a == f64::NEG_INFINITY);
        if let Some((a, b)) = range {
            ranges.push((name.clone(), a, b));
        }
        if side != 0 && !ran_off {
            warnings.push(format!(
                "{name} = {} is at its {} bound",
                readable(theta[k]),
                if side < 0 { "lower" } else { "upper" }
            ));
        } else if !(rel <= 0.5) || singular[k] || ran_off || wide {
            let why = if ran_off {
                format!(
                    "{name} ran to the edge of its range ({})",
                    readable(theta[k])
                )
            } else if singular[k] {
                format!("{name} is not determined by the data (JᵀJ is near-singular in it)")
            } else if !(rel <= 10.0) {
                format!("{name} is not determined by the data (standard error over 10× the value)")
            } else if !(rel <= 0.5) {
                format!(
                    "{name} is not determined by the data (relative standard error {} %)",
                    readable((100.0 * rel).round())
                )
            } else {
                format!("{name} is only weakly determined by the data")
            };
            warnings.push(match range {
                Some(r) => format!("{why}: {}", describe_range(name, r)),
                None => why,
            });
        }
    }
    Uncertainty {
        se,
        corr,
        ranges,
        at_bound,
    }
}

/// Every model parameter as reported, fixed ones included: (params, stderr, free,
/// correlation), in model order.
pub(super) type Reported = (Vec<(String, f64)>, Vec<f64>, Vec<bool>, Vec<Vec<f64>>);

/// Step 7: the reported parameters from the solver variables.
pub(super) fn reported(lay: &Layout, theta: &[f64], u: &Uncertainty) -> Reported {
    let order: Vec<Option<usize>> = lay
        .entries
        .iter()
        .map(|e| match e.slot {
            Slot::Free(k) => Some(k),
            Slot::Fixed(_) => None,
        })
        .collect();
    let params = lay
        .entries
        .iter()
        .map(|e| match e.slot {
            Slot::Free(k) => (e.name.clone(), theta[k]),
            Slot::Fixed(v) => (e.name.clone(), v),
        })
        .collect();
    let stderr = order.iter().map(|o| o.map_or(0.0, |k| u.se[k])).collect();
    let free = order.iter().map(Option::is_some).collect();
    let correlation = (0..order.len())
        .map(|a| {
            (0..order.len())
                .map(|b| match (order[a], order[b]) {
                    (Some(i), Some(j)) => u.corr[i][j],
                    _ if a == b => 1.0,
                    _ => 0.0,
                })
                .collect()
        })
        .collect();
    (params, stderr, free, correlation)
}

/// Standard errors, correlations and per-parameter near-singularity flags from JᵀJ in natural
/// parameters (σ̂² = 2 cost/(m − p)).
pub(super) fn statistics(
    full: &BrdfProblem,
    sol: &Solution,
    theta: &[f64],
    cost: f64,
    m: usize,
) -> (Vec<f64>, Vec<Vec<f64>>, Vec<bool>) {
    let p = theta.len();
    if p == 0 {
        // Every parameter held: nothing to estimate.
        return (vec![], vec![], vec![]);
    }
    // JᵀJ in natural parameters: from the solver's last pass by the chain rule
    // (J_θ = J_u / (dθ/du)) when every dθ/du is non-zero, else from one more pass.
    let chain: Vec<f64> = (0..p)
        .map(|k| full.transforms[k].apply(sol.x[k]).1)
        .collect();
    let reuse = sol
        .normal
        .as_ref()
        .filter(|_| chain.iter().all(|d| d.abs() > 1e-12))
        .map(|n| lsq::Normal {
            cost: n.cost,
            jtj: (0..p * p)
                .map(|i| n.jtj[i] / (chain[i / p] * chain[i % p]))
                .collect(),
            jtr: (0..p).map(|i| n.jtr[i] / chain[i]).collect(),
        });
    let Some(ne) = reuse.or_else(|| lsq::normal_equations(&full.natural(), theta, Robust::None))
    else {
        return (
            vec![f64::INFINITY; p],
            vec![vec![f64::NAN; p]; p],
            vec![true; p],
        );
    };
    let a = nalgebra::DMatrix::from_row_slice(p, p, &ne.jtj);
    let d: Vec<f64> = (0..p).map(|i| a[(i, i)].max(1e-300).sqrt()).collect();
    let scaled = nalgebra::DMatrix::from_fn(p, p, |i, j| a[(i, j)] / (d[i] * d[j]));
    let eig = scaled.clone().symmetric_eigen();
    let (imin, lmin) =
        eig.eigenvalues
            .iter()
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |acc, (i, &l)| if l < acc.1 { (i, l) } else { acc },
            );
    let lmax = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let near_singular = !(lmin > 1e-12 * lmax);
    let singular: Vec<bool> = (0..p)
        .map(|i| near_singular && eig.eigenvectors[(i, imin)].abs() > 0.3)
        .collect();
    let sigma2 = 2.0 * cost / (m.saturating_sub(p)).max(1) as f64;
    // Pseudo-inverse in the scaled space, dropping directions below 1e-14 of the largest.
    let mut inv = nalgebra::DMatrix::<f64>::zeros(p, p);
    for k in 0..p {
        let l = eig.eigenvalues[k];
        let v = eig.eigenvectors.column(k);
        let il = if l > 1e-14 * lmax {
            1.0 / l
        } else {
            1e14 / lmax.max(1e-300)
        };
        inv += v * v.transpose() * il;
    }
    let cov = nalgebra::DMatrix::from_fn(p, p, |i, j| sigma2 * inv[(i, j)] / (d[i] * d[j]));
    let se: Vec<f64> = (0..p).map(|i| cov[(i, i)].max(0.0).sqrt()).collect();
    let corr = (0..p)
        .map(|i| {
            (0..p)
                .map(|j| {
                    let c = cov[(i, j)] / (se[i] * se[j]);
                    if c.is_finite() {
                        c.clamp(-1.0, 1.0)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    (se, corr, singular)
}

/// Human-readable form of a profiled range (∞ upper bound = open).
pub fn describe_range(name: &str, (lo, hi): (f64, f64)) -> String {
    let what = match (lo == f64::NEG_INFINITY, hi == f64::INFINITY) {
        (true, true) => format!("any {name}"),
        (true, false) => format!("{name} ≤ {}", readable(hi)),
        (false, true) => format!("{name} ≥ {}", readable(lo)),
        (false, false) => format!("{name} in [{}, {}]", readable(lo), readable(hi)),
    };
    format!("{what} fits within 1 % of the minimum cost")
}

/// Profile a free variable on problem `p`: hold it at grid values, refit the rest from the
/// optimum `x`, and return the range of values whose cost is within 1 % of the minimum. The
/// bounds are the nearest grid values that do *not* fit, so the range contains every value
/// that does; an end that reaches the parameter's own bound is ∓∞ (open).
pub(super) fn profile_range(
    p: &BrdfProblem,
    x: &[f64],
    k: usize,
    opts: &FitOptions,
) -> Option<(f64, f64)> {
    let t = p.transforms[k];
    let (ulo, uhi) = t.bounds();
    // The 1 % test needs the profiled cost to a few digits only.
    let limits = Limits {
        max_iter: 40,
        ftol: 1e-8,
        ..opts.limits
    };
    // Cost of the problem with variable k held at solver value u, the rest refitted from x.
    let held = |u: f64| -> f64 {
        let mut q = p.clone();
        let v = t.apply(u).0;
        for slots in q.layout.iter_mut() {
            for s in slots.iter_mut() {
                *s = match *s {
                    Slot::Free(j) if j == k => Slot::Fixed(v),
                    Slot::Free(j) if j > k => Slot::Free(j - 1),
                    other => other,
                };
            }
        }
        q.transforms.remove(k);
        let mut x0 = x.to_vec();
        x0.remove(k);
        let s = lsq::levenberg_marquardt(&q, &x0, Robust::None, &limits);
        if s.cost.is_finite() {
            s.cost
        } else {
            f64::INFINITY
        }
    };
    let c0 = lsq::cost(p, x, Robust::None)?;
    let limit = 1.01 * c0;
    // Walk outward in solver space with doubling steps until the cost exceeds the limit, then
    // bisect; the bound returned is the failing end of the last bracket.
    let side = |dir: f64| -> Option<f64> {
        let edge = if dir > 0.0 { uhi } else { ulo };
        let mut inside = x[k];
        let mut step = 0.05;
        let outside = loop {
            let u = (inside + dir * step).clamp(ulo, uhi);
            if held(u) > limit {
                break u;
            }
            if u == edge {
                return None;
            }
            inside = u;
            step *= 2.0;
        };
        let (mut a, mut b) = (inside, outside);
        for _ in 0..4 {
            let mid = 0.5 * (a + b);
            if held(mid) > limit {
                b = mid;
            } else {
                a = mid;
            }
        }
        Some(b)
    };
    let (lo, hi) = rayon::join(|| side(-1.0), || side(1.0));
    let lo = lo.map_or(f64::NEG_INFINITY, |u| t.apply(u).0);
    let hi = hi.map_or(f64::INFINITY, |u| t.apply(u).0);
    Some((lo, hi))
}

//! Stage 5 of a fit: what the data say about each parameter (standard errors,
//! correlations, 1 % ranges, profiles) and the reported parameters.

use super::lsq::{self, Limits, Robust, Solution};
use super::options::FitOptions;
use super::problem::{BrdfProblem, Slot};
use super::setup::Layout;
use crate::model::{Scale, readable};

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
    // The profile-likelihood interval at INTERVAL_LEVEL: the values of a parameter at which
    // the cost, the others refitted, stays below S (1 + F/(m − p)), F = t² the F(1, m − p)
    // quantile (Bates & Watts, "Nonlinear Regression Analysis and Its Applications", 1988,
    // §6.1.2, the profile t; σ² = 2S/(m − p)).
    let dof = m.saturating_sub(nfree).max(1) as f64;
    let q = {
        let t = super::quantile::t_quantile(INTERVAL_LEVEL, dof);
        t * t
    };
    let rise = 1.0 + q / dof;
    // Each free parameter's interval, the parameters in parallel (a profile is a series of
    // refits; each interval is the same on any number of threads).
    let range_of = |k: usize| -> Option<(f64, f64)> {
        // The quadratic model of the cost: the Wald half-width in solver space,
        // Δu = (σ_θ/|dθ/du|)·t; where the profile is not run (or this is a fit held by a
        // constraint), the interval.
        let t = full.transforms[k];
        let (ulo, uhi) = t.bounds();
        let du = se[k] / t.apply(sol.x[k]).1.abs().max(1e-300) * q.sqrt();
        if opts.profile {
            // How the others move with variable k along the profile, to first order
            // (Σ_jk/Σ_kk in solver space): each refit starts where the quadratic model puts
            // its minimum.
            let chain = |j: usize| full.transforms[j].apply(sol.x[j]).1;
            let slope: Vec<f64> = (0..nfree)
                .filter(|&j| j != k)
                .map(|j| {
                    let s = corr[j][k] * se[j] / se[k] * chain(k) / chain(j);
                    if s.is_finite() { s } else { 0.0 }
                })
                .collect();
            return profile_range(full, &sol.x, None, k, du, rise, &slope, opts);
        }
        if !du.is_finite() {
            return None;
        }
        let lo = if sol.x[k] - du > ulo {
            t.apply(sol.x[k] - du).0
        } else {
            f64::NEG_INFINITY
        };
        let hi = if sol.x[k] + du < uhi {
            t.apply(sol.x[k] + du).0
        } else {
            f64::INFINITY
        };
        Some((lo, hi))
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
        // Where the profiled interval contradicts the standard error, it alone judges.
        let contradiction = range.and_then(|r| wald_warning(name, theta[k], se[k], r, q.sqrt()));
        let rel = if contradiction.is_some() { 0.0 } else { rel };
        // Weak: the interval spans more than a factor 1.25, or reaches a bound.
        let wide = range.is_some_and(|(a, b)| !(b / a <= 1.25) || a == f64::NEG_INFINITY);
        if let Some((a, b)) = range {
            ranges.push((name.clone(), a, b));
        }
        if lay.specs[k].role == crate::model::Role::Index && theta[k] >= lay.specs[k].absurd_above {
            // F = 1 − 4/n + … at normal incidence and larger elsewhere (Blinn 1977): above the
            // limit every angle sees F ≈ 1 and the data say only that n is large.
            warnings.push(match range {
                Some(r) => format!("{METAL}: {}", describe_range(name, r, INTERVAL_LEVEL)),
                None => METAL.to_string(),
            });
        } else if side != 0 && !ran_off {
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
                Some(r) => format!("{why}: {}", describe_range(name, r, INTERVAL_LEVEL)),
                None => why,
            });
        }
        warnings.extend(contradiction);
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

/// The confidence level of the intervals a fit reports (`interval_level` in the fit JSON).
pub const INTERVAL_LEVEL: f64 = 0.95;

/// Where the Wald interval (value ± t·se, from JᵀJ) and the profiled one differ in their
/// distance from the value by more than this factor on a side, the output says so: the cost is
/// far from quadratic in the parameter, and the profiled interval is the one that holds.
pub const WALD_FACTOR: f64 = 2.0;

/// The factor by which the Wald interval `value ± t·se` and the profiled `[lo, hi]` differ in
/// their distance from `value`, the larger of the two sides (≥ 1); `None` where either is
/// not finite (an open interval is described as such already).
pub fn wald_mismatch(value: f64, se: f64, (lo, hi): (f64, f64), t: f64) -> Option<f64> {
    let w = t * se;
    let ratio = |d: f64| (w / d).max(d / w);
    let r = ratio(value - lo).max(ratio(hi - value));
    (w > 0.0 && r.is_finite()).then_some(r)
}

/// The warning of a Wald interval that contradicts the profiled one ([`wald_mismatch`]).
pub fn wald_warning(name: &str, value: f64, se: f64, range: (f64, f64), t: f64) -> Option<String> {
    let r = wald_mismatch(value, se, range, t).filter(|r| *r > WALD_FACTOR)?;
    Some(format!(
        "{name}'s standard error {} contradicts its profiled interval: value ± t·se is [{}, {}] \
         where the data allow [{}, {}] (a factor {} apart; the cost is not quadratic in {name}): \
         use the interval, not the standard error",
        readable(se),
        readable(value - t * se),
        readable(value + t * se),
        readable(range.0),
        readable(range.1),
        readable((10.0 * r).round() / 10.0),
    ))
}

/// The warning of a Fresnel index at or above its limit (1e6, where F ≥ 1 − 4e-6 at every
/// angle): a metal's, usable, with n not determined.
pub const METAL: &str = "n is not determined: F ≈ 1 at every angle (a metal)";

/// Human-readable form of an interval (∓∞ = open on that side) at confidence `level`; a
/// level of 0 (fit files of earlier versions, whose `ranges` held the values within 1 % of
/// the minimum cost) says so.
pub fn describe_range(name: &str, (lo, hi): (f64, f64), level: f64) -> String {
    let what = match (lo == f64::NEG_INFINITY, hi == f64::INFINITY) {
        (true, true) => format!("any {name}"),
        (true, false) => format!("{name} ≤ {}", readable(hi)),
        (false, true) => format!("{name} ≥ {}", readable(lo)),
        (false, false) => format!("{name} in [{}, {}]", readable(lo), readable(hi)),
    };
    if level > 0.0 {
        format!("{what} ({} % confidence)", readable(100.0 * level))
    } else {
        format!("{what} fits within 1 % of the minimum cost")
    }
}

/// The relative cost reduction that ends a profile refit, at most.
const PROFILE_FTOL: f64 = 1e-6;

/// The limits of a profile refit whose limit is `rise` times the minimum cost: stopped at a
/// relative reduction of at most a hundredth of the rise (and [`PROFILE_FTOL`]), which moves an
/// end by well under the bracket's 1 % resolution.
fn profile_limits(opts: &FitOptions, rise: f64) -> Limits {
    Limits {
        max_iter: 40,
        ftol: PROFILE_FTOL.min(0.01 * (rise - 1.0)),
        ..opts.limits
    }
}

/// Profile a free variable on problem `p`: hold it at probed values, refit the rest, and
/// return the range of values whose cost is at most `rise` times the minimum (1.01: within
/// 1 %; a confidence interval's 1 + F/(m − p)). The bounds are the
/// nearest probed values that do *not* fit, so the range contains every value that does; an
/// end that reaches the parameter's own bound is ∓∞ (open). `du` is the step in solver space
/// the quadratic model of the cost predicts for a 1 % rise (where it is not finite, 0.05):
/// each side starts there (see [`crossing`]), and each refit starts from the other
/// variables' values at the nearest value probed before (a failing one that stopped at its
/// iteration limit also from the optimum's), moved by `slope` (the others' first-order change
/// per unit of variable k, in solver space; empty = none) to where the quadratic model of the
/// cost puts their minimum.
#[allow(clippy::too_many_arguments)]
pub(super) fn profile_range(
    p: &BrdfProblem,
    x: &[f64],
    centre: Option<(&[f64], f64)>,
    k: usize,
    du: f64,
    rise: f64,
    slope: &[f64],
    opts: &FitOptions,
) -> Option<(f64, f64)> {
    let t = p.transforms[k];
    let (ulo, uhi) = t.bounds();
    let limits = profile_limits(opts, rise);
    // The problem with variable k held at solver value u (the rest free).
    let held_problem = |u: f64| -> BrdfProblem {
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
        q
    };
    let c0 = lsq::cost(p, x, Robust::None)?;
    let limit = rise * c0;
    let mut rest = x.to_vec();
    rest.remove(k);
    // A start for the refit at u from the others' values `w` found at `from`: moved along
    // `slope`, kept inside their bounds.
    let predicted = |w: &[f64], from: f64, u: f64| -> Vec<f64> {
        w.iter()
            .enumerate()
            .map(|(j, &v)| {
                let (lo, hi) = p.transforms[if j < k { j } else { j + 1 }].bounds();
                let moved = v + slope.get(j).copied().unwrap_or(0.0) * (u - from);
                if moved.is_finite() {
                    moved.clamp(lo, hi)
                } else {
                    v
                }
            })
            .collect()
    };
    // Cost with variable k held at u, the rest refitted from `warm`, and where they ended. A
    // refit above the limit that stopped at its iteration limit (not by a convergence test)
    // is made again from the optimum, and the lower kept: a warm start from a distant probe
    // can stall (40 iterations) where the optimum's values do not. (A converged one is not:
    // on every fit of the bundled files that second refit opened or closed no range and moved
    // no end by more than 2e-4 of its value, and it took GGX–Smith-2's statistics on MERL
    // alumina-oxide from 0.84 to 1.27 ms.)
    // (`warm` carries, last, the value of variable k it was found at.)
    let held = |u: f64, warm: &[f64]| -> (f64, Vec<f64>) {
        let q = held_problem(u);
        let refit = |w: &[f64], from: f64| {
            let start = predicted(w, from, u);
            let s = lsq::levenberg_marquardt(&q, &start, Robust::None, &limits);
            let c = if s.cost.is_finite() {
                s.cost
            } else {
                f64::INFINITY
            };
            let mut end = s.x;
            end.push(u);
            (c, end, s.converged)
        };
        let (w, from) = warm.split_at(warm.len() - 1);
        let (c, end, converged) = refit(w, from[0]);
        if c <= limit || converged || w == rest.as_slice() {
            return (c, end);
        }
        let (cc, cend, _) = refit(&rest, x[k]);
        if cc < c { (cc, cend) } else { (c, end) }
    };
    let mut warm0 = rest.clone();
    warm0.push(x[k]);
    // The subsample's own minimum, where the profiled cost bottoms out: the walk's steps are
    // placed from it.
    let (uc, cc) = centre
        .map(|(c, cc)| (c[k], cc))
        .filter(|&(_, cc)| cc < c0)
        .unwrap_or((x[k], c0));
    let side = |dir: f64| {
        let edge = if dir > 0.0 { uhi } else { ulo };
        let vertex = ((uc - x[k]) * dir, cc);
        crossing(&held, x[k], &warm0, c0, limit, dir, du, edge, vertex).0
    };
    let (lo, hi) = rayon::join(|| side(-1.0), || side(1.0));
    let lo = lo.map_or(f64::NEG_INFINITY, |u| t.apply(u).0);
    let hi = hi.map_or(f64::INFINITY, |u| t.apply(u).0);
    Some((lo, hi))
}

/// The first probe of a side goes this far beyond the quadratic model's crossing, so that
/// where that model holds it lands just outside.
const FIRST_STEP: f64 = 1.005;

/// A first probe whose profiled cost exceeds the limit by at most this share of the rise
/// (limit − minimum) ends its side: on a quadratic profile it is then at most √1.02 − 1 <
/// 1 % of the distance outside the crossing, the bracket's resolution, and one probe a side
/// is all a near-quadratic profile costs.
const QUADRATIC_EXCESS: f64 = 0.02;

/// Probes of one side of a profile at most (the walk grows its step at least 1.1× a probe, so
/// only an unbounded variable whose cost never rises reaches this; that side is then open).
const MAX_PROBES: usize = 60;

/// One side of a profile: from the minimum `u0` (cost `c0`) in direction `dir` (±1), the
/// nearest probed value whose profiled cost exceeds `limit`, or `None` when `edge` itself
/// does not exceed it (the range is open on that side); with the number of probes. `held(u,
/// warm)` is the profiled cost at u, refitted from `warm`, and where the other variables end.
///
/// The walk starts just beyond the predicted distance `du` (the quadratic model's, times
/// [`FIRST_STEP`]; 0.05 where it is not finite or not positive), and a first probe that fails
/// by at most [`QUADRATIC_EXCESS`] of the rise is the end; while a probe fits, the next goes where c(d) = cv + a (d −
/// dv)² through it reaches the limit (1 % beyond, at least 1.1× and at most 10× the
/// distance), (dv, cv) = `vertex` being where the profiled cost bottoms out: (0, c0) when the
/// walk starts at the minimum, else (a subsample's profile measured from the full data's
/// optimum) its own minimum's distance along `dir` and cost, for a profile that first dips
/// below c0 rises from there, not from c0. The bracket (last fitting distance, first failing
/// one) then closes by interpolation in (d − dv)² (exact for a quadratic profile), nudged by
/// a quarter of the tolerance towards the side the last probe did not land on, with a
/// bisection after three probes in a row on one side, until it is at most 1 % of the distance
/// wide (or 1e-9): the end returned is then within that of the true crossing, from outside.
#[allow(clippy::too_many_arguments)]
pub(super) fn crossing(
    held: &impl Fn(f64, &[f64]) -> (f64, Vec<f64>),
    u0: f64,
    warm0: &[f64],
    c0: f64,
    limit: f64,
    dir: f64,
    du: f64,
    edge: f64,
    vertex: (f64, f64),
) -> (Option<f64>, usize) {
    let (dv, cv) = vertex;
    let reach = (edge - u0).abs();
    let at = |d: f64| if d >= reach { edge } else { u0 + dir * d };
    let mut probes = 0;
    // The last fitting probe: distance, cost, the other variables there.
    let (mut a, mut ca, mut wa) = (0.0, c0, warm0.to_vec());
    let mut d = if du.is_finite() && du > 0.0 {
        FIRST_STEP * du
    } else {
        0.05
    };
    let (mut b, mut cb, mut wb) = loop {
        d = d.min(reach);
        let (c, w) = held(at(d), &wa);
        probes += 1;
        if !(c <= limit) {
            // A first probe that fails by at most QUADRATIC_EXCESS of the rise is within 1 %
            // outside the crossing on a quadratic profile: it is the end.
            if probes == 1 && dv == 0.0 && c - cv <= (1.0 + QUADRATIC_EXCESS) * (limit - cv) {
                return (Some(at(d)), probes);
            }
            break (d, c, w);
        }
        if d >= reach || probes >= MAX_PROBES {
            return (None, probes);
        }
        let rise = c - cv;
        let next = if rise > 0.0 && d > dv {
            dv + 1.01 * (d - dv) * ((limit - cv) / rise).sqrt()
        } else {
            f64::INFINITY
        };
        (a, ca, wa) = (d, c, w);
        d = next.clamp(1.1 * d, 10.0 * d);
    };
    // The side the last probe landed on (+1 failing) and how many in a row landed there.
    let (mut last, mut streak) = (1, 1);
    while probes < MAX_PROBES {
        let width = b - a;
        let tol = (0.01 * b).max(1e-9);
        if width <= tol {
            break;
        }
        // (Before the vertex the profile is not monotone in (d − dv)²: in d² then.)
        let v = if a > dv { dv } else { 0.0 };
        let (sa, sb) = ((a - v) * (a - v), (b - v) * (b - v));
        // (A failing end whose refit has no finite cost gives no slope: bisect.)
        let r = if cb.is_finite() {
            v + (sa + (limit - ca) * (sb - sa) / (cb - ca)).sqrt()
        } else {
            f64::NAN
        };
        let q = 0.25 * tol.min(0.5 * width);
        let m = if !r.is_finite() || streak >= 3 {
            streak = 0;
            0.5 * (a + b)
        } else if last > 0 {
            (r - q).clamp(a + q, b - q)
        } else {
            (r + q).clamp(a + q, b - q)
        };
        // Warm from the nearer end (the failing end only if its refit is finite).
        let warm = if m - a <= b - m || !cb.is_finite() {
            &wa
        } else {
            &wb
        };
        let (c, w) = held(at(m), warm);
        probes += 1;
        let side = if c <= limit {
            (a, ca, wa) = (m, c, w);
            -1
        } else {
            (b, cb, wb) = (m, c, w);
            1
        };
        streak = if side == last { streak + 1 } else { 1 };
        last = side;
    }
    (Some(at(b)), probes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::problem::Loss;
    use crate::model::ModelKind;

    /// A profiled cost given as a function (no refit: `warm` is passed through).
    fn probe(f: impl Fn(f64) -> f64) -> impl Fn(f64, &[f64]) -> (f64, Vec<f64>) {
        move |u, w| (f(u), w.to_vec())
    }

    /// A quadratic profile c(u) = c0 (1 + (u − u0)²/s²) rises by 1 % at u0 ± s/10 exactly:
    /// each side returns a failing value at most 1 % of the distance beyond it, from the
    /// predicted step (exact here) in one probe, and from a poor prediction (100× too short
    /// or too long, or none) in a few more.
    #[test]
    fn quadratic_profile_crosses_at_the_hand_worked_value() {
        let (u0, s, c0) = (0.7, 0.4, 3.0);
        let f = probe(move |u: f64| c0 * (1.0 + (u - u0).powi(2) / (s * s)));
        let exact = s / 10.0;
        for (du, most) in [
            (exact, 1),
            (exact * 0.99, 4),
            (exact / 100.0, 12),
            (exact * 100.0, 14),
            (f64::NAN, 12),
        ] {
            for dir in [-1.0, 1.0] {
                let (u, n) = crossing(&f, u0, &[], c0, 1.01 * c0, dir, du, dir * 50.0, (0.0, c0));
                let d = (u.expect("a closed side") - u0) * dir;
                assert!(
                    d >= exact * (1.0 - 1e-12) && d <= exact * 1.0101,
                    "du {du} dir {dir}: {d} vs {exact}"
                );
                assert!(f(u0 + dir * d, &[]).0 > 1.01 * c0);
                assert!(n <= most, "du {du} dir {dir}: {n} probes");
            }
        }
    }

    /// A skewed profile c(u) = c0 e^{(u − u0)} − c0 (u − u0) (minimum c0 at u0): the 1 % rise
    /// is where e^d − d = 1.01 (d²/2 + d³/6 + … = 0.01): d = 0.138165… above and −0.144835…
    /// below (Newton's method on it, here and by hand); a side whose cost never reaches the
    /// limit before the edge is open.
    #[test]
    fn skewed_profile_and_an_open_side() {
        let (u0, c0) = (-1.0, 2.0);
        let f = probe(move |u: f64| c0 * ((u - u0).exp() - (u - u0)));
        // Newton on g(d) = e^d − d − 1.01 from each side.
        let root = |mut d: f64| {
            for _ in 0..50 {
                d -= (d.exp() - d - 1.01) / (d.exp() - 1.0);
            }
            d
        };
        let (up, down) = (root(0.2), root(-0.2));
        assert!((up - 0.138_165).abs() < 1e-6 && (down + 0.144_835).abs() < 1e-6);
        let (hi, _) = crossing(&f, u0, &[], c0, 1.01 * c0, 1.0, 0.05, 10.0, (0.0, c0));
        let (lo, _) = crossing(&f, u0, &[], c0, 1.01 * c0, -1.0, 0.05, -10.0, (0.0, c0));
        let (hi, lo) = (hi.unwrap() - u0, lo.unwrap() - u0);
        assert!(hi >= up * (1.0 - 1e-9) && hi <= up * 1.0101, "{hi} vs {up}");
        assert!(
            lo <= down * (1.0 - 1e-9) && lo >= down * 1.0101,
            "{lo} vs {down}"
        );
        // The edge at u0 + 0.1 lies inside the range: open.
        let (open, n) = crossing(&f, u0, &[], c0, 1.01 * c0, 1.0, 0.05, u0 + 0.1, (0.0, c0));
        assert_eq!(open, None);
        assert!(n <= 2, "{n}");
    }

    /// A profile measured from off its minimum (a subsample's, from the full data's optimum):
    /// c(u) = 3 (1 + (u − 0.7)²/0.16) from u0 = 0.72, c0 = c(u0) = 3.0075, limit 1.01 c0 =
    /// 3.037575, crosses where (u − 0.7)² = 0.16 (limit/3 − 1) = 0.002004, |u − 0.7| =
    /// 0.0447660: 0.0247660 above u0 and 0.0647660 below. From a first step of 0.03 each side
    /// ends within 1 % outside the crossing; told the vertex (its distance along each side and
    /// its cost 3), the walk needs at most 4 probes a side and fewer in all than from c0 alone,
    /// whose first probe below (cost under c0) shows no rise and steps tenfold out.
    #[test]
    fn a_profile_off_its_minimum_crosses_where_worked_by_hand() {
        let (uv, cv, u0) = (0.7, 3.0, 0.72);
        let c = move |u: f64| cv * (1.0 + (u - uv).powi(2) / 0.16);
        let f = probe(c);
        let c0 = c(u0);
        assert!((c0 - 3.0075).abs() < 1e-12);
        let half = (0.16f64 * (1.01 * c0 / cv - 1.0)).sqrt();
        assert!((half - 0.044_766).abs() < 1e-6);
        let mut with = 0;
        let mut without = 0;
        for dir in [1.0, -1.0] {
            let exact = (uv + dir * half - u0) * dir;
            for (vertex, count) in [
                (((uv - u0) * dir, cv), &mut with),
                ((0.0, c0), &mut without),
            ] {
                let (u, n) = crossing(&f, u0, &[], c0, 1.01 * c0, dir, 0.03, dir * 50.0, vertex);
                let d = (u.expect("a crossing") - u0) * dir;
                assert!(
                    d >= exact * (1.0 - 1e-9) && d <= 1.0101 * exact,
                    "{dir} {vertex:?}: {d}"
                );
                *count += n;
                if vertex.1 == cv {
                    assert!(n <= 4, "{dir}: {n} probes");
                }
            }
        }
        assert!(
            with < without,
            "{with} probes with the vertex, {without} without"
        );
    }

    /// Profiling on a real problem: Lambert's f_r = pd/π with the linear loss has the cost
    /// ½ Σ (pd/π − f_i)², quadratic in pd; for f = 1, 2, 3, 4 the minimum is pd = 2.5π with
    /// cost 2.5, and the cost rises by 1 % (0.025) where ½·4·(Δ/π)² = 0.025, Δ = π √0.0125 =
    /// 0.351240…: the range is [7.502741, 8.205222] to within 1 % of Δ, outside it.
    #[test]
    fn lambert_linear_range_by_hand() {
        use crate::data::{Dataset, Quantity};
        let mut ds = Dataset::new(Quantity::Brdf, vec![("y".into(), None)]);
        for (i, f) in [1.0, 2.0, 3.0, 4.0].iter().enumerate() {
            let t = 0.1 + 0.2 * i as f64;
            ds.push([t, 0.0, t + 0.1, 3.0], &[*f]);
        }
        let mut opts = FitOptions::new(ModelKind::Lambert);
        opts.loss = Loss::Linear;
        let rows = super::super::setup::channel_rows(&ds, 0, &opts);
        let lay = super::super::setup::layout(&["y".to_string()], &opts);
        let p = super::super::setup::problem(vec![rows], &lay, &opts);
        let pi = std::f64::consts::PI;
        let x = [2.5 * pi];
        assert!((lsq::cost(&p, &x, Robust::None).unwrap() - 2.5).abs() < 1e-12);
        let delta = pi * 0.0125f64.sqrt();
        assert!((delta - 0.351_240).abs() < 1e-6);
        for du in [delta, 0.05, f64::NAN] {
            let (lo, hi) =
                profile_range(&p, &x, None, 0, du, 1.01, &[], &opts).expect("a finite cost");
            // (An end may be the crossing itself, whose cost rounds above the limit.)
            let (dlo, dhi) = (2.5 * pi - lo, hi - 2.5 * pi);
            assert!(dlo >= delta * (1.0 - 1e-9) && dlo <= 1.0101 * delta, "{lo}");
            assert!(dhi >= delta * (1.0 - 1e-9) && dhi <= 1.0101 * delta, "{hi}");
        }
        assert!((2.5 * pi - delta - 7.502_741).abs() < 1e-6);
        assert!((2.5 * pi + delta - 8.205_222).abs() < 1e-6);
    }
}

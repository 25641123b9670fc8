//! Where to measure next: the configurations whose measurement would most reduce what the
//! prior and the samples leave uncertain, in the pixels of a scene or over the whole table.
//!
//! Under the prior ([`crate::prior`]) a material's mapped table is x = m + B c, the
//! coefficients c Gaussian with the components' variances Λ; a sample at configuration g
//! observes aᵀc + noise (a = the components at g, interpolated as the reconstruction does;
//! noise variance σ²). Given samples A, the posterior covariance is Σ = (AᵀA/σ² + Λ⁻¹)⁻¹: it
//! depends on where the samples are, not on their values. What remains uncertain in a target
//! (the scene's lit pixels, each configuration weighted by its pixel count; or every cell of
//! the table alike) is the weighted posterior variance of the mapped value there, V = tr(Σ W)
//! with W = Σ_p w_p a_p a_pᵀ. One more sample at a removes
//! aᵀΣWΣa / (σ² + aᵀΣa) of it (the rank-one update of Σ). The plan adds, greedily, the
//! reachable configuration that removes the most (a V-optimal design: Fedorov, "Theory of
//! Optimal Experiments", 1972; the greedy order makes the first k of a plan the best k it
//! found), each candidate's Σa and WΣa updated in O(K) per step.

use crate::data::Dataset;
use crate::model::Geometry;
use crate::prior::Prior;
use nalgebra::DMatrix;
use std::f64::consts::{FRAC_PI_2, PI};

/// Noise variance of a sample (mapped units: ln² of a ratio) where no measurement gives one
/// by cross-validation: a 10 % relative error.
pub const DEFAULT_NOISE: f64 = 1e-2;

/// Most configurations a plan may ask for.
pub const MAX_BUDGET: usize = 10_000;

/// What a goniometer can reach, and how many configurations to plan.
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// Configurations to plan.
    pub budget: usize,
    /// Largest θi and θo (degrees).
    pub max_theta_deg: f64,
    /// Smallest angle between source and detector (degrees): 2 θd.
    pub min_separation_deg: f64,
    /// Only configurations in the plane of incidence (φo − φi = 0° or 180°).
    pub in_plane: bool,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            budget: 100,
            max_theta_deg: 85.0,
            min_separation_deg: 5.0,
            in_plane: false,
        }
    }
}

/// What a plan reduces the uncertainty of.
#[derive(Clone, Debug)]
pub enum Target {
    /// Every cell of the prior's table alike (a first measurement, no scene).
    Table,
    /// Configurations (θi, φi, θo, φo in radians) with weights: a scene's lit pixels.
    Configurations(Vec<([f64; 4], f64)>),
}

impl Target {
    /// The lit pixels of the test object (material 0) in each case, binned as `choose` bins
    /// them ([`crate::choose::scene_samples`]), each case weighing the same in all.
    pub fn scene(cases: &[crate::choose::Case]) -> Target {
        let mut out = Vec::new();
        for case in cases {
            let (ds, _, _) = crate::choose::scene_samples(&case.scene, 0, &|_| 1.0);
            let w = ds.weights.clone().unwrap_or_default();
            let total: f64 = w.iter().sum();
            for (i, wi) in w.iter().enumerate().take(ds.len()) {
                out.push((ds.angles(i), wi / total.max(1e-300)));
            }
        }
        Target::Configurations(out)
    }
}

/// One planned configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    /// θi, φi, θo, φo (radians; φi = 0).
    pub angles: [f64; 4],
    /// The predicted variance it removes from the target.
    pub reduction: f64,
    /// That reduction as a share of the variance left before it.
    pub share: f64,
}

/// A measurement plan.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The configurations, best first.
    pub rows: Vec<Planned>,
    /// The target's weighted posterior variance before the plan (mapped units).
    pub before: f64,
    /// The noise variance assumed for every sample.
    pub noise: f64,
    /// Reachable candidate configurations considered.
    pub candidates: usize,
}

impl Plan {
    /// The target's predicted variance after the first `k` planned samples.
    pub fn after(&self, k: usize) -> f64 {
        self.before - self.rows.iter().take(k).map(|r| r.reduction).sum::<f64>()
    }
}

/// The prior's components at a configuration.
fn components_at(prior: &Prior, g: &Geometry, out: &mut [f64]) {
    prior.components_at(&prior.corners(g), out);
}

/// `m += s a aᵀ` on the lower triangle.
fn add_outer(m: &mut DMatrix<f64>, a: &[f64], s: f64) {
    for r in 0..a.len() {
        for c in 0..=r {
            m[(r, c)] += s * a[r] * a[c];
        }
    }
}

/// Copy the lower triangle of `m` onto the upper.
fn symmetrise(m: &mut DMatrix<f64>) {
    for r in 0..m.nrows() {
        for c in 0..r {
            m[(c, r)] = m[(r, c)];
        }
    }
}

/// Σ = (AᵀA/σ² + Λ⁻¹)⁻¹ of the samples of `data` (visible configurations with a value in
/// the first channel) under `prior`.
pub fn posterior_covariance(prior: &Prior, data: Option<&Dataset>, noise: f64) -> DMatrix<f64> {
    let k = prior.components();
    let mut info = DMatrix::<f64>::zeros(k, k);
    if let Some(ds) = data {
        let mut a = vec![0.0; k];
        let values = ds.channels.first().map(|c| &c.values[..]).unwrap_or(&[]);
        for i in 0..ds.len().min(values.len()) {
            let [ti, pi, to, po] = ds.angles(i);
            let g = Geometry::from_angles(ti, pi, to, po);
            // A configuration not yet measured (a plan's empty value) informs nothing.
            if !g.visible() || !values[i].is_finite() {
                continue;
            }
            components_at(prior, &g, &mut a);
            add_outer(&mut info, &a, 1.0 / noise);
        }
    }
    symmetrise(&mut info);
    for r in 0..k {
        info[(r, r)] += 1.0 / prior.variance[r].max(1e-300);
    }
    info.clone()
        .cholesky()
        .map(|ch| ch.inverse())
        .unwrap_or_else(|| info.pseudo_inverse(1e-14).unwrap_or(DMatrix::zeros(k, k)))
}

/// W of the target: Σ_p w_p a_p a_pᵀ (weights normalised to sum 1), or the identity over the
/// table's cells (the components are orthonormal over them) divided by the cell count.
fn target_matrix(prior: &Prior, target: &Target) -> DMatrix<f64> {
    let k = prior.components();
    match target {
        Target::Table => DMatrix::identity(k, k) / prior.cells() as f64,
        Target::Configurations(configs) => {
            let total: f64 = configs.iter().map(|c| c.1.max(0.0)).sum();
            let mut w = DMatrix::<f64>::zeros(k, k);
            let mut a = vec![0.0; k];
            for (angles, weight) in configs {
                let g = Geometry::from_angles(angles[0], angles[1], angles[2], angles[3]);
                if !g.visible() || !(*weight > 0.0) {
                    continue;
                }
                components_at(prior, &g, &mut a);
                add_outer(&mut w, &a, weight / total);
            }
            symmetrise(&mut w);
            w
        }
    }
}

/// The reachable candidate configurations: on the prior's half/difference cells (every θh,
/// every third θd, every fifth φd plus 0° and 90°, each φd and its mirror 180° − φd), turned
/// so that φi = 0, with θi, θo ≤ the largest θ, 2 θd ≥ the smallest separation and, in the
/// plane only if asked; in a fixed order.
pub fn candidates(prior: &Prior, opts: &PlanOptions) -> Vec<[f64; 4]> {
    let [nh, nd, np] = prior.dims;
    let max_t = opts.max_theta_deg.to_radians();
    let min_sep = opts.min_separation_deg.to_radians();
    let mut phis: Vec<f64> = if opts.in_plane {
        vec![0.0]
    } else {
        let mut v: Vec<f64> = (0..np)
            .step_by(5)
            .map(|ip| (ip as f64 + 0.5) / np as f64 * FRAC_PI_2)
            .collect();
        v.push(0.0);
        v.push(FRAC_PI_2);
        v
    };
    phis.sort_by(f64::total_cmp);
    let mut out = Vec::new();
    for ih in 0..nh {
        let u = (ih as f64 + 0.5) / nh as f64;
        let th = u * u * FRAC_PI_2;
        for id in (0..nd).step_by(3) {
            let td = (id as f64 + 0.5) / nd as f64 * FRAC_PI_2;
            if 2.0 * td < min_sep {
                continue;
            }
            for &pd in &phis {
                for pd in [pd, PI - pd] {
                    let [ti, pi, to, po] = crate::data::merl::half_diff_to_std(th, 0.0, td, pd);
                    let a = [ti, 0.0, to, (po - pi).rem_euclid(2.0 * PI)];
                    let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
                    if !g.visible() || ti > max_t || to > max_t {
                        continue;
                    }
                    if !out
                        .iter()
                        .rev()
                        .take(4)
                        .any(|b: &[f64; 4]| b.iter().zip(&a).all(|(x, y)| (x - y).abs() < 1e-9))
                    {
                        out.push(a);
                    }
                }
            }
        }
    }
    out
}

/// Plan `opts.budget` configurations under `prior`, given the samples of `data` (or none), a
/// noise variance `noise` (mapped units) and a target. Errors name the fix.
pub fn plan(
    prior: &Prior,
    data: Option<&Dataset>,
    noise: f64,
    target: &Target,
    opts: &PlanOptions,
) -> Result<Plan, String> {
    use rayon::prelude::*;
    if opts.budget == 0 || opts.budget > MAX_BUDGET {
        return Err(format!(
            "a budget of {} configurations: give 1 to {MAX_BUDGET}",
            opts.budget
        ));
    }
    if !(opts.max_theta_deg > 0.0 && opts.max_theta_deg <= 90.0) {
        return Err("the largest θ must be in (0°, 90°]".into());
    }
    if !(opts.min_separation_deg >= 0.0 && opts.min_separation_deg < 180.0) {
        return Err("the smallest separation must be in [0°, 180°)".into());
    }
    if !(noise > 0.0 && noise.is_finite()) {
        return Err(format!(
            "a noise variance of {noise}: give a positive number"
        ));
    }
    let k = prior.components();
    let sigma = posterior_covariance(prior, data, noise);
    let w = target_matrix(prior, target);
    let cands = candidates(prior, opts);
    if cands.is_empty() {
        return Err(
            "no configuration is reachable within the limits: raise --max-theta or lower \
             --min-separation"
                .into(),
        );
    }
    // Per candidate: a, s = Σa, t = W s (row-major, K each).
    let a: Vec<f64> = cands
        .par_iter()
        .flat_map_iter(|c| {
            let mut v = vec![0.0; k];
            components_at(
                prior,
                &Geometry::from_angles(c[0], c[1], c[2], c[3]),
                &mut v,
            );
            v
        })
        .collect();
    let times = |m: &DMatrix<f64>, rows: &[f64]| -> Vec<f64> {
        rows.par_chunks(k)
            .flat_map_iter(|r| (0..k).map(move |i| (0..k).map(|j| m[(i, j)] * r[j]).sum::<f64>()))
            .collect()
    };
    let mut s = times(&sigma, &a);
    let mut t = times(&w, &s);
    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
    let before = (0..k)
        .map(|i| (0..k).map(|j| sigma[(i, j)] * w[(j, i)]).sum::<f64>())
        .sum::<f64>();
    let mut remaining = before;
    let mut rows = Vec::with_capacity(opts.budget);
    for _ in 0..opts.budget {
        let best = (0..cands.len())
            .into_par_iter()
            .map(|c| {
                let r = c * k..(c + 1) * k;
                let gain = dot(&s[r.clone()], &t[r.clone()]) / (noise + dot(&a[r.clone()], &s[r]));
                (if gain.is_finite() { gain } else { 0.0 }, c)
            })
            .reduce(
                || (f64::NEG_INFINITY, usize::MAX),
                |x, y| {
                    if y.0 > x.0 || (y.0 == x.0 && y.1 < x.1) {
                        y
                    } else {
                        x
                    }
                },
            );
        let (gain, c) = best;
        if c == usize::MAX || !(gain > 0.0) {
            break;
        }
        let r = c * k..(c + 1) * k;
        let (u, wu, ac) = (s[r.clone()].to_vec(), t[r.clone()].to_vec(), a[r].to_vec());
        let gamma = noise + dot(&ac, &u);
        s.par_chunks_mut(k)
            .zip(t.par_chunks_mut(k))
            .for_each(|(sc, tc)| {
                let alpha = dot(sc, &ac) / gamma;
                for i in 0..k {
                    sc[i] -= alpha * u[i];
                    tc[i] -= alpha * wu[i];
                }
            });
        rows.push(Planned {
            angles: cands[c],
            reduction: gain,
            share: gain / remaining.max(1e-300),
        });
        remaining -= gain;
    }
    Ok(Plan {
        rows,
        before,
        noise,
        candidates: cands.len(),
    })
}

/// The plan as brdfit CSV: the four angles in degrees, an empty `brdf` column to fill in with
/// the measured values, and the columns `plan_rank` and `plan_share` (the share of the
/// remaining variance each configuration removes; the reader ignores both), after comment
/// lines `notes`.
pub fn to_csv(plan: &Plan, notes: &[String]) -> String {
    let mut out = String::new();
    for n in notes {
        for line in n.lines() {
            out.push_str("# ");
            out.push_str(line);
            out.push('\n');
        }
    }
    out.push_str("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf,plan_rank,plan_share\n");
    for (i, r) in plan.rows.iter().enumerate() {
        let d = r.angles.map(f64::to_degrees);
        out.push_str(&format!(
            "{},{},{},{},,{},{:.6}\n",
            round6(d[0]),
            round6(d[1]),
            round6(d[2]),
            round6(d[3]),
            i + 1,
            r.share
        ));
    }
    out
}

/// `x` to 6 decimals, without a trailing `-0`.
fn round6(x: f64) -> f64 {
    let r = (x * 1e6).round() / 1e6;
    if r == 0.0 { 0.0 } else { r }
}

#[cfg(test)]
mod tests;

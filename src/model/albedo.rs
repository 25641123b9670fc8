//! Directional albedo ρ(θi) = ∫ f_r(L, E) cosθo dω_o over the outgoing hemisphere: the share
//! of the light arriving from θi that a surface reflects (energy conservation asks ρ ≤ 1;
//! Nicodemus et al. 1977, NBS Monograph 160, "directional-hemispherical reflectance").
//!
//! Quadrature: composite Gauss–Legendre (6 points a panel) in θo ∈ [0, π/2] and φo ∈ [0, π]
//! (doubled: every model is symmetric about the plane of incidence), with panels that grow
//! geometrically (×3, at most 0.8 rad wide) away from the mirror direction (θo = θi,
//! φo = π) from a first panel over which the lobe is flat (1e-5 to 0.03 rad, probed), so a
//! lobe of any width down to the models' sharpest (GGX α = 1e-4) is resolved, and a smooth
//! integrand (Lambert) is integrated to about 1e-15. About 1,700–13,000 evaluations per θi
//! (tests/it/albedo.rs checks it against values worked by hand).

use super::{Geometry, Model};
use std::f64::consts::{FRAC_PI_2, PI};

/// Gauss–Legendre nodes and weights on [−1, 1], 6 points (Abramowitz & Stegun, Table 25.4).
const GL6: [(f64, f64); 6] = [
    (-0.932_469_514_203_152, 0.171_324_492_379_170_4),
    (-0.661_209_386_466_264_5, 0.360_761_573_048_138_6),
    (-0.238_619_186_083_196_9, 0.467_913_934_572_691),
    (0.238_619_186_083_196_9, 0.467_913_934_572_691),
    (0.661_209_386_466_264_5, 0.360_761_573_048_138_6),
    (0.932_469_514_203_152, 0.171_324_492_379_170_4),
];

/// Gauss–Legendre nodes and weights on [−1, 1], 3 points (Abramowitz & Stegun, Table 25.4):
/// the coarse rule of [`coarse_albedos`].
const GL3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 0.555_555_555_555_555_6),
    (0.0, 0.888_888_888_888_888_8),
    (0.774_596_669_241_483_4, 0.555_555_555_555_555_6),
];

/// Width of the panels next to the mirror direction (radians): the narrowest, and the widest
/// used where the lobe is broad or absent (see [`first_panel`]).
const FIRST_PANEL: (f64, f64) = (1e-5, 0.03);

/// Growth of the panels away from the mirror direction.
const GROWTH: f64 = 3.0;

/// The widest panel (radians): a smooth integrand (a diffuse term) is integrated to ~1e-15.
const WIDEST_PANEL: f64 = 0.8;

/// The incidence angles (degrees) at which [`max_albedo`] checks energy conservation: 0° to
/// 80° in 10° steps and 85° (beyond 85° nothing is measured and every model's value is
/// extrapolated; ρ(θi) is smooth in θi, so a 10° grid finds where it exceeds 1).
pub const ALBEDO_THETA_I_DEG: [f64; 10] =
    [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0];

/// The first panel's width for light at `theta_i`: the largest step 1e-5·3^k (within
/// [`FIRST_PANEL`]) over which f_r, probed from the mirror direction towards the normal in the
/// plane of incidence, stays within 10 % of its mirror value: the lobe is flat on that panel,
/// whatever the model (a broad lobe needs far fewer panels than a mirror-sharp one). Returns
/// (k, the width).
fn first_panel(model: &Model, theta_i: f64) -> (usize, f64) {
    let f = |d: f64| model.brdf(&Geometry::from_angles(theta_i, 0.0, theta_i - d, PI));
    let peak = f(0.0);
    let (mut k, mut h) = (0, FIRST_PANEL.0);
    while h * GROWTH <= FIRST_PANEL.1 {
        let v = f(h * GROWTH);
        if !((v - peak).abs() <= 0.1 * peak.abs()) {
            break;
        }
        h *= GROWTH;
        k += 1;
    }
    (k, h)
}

/// How many widths [`first_panel`] can return (eight: 1e-5·3^k for k = 0 to 7), by its own
/// loop.
const FIRST_PANELS: usize = {
    let (mut k, mut h) = (1, FIRST_PANEL.0);
    while h * GROWTH <= FIRST_PANEL.1 {
        h *= GROWTH;
        k += 1;
    }
    k
};

/// Panel ends on [lo, hi] growing geometrically (×[`GROWTH`] from `first`) away from `centre`.
fn graded(lo: f64, hi: f64, centre: f64, first: f64) -> Vec<f64> {
    let mut ends = vec![lo, hi];
    if centre > lo && centre < hi {
        ends.push(centre);
    }
    let mut h = first;
    while h < hi - lo {
        for x in [centre - h, centre + h] {
            if x > lo && x < hi {
                ends.push(x);
            }
        }
        h *= GROWTH;
    }
    ends.sort_by(f64::total_cmp);
    // Split panels wider than WIDEST_PANEL evenly.
    let mut out = vec![ends[0]];
    for &b in &ends[1..] {
        let a = *out.last().expect("one end");
        let k = ((b - a) / WIDEST_PANEL).ceil().max(1.0) as usize;
        out.extend((1..=k).map(|j| a + (b - a) * j as f64 / k as f64));
    }
    out
}

/// (node, weight) pairs of the composite rule `rule` (nodes and weights on [−1, 1]) on the
/// panels `ends`.
fn nodes(ends: &[f64], rule: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(rule.len() * ends.len());
    for w in ends.windows(2) {
        let (mid, half) = (0.5 * (w[0] + w[1]), 0.5 * (w[1] - w[0]));
        out.extend(rule.iter().map(|&(x, a)| (mid + half * x, half * a)));
    }
    out
}

/// Directional albedo ρ(θi) = ∫ f_r cosθo dω_o of `model` for light at `theta_i` (radians).
pub fn directional_albedo(model: &Model, theta_i: f64) -> f64 {
    let (_, first) = first_panel(model, theta_i);
    albedo_by(model, theta_i, first, &GL6)
}

/// ρ(θi) by `rule` on each panel, the first panel `first` wide, each node's geometry made as
/// the sum runs (the fine rule's 1,700–13,000 nodes are not kept: written out first, they
/// cost more than they save, their memory fresh on every call).
fn albedo_by(model: &Model, theta_i: f64, first: f64, rule: &[(f64, f64)]) -> f64 {
    let theta = nodes(&graded(0.0, FRAC_PI_2, theta_i, first), rule);
    let phi = nodes(&graded(0.0, PI, PI, first), rule);
    let cos_phi: Vec<(f64, f64)> = phi.iter().map(|&(p, w)| (p.cos(), w)).collect();
    let (si, ci) = theta_i.sin_cos();
    let mut sum = 0.0;
    for &(to, wt) in &theta {
        let (so, co) = to.sin_cos();
        let mut ring = 0.0;
        for &(cp, wp) in &cos_phi {
            // L·E = sinθi sinθo cos φo + cosθi cosθo, as in `Geometry::from_angles`.
            ring += wp * model.brdf(&Geometry::from_cosines(ci, co, si * so * cp + ci * co));
        }
        sum += wt * co * so * ring;
    }
    2.0 * sum
}

/// The coarse rule's nodes at one θi, parameter-free: the geometry of every node (θo the
/// outer, φo the inner index) and the weights of each axis (the θo weight times cosθo sinθo;
/// the φo weight), kept by [`coarse_nodes`]; [`Nodes::albedo`] sums as [`albedo_by`] does.
struct Nodes {
    geometry: Vec<Geometry>,
    outer: Vec<f64>,
    inner: Vec<f64>,
}

impl Nodes {
    /// The nodes of `rule` on the panels for light at `theta_i` whose first panel is `first`
    /// wide (the geometry as [`albedo_by`] makes it).
    fn new(theta_i: f64, first: f64, rule: &[(f64, f64)]) -> Self {
        let theta = nodes(&graded(0.0, FRAC_PI_2, theta_i, first), rule);
        let phi = nodes(&graded(0.0, PI, PI, first), rule);
        let cos_phi: Vec<f64> = phi.iter().map(|&(p, _)| p.cos()).collect();
        let (si, ci) = theta_i.sin_cos();
        let mut geometry = Vec::with_capacity(theta.len() * phi.len());
        let mut outer = Vec::with_capacity(theta.len());
        for &(to, wt) in &theta {
            let (so, co) = to.sin_cos();
            // L·E = sinθi sinθo cos φo + cosθi cosθo, as in `Geometry::from_angles`.
            geometry.extend(
                cos_phi
                    .iter()
                    .map(|&cp| Geometry::from_cosines(ci, co, si * so * cp + ci * co)),
            );
            outer.push(wt * co * so);
        }
        let inner = phi.iter().map(|&(_, w)| w).collect();
        Nodes {
            geometry,
            outer,
            inner,
        }
    }

    /// ρ of `model` by these nodes (doubled: every model is symmetric about the plane of
    /// incidence).
    fn albedo(&self, model: &Model) -> f64 {
        let mut sum = 0.0;
        for (ring, w) in self
            .geometry
            .chunks_exact(self.inner.len())
            .zip(&self.outer)
        {
            let mut r = 0.0;
            for (g, wp) in ring.iter().zip(&self.inner) {
                r += wp * model.brdf(g);
            }
            sum += w * r;
        }
        2.0 * sum
    }
}

/// The coarse rule's nodes for the θi of [`ALBEDO_THETA_I_DEG`] at index `t` and the first
/// panel 1e-5·3^`k` wide (of width `first`), made on first use and kept: the nodes do not
/// depend on the model, and the physical check of every fit screens with them. (At most 80
/// node sets, about 6.5 MB if every width were used at every θi; a few hundred kB in practice.
/// Kept for the life of the process.)
fn coarse_nodes(t: usize, k: usize, first: f64) -> &'static Nodes {
    use std::sync::OnceLock;
    static CACHE: [[OnceLock<Nodes>; FIRST_PANELS]; ALBEDO_THETA_I_DEG.len()] =
        [const { [const { OnceLock::new() }; FIRST_PANELS] }; ALBEDO_THETA_I_DEG.len()];
    CACHE[t][k].get_or_init(|| Nodes::new(ALBEDO_THETA_I_DEG[t].to_radians(), first, &GL3))
}

/// The directional albedo at each θi of [`ALBEDO_THETA_I_DEG`]: (θi in degrees, ρ), in that
/// order (the angles in parallel; each value is the same on any number of threads).
pub fn albedos(model: &Model) -> Vec<(f64, f64)> {
    use rayon::prelude::*;
    ALBEDO_THETA_I_DEG
        .par_iter()
        .map(|&t| (t, directional_albedo(model, t.to_radians())))
        .collect()
}

/// [`albedos`] by a coarse rule: the same panels with 3-point instead of 6-point
/// Gauss–Legendre on each, a quarter of the evaluations. Within 0.2 % of [`albedos`] on every
/// model of tests/it/albedo.rs's sweep, broad lobe or mirror-sharp (at most 1 % is asserted): a
/// screen that spares the fine quadrature where the answer is clearly below a threshold.
pub fn coarse_albedos(model: &Model) -> Vec<(f64, f64)> {
    use rayon::prelude::*;
    (0..ALBEDO_THETA_I_DEG.len())
        .into_par_iter()
        .map(|t| {
            let theta_i = ALBEDO_THETA_I_DEG[t];
            let (k, first) = first_panel(model, theta_i.to_radians());
            (theta_i, coarse_nodes(t, k, first).albedo(model))
        })
        .collect()
}

/// The largest directional albedo over [`ALBEDO_THETA_I_DEG`]: (θi in degrees, ρ).
pub fn max_albedo(model: &Model) -> (f64, f64) {
    albedos(model)
        .into_iter()
        .fold((0.0, f64::NEG_INFINITY), |best, x| {
            if x.1 > best.1 || x.1.is_nan() {
                x
            } else {
                best
            }
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Distribution, ModelKind};

    /// The coarse rule's kept nodes give, to the bit, what nodes made afresh for the model's
    /// own first panel give, over models whose first panels span every width from the
    /// sharpest (1e-5) to the widest (0.0219), broad to sharp and back; and the k the cache
    /// is keyed by names that width (1e-5·3^k).
    #[test]
    fn kept_coarse_nodes_match_fresh_ones() {
        let mut models = Vec::new();
        for j in 0..24 {
            let c = 3f64.powi(j);
            models.push(Model::new(ModelKind::Phong, Distribution::D3, &[c, 0.4, 0.2]).unwrap());
        }
        for a in [0.5, 0.1, 0.02, 3e-3, 1e-3, 1e-4] {
            let p = [a, 1.5, 0.5, 0.1];
            models.push(Model::new(ModelKind::GgxSmith, Distribution::D3, &p).unwrap());
        }
        let mut widths = std::collections::BTreeSet::new();
        // Broad to sharp, then sharp to broad: the second pass reads nodes the first kept.
        for m in models.iter().chain(models.iter().rev()) {
            for (t, (theta_i, rho)) in coarse_albedos(m).into_iter().enumerate() {
                let (k, first) = first_panel(m, theta_i.to_radians());
                let want = FIRST_PANEL.0 * GROWTH.powi(k as i32);
                assert!(
                    (first - want).abs() <= 1e-12 * want,
                    "k {k}: {first} against {want}"
                );
                widths.insert(k);
                let fresh = Nodes::new(theta_i.to_radians(), first, &GL3).albedo(m);
                assert_eq!(rho.to_bits(), fresh.to_bits(), "{m:?} at θi index {t}");
            }
        }
        assert_eq!(widths.len(), FIRST_PANELS, "widths used: {widths:?}");
    }

    /// The coarse rule's kept nodes sum, to the bit, as the streamed quadrature
    /// ([`albedo_by`], each node's geometry made as the sum runs, as the fine rule sums).
    #[test]
    fn kept_nodes_sum_as_the_streamed_quadrature() {
        let models = [
            Model::new(
                ModelKind::TorranceSparrow,
                Distribution::D3,
                &[1.8, 0.35, 0.67, 0.33],
            ),
            Model::new(
                ModelKind::GgxSmith,
                Distribution::D3,
                &[0.01, 1.5, 0.5, 0.1],
            ),
            Model::new(ModelKind::Phong, Distribution::D3, &[3e4, 0.4, 0.2]),
        ];
        for m in models.map(Result::unwrap) {
            for (&t, (_, coarse)) in ALBEDO_THETA_I_DEG.iter().zip(coarse_albedos(&m)) {
                let theta_i = t.to_radians();
                let want = albedo_by(&m, theta_i, first_panel(&m, theta_i).1, &GL3);
                assert_eq!(coarse.to_bits(), want.to_bits(), "{m:?} θi {t}");
            }
        }
    }
}

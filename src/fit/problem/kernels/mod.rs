//! Lane kernels of every model but Lambert (Torrance–Sparrow D3 with the log loss, the default fit,
//! keeps its own in `passes.rs`): Phong and Blinn–Phong (Phong 1975; Blinn 1977), Blinn's
//! Torrance–Sparrow with D1, D2, D3 (Blinn 1977, "Facet distribution functions") and Löw et al.
//! 2012's ABC lobe (eq. 6 with A = 1), GGX–Smith (Walter et al. 2007, eqs. 33 and 34 with Smith's
//! G1) and its two-lobe form, for the log and the linear loss, with or without a robust weight
//! (Huber, Cauchy). Each computes, [`LANES`](crate::support::lanes::LANES) rows at a time and without
//! branches, what the row path through [`Model::brdf_grad`] computes: Σ ρ(r), Jᵀr and JᵀJ in model
//! parameters. Each lane keeps its own sums, added in lane order at the end, so the result does not
//! depend on the instruction set; the entries are compiled for AVX-512 and AVX2 as well and picked
//! at run time (the `multiversion` crate).

mod blocks;
mod drive;

use super::loss::Loss;
use super::rows::Rows;
use crate::fit::lsq::Robust;
use crate::model::{MAX_PARAMS, Model};
use blocks::body;
pub(super) use blocks::{Lane, abc_shape_rows, ggx_lobe_values};
pub(super) use drive::{Acc, Block, TRI, accumulate_lane, drive};
use drive::{LINEAR, LOG, PIXEL};

/// Σ ρ(r) of rows `range` with Jᵀr and JᵀJ (upper triangle) in the model's parameters added to
/// `gr` and `g` (each row's terms weighted by the robust weight ρ'(r)/r, as the row path does),
/// for `how` = (the kernel, the loss, the robust loss).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn rows_normal(
    how: (Lane, Loss, Robust),
    rows: &Rows,
    range: std::ops::Range<usize>,
    model: &Model,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let (lane, loss, rob) = how;
    let plain = rob == Robust::None;
    match (loss, plain) {
        (Loss::Log, true) => body::<LOG, true, false>(lane, rob, rows, range, model, g, gr),
        (Loss::Linear, true) => body::<LINEAR, true, false>(lane, rob, rows, range, model, g, gr),
        (Loss::Pixel, true) => body::<PIXEL, true, false>(lane, rob, rows, range, model, g, gr),
        (Loss::Log, false) => body::<LOG, true, true>(lane, rob, rows, range, model, g, gr),
        (Loss::Linear, false) => body::<LINEAR, true, true>(lane, rob, rows, range, model, g, gr),
        (Loss::Pixel, false) => body::<PIXEL, true, true>(lane, rob, rows, range, model, g, gr),
    }
}

/// Σ ρ(r) of rows `range` alone (cost-only evaluations).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn rows_cost(
    lane: Lane,
    loss: Loss,
    rob: Robust,
    rows: &Rows,
    range: std::ops::Range<usize>,
    model: &Model,
) -> f64 {
    let (mut g, mut gr) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
    let (g, gr) = (&mut g, &mut gr);
    let plain = rob == Robust::None;
    match (loss, plain) {
        (Loss::Log, true) => body::<LOG, false, false>(lane, rob, rows, range, model, g, gr),
        (Loss::Linear, true) => body::<LINEAR, false, false>(lane, rob, rows, range, model, g, gr),
        (Loss::Pixel, true) => body::<PIXEL, false, false>(lane, rob, rows, range, model, g, gr),
        (Loss::Log, false) => body::<LOG, false, true>(lane, rob, rows, range, model, g, gr),
        (Loss::Linear, false) => body::<LINEAR, false, true>(lane, rob, rows, range, model, g, gr),
        (Loss::Pixel, false) => body::<PIXEL, false, true>(lane, rob, rows, range, model, g, gr),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::problem::Row;
    use crate::fit::problem::passes::kernel_rows_any;
    use crate::model::Geometry;
    use crate::model::{Distribution, ModelKind};
    use crate::support::lanes::LANES;
    use drive::pixel_lanes;
    use rand::{Rng, SeedableRng};

    /// ABC's shape rows against `powf` (the definition, (1 + b (1 − N·H))^(−c)) for lengths
    /// that do and do not fill the lanes, N·H outside [0, 1] clamped, and a lobe sharp
    /// enough to underflow to 0 far from its peak.
    #[test]
    fn abc_shape_rows_match_powf() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(25);
        for m in [1, 7, 8, 9, 500] {
            let mut nh: Vec<f64> = (0..m).map(|_| rng.random_range(-0.1..1.1)).collect();
            nh[0] = 1.0;
            for b in [1e-3, 3.7, 2e4, 1e9] {
                let cs = [0.05, 0.3, 2.0, 50.0];
                let mut out = Vec::new();
                abc_shape_rows(b, &cs, &nh, &mut out);
                assert_eq!(out.len(), cs.len() * m);
                for (j, c) in cs.iter().enumerate() {
                    for (i, x) in nh.iter().enumerate() {
                        let want = (1.0 + b * (1.0 - x.clamp(0.0, 1.0))).powf(-c);
                        let got = out[j * m + i];
                        let tol = 1e-13 * want + 1e-300;
                        assert!(
                            (got - want).abs() <= tol,
                            "m {m} b {b} c {c} nh {x}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }

    /// Random rows over the hemisphere (targets of either loss), weighted or not.
    fn random_rows(rng: &mut impl Rng, m: usize, weighted: bool, loss: Loss) -> Rows {
        let mut rows = Rows::with_capacity(m, weighted);
        for _ in 0..m {
            let a: [f64; 4] = [
                rng.random_range(0.0..1.5),
                rng.random_range(0.0..6.3),
                rng.random_range(0.0..1.5),
                rng.random_range(0.0..6.3),
            ];
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            let f: f64 = rng.random_range(0.0..3.0);
            rows.push(&Row {
                g,
                cos_i: g.nl,
                target: loss.target(f, g.nl),
                sw: if weighted {
                    rng.random_range(0.1..2.0)
                } else {
                    1.0
                },
            });
        }
        rows
    }

    /// Parameters of `kind` (with `dist`) drawn over sharp to broad lobes.
    fn random_params(rng: &mut impl Rng, kind: ModelKind, dist: Distribution) -> Vec<f64> {
        let mut ten = |lo: f64, hi: f64| 10f64.powf(rng.random_range(lo..hi));
        match (kind, dist) {
            (ModelKind::GgxSmith, _) => vec![
                ten(-3.0, 0.0),
                1.01 + ten(-2.0, 1.5),
                ten(-1.0, 0.3),
                ten(-2.0, 0.3),
            ],
            (ModelKind::GgxSmith2, _) => {
                let (a, b) = (ten(-3.0, 0.0), ten(-3.0, 0.0));
                vec![
                    a.min(b),
                    ten(-1.0, 0.3),
                    a.max(b),
                    ten(-1.0, 0.3),
                    1.01 + ten(-2.0, 1.5),
                    ten(-2.0, 0.3),
                ]
            }
            (ModelKind::TorranceSparrow, Distribution::D1) => vec![
                1.01 + ten(-2.0, 2.5),
                ten(-1.0, 4.0),
                ten(-1.0, 0.3),
                ten(-2.0, 0.3),
            ],
            (ModelKind::TorranceSparrow, Distribution::D2) => vec![
                1.01 + ten(-2.0, 2.5),
                ten(-1.0, 2.5),
                ten(-1.0, 0.3),
                ten(-2.0, 0.3),
            ],
            (ModelKind::TorranceSparrow, Distribution::D3) => vec![
                1.01 + ten(-2.0, 2.5),
                ten(-2.0, 0.0),
                ten(-1.0, 0.3),
                ten(-2.0, 0.3),
            ],
            (ModelKind::TorranceSparrow, Distribution::Abc) => vec![
                1.01 + ten(-2.0, 2.5),
                ten(0.0, 5.0),
                ten(-0.5, 0.6),
                ten(-1.0, 0.3),
                ten(-2.0, 0.3),
            ],
            _ => vec![ten(-2.0, 5.0), ten(-1.0, 0.3), ten(-2.0, 0.3)],
        }
    }

    /// Each lane kernel gives the cost and normal equations of the row-by-row path through
    /// `Model::brdf_grad` (an independent code path: library `powf`, `exp`, `acos`, `ln_1p`, the
    /// model's own Fresnel, D and G, the robust ρ and weight) to 1e-11 relative, for the three
    /// losses (log, linear, pixel: targets up to 3, across the pixel's knee and clip), without and
    /// with a robust weight (Huber, Cauchy at a threshold some residuals pass), weighted rows or
    /// not, for any row count (a tail shorter than a block included), sharp and broad lobes, every
    /// model with a kernel.
    #[test]
    fn lane_kernels_match_row_kernel() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-11 * (a.abs() + b.abs()) + 1e-300;
        let models = [
            (ModelKind::Phong, Distribution::D3),
            (ModelKind::BlinnPhong, Distribution::D3),
            (ModelKind::GgxSmith, Distribution::D3),
            (ModelKind::GgxSmith2, Distribution::D3),
            (ModelKind::TorranceSparrow, Distribution::D1),
            (ModelKind::TorranceSparrow, Distribution::D2),
            (ModelKind::TorranceSparrow, Distribution::D3),
            (ModelKind::TorranceSparrow, Distribution::Abc),
        ];
        let mut robust_hits = 0;
        for (kind, dist) in models {
            for loss in [Loss::Log, Loss::Linear, Loss::Pixel] {
                for (case, weighted) in [(0, false), (1, true), (2, false), (3, true)] {
                    let m = [1, 7, 8, 1003][case];
                    let rows = random_rows(&mut rng, m, weighted, loss);
                    for t in 0..18 {
                        let p = random_params(&mut rng, kind, dist);
                        let model = Model::new(kind, dist, &p).unwrap();
                        let lane = Lane::of(&model, loss).expect("a lane kernel");
                        let delta = rng.random_range(0.01..0.5);
                        let rob =
                            [Robust::None, Robust::Huber(delta), Robust::Cauchy(delta)][t % 3];
                        let (mut g1, mut r1) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
                        let (mut g2, mut r2) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
                        let how = (lane, loss, rob);
                        let c1 = rows_normal(how, &rows, 0..m, &model, &mut g1, &mut r1);
                        assert_eq!(c1, rows_cost(lane, loss, rob, &rows, 0..m, &model));
                        let c2 = kernel_rows_any(&rows, 0..m, loss, &model, rob, &mut g2, &mut r2);
                        if rob != Robust::None
                            && (c2
                                - kernel_rows_any(
                                    &rows,
                                    0..m,
                                    loss,
                                    &model,
                                    Robust::None,
                                    &mut g2.clone(),
                                    &mut r2.clone(),
                                ))
                            .abs()
                                > 1e-9 * c2
                        {
                            robust_hits += 1;
                        }
                        let what = format!("{kind:?} {dist:?} {loss:?} {rob:?} m {m} {p:?}");
                        assert!(close(c1, c2), "cost {c1} vs {c2} ({what})");
                        for a in 0..p.len() {
                            assert!(
                                close(r1[a], r2[a]),
                                "Jᵀr[{a}] {} vs {} ({what})",
                                r1[a],
                                r2[a]
                            );
                            for b in a..p.len() {
                                assert!(
                                    close(g1[a][b], g2[a][b]),
                                    "JᵀJ[{a}][{b}] {} vs {} ({what})",
                                    g1[a][b],
                                    g2[a][b]
                                );
                            }
                        }
                    }
                }
            }
        }
        // The robust cases did cut residuals (the comparison exercised ρ and its weight).
        assert!(robust_hits > 100, "{robust_hits}");
    }

    /// The lanes' display value and derivative against the row path's `pixel` (library `exp`,
    /// `ln_1p`, `powf`) to 1e-13 relative at radiances from 0 through the sRGB knee (0.0031308)
    /// and the clip at 1 to 1e300, where both give 1 and a derivative of 0.
    #[test]
    fn pixel_lanes_match_pixel() {
        let mut ys: Vec<f64> = vec![0.0, 1e-300, 1e-12, 0.003_130_8, 0.003_130_9, 1.0, 1e300];
        ys.extend((0..4000).map(|k| 10f64.powf(-6.0 + 8.0 * k as f64 / 4000.0)));
        ys.extend((0..400).map(|k| 0.9 + 0.2 * k as f64 / 400.0));
        for chunk in ys.chunks(LANES) {
            let y: [f64; LANES] = std::array::from_fn(|l| chunk[l.min(chunk.len() - 1)]);
            let (v, d) = pixel_lanes(&y);
            for l in 0..chunk.len() {
                let (want, dwant) = super::super::pixel(y[l]);
                let tol = |w: f64| 1e-13 * w.abs() + 1e-300;
                assert!(
                    (v[l] - want).abs() <= tol(want),
                    "φ({}) {} vs {want}",
                    y[l],
                    v[l]
                );
                assert!(
                    (d[l] - dwant).abs() <= tol(dwant),
                    "φ'({}) {} vs {dwant}",
                    y[l],
                    d[l]
                );
            }
        }
    }

    /// The kernels of Torrance–Sparrow D1 and D2 and of GGX–Smith read columns derived from the
    /// rows and cached (ln N·H; θh; tan² θi, tan² θo, tan² θh, 1/(4π N·E (N·H)⁴), E·H); rows
    /// pushed after they were computed get theirs (the caches are rebuilt). Each value against
    /// its definition by the library's acos, tan and ln (an independent path): the tangents to
    /// 1e-12 relative, the logarithm to 1e-15.
    #[test]
    fn derived_columns_follow_the_rows() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut rows = random_rows(&mut rng, 5, false, Loss::Log);
        assert_eq!(rows.theta_h().len(), 5);
        assert_eq!(rows.ggx().factor.len(), 5);
        let more = random_rows(&mut rng, 4, false, Loss::Log);
        rows.extend(&more);
        assert_eq!(rows.theta_h().len(), 9);
        let t = rows.ggx();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        let tan2 = |c: f64| c.acos().tan().powi(2);
        for i in 0..9 {
            assert_eq!(rows.theta_h()[i], rows.nh[i].clamp(0.0, 1.0).acos());
            let (nl, ne, nh) = (rows.nl[i], rows.ne[i], rows.nh[i]);
            assert!(close(t.tan2_i[i], tan2(nl)), "{} {}", t.tan2_i[i], tan2(nl));
            assert!(close(t.tan2_o[i], tan2(ne)));
            assert!(close(t.tan2_h[i], tan2(nh)));
            assert!(close(
                t.factor[i],
                1.0 / (4.0 * std::f64::consts::PI * ne * nh.powi(4))
            ));
            assert_eq!(t.eh[i], rows.eh[i]);
            let ln = rows.ln_nh()[i];
            assert!(
                (ln - nh.ln()).abs() <= 1e-15 * nh.ln().abs().max(1.0),
                "{ln} {nh}"
            );
        }
        assert_eq!(rows.ln_nh().len(), 9);
    }

    /// Phong's fast power and Lambert keep the row path; the pixel loss, robust weights and
    /// every Torrance–Sparrow distribution have kernels.
    #[test]
    fn kernels_apply_where_they_compute_the_same() {
        let phong = Model::new(ModelKind::Phong, Distribution::D3, &[10.0, 1.0, 0.1]).unwrap();
        assert_eq!(Lane::of(&phong, Loss::Log), Some(Lane::Phong));
        assert_eq!(Lane::of(&phong, Loss::Pixel), Some(Lane::Phong));
        let mut fast = phong;
        fast.fast_pow = Some(3);
        assert_eq!(Lane::of(&fast, Loss::Log), None);
        let lambert = Model::new(ModelKind::Lambert, Distribution::D3, &[0.5]).unwrap();
        assert_eq!(Lane::of(&lambert, Loss::Linear), None);
        let ts = Model::new(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[1.8, 0.35, 0.6, 0.3],
        )
        .unwrap();
        assert_eq!(Lane::of(&ts, Loss::Log), Some(Lane::Ts(Distribution::D3)));
    }
}

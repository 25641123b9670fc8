//! Lane kernels of the models other than Torrance–Sparrow D3 (whose kernel is in
//! `problem.rs`): Phong and Blinn–Phong (Phong 1975; Blinn 1977) and GGX–Smith (Walter et al.
//! 2007, eqs. 33 and 34 with Smith's G1), for the log and the linear loss without a robust
//! weight. Each computes, [`LANES`] rows at a time and without branches, what the row path
//! through [`Model::brdf_grad`] computes: Σ ½r², Jᵀr and JᵀJ in model parameters. Each lane
//! keeps its own sums, added in lane order at the end, so the result does not depend on the
//! instruction set; the entries are compiled for AVX-512 and AVX2 as well and picked at run
//! time (the `multiversion` crate).

use super::{Loss, Rows};
use crate::fit::lsq::Robust;
use crate::lanes::{self, LANES};
use crate::model::{MAX_PARAMS, Model, ModelKind};
use std::f64::consts::{FRAC_1_PI, PI};

/// Per-lane sums of a kernel of at most four parameters: Σ ½r², Jᵀr (4), the upper triangle
/// of JᵀJ (10).
pub(super) const SUMS: usize = 15;

/// The per-lane sums.
pub(super) type Acc = [[f64; LANES]; SUMS];

/// A model with a lane kernel here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Lane {
    /// Phong: x = R·E.
    Phong,
    /// Blinn–Phong: x = N·H.
    BlinnPhong,
    /// GGX–Smith.
    Ggx,
}

impl Lane {
    /// The kernel for `model` under `loss`, if any (a robust weight, the pixel loss and Phong's
    /// fast power take the row path).
    pub(super) fn of(model: &Model, robust: Robust, loss: Loss) -> Option<Lane> {
        if robust != Robust::None || loss == Loss::Pixel {
            return None;
        }
        match model.kind {
            ModelKind::Phong if model.fast_pow.is_none() => Some(Lane::Phong),
            ModelKind::BlinnPhong => Some(Lane::BlinnPhong),
            ModelKind::GgxSmith => Some(Lane::Ggx),
            _ => None,
        }
    }
}

/// Σ ½r² of rows `range` with Jᵀr and JᵀJ (upper triangle) in the model's parameters added to
/// `gr` and `g`.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn rows_normal(
    lane: Lane,
    loss: Loss,
    rows: &Rows,
    range: std::ops::Range<usize>,
    model: &Model,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    match loss {
        Loss::Log => body::<true, true>(lane, rows, range, model, g, gr),
        Loss::Linear => body::<false, true>(lane, rows, range, model, g, gr),
        Loss::Pixel => unreachable!("Lane::of gives the pixel loss no lane kernel"),
    }
}

/// Σ ½r² of rows `range` alone (cost-only evaluations).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn rows_cost(
    lane: Lane,
    loss: Loss,
    rows: &Rows,
    range: std::ops::Range<usize>,
    model: &Model,
) -> f64 {
    let (mut g, mut gr) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
    match loss {
        Loss::Log => body::<true, false>(lane, rows, range, model, &mut g, &mut gr),
        Loss::Linear => body::<false, false>(lane, rows, range, model, &mut g, &mut gr),
        Loss::Pixel => unreachable!("Lane::of gives the pixel loss no lane kernel"),
    }
}

#[inline(always)]
fn body<const LOG: bool, const JAC: bool>(
    lane: Lane,
    rows: &Rows,
    range: std::ops::Range<usize>,
    model: &Model,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let p = model.p;
    match lane {
        Lane::Phong | Lane::BlinnPhong => {
            let x = if lane == Lane::Phong {
                &rows.re
            } else {
                &rows.nh
            };
            let cols = [&rows.nl, x, &rows.target, &rows.nl, &rows.nl];
            let acc = drive(
                rows,
                range,
                cols,
                &PhongBlock::<LOG, JAC>([p[0], p[1], p[2]]),
            );
            finish::<3>(&acc, g, gr)
        }
        Lane::Ggx => {
            let k = Ggx::new([p[0], p[1], p[2], p[3]]);
            let cols = [&rows.nl, &rows.ne, &rows.nh, &rows.eh, &rows.target];
            let acc = drive(rows, range, cols, &GgxBlock::<LOG, JAC>(k));
            finish::<4>(&acc, g, gr)
        }
    }
}

/// One block of [`LANES`] rows of a kernel: five columns and the √weights, added to the sums.
/// (A trait rather than a closure, so the block is inlined into each instruction-set version.)
pub(super) trait Block {
    /// Add the block's residuals and Jacobian rows to `acc`.
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut Acc);
}

/// Run `block` over rows `range` in blocks of [`LANES`] rows of the five columns `cols` and
/// their √weights; the tail's lanes past the end repeat the last row with weight 0.
#[inline(always)]
pub(super) fn drive<B: Block>(
    rows: &Rows,
    range: std::ops::Range<usize>,
    cols: [&Vec<f64>; 5],
    block: &B,
) -> Acc {
    let mut acc = [[0.0f64; LANES]; SUMS];
    let ones = [1.0f64; LANES];
    let mut i = range.start;
    while i + LANES <= range.end {
        let lane = |v: &Vec<f64>| -> [f64; LANES] { v[i..i + LANES].try_into().expect("block") };
        let sw = if rows.weighted { lane(&rows.sw) } else { ones };
        block.run(&cols.map(lane), &sw, &mut acc);
        i += LANES;
    }
    if i < range.end {
        let len = range.end - i;
        let pad = |v: &Vec<f64>| -> [f64; LANES] { std::array::from_fn(|l| v[i + l.min(len - 1)]) };
        let sw: [f64; LANES] = std::array::from_fn(|l| match (l < len, rows.weighted) {
            (false, _) => 0.0,
            (true, true) => rows.sw[i + l],
            (true, false) => 1.0,
        });
        block.run(&cols.map(pad), &sw, &mut acc);
    }
    acc
}

/// Add lane `l`'s residual `r` and Jacobian row `j` to the sums (layout of [`SUMS`]).
#[inline(always)]
pub(super) fn accumulate_lane<const N: usize>(acc: &mut Acc, l: usize, r: f64, j: [f64; N]) {
    acc[0][l] += 0.5 * r * r;
    let mut t = 5;
    for a in 0..N {
        acc[1 + a][l] += j[a] * r;
        for b in a..N {
            acc[t][l] += j[a] * j[b];
            t += 1;
        }
    }
}

/// The lane sums into `g`, `gr`; returns Σ ½r².
fn finish<const N: usize>(
    acc: &Acc,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let lane_sum = |k: usize| acc[k].iter().sum::<f64>();
    let mut t = 5;
    for a in 0..N {
        gr[a] += lane_sum(1 + a);
        for b in a..N {
            g[a][b] += lane_sum(t);
            t += 1;
        }
    }
    lane_sum(0)
}

/// Residuals and Jacobian rows of one block from y = cosθi f_r and dy/dθ: the log loss
/// r = ln(1 + y) − target, dr/dθ = (dy/dθ)/(1 + y); the linear loss r = y/cosθi − target,
/// dr/dθ = (dy/dθ)/cosθi.
#[inline(always)]
fn residuals<const LOG: bool, const JAC: bool, const N: usize>(
    nl: &[f64; LANES],
    y: &[f64; LANES],
    dy: &[[f64; LANES]; N],
    tg: &[f64; LANES],
    sw: &[f64; LANES],
    acc: &mut Acc,
) {
    let (fy, scale) = if LOG {
        lanes::ln_1p(y)
    } else {
        let inl: [f64; LANES] = std::array::from_fn(|l| 1.0 / nl[l]);
        (std::array::from_fn(|l| y[l] * inl[l]), inl)
    };
    for l in 0..LANES {
        let r = sw[l] * (fy[l] - tg[l]);
        if JAC {
            let s = sw[l] * scale[l];
            accumulate_lane::<N>(acc, l, r, std::array::from_fn(|a| s * dy[a][l]));
        } else {
            acc[0][l] += 0.5 * r * r;
        }
    }
}

/// One block of Phong or Blinn–Phong (c1, ps, pd): columns nl, x (R·E or N·H), target.
/// y = cosθi f_r = (pd cosθi + ps x^c1)/π with x^c1 = e^(c1 ln x) (0 where x ≤ 0), as in
/// `model::phong::brdf_grad`.
struct PhongBlock<const LOG: bool, const JAC: bool>([f64; 3]);

impl<const LOG: bool, const JAC: bool> Block for PhongBlock<LOG, JAC> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut Acc) {
        phong_block::<LOG, JAC>(self.0, c, sw, acc)
    }
}

#[inline(always)]
fn phong_block<const LOG: bool, const JAC: bool>(
    p: [f64; 3],
    c: &[[f64; LANES]; 5],
    sw: &[f64; LANES],
    acc: &mut Acc,
) {
    let [nl, x, tg, _, _] = c;
    let (c1, ps, pd) = (p[0], p[1], p[2]);
    let xs: [f64; LANES] = std::array::from_fn(|l| if x[l] > 0.0 { x[l] } else { 1.0 });
    let lx = lanes::ln(&xs);
    let e = lanes::exp(&std::array::from_fn(|l| c1 * lx[l]));
    let mut y = [0.0f64; LANES];
    let mut dy = [[0.0f64; LANES]; 3];
    for l in 0..LANES {
        let s = if x[l] > 0.0 { e[l] } else { 0.0 };
        y[l] = (pd * nl[l] + ps * s) * FRAC_1_PI;
        dy[0][l] = ps * s * lx[l] * FRAC_1_PI;
        dy[1][l] = s * FRAC_1_PI;
        dy[2][l] = nl[l] * FRAC_1_PI;
    }
    residuals::<LOG, JAC, 3>(nl, &y, &dy, tg, sw, acc);
}

/// GGX–Smith at fixed parameters (α, n, ps, pd).
#[derive(Clone, Copy)]
struct Ggx {
    alpha: f64,
    a2: f64,
    n: f64,
    n2m1: f64,
    ps: f64,
    pd: f64,
}

impl Ggx {
    fn new(p: [f64; 4]) -> Self {
        Ggx {
            alpha: p[0],
            a2: p[0] * p[0],
            n: p[1],
            n2m1: p[1] * p[1] - 1.0,
            ps: p[2],
            pd: p[3],
        }
    }

    /// Smith's G1 for GGX at cosine `c` and its α-derivative: G1 = 2/(1 + √(1 + α² tan²)).
    #[inline(always)]
    fn g1(&self, c: f64) -> (f64, f64) {
        let c2 = c * c;
        let tan2 = (1.0 - c2).max(0.0) / c2;
        let s = (1.0 + self.a2 * tan2).sqrt();
        let g = 2.0 / (1.0 + s);
        (g, -g * g * 0.5 * self.alpha * tan2 / s)
    }
}

/// One block of GGX–Smith: columns nl, ne, nh, eh, target. y = cosθi f_r =
/// pd cosθi/π + ps F D G1(L) G1(E)/(4 N·E), zero specular where N·H ≤ 0 or E·H ≤ 0, as in
/// `model::ggx_smith::brdf_grad`.
struct GgxBlock<const LOG: bool, const JAC: bool>(Ggx);

impl<const LOG: bool, const JAC: bool> Block for GgxBlock<LOG, JAC> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut Acc) {
        ggx_block::<LOG, JAC>(&self.0, c, sw, acc)
    }
}

#[inline(always)]
fn ggx_block<const LOG: bool, const JAC: bool>(
    k: &Ggx,
    c: &[[f64; LANES]; 5],
    sw: &[f64; LANES],
    acc: &mut Acc,
) {
    let [nl, ne, nh, eh, tg] = c;
    let mut y = [0.0f64; LANES];
    let mut dy = [[0.0f64; LANES]; 4];
    for l in 0..LANES {
        let ok = nh[l] > 0.0 && eh[l] > 0.0;
        let h = if ok { nh[l] } else { 1.0 };
        let nh2 = h * h;
        let tan2 = (1.0 - nh2).max(0.0) / nh2;
        let q = k.a2 + tan2;
        let d = k.a2 / (PI * nh2 * nh2 * q * q);
        let dd = d * (2.0 / k.alpha - 4.0 * k.alpha / q);
        let (gl, dgl) = k.g1(nl[l]);
        let (ge, dge) = k.g1(ne[l]);
        let (f, df) = fresnel(k.n, k.n2m1, if ok { eh[l] } else { 1.0 });
        let w = 0.25 / ne[l];
        let a = if ok { f * d * gl * ge * w } else { 0.0 };
        y[l] = k.pd * nl[l] * FRAC_1_PI + k.ps * a;
        dy[0][l] = if ok {
            k.ps * f * w * (dd * gl * ge + d * (dgl * ge + gl * dge))
        } else {
            0.0
        };
        dy[1][l] = if ok { k.ps * df * d * gl * ge * w } else { 0.0 };
        dy[2][l] = a;
        dy[3][l] = nl[l] * FRAC_1_PI;
    }
    residuals::<LOG, JAC, 4>(nl, &y, &dy, tg, sw, acc);
}

/// Exact Fresnel reflectance of an index `n` at cos θ = `eh` and its n-derivative, without
/// branches (`n2m1` = n² − 1): F = ½ (g−c)²/(g+c)² [1 + (c(g+c)−1)²/(c(g−c)+1)²],
/// g = √(n² + c² − 1) (Blinn 1977, eq. 5; Cook & Torrance 1982). The formulas of
/// `model::fresnel_dn` with the divisions shared; where it returns early the selects give the
/// same.
#[inline(always)]
pub(super) fn fresnel(n: f64, n2m1: f64, eh: f64) -> (f64, f64) {
    let cc = eh.clamp(0.0, 1.0);
    let gg = (n2m1 + cc * cc).max(0.0).sqrt();
    let gp = gg + cc;
    let ok_f = gp > 0.0;
    let gp = if ok_f { gp } else { 1.0 };
    let gm = gg - cc;
    let vv = cc * gm + 1.0;
    // 1/(g+c), 1/(c(g−c)+1) and 1/g from one division (g = 0 only at n = 1, c = 0).
    let ok_g = gg > 0.0;
    let g1 = if ok_g { gg } else { 1.0 };
    let inv = 1.0 / (gp * vv * g1);
    let igp = vv * g1 * inv;
    let iv = gp * g1 * inv;
    let qf = gm * igp;
    let a = qf * qf;
    let t = (cc * gp - 1.0) * iv;
    let b = t * t;
    let f = if ok_f { 0.5 * a * (1.0 + b) } else { 1.0 };
    // dA/dg = 4c(g−c)/(g+c)³, dB/dg = 4c(1−c²)u/v³, dg/dn = n/g.
    let da = 4.0 * cc * qf * igp * igp;
    let db = 4.0 * cc * (1.0 - cc * cc) * t * iv * iv;
    let dn_dg = if ok_g { n * gp * vv * inv } else { 0.0 };
    let df = if ok_f {
        0.5 * (da * (1.0 + b) + a * db) * dn_dg
    } else {
        0.0
    };
    (f, df)
}

#[cfg(test)]
mod tests {
    use super::super::{Row, kernel_rows_any};
    use super::*;
    use crate::model::{Distribution, Geometry};
    use rand::{Rng, SeedableRng};

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

    /// Each lane kernel gives the cost and normal equations of the row-by-row path through
    /// `Model::brdf_grad` (an independent code path: library `powf`, `ln_1p`, the model's own
    /// Fresnel, D and G) to 1e-11 relative, for both losses, weighted or not, for any row count
    /// (a tail shorter than a block included), sharp and broad lobes.
    #[test]
    fn lane_kernels_match_row_kernel() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-11 * (a.abs() + b.abs()) + 1e-300;
        for kind in [ModelKind::Phong, ModelKind::BlinnPhong, ModelKind::GgxSmith] {
            for loss in [Loss::Log, Loss::Linear] {
                for (case, weighted) in [(0, false), (1, true), (2, false), (3, true)] {
                    let m = [1, 7, 8, 1003][case];
                    let rows = random_rows(&mut rng, m, weighted, loss);
                    for _ in 0..20 {
                        let p: Vec<f64> = match kind {
                            ModelKind::GgxSmith => vec![
                                10f64.powf(rng.random_range(-3.0..0.0)),
                                rng.random_range(1.01..30.0),
                                rng.random_range(0.0..2.0),
                                rng.random_range(0.0..2.0),
                            ],
                            _ => vec![
                                10f64.powf(rng.random_range(-2.0..5.0)),
                                rng.random_range(0.0..2.0),
                                rng.random_range(0.0..2.0),
                            ],
                        };
                        let model = Model::new(kind, Distribution::D3, &p).unwrap();
                        let lane =
                            Lane::of(&model, Robust::None, Loss::Log).expect("a lane kernel");
                        let (mut g1, mut r1) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
                        let (mut g2, mut r2) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
                        let c1 = rows_normal(lane, loss, &rows, 0..m, &model, &mut g1, &mut r1);
                        assert_eq!(c1, rows_cost(lane, loss, &rows, 0..m, &model));
                        let c2 = kernel_rows_any(
                            &rows,
                            0..m,
                            loss,
                            &model,
                            Robust::None,
                            &mut g2,
                            &mut r2,
                        );
                        let what = format!("{kind:?} {loss:?} m {m} {p:?}");
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
    }

    /// Robust weights and Phong's fast power keep the row path; Torrance–Sparrow and Lambert
    /// have no kernel here.
    #[test]
    fn kernels_apply_where_they_compute_the_same() {
        let phong = Model::new(ModelKind::Phong, Distribution::D3, &[10.0, 1.0, 0.1]).unwrap();
        assert_eq!(Lane::of(&phong, Robust::None, Loss::Log), Some(Lane::Phong));
        assert_eq!(Lane::of(&phong, Robust::Huber(1.0), Loss::Log), None);
        assert_eq!(Lane::of(&phong, Robust::None, Loss::Pixel), None);
        let mut fast = phong;
        fast.fast_pow = Some(3);
        assert_eq!(Lane::of(&fast, Robust::None, Loss::Log), None);
        let ts = Model::new(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[1.8, 0.35, 0.6, 0.3],
        )
        .unwrap();
        assert_eq!(Lane::of(&ts, Robust::None, Loss::Log), None);
    }
}

//! Lane kernels of every model but Lambert (Torrance–Sparrow D3 with the log loss, the default
//! fit, keeps its own in `problem.rs`): Phong and Blinn–Phong (Phong 1975; Blinn 1977),
//! Blinn's Torrance–Sparrow with D1, D2, D3 (Blinn 1977, "Facet distribution functions") and
//! Löw et al. 2012's ABC lobe (eq. 6 with A = 1), GGX–Smith (Walter et al. 2007, eqs. 33 and 34
//! with Smith's G1) and its two-lobe form, for the log and the linear loss, with or without a
//! robust weight (Huber, Cauchy). Each computes, [`LANES`] rows at a time and without branches,
//! what the row path through [`Model::brdf_grad`] computes: Σ ρ(r), Jᵀr and JᵀJ in model
//! parameters. Each lane keeps its own sums, added in lane order at the end, so the result does
//! not depend on the instruction set; the entries are compiled for AVX-512 and AVX2 as well and
//! picked at run time (the `multiversion` crate).

use super::lane_terms::{TsD3, fresnel};
use super::loss::Loss;
use super::rows::Rows;
use crate::fit::lsq::Robust;
use crate::lanes::{self, LANES};
use crate::model::{Distribution, MAX_PARAMS, Model, ModelKind};
use std::f64::consts::FRAC_1_PI;

/// The most parameters a lane kernel handles (GGX–Smith with two lobes).
const MAX_K: usize = 6;

/// Where the upper triangle of JᵀJ starts in [`Acc`] (after Σ ρ and Jᵀr).
pub(super) const TRI: usize = 1 + MAX_K;

/// Per-lane sums of a kernel of at most [`MAX_K`] parameters: Σ ρ(r), Jᵀr, the upper triangle
/// of JᵀJ.
pub(super) const SUMS: usize = TRI + MAX_K * (MAX_K + 1) / 2;

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
    /// GGX–Smith with two lobes.
    Ggx2,
    /// Blinn's Torrance–Sparrow with a facet distribution.
    Ts(Distribution),
}

impl Lane {
    /// The kernel for `model` under `loss`, if any (Phong's fast power and Lambert take the
    /// row path).
    pub(super) fn of(model: &Model, _loss: Loss) -> Option<Lane> {
        match model.kind {
            ModelKind::Phong if model.fast_pow.is_none() => Some(Lane::Phong),
            ModelKind::BlinnPhong => Some(Lane::BlinnPhong),
            ModelKind::GgxSmith => Some(Lane::Ggx),
            ModelKind::GgxSmith2 => Some(Lane::Ggx2),
            ModelKind::TorranceSparrow => Some(Lane::Ts(model.dist)),
            _ => None,
        }
    }
}

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

/// [`Res`]'s loss: the log loss.
const LOG: u8 = 0;
/// [`Res`]'s loss: the linear loss.
const LINEAR: u8 = 1;
/// [`Res`]'s loss: the pixel loss ([`Loss::Pixel`]).
const PIXEL: u8 = 2;

/// The residual's options of a block: the loss (`LOSS`: [`LOG`], [`LINEAR`] or [`PIXEL`]),
/// whether the Jacobian is wanted
/// (`JAC`), whether a robust weight applies (`ROB`, with `rob`).
#[derive(Clone, Copy)]
struct Res<const LOSS: u8, const JAC: bool, const ROB: bool>(Robust);

#[inline(always)]
fn body<const LOSS: u8, const JAC: bool, const ROB: bool>(
    lane: Lane,
    rob: Robust,
    rows: &Rows,
    range: std::ops::Range<usize>,
    model: &Model,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let p = model.p;
    let res = Res::<LOSS, JAC, ROB>(rob);
    match lane {
        Lane::Phong | Lane::BlinnPhong => {
            let x = if lane == Lane::Phong {
                &rows.re
            } else {
                &rows.nh
            };
            let cols = [&rows.nl, x, &rows.target, &rows.nl, &rows.nl];
            let acc = drive(rows, range, cols, &PhongBlock([p[0], p[1], p[2]], res));
            finish::<3>(&acc, g, gr)
        }
        Lane::Ggx => {
            let k = Ggx::new([p[0], p[1], p[2], p[3]]);
            let acc = drive(rows, range, ggx_columns(rows), &GgxBlock(k, res));
            finish::<4>(&acc, g, gr)
        }
        Lane::Ggx2 => {
            // alpha1, ps1, alpha2, ps2, n, pd.
            let k1 = Ggx::new([p[0], p[4], p[1], p[5]]);
            let k2 = Ggx::new([p[2], p[4], p[3], p[5]]);
            let acc = drive(rows, range, ggx_columns(rows), &Ggx2Block(k1, k2, res));
            finish::<6>(&acc, g, gr)
        }
        Lane::Ts(dist) => {
            let (d2, nh) = (rows.theta_h(), &rows.nh);
            let x = if dist == Distribution::D2 { d2 } else { nh };
            let cols = [&rows.nl, x, &rows.eh, &rows.g_ne, &rows.target];
            let acc = match dist {
                Distribution::D1 => {
                    let [nl, x, eh, gn, tg] = cols;
                    let cols = [nl, x, rows.ln_nh(), eh, gn, tg];
                    drive(rows, range, cols, &TsD1Block(p, res))
                }
                Distribution::D2 => drive(rows, range, cols, &TsBlock::<2, _, _, _>(p, res)),
                Distribution::D3 => drive(rows, range, cols, &TsBlock::<3, _, _, _>(p, res)),
                Distribution::Abc => {
                    let acc = drive(rows, range, cols, &AbcBlock(p, res));
                    return finish::<5>(&acc, g, gr);
                }
            };
            finish::<4>(&acc, g, gr)
        }
    }
}

/// One block of [`LANES`] rows of a kernel: `C` columns (five unless it says) and the
/// √weights, added to the sums. (A trait rather than a closure, so the block is inlined into
/// each instruction-set version.)
pub(super) trait Block<const C: usize = 5> {
    /// Add the block's residuals and Jacobian rows to `acc`.
    fn run(&self, c: &[[f64; LANES]; C], sw: &[f64; LANES], acc: &mut Acc);
}

/// Run `block` over rows `range` in blocks of [`LANES`] rows of the `C` columns `cols` and
/// their √weights; the tail's lanes past the end repeat the last row with weight 0.
#[inline(always)]
pub(super) fn drive<const C: usize, B: Block<C>>(
    rows: &Rows,
    range: std::ops::Range<usize>,
    cols: [&Vec<f64>; C],
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
    let mut t = TRI;
    for a in 0..N {
        acc[1 + a][l] += j[a] * r;
        for b in a..N {
            acc[t][l] += j[a] * j[b];
            t += 1;
        }
    }
}

/// [`accumulate_lane`] with a robust loss: ρ(r) and the IRLS weight w = ρ'(r)/r on the
/// Jacobian's terms, in the row path's order (wj·r, wj·j).
#[inline(always)]
fn accumulate_robust<const N: usize>(
    acc: &mut Acc,
    l: usize,
    rho: f64,
    w: f64,
    r: f64,
    j: [f64; N],
) {
    acc[0][l] += rho;
    let mut t = TRI;
    for a in 0..N {
        let wa = w * j[a];
        acc[1 + a][l] += wa * r;
        for b in a..N {
            acc[t][l] += wa * j[b];
            t += 1;
        }
    }
}

/// The lane sums into `g`, `gr`; returns Σ ρ(r).
pub(super) fn finish<const N: usize>(
    acc: &Acc,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let lane_sum = |k: usize| acc[k].iter().sum::<f64>();
    let mut t = TRI;
    for a in 0..N {
        gr[a] += lane_sum(1 + a);
        for b in a..N {
            g[a][b] += lane_sum(t);
            t += 1;
        }
    }
    lane_sum(0)
}

impl<const LOSS: u8, const JAC: bool, const ROB: bool> Res<LOSS, JAC, ROB> {
    /// Residuals and Jacobian rows of one block from y = cosθi f_r and dy/dθ: the log loss
    /// r = ln(1 + y) − target, dr/dθ = (dy/dθ)/(1 + y); the linear loss r = y/cosθi − target,
    /// dr/dθ = (dy/dθ)/cosθi; the pixel loss r = φ(y) − target, dr/dθ = φ'(y) dy/dθ
    /// ([`pixel_lanes`]); ρ(r) of the robust loss, if any.
    #[inline(always)]
    fn add<const N: usize>(
        self,
        nl: &[f64; LANES],
        y: &[f64; LANES],
        dy: &[[f64; LANES]; N],
        tg: &[f64; LANES],
        sw: &[f64; LANES],
        acc: &mut Acc,
    ) {
        let (fy, scale) = if LOSS == LOG {
            lanes::ln_1p(y)
        } else if LOSS == PIXEL {
            pixel_lanes(y)
        } else {
            let inl: [f64; LANES] = std::array::from_fn(|l| 1.0 / nl[l]);
            (std::array::from_fn(|l| y[l] * inl[l]), inl)
        };
        for l in 0..LANES {
            let r = sw[l] * (fy[l] - tg[l]);
            if ROB {
                let rho = self.0.rho(r);
                if JAC {
                    let s = sw[l] * scale[l];
                    let j = std::array::from_fn(|a| s * dy[a][l]);
                    accumulate_robust::<N>(acc, l, rho, self.0.weight(r), r, j);
                } else {
                    acc[0][l] += rho;
                }
            } else if JAC {
                let s = sw[l] * scale[l];
                accumulate_lane::<N>(acc, l, r, std::array::from_fn(|a| s * dy[a][l]));
            } else {
                acc[0][l] += 0.5 * r * r;
            }
        }
    }
}

/// The display value φ(y) of each lane and its derivative φ'(y): [`super::pixel`] without
/// branches. The smooth clip c = y − δ ln(1 + e^(−t)), c' = 1/(1 + e^(−t)) for t = (1 − y)/δ > 0,
/// else c = 1 − δ ln(1 + e^t), c' = e^t/(1 + e^t), both from e^(−|t|); then the sRGB transfer
/// (IEC 61966-2-1) 12.92 c up to 0.0031308, else 1.055 c^(1/2.4) − 0.055 with c^(1/2.4) =
/// e^(ln c / 2.4).
#[inline(always)]
fn pixel_lanes(y: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    const D: f64 = super::loss::PIXEL_CLIP_WIDTH;
    const KNEE: f64 = 0.003_130_8;
    let t: [f64; LANES] = std::array::from_fn(|l| (1.0 - y[l]) / D);
    let e = lanes::exp(&std::array::from_fn(|l| -t[l].abs()));
    let (l1p, inv) = lanes::ln_1p(&e);
    let mut c = [0.0f64; LANES];
    let mut dc = [0.0f64; LANES];
    for l in 0..LANES {
        let pos = t[l] > 0.0;
        c[l] = if pos { y[l] } else { 1.0 } - D * l1p[l];
        dc[l] = if pos { inv[l] } else { e[l] * inv[l] };
    }
    let cs: [f64; LANES] = std::array::from_fn(|l| if c[l] > KNEE { c[l] } else { 1.0 });
    let lc = lanes::ln(&cs);
    let p = lanes::exp(&std::array::from_fn(|l| lc[l] / 2.4));
    let mut v = [0.0f64; LANES];
    let mut dv = [0.0f64; LANES];
    for l in 0..LANES {
        let lin = c[l] <= KNEE;
        v[l] = if lin {
            12.92 * c[l]
        } else {
            1.055 * p[l] - 0.055
        };
        dv[l] = if lin {
            12.92 * dc[l]
        } else {
            1.055 / 2.4 * p[l] / cs[l] * dc[l]
        };
    }
    (v, dv)
}

/// One block of Phong or Blinn–Phong (c1, ps, pd): columns nl, x (R·E or N·H), target.
/// y = cosθi f_r = (pd cosθi + ps x^c1)/π with x^c1 = e^(c1 ln x) (0 where x ≤ 0), as in
/// `model::phong::brdf_grad`.
struct PhongBlock<const LOSS: u8, const JAC: bool, const ROB: bool>([f64; 3], Res<LOSS, JAC, ROB>);

impl<const LOSS: u8, const JAC: bool, const ROB: bool> Block for PhongBlock<LOSS, JAC, ROB> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut Acc) {
        let [nl, x, tg, _, _] = c;
        let (c1, ps, pd) = (self.0[0], self.0[1], self.0[2]);
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
        self.1.add::<3>(nl, &y, &dy, tg, sw, acc);
    }
}

/// GGX–Smith at fixed parameters (α, n, ps, pd).
#[derive(Clone, Copy)]
struct Ggx {
    alpha: f64,
    a2: f64,
    two_over_alpha: f64,
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
            two_over_alpha: 2.0 / p[0],
            n: p[1],
            n2m1: p[1] * p[1] - 1.0,
            ps: p[2],
            pd: p[3],
        }
    }

    /// Smith's G1 for GGX from tan² of the angle, and its α-derivative: G1 = 2/(1 + s) with
    /// s = √(1 + α² tan²) (Walter et al. 2007, eq. 34), dG1/dα = −G1 α tan²/(s (1 + s)); both
    /// from the one division u = 1/(s (1 + s)), G1 = 2 s u.
    #[inline(always)]
    fn g1(&self, tan2: f64) -> (f64, f64) {
        let s = (1.0 + self.a2 * tan2).sqrt();
        let u = 1.0 / (s * (1.0 + s));
        let g = 2.0 * s * u;
        (g, -g * self.alpha * tan2 * u)
    }

    /// The lobe D G1(L) G1(E)/(4 N·E) (cosθi f_r per unit ps F) and its α-derivative from a
    /// row's [tan² θi, tan² θo, tan² θh, 1/(4π N·E (N·H)⁴)] ([`super::rows::GgxTerms`]):
    /// D/(4 N·E) = α² factor/q², q = α² + tan² θh (Walter et al. 2007, eq. 33), and
    /// dD/dα = D (2/α − 4α/q).
    #[inline(always)]
    fn lobe(&self, [ti, to, th, factor]: [f64; 4]) -> (f64, f64) {
        let r = 1.0 / (self.a2 + th);
        let d = self.a2 * factor * r * r;
        let dd = d * (self.two_over_alpha - 4.0 * self.alpha * r);
        let (gl, dgl) = self.g1(ti);
        let (ge, dge) = self.g1(to);
        (d * gl * ge, dd * gl * ge + d * (dgl * ge + gl * dge))
    }
}

/// The columns GGX–Smith's kernels read: N·L, the rows' [`super::rows::GgxTerms`] (computed on
/// first use), the target.
fn ggx_columns(rows: &Rows) -> [&Vec<f64>; 7] {
    let t = rows.ggx();
    [
        &rows.nl,
        &t.tan2_i,
        &t.tan2_o,
        &t.tan2_h,
        &t.factor,
        &t.eh,
        &rows.target,
    ]
}

/// [`Ggx::lobe`] per unit cosθi at rows `range`: D G1(L) G1(E)/(4 N·L N·E), 0 where N·H ≤ 0
/// or E·H ≤ 0.
pub(super) fn ggx_lobe_values(alpha: f64, rows: &Rows, range: std::ops::Range<usize>) -> Vec<f64> {
    let k = Ggx::new([alpha, 1.5, 1.0, 0.0]);
    let t = rows.ggx();
    range
        .map(|i| {
            let terms = [t.tan2_i[i], t.tan2_o[i], t.tan2_h[i], t.factor[i]];
            k.lobe(terms).0 / rows.nl[i]
        })
        .collect()
}

/// ABC's shape term D = (1 + b (1 − N·H))^(−c) (Löw et al. 2012, eq. 6 with A = 1) at each
/// N·H of `nh` for every c of `cs`, appended to `out` one row of `nh.len()` per c: ln u once
/// per row for all c, then e^(−c ln u) in lanes, as [`AbcBlock`] computes D.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn abc_shape_rows(b: f64, cs: &[f64], nh: &[f64], out: &mut Vec<f64>) {
    // The tail's lanes past the end are N·H = 1 (u = 1) and are dropped.
    let mut lu = Vec::with_capacity(nh.len().next_multiple_of(LANES));
    for chunk in nh.chunks(LANES) {
        let u: [f64; LANES] = std::array::from_fn(|l| {
            1.0 + b * (1.0 - chunk.get(l).map_or(1.0, |v| v.clamp(0.0, 1.0)))
        });
        lu.extend(lanes::ln(&u));
    }
    let pad = lu.len() - nh.len();
    for &c in cs {
        for chunk in lu.chunks_exact(LANES) {
            out.extend(lanes::exp(&std::array::from_fn(|l| -c * chunk[l])));
        }
        out.truncate(out.len() - pad);
    }
}

/// One block of GGX–Smith: columns nl, the four [`super::rows::GgxTerms`] of [`Ggx::lobe`], E·H (or
/// 1), target ([`ggx_columns`]). y = cosθi f_r = pd cosθi/π + ps F D G1(L) G1(E)/(4 N·E), zero
/// specular where N·H ≤ 0 or E·H ≤ 0 (there the terms make the lobe 0), as in
/// `model::ggx_smith::brdf_grad`.
struct GgxBlock<const LOSS: u8, const JAC: bool, const ROB: bool>(Ggx, Res<LOSS, JAC, ROB>);

impl<const LOSS: u8, const JAC: bool, const ROB: bool> Block<7> for GgxBlock<LOSS, JAC, ROB> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 7], sw: &[f64; LANES], acc: &mut Acc) {
        let k = &self.0;
        let [nl, ti, to, th, fa, eh, tg] = c;
        let mut y = [0.0f64; LANES];
        let mut dy = [[0.0f64; LANES]; 4];
        for l in 0..LANES {
            let (lobe, dlobe) = k.lobe([ti[l], to[l], th[l], fa[l]]);
            let (f, df) = fresnel(k.n, k.n2m1, eh[l]);
            let a = f * lobe;
            y[l] = k.pd * nl[l] * FRAC_1_PI + k.ps * a;
            dy[0][l] = k.ps * f * dlobe;
            dy[1][l] = k.ps * df * lobe;
            dy[2][l] = a;
            dy[3][l] = nl[l] * FRAC_1_PI;
        }
        self.1.add::<4>(nl, &y, &dy, tg, sw, acc);
    }
}

/// One block of GGX–Smith with two lobes (alpha1, ps1, alpha2, ps2, n, pd; the lobes as
/// [`Ggx`] with their ps, sharing n and pd), the columns of [`GgxBlock`]. y = pd cosθi/π +
/// F (ps1 L1 + ps2 L2), as in `model::ggx_smith_2::brdf_grad`.
struct Ggx2Block<const LOSS: u8, const JAC: bool, const ROB: bool>(Ggx, Ggx, Res<LOSS, JAC, ROB>);

impl<const LOSS: u8, const JAC: bool, const ROB: bool> Block<7> for Ggx2Block<LOSS, JAC, ROB> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 7], sw: &[f64; LANES], acc: &mut Acc) {
        let (k1, k2) = (&self.0, &self.1);
        let [nl, ti, to, th, fa, eh, tg] = c;
        let mut y = [0.0f64; LANES];
        let mut dy = [[0.0f64; LANES]; 6];
        for l in 0..LANES {
            let terms = [ti[l], to[l], th[l], fa[l]];
            let (l1, dl1) = k1.lobe(terms);
            let (l2, dl2) = k2.lobe(terms);
            let (f, df) = fresnel(k1.n, k1.n2m1, eh[l]);
            let spec = k1.ps * l1 + k2.ps * l2;
            y[l] = k1.pd * nl[l] * FRAC_1_PI + f * spec;
            dy[0][l] = k1.ps * f * dl1;
            dy[1][l] = f * l1;
            dy[2][l] = k2.ps * f * dl2;
            dy[3][l] = f * l2;
            dy[4][l] = df * spec;
            dy[5][l] = nl[l] * FRAC_1_PI;
        }
        self.2.add::<6>(nl, &y, &dy, tg, sw, acc);
    }
}

/// One block of Blinn's Torrance–Sparrow with D2 (`D` = 2) or D3 (3): parameters n, c, ps,
/// pd; columns nl, x, eh, G/N·E, target with x = θh = acos N·H (D2) or N·H (D3).
/// y = cosθi f_r = pd cosθi/π + ps D F G/(π N·E), as in `model::torrance_sparrow::brdf_grad`
/// with [`Distribution::eval_dc`]: D2 = e^(−(θh c2)²), D3 as [`TsD3`].
struct TsBlock<const D: u8, const LOSS: u8, const JAC: bool, const ROB: bool>(
    [f64; MAX_PARAMS],
    Res<LOSS, JAC, ROB>,
);

impl<const D: u8, const LOSS: u8, const JAC: bool, const ROB: bool> Block
    for TsBlock<D, LOSS, JAC, ROB>
{
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut Acc) {
        let p = &self.0;
        let [nl, x, eh, gn, tg] = c;
        let cc = p[1];
        // D·w and dD/dc·w, w = G/(π N·E), per lane.
        let mut dw = [0.0f64; LANES];
        let mut ddw = [0.0f64; LANES];
        if D == 2 {
            let e = lanes::exp(&std::array::from_fn(|l| {
                let t = x[l] * cc;
                -t * t
            }));
            for l in 0..LANES {
                let w = gn[l] * FRAC_1_PI;
                dw[l] = e[l] * w;
                ddw[l] = -2.0 * x[l] * x[l] * cc * e[l] * w;
            }
        } else {
            let k = TsD3::new([p[0], cc, 1.0, 0.0]);
            for l in 0..LANES {
                // TsD3's a with F = 1: D w and dD/dc w.
                let (d, dd) = k.d(x[l]);
                let w = gn[l] * FRAC_1_PI;
                dw[l] = d * w;
                ddw[l] = dd * w;
            }
        }
        ts_add(p, &self.1, (&dw, &ddw), [nl, eh, tg], sw, acc);
    }
}

/// One block of Blinn's Torrance–Sparrow with D1 = (N·H)^c1 = e^(c1 ln N·H), 0 where N·H ≤ 0
/// (parameters n, c1, ps, pd): columns nl, N·H, ln N·H ([`super::rows::Rows::ln_nh`], computed once
/// with the rows), eh, G/N·E, target; as [`TsBlock`] otherwise.
struct TsD1Block<const LOSS: u8, const JAC: bool, const ROB: bool>(
    [f64; MAX_PARAMS],
    Res<LOSS, JAC, ROB>,
);

impl<const LOSS: u8, const JAC: bool, const ROB: bool> Block<6> for TsD1Block<LOSS, JAC, ROB> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 6], sw: &[f64; LANES], acc: &mut Acc) {
        let p = &self.0;
        let [nl, x, lx, eh, gn, tg] = c;
        let e = lanes::exp(&std::array::from_fn(|l| p[1] * lx[l]));
        let mut dw = [0.0f64; LANES];
        let mut ddw = [0.0f64; LANES];
        for l in 0..LANES {
            let d = if x[l].clamp(0.0, 1.0) > 0.0 {
                e[l]
            } else {
                0.0
            };
            let w = gn[l] * FRAC_1_PI;
            dw[l] = d * w;
            ddw[l] = d * lx[l] * w;
        }
        ts_add(p, &self.1, (&dw, &ddw), [nl, eh, tg], sw, acc);
    }
}

/// Torrance–Sparrow's residuals of one block from D·w and dD/dc·w (w = G/(π N·E)): F and dF/dn
/// at E·H, y = pd cosθi/π + ps D w F and its gradient in (n, c, ps, pd), added to `acc`.
#[inline(always)]
fn ts_add<const LOSS: u8, const JAC: bool, const ROB: bool>(
    p: &[f64; MAX_PARAMS],
    res: &Res<LOSS, JAC, ROB>,
    (dw, ddw): (&[f64; LANES], &[f64; LANES]),
    [nl, eh, tg]: [&[f64; LANES]; 3],
    sw: &[f64; LANES],
    acc: &mut Acc,
) {
    let (n, ps, pd) = (p[0], p[2], p[3]);
    let n2m1 = n * n - 1.0;
    let mut y = [0.0f64; LANES];
    let mut dy = [[0.0f64; LANES]; 4];
    for l in 0..LANES {
        let (f, df) = fresnel(n, n2m1, eh[l]);
        let a = dw[l] * f;
        y[l] = nl[l] * pd * FRAC_1_PI + ps * a;
        dy[0][l] = ps * dw[l] * df;
        dy[1][l] = ps * ddw[l] * f;
        dy[2][l] = a;
        dy[3][l] = nl[l] * FRAC_1_PI;
    }
    res.add::<4>(nl, &y, &dy, tg, sw, acc);
}

/// One block of Torrance–Sparrow with Löw et al.'s ABC lobe D = (1 + b (1 − N·H))^(−c):
/// parameters n, b, c, ps, pd; columns nl, N·H, eh, G/N·E, target; ∂D/∂b = −c (1 − N·H) D/u,
/// ∂D/∂c = −ln(u) D, u = 1 + b (1 − N·H), as in `model::torrance_sparrow::abc_brdf_grad`.
struct AbcBlock<const LOSS: u8, const JAC: bool, const ROB: bool>(
    [f64; MAX_PARAMS],
    Res<LOSS, JAC, ROB>,
);

impl<const LOSS: u8, const JAC: bool, const ROB: bool> Block for AbcBlock<LOSS, JAC, ROB> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut Acc) {
        let p = &self.0;
        let [nl, nh, eh, gn, tg] = c;
        let (n, b, cc, ps, pd) = (p[0], p[1], p[2], p[3], p[4]);
        let n2m1 = n * n - 1.0;
        let x: [f64; LANES] = std::array::from_fn(|l| 1.0 - nh[l].clamp(0.0, 1.0));
        let u: [f64; LANES] = std::array::from_fn(|l| 1.0 + b * x[l]);
        let lu = lanes::ln(&u);
        let d = lanes::exp(&std::array::from_fn(|l| -cc * lu[l]));
        let mut y = [0.0f64; LANES];
        let mut dy = [[0.0f64; LANES]; 5];
        for l in 0..LANES {
            let (f, df) = fresnel(n, n2m1, eh[l]);
            let w = gn[l] * FRAC_1_PI;
            let s = ps * f * w;
            let a = d[l] * f * w;
            y[l] = nl[l] * pd * FRAC_1_PI + ps * a;
            dy[0][l] = ps * d[l] * df * w;
            dy[1][l] = -s * cc * x[l] * d[l] / u[l];
            dy[2][l] = -s * lu[l] * d[l];
            dy[3][l] = a;
            dy[4][l] = nl[l] * FRAC_1_PI;
        }
        self.1.add::<5>(nl, &y, &dy, tg, sw, acc);
    }
}

#[cfg(test)]
mod tests {
    use super::super::passes::kernel_rows_any;
    use super::*;
    use crate::fit::problem::Row;
    use crate::model::Geometry;
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

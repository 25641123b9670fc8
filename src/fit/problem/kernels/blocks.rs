//! The lane kernel of each model: which models have one ([`Lane`]), the [`body`] that runs a
//! model's block over the rows, and the blocks themselves (Phong and Blinn–Phong,
//! Torrance–Sparrow D1, D2, D3 and ABC, GGX–Smith with one lobe or two).

use super::drive::{Acc, Block, Res, drive, finish};
use crate::fit::lsq::Robust;
use crate::fit::problem::lane_terms::{TsD3, fresnel};
use crate::fit::problem::loss::Loss;
use crate::fit::problem::rows::Rows;
use crate::model::{Distribution, MAX_PARAMS, Model, ModelKind};
use crate::support::lanes::{self, LANES};
use std::f64::consts::FRAC_1_PI;

/// A model with a lane kernel here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::fit::problem) enum Lane {
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
    pub(in crate::fit::problem) fn of(model: &Model, _loss: Loss) -> Option<Lane> {
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

/// The kernel of `lane` over rows `range` at `model`'s parameters with the residual options
/// `Res<LOSS, JAC, ROB>`: returns Σ ρ(r), and with `JAC` adds Jᵀr and JᵀJ to `gr` and `g`
/// (see [`super::rows_normal`]).
#[inline(always)]
pub(super) fn body<const LOSS: u8, const JAC: bool, const ROB: bool>(
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

    /// The lobe D G1(L) G1(E)/(4 N·E) (cosθi f_r per unit ps F) and its α-derivative from a row's
    /// [tan² θi, tan² θo, tan² θh, 1/(4π N·E (N·H)⁴)]
    /// ([`GgxTerms`](crate::fit::problem::GgxTerms)): D/(4 N·E) = α² factor/q², q = α² + tan² θh
    /// (Walter et al. 2007, eq. 33), and dD/dα = D (2/α − 4α/q).
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

/// The columns GGX–Smith's kernels read: N·L, the rows' [`GgxTerms`](crate::fit::problem::GgxTerms)
/// (computed on first use), the target.
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
pub(in crate::fit::problem) fn ggx_lobe_values(
    alpha: f64,
    rows: &Rows,
    range: std::ops::Range<usize>,
) -> Vec<f64> {
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
pub(in crate::fit::problem) fn abc_shape_rows(b: f64, cs: &[f64], nh: &[f64], out: &mut Vec<f64>) {
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

/// One block of GGX–Smith: columns nl, the four [`GgxTerms`](crate::fit::problem::GgxTerms) of
/// [`Ggx::lobe`], E·H (or 1), target ([`ggx_columns`]). y = cosθi f_r = pd cosθi/π + ps F D G1(L)
/// G1(E)/(4 N·E), zero specular where N·H ≤ 0 or E·H ≤ 0 (there the terms make the lobe 0), as in
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
/// (parameters n, c1, ps, pd): columns nl, N·H, ln N·H ([`Rows::ln_nh`], computed once
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

//! What every lane kernel shares: the per-lane sums, the [`Block`] a kernel runs over the
//! rows ([`drive`]), the residual of each loss with its robust weight ([`Res`]), and the sums'
//! reduction to the normal equations ([`finish`]).

use crate::fit::lsq::Robust;
use crate::fit::problem::loss::PIXEL_CLIP_WIDTH;
use crate::fit::problem::rows::Rows;
use crate::model::MAX_PARAMS;
use crate::support::lanes::{self, LANES};

/// The most parameters a lane kernel handles (GGX–Smith with two lobes).
const MAX_K: usize = 6;

/// Where the upper triangle of JᵀJ starts in [`Acc`] (after Σ ρ and Jᵀr).
pub(in crate::fit::problem) const TRI: usize = 1 + MAX_K;

/// Per-lane sums of a kernel of at most [`MAX_K`] parameters: Σ ρ(r), Jᵀr, the upper triangle
/// of JᵀJ.
pub(in crate::fit::problem) const SUMS: usize = TRI + MAX_K * (MAX_K + 1) / 2;

/// The per-lane sums.
pub(in crate::fit::problem) type Acc = [[f64; LANES]; SUMS];

/// [`Res`]'s loss: the log loss.
pub(super) const LOG: u8 = 0;
/// [`Res`]'s loss: the linear loss.
pub(super) const LINEAR: u8 = 1;
/// [`Res`]'s loss: the pixel loss ([`Loss::Pixel`](crate::fit::problem::Loss::Pixel)).
pub(super) const PIXEL: u8 = 2;

/// The residual's options of a block: the loss (`LOSS`: [`LOG`], [`LINEAR`] or [`PIXEL`]),
/// whether the Jacobian is wanted
/// (`JAC`), whether a robust weight applies (`ROB`, with `rob`).
#[derive(Clone, Copy)]
pub(super) struct Res<const LOSS: u8, const JAC: bool, const ROB: bool>(pub(super) Robust);

/// One block of [`LANES`] rows of a kernel: `C` columns (five unless it says) and the
/// √weights, added to the sums. (A trait rather than a closure, so the block is inlined into
/// each instruction-set version.)
pub(in crate::fit::problem) trait Block<const C: usize = 5> {
    /// Add the block's residuals and Jacobian rows to `acc`.
    fn run(&self, c: &[[f64; LANES]; C], sw: &[f64; LANES], acc: &mut Acc);
}

/// Run `block` over rows `range` in blocks of [`LANES`] rows of the `C` columns `cols` and
/// their √weights; the tail's lanes past the end repeat the last row with weight 0.
#[inline(always)]
pub(in crate::fit::problem) fn drive<const C: usize, B: Block<C>>(
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
pub(in crate::fit::problem) fn accumulate_lane<const N: usize>(
    acc: &mut Acc,
    l: usize,
    r: f64,
    j: [f64; N],
) {
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
pub(in crate::fit::problem) fn finish<const N: usize>(
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
    pub(super) fn add<const N: usize>(
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

/// The display value φ(y) of each lane and its derivative φ'(y):
/// [`pixel`](crate::fit::problem::pixel) without branches. The smooth clip c = y − δ ln(1 +
/// e^(−t)), c' = 1/(1 + e^(−t)) for t = (1 − y)/δ > 0, else c = 1 − δ ln(1 + e^t), c' = e^t/(1 +
/// e^t), both from e^(−|t|); then the sRGB transfer (IEC 61966-2-1) 12.92 c up to 0.0031308, else
/// 1.055 c^(1/2.4) − 0.055 with c^(1/2.4) = e^(ln c / 2.4).
#[inline(always)]
pub(super) fn pixel_lanes(y: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    const D: f64 = PIXEL_CLIP_WIDTH;
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

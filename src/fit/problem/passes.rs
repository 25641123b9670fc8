//! Passes over rows at fixed model parameters: f_r of a model or of one lobe, the row-by-row
//! residual loop every model takes, and Torrance–Sparrow D3's lane kernel for the log loss.

use super::kernels;
use super::lane_terms::TsD3;
use super::loss::Loss;
use super::rows::Rows;
use crate::fit::lsq::Robust;
use crate::model::{Distribution, MAX_PARAMS, Model, ModelKind};
use crate::support::lanes::{self, LANES};

/// The GGX lobe D G1(L) G1(E)/(4 N·L N·E) of roughness `alpha` (GGX–Smith's f_r per unit
/// ps·F; Walter et al. 2007, eqs. 33 and 34) at rows `range`, 0 where N·H ≤ 0 or E·H ≤ 0.
pub fn ggx_lobe_values(alpha: f64, rows: &Rows, range: std::ops::Range<usize>) -> Vec<f64> {
    kernels::ggx_lobe_values(alpha, rows, range)
}

/// ABC's shape term (1 + b (1 − N·H))^(−c) at each N·H of `nh` for every c of `cs`, one row
/// per c appended to `out` (the form of ABC's lane kernel).
pub fn abc_shape_rows(b: f64, cs: &[f64], nh: &[f64], out: &mut Vec<f64>) {
    kernels::abc_shape_rows(b, cs, nh, out)
}

/// f_r of `model` at rows `range` (the lane form of `TsD3` for Torrance–Sparrow with D3).
pub fn brdf_values(model: &Model, rows: &Rows, range: std::ops::Range<usize>) -> Vec<f64> {
    if model.kind == ModelKind::TorranceSparrow && model.dist == Distribution::D3 {
        ts_d3_values(p4(model), rows, range)
    } else {
        range.map(|i| model.brdf(&rows.get(i).g)).collect()
    }
}

#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn ts_d3_values(p: [f64; 4], rows: &Rows, range: std::ops::Range<usize>) -> Vec<f64> {
    let k = TsD3::new(p);
    let pd_pi = p[3] * std::f64::consts::FRAC_1_PI;
    range
        .map(|i| pd_pi + k.ps * k.eval(rows.nh[i], rows.eh[i], rows.g_ne[i]).0 / rows.nl[i])
        .collect()
}

/// True where the lane kernel [`ts_d3_log`] computes what [`kernel_rows`] would.
pub(super) fn ts_d3_log_applies(loss: Loss, model: &Model, robust: Robust) -> bool {
    loss == Loss::Log
        && robust == Robust::None
        && model.kind == ModelKind::TorranceSparrow
        && model.dist == Distribution::D3
}

/// The first four parameters of a model (Torrance–Sparrow D3's n, c3, ps, pd) for its lane kernel.
pub(super) fn p4(model: &Model) -> [f64; 4] {
    [model.p[0], model.p[1], model.p[2], model.p[3]]
}

/// [`kernel_rows`] for the model's number of parameters (a constant inside, so its loops unroll).
pub(super) fn kernel_rows_any(
    rows: &Rows,
    range: std::ops::Range<usize>,
    loss: Loss,
    model: &Model,
    robust: Robust,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    match model.specs().len() {
        1 => kernel_rows::<1>(rows, range, loss, model, robust, g, gr),
        2 => kernel_rows::<2>(rows, range, loss, model, robust, g, gr),
        3 => kernel_rows::<3>(rows, range, loss, model, robust, g, gr),
        4 => kernel_rows::<4>(rows, range, loss, model, robust, g, gr),
        5 => kernel_rows::<5>(rows, range, loss, model, robust, g, gr),
        6 => kernel_rows::<6>(rows, range, loss, model, robust, g, gr),
        7 => kernel_rows::<7>(rows, range, loss, model, robust, g, gr),
        _ => kernel_rows::<MAX_PARAMS>(rows, range, loss, model, robust, g, gr),
    }
}

/// The hot loop, row by row through [`Model::brdf_grad`] (every model, loss and robust weight):
/// residuals of one channel's rows `range` with the gradient of the model's `N` parameters,
/// accumulated into the model-space normal equations `g` (upper triangle) and `gr`; returns
/// Σ ρ(r). Free of allocation.
fn kernel_rows<const N: usize>(
    rows: &Rows,
    range: std::ops::Range<usize>,
    loss: Loss,
    model: &Model,
    robust: Robust,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let mut cost = 0.0;
    let mut grad = [0.0; MAX_PARAMS];
    for i in range {
        let rw = rows.get(i);
        let f = model.brdf_grad(&rw.g, &mut grad);
        let (r, drdf) = match loss {
            Loss::Log => {
                let fm = rw.cos_i * f;
                (fm.ln_1p() - rw.target, rw.cos_i / (1.0 + fm))
            }
            Loss::Linear => (f - rw.target, 1.0),
            Loss::Pixel => {
                let (v, d) = loss.term(f, rw.cos_i);
                (v - rw.target, d)
            }
        };
        let r = rw.sw * r;
        let s = rw.sw * drdf;
        let j: [f64; N] = std::array::from_fn(|a| s * grad[a]);
        let (rho, w) = match robust {
            Robust::None => (0.5 * r * r, 1.0),
            _ => (robust.rho(r), robust.weight(r)),
        };
        cost += rho;
        for a in 0..N {
            let wa = w * j[a];
            gr[a] += wa * r;
            for b in a..N {
                g[a][b] += wa * j[b];
            }
        }
    }
    cost
}

/// Torrance–Sparrow with D3 and the log loss, [`LANES`] rows at a time: the same formulas
/// as [`Model::brdf_grad`] (Blinn 1977: D3, exact Fresnel with its n-derivative, G/(N·E))
/// written without branches so the compiler turns each lane loop into vector instructions,
/// with [`lanes::ln_1p`] for the logarithm. Each lane keeps its own sums, added in lane order at
/// the end, so the result does not depend on the instruction set; it is compiled for AVX-512
/// and AVX2 as well and picked at run time (the `multiversion` crate).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn ts_d3_log(
    rows: &Rows,
    range: std::ops::Range<usize>,
    p: [f64; 4],
    g: &mut [[f64; 4]; 4],
    gr: &mut [f64; 4],
) -> f64 {
    ts_d3_log_body::<true>(rows, range, p, g, gr)
}

/// Σ ½r² of [`ts_d3_log`] alone (no Jacobian), for cost-only evaluations.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn ts_d3_log_cost(rows: &Rows, range: std::ops::Range<usize>, p: [f64; 4]) -> f64 {
    ts_d3_log_body::<false>(rows, range, p, &mut [[0.0; 4]; 4], &mut [0.0; 4])
}

#[inline(always)]
fn ts_d3_log_body<const JAC: bool>(
    rows: &Rows,
    range: std::ops::Range<usize>,
    p: [f64; 4],
    g: &mut [[f64; 4]; 4],
    gr: &mut [f64; 4],
) -> f64 {
    let k = TsD3::new(p);
    let pd_pi = p[3] * std::f64::consts::FRAC_1_PI;
    let cols = [&rows.nl, &rows.nh, &rows.eh, &rows.g_ne, &rows.target];
    let acc = kernels::drive(rows, range, cols, &TsD3Block::<JAC>(k, pd_pi));
    let lane_sum = |k: usize| acc[k].iter().sum::<f64>();
    let mut t = kernels::TRI;
    for a in 0..4 {
        gr[a] += lane_sum(1 + a);
        for b in a..4 {
            g[a][b] += lane_sum(t);
            t += 1;
        }
    }
    lane_sum(0)
}

/// [`ts_d3_block`] with its parameters (D3 at fixed n, c3, ps; pd/π).
struct TsD3Block<const JAC: bool>(TsD3, f64);

impl<const JAC: bool> kernels::Block for TsD3Block<JAC> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut kernels::Acc) {
        ts_d3_block::<JAC>(&self.0, self.1, c, sw, acc)
    }
}

/// One block of [`LANES`] rows of [`ts_d3_log`]: columns nl, nh, eh, g_ne, target; √weight.
#[inline(always)]
fn ts_d3_block<const JAC: bool>(
    k: &TsD3,
    pd_pi: f64,
    c: &[[f64; LANES]; 5],
    sw: &[f64; LANES],
    acc: &mut kernels::Acc,
) {
    let [nl, nh, eh, gn, tg] = c;
    let mut y = [0.0f64; LANES];
    let mut dy = [[0.0f64; LANES]; 3];
    for l in 0..LANES {
        // y = cosθi f_r = cosθi pd/π + ps a, a = D F G/(π N·E) (no division by cosθi).
        let (a, da) = k.eval(nh[l], eh[l], gn[l]);
        y[l] = nl[l] * pd_pi + k.ps * a;
        dy[0][l] = k.ps * da[0];
        dy[1][l] = k.ps * da[1];
        dy[2][l] = a;
    }
    let (ly, iu) = lanes::ln_1p(&y);
    for l in 0..LANES {
        // r = ln(1 + y) − target, dr/dθ = (dy/dθ)/(1 + y).
        let r = sw[l] * (ly[l] - tg[l]);
        if JAC {
            let s = sw[l] * iu[l];
            let j = [
                s * dy[0][l],
                s * dy[1][l],
                s * dy[2][l],
                s * nl[l] * std::f64::consts::FRAC_1_PI,
            ];
            kernels::accumulate_lane(acc, l, r, j);
        } else {
            acc[0][l] += 0.5 * r * r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::problem::Row;
    use crate::model::Geometry;
    use rand::{Rng, SeedableRng};

    /// The lane kernel of Torrance–Sparrow D3 with the log loss gives the same cost and normal
    /// equations as the row-by-row path through `Model::brdf_grad` (an independent code path:
    /// library `ln_1p`, the model's own Fresnel and D3), weighted or not, for any row count.
    #[test]
    fn lane_kernel_matches_row_kernel() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for (case, weighted) in [(0, false), (1, true), (2, false), (3, true)] {
            let m = [1, 7, 8, 1003][case];
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
                    target: (g.nl * f).ln_1p(),
                    sw: if weighted {
                        rng.random_range(0.1..2.0)
                    } else {
                        1.0
                    },
                });
            }
            for _ in 0..20 {
                let p = [
                    rng.random_range(1.01..300.0),
                    rng.random_range(0.01..1.0),
                    rng.random_range(0.0..2.0),
                    rng.random_range(0.0..2.0),
                ];
                let model = Model::new(ModelKind::TorranceSparrow, Distribution::D3, &p).unwrap();
                let (mut g1, mut r1) = ([[0.0; 4]; 4], [0.0; 4]);
                let (mut g2, mut r2) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
                let c1 = ts_d3_log(&rows, 0..m, p, &mut g1, &mut r1);
                assert_eq!(c1, ts_d3_log_cost(&rows, 0..m, p));
                let c2 = kernel_rows_any(
                    &rows,
                    0..m,
                    Loss::Log,
                    &model,
                    Robust::None,
                    &mut g2,
                    &mut r2,
                );
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-11 * (a.abs() + b.abs()) + 1e-300;
                assert!(close(c1, c2), "cost {c1} vs {c2} ({p:?})");
                for a in 0..4 {
                    assert!(close(r1[a], r2[a]), "Jᵀr[{a}] {} vs {}", r1[a], r2[a]);
                    for b in a..4 {
                        assert!(
                            close(g1[a][b], g2[a][b]),
                            "JᵀJ[{a}][{b}] {} vs {}",
                            g1[a][b],
                            g2[a][b]
                        );
                    }
                }
            }
        }
    }
}

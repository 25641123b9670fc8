//! The linear coefficients at one grid point: the passes of the declared loss over the rows
//! for model values a·s + b (one lobe) or Σ c_i s_i (several), their lane kernels, the
//! Gauss–Newton refinement of the coefficients, and the data and weights that linearise the
//! loss.

use crate::fit::lsq;
use crate::fit::problem::{BrdfProblem, Loss, Rows, Slot};
use crate::support::lanes::{self, LANES};

/// A specular basis s row by row, as the product of two factors (Torrance–Sparrow's term in
/// n times its term in c, or the basis times ones), so no grid point allocates its basis.
#[derive(Clone, Copy)]
pub(super) struct Basis<'a> {
    pub(super) a: &'a [f64],
    pub(super) b: &'a [f64],
}

/// The √weights of rows `range`, or an empty slice for unweighted rows.
pub(super) fn weights(rows: &Rows, range: std::ops::Range<usize>) -> &[f64] {
    if rows.weighted() {
        &rows.sw[range]
    } else {
        &[]
    }
}

/// One pass of the declared loss over rows `range` for model values f = a·s + b (s the
/// basis): ½ Σ r² with r = sw (ℓ(f) − target), and the normal equations of (a, b):
/// [JᵀJ_aa, JᵀJ_ab, JᵀJ_bb] and [Jᵀr_a, Jᵀr_b].
pub(super) fn linear_pass(
    rows: &Rows,
    range: std::ops::Range<usize>,
    s: Basis,
    ab: (f64, f64),
    loss: Loss,
) -> (f64, [f64; 3], [f64; 2]) {
    let sw = weights(rows, range.clone());
    let t = match loss {
        Loss::Log => linear_pass_log(
            &rows.nl[range.clone()],
            &rows.target[range.clone()],
            sw,
            s,
            ab,
        ),
        Loss::Linear => linear_pass_linear(&rows.target[range], sw, s, ab),
        Loss::Pixel => {
            // Row by row (the pixel loss serves small scene-weighted sets).
            let mut t = [0.0; 6];
            for (k, i) in range.enumerate() {
                let w = sw.get(k).copied().unwrap_or(1.0);
                let (v, d) = loss.term(ab.0 * s.a[k] + ab.1 * s.b[k], rows.nl[i]);
                let r = w * (v - rows.target[i]);
                let (ja, jb) = (w * d * s.a[k], w * d * s.b[k]);
                t[0] += 0.5 * r * r;
                t[1] += ja * ja;
                t[2] += ja * jb;
                t[3] += jb * jb;
                t[4] += ja * r;
                t[5] += jb * r;
            }
            t
        }
    };
    (t[0], [t[1], t[2], t[3]], [t[4], t[5]])
}

/// [`linear_pass`] for the log loss, eight rows at a time with the lane logarithm (`sw` empty =
/// unweighted); the sums are added per lane, then in lane order.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn linear_pass_log(
    nl: &[f64],
    tg: &[f64],
    sw: &[f64],
    s: Basis,
    ab: (f64, f64),
) -> [f64; 6] {
    linear_pass_log_body::<true>(nl, tg, sw, s, ab)
}

/// The cost alone of [`linear_pass_log`] (no Jacobian: no division per row).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn linear_cost_log(nl: &[f64], tg: &[f64], sw: &[f64], s: Basis, ab: (f64, f64)) -> f64 {
    linear_pass_log_body::<false>(nl, tg, sw, s, ab)[0]
}

#[inline(always)]
pub(super) fn linear_pass_log_body<const JAC: bool>(
    nl: &[f64],
    tg: &[f64],
    sw: &[f64],
    s: Basis,
    ab: (f64, f64),
) -> [f64; 6] {
    let m = nl.len();
    let mut acc = [[0.0f64; LANES]; 6];
    let full = m / LANES * LANES;
    let ones = [1.0f64; LANES];
    let mut i = 0;
    while i < full {
        let get = |v: &[f64]| -> [f64; LANES] { v[i..i + LANES].try_into().expect("lane block") };
        let w = if sw.is_empty() { ones } else { get(sw) };
        let (sa, sb) = (get(s.a), get(s.b));
        let sv = std::array::from_fn(|l| sa[l] * sb[l]);
        linear_block::<JAC>(&get(nl), &get(tg), &w, &sv, ab, &mut acc);
        i += LANES;
    }
    if i < m {
        // The last block: lanes past the end have weight 0.
        let len = m - i;
        let pad = |v: &[f64]| -> [f64; LANES] { std::array::from_fn(|l| v[i + l.min(len - 1)]) };
        let w = lane_weights(sw, i, len);
        let (sa, sb) = (pad(s.a), pad(s.b));
        let sv = std::array::from_fn(|l| sa[l] * sb[l]);
        linear_block::<JAC>(&pad(nl), &pad(tg), &w, &sv, ab, &mut acc);
    }
    acc.map(|a| a.iter().sum::<f64>())
}

/// One block of [`LANES`] rows of [`linear_pass_log_body`].
#[inline(always)]
pub(super) fn linear_block<const JAC: bool>(
    c: &[f64; LANES],
    t: &[f64; LANES],
    w: &[f64; LANES],
    sv: &[f64; LANES],
    (a, b): (f64, f64),
    acc: &mut [[f64; LANES]; 6],
) {
    let y: [f64; LANES] = std::array::from_fn(|l| c[l] * (a * sv[l] + b));
    if !JAC {
        let u: [f64; LANES] = std::array::from_fn(|l| 1.0 + y[l]);
        let v = lanes::ln(&u);
        for l in 0..LANES {
            // fdlibm log1p's correction for the rounding of u, without its division by u
            // (a change below 2⁻⁵³ relative, enough for ranking grid points).
            let r = w[l] * (v[l] + (y[l] - (u[l] - 1.0)) - t[l]);
            acc[0][l] += 0.5 * r * r;
        }
        return;
    }
    let (v, iu) = lanes::ln_1p(&y);
    for l in 0..LANES {
        let r = w[l] * (v[l] - t[l]);
        let jb = w[l] * c[l] * iu[l];
        let ja = jb * sv[l];
        acc[0][l] += 0.5 * r * r;
        acc[1][l] += ja * ja;
        acc[2][l] += ja * jb;
        acc[3][l] += jb * jb;
        acc[4][l] += ja * r;
        acc[5][l] += jb * r;
    }
}

/// Rows `i..i + len` of `v` as one lane block (`len` ≤ [`LANES`]): lanes past the end repeat
/// the last row (a full block: plain loads).
#[inline(always)]
fn lane_block(v: &[f64], i: usize, len: usize) -> [f64; LANES] {
    if len == LANES {
        v[i..i + LANES].try_into().expect("a full block")
    } else {
        std::array::from_fn(|l| v[i + l.min(len - 1)])
    }
}

/// The √weights of [`lane_block`]'s rows (`sw` empty: 1), 0 in the lanes past the end.
#[inline(always)]
fn lane_weights(sw: &[f64], i: usize, len: usize) -> [f64; LANES] {
    match (sw.is_empty(), len == LANES) {
        (true, true) => [1.0; LANES],
        (false, true) => lane_block(sw, i, len),
        (empty, false) => std::array::from_fn(|l| match (l < len, empty) {
            (false, _) => 0.0,
            (true, true) => 1.0,
            (true, false) => sw[i + l],
        }),
    }
}

/// The cost alone of [`linear_pass_many`] for the log loss when the last basis is ones (pd/π):
/// f = Σ c_j s_j over the specular bases `spec` plus `b`, eight rows at a time with
/// [`linear_block`] (`sw` empty = unweighted).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn linear_cost_log_many(
    nl: &[f64],
    tg: &[f64],
    sw: &[f64],
    spec: &[Basis],
    coef: &[f64],
    b: f64,
) -> f64 {
    let m = nl.len();
    let mut acc = [[0.0f64; LANES]; 6];
    let mut i = 0;
    while i < m {
        let len = (m - i).min(LANES);
        let get = |v: &[f64]| lane_block(v, i, len);
        let w = lane_weights(sw, i, len);
        let mut sv = [0.0f64; LANES];
        for (s, &c) in spec.iter().zip(coef) {
            let (sa, sb) = (get(s.a), get(s.b));
            for l in 0..LANES {
                sv[l] += c * (sa[l] * sb[l]);
            }
        }
        linear_block::<false>(&get(nl), &get(tg), &w, &sv, (1.0, b), &mut acc);
        i += LANES;
    }
    acc[0].iter().sum()
}

/// [`linear_pass`] for the linear loss.
pub(super) fn linear_pass_linear(tg: &[f64], sw: &[f64], s: Basis, (a, b): (f64, f64)) -> [f64; 6] {
    let mut t = [0.0f64; 6];
    for i in 0..tg.len() {
        let w = sw.get(i).copied().unwrap_or(1.0);
        let si = s.a[i] * s.b[i];
        let r = w * (a * si + b - tg[i]);
        let (ja, jb) = (w * si, w);
        t[0] += 0.5 * r * r;
        t[1] += ja * ja;
        t[2] += ja * jb;
        t[3] += jb * jb;
        t[4] += ja * r;
        t[5] += jb * r;
    }
    t
}

/// Minimise the declared loss over the linear coefficients c of f = Σ c_j s_j from `start`
/// by `steps` projected Gauss–Newton steps (each backtracked up to three times); a free
/// coefficient stays ≥ 0, a held one keeps its value. `pass` gives ½ Σ r², JᵀJ (row-major)
/// and Jᵀr at c; `cost` the first alone (cheaper). Returns the cost and c.
pub(super) fn refine_linear(
    start: &[f64],
    free: &[bool],
    loss: Loss,
    steps: usize,
    pass: impl Fn(&[f64]) -> (f64, Vec<f64>, Vec<f64>),
    cost: impl Fn(&[f64]) -> f64,
) -> (f64, Vec<f64>) {
    let mut x = start.to_vec();
    // The linear loss is minimised exactly by the linear solve.
    if steps == 0 || loss == Loss::Linear {
        return (cost(&x), x);
    }
    let k = x.len();
    let (mut c, mut jtj, mut jtr) = pass(&x);
    for _ in 0..steps {
        let diag: Vec<f64> = (0..k).map(|i| jtj[i * k + i]).collect();
        let held: Vec<bool> = (0..k).map(|i| !free[i] || !(diag[i] > 0.0)).collect();
        if held.iter().all(|&h| h) {
            break;
        }
        let d: Vec<f64> = diag
            .iter()
            .map(|&v| if v > 0.0 { v } else { 1.0 })
            .collect();
        let Some(dx) = lsq::damped_solve(&jtj, &jtr, &d, 1e-9, &held) else {
            break;
        };
        let mut step = 1.0;
        let mut accepted = false;
        for _ in 0..3 {
            let xn: Vec<f64> = (0..k)
                .map(|i| {
                    if held[i] {
                        x[i]
                    } else {
                        (x[i] + step * dx[i]).max(0.0)
                    }
                })
                .collect();
            let (cn, jn, gn) = pass(&xn);
            if cn < c {
                (x, c, jtj, jtr) = (xn, cn, jn, gn);
                accepted = true;
                break;
            }
            step *= 0.25;
        }
        if !accepted {
            break;
        }
    }
    (c, x)
}

/// One pass of the declared loss over rows `range` for f = Σ c_j s_j with the bases `s` (for
/// models with several specular lobes): ½ Σ r² with r = sw (ℓ(f) − target), JᵀJ (row-major)
/// and Jᵀr of c. The log loss with two to four bases takes the lane kernel
/// [`linear_pass_log_many`], the rest the row loop [`linear_pass_many_rows`].
pub(super) fn linear_pass_many(
    rows: &Rows,
    range: std::ops::Range<usize>,
    s: &[Basis],
    c: &[f64],
    loss: Loss,
) -> (f64, Vec<f64>, Vec<f64>) {
    if loss == Loss::Log && (2..=4).contains(&s.len()) {
        let sw = weights(rows, range.clone());
        return linear_pass_log_many(&rows.nl[range.clone()], &rows.target[range], sw, s, c);
    }
    linear_pass_many_rows(rows, range, s, c, loss)
}

/// [`linear_pass_many`] for the log loss with 2 to 4 bases, [`LANES`] rows at a time with the
/// lane logarithm (`sw` empty = unweighted); the sums are added per lane, then in lane order.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn linear_pass_log_many(
    nl: &[f64],
    tg: &[f64],
    sw: &[f64],
    s: &[Basis],
    c: &[f64],
) -> (f64, Vec<f64>, Vec<f64>) {
    match s.len() {
        2 => linear_pass_log_many_body::<2>(nl, tg, sw, s, c),
        3 => linear_pass_log_many_body::<3>(nl, tg, sw, s, c),
        _ => linear_pass_log_many_body::<4>(nl, tg, sw, s, c),
    }
}

/// The body of [`linear_pass_log_many`] for `K` bases.
#[inline(always)]
fn linear_pass_log_many_body<const K: usize>(
    nl: &[f64],
    tg: &[f64],
    sw: &[f64],
    s: &[Basis],
    c: &[f64],
) -> (f64, Vec<f64>, Vec<f64>) {
    let m = nl.len();
    let coef: [f64; K] = std::array::from_fn(|j| c[j]);
    let mut cost = [0.0f64; LANES];
    let mut gr = [[0.0f64; LANES]; K];
    let mut g = [[[0.0f64; LANES]; K]; K];
    let mut i = 0;
    while i < m {
        let len = (m - i).min(LANES);
        let get = |v: &[f64]| lane_block(v, i, len);
        let w = lane_weights(sw, i, len);
        let sv: [[f64; LANES]; K] = std::array::from_fn(|j| {
            let (a, b) = (get(s[j].a), get(s[j].b));
            std::array::from_fn(|l| a[l] * b[l])
        });
        let (x, t) = (get(nl), get(tg));
        let mut f = [0.0f64; LANES];
        for j in 0..K {
            for l in 0..LANES {
                f[l] += coef[j] * sv[j][l];
            }
        }
        let y: [f64; LANES] = std::array::from_fn(|l| x[l] * f[l]);
        let (v, iu) = lanes::ln_1p(&y);
        for l in 0..LANES {
            let r = w[l] * (v[l] - t[l]);
            let d = w[l] * x[l] * iu[l];
            cost[l] += 0.5 * r * r;
            for a in 0..K {
                let ja = d * sv[a][l];
                gr[a][l] += ja * r;
                for b in a..K {
                    g[a][b][l] += ja * d * sv[b][l];
                }
            }
        }
        i += LANES;
    }
    let sum = |v: &[f64; LANES]| v.iter().sum::<f64>();
    let mut jtj = vec![0.0; K * K];
    for a in 0..K {
        for b in a..K {
            jtj[a * K + b] = sum(&g[a][b]);
            jtj[b * K + a] = jtj[a * K + b];
        }
    }
    (sum(&cost), jtj, gr.iter().map(sum).collect())
}

/// One pass of the declared loss over rows `range` for f = Σ c_j s_j with the bases `s` (a
/// row loop, for models with several specular lobes): ½ Σ r² with r = sw (ℓ(f) − target),
/// JᵀJ (row-major) and Jᵀr of c.
pub(super) fn linear_pass_many_rows(
    rows: &Rows,
    range: std::ops::Range<usize>,
    s: &[Basis],
    c: &[f64],
    loss: Loss,
) -> (f64, Vec<f64>, Vec<f64>) {
    let k = s.len();
    let (mut cost, mut jtj, mut jtr) = (0.0, vec![0.0; k * k], vec![0.0; k]);
    let mut j = vec![0.0; k];
    let mut sv = vec![0.0; k];
    for (i, r) in range.enumerate() {
        let w = if rows.weighted() { rows.sw[r] } else { 1.0 };
        for (v, b) in sv.iter_mut().zip(s) {
            *v = b.a[i] * b.b[i];
        }
        let f: f64 = sv.iter().zip(c).map(|(a, b)| a * b).sum();
        let res = match loss {
            Loss::Log => {
                let y = rows.nl[r] * f;
                let d = w * rows.nl[r] / (1.0 + y);
                for (jj, si) in j.iter_mut().zip(&sv) {
                    *jj = d * si;
                }
                w * (y.ln_1p() - rows.target[r])
            }
            Loss::Linear => {
                for (jj, si) in j.iter_mut().zip(&sv) {
                    *jj = w * si;
                }
                w * (f - rows.target[r])
            }
            Loss::Pixel => {
                let (v, d) = loss.term(f, rows.nl[r]);
                for (jj, si) in j.iter_mut().zip(&sv) {
                    *jj = w * d * si;
                }
                w * (v - rows.target[r])
            }
        };
        cost += 0.5 * res * res;
        for a in 0..k {
            jtr[a] += j[a] * res;
            for b in 0..k {
                jtj[a * k + b] += j[a] * j[b];
            }
        }
    }
    (cost, jtj, jtr)
}

/// The weighted normal equations of the linear problem f_data ≈ Σ c_j s_j: the Gram matrix
/// Σ w s_i s_j (row-major) and Σ (w f) s_i, for bases `s`, weights `w` and `wf` = w·f_data.
pub(super) fn gram_sums(s: &[Basis], w: &[f64], wf: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let k = s.len();
    let (mut g, mut h) = (vec![0.0; k * k], vec![0.0; k]);
    let mut sv = vec![0.0; k];
    for i in 0..w.len() {
        for (v, b) in sv.iter_mut().zip(s) {
            *v = b.a[i] * b.b[i];
        }
        for a in 0..k {
            h[a] += wf[i] * sv[a];
            for b in 0..k {
                g[a * k + b] += w[i] * sv[a] * sv[b];
            }
        }
    }
    (g, h)
}

/// The linearised cost ½ Σ w (a·s + b − f)² of one lobe's basis s with coefficients
/// x = (a, b) from the sums alone: `g` = [Σws², Σws, Σw], `h` = [Σwfs, Σwf], `ff` = Σwf²
/// (expanded: ½ (a²Σws² + 2abΣws + b²Σw + Σwf²) − aΣwfs − bΣwf).
pub(super) fn linearised_cost(g: [f64; 3], h: [f64; 2], ff: f64, [a, b]: [f64; 2]) -> f64 {
    0.5 * (g[0] * a * a + 2.0 * g[1] * a * b + g[2] * b * b + ff) - (h[0] * a + h[1] * b)
}

/// A channel's linear coefficients (each lobe's ps at model indices `ips`, then pd/π at
/// `ipd`) from its `slots`: each one's value where held (0 where free; pd divided by π, its
/// basis being 1) and whether it is free.
pub(super) fn linear_coefficients(
    slots: &[Slot],
    ips: &[usize],
    ipd: usize,
) -> (Vec<f64>, Vec<bool>) {
    let k = ips.len() + 1;
    let mut held = vec![0.0; k];
    let mut free = vec![false; k];
    for (j, &i) in ips.iter().chain([&ipd]).enumerate() {
        match slots[i] {
            Slot::Fixed(v) => held[j] = v,
            Slot::Free(_) => free[j] = true,
        }
    }
    held[k - 1] *= std::f64::consts::FRAC_1_PI;
    (held, free)
}

/// Per row, the data f_r and the weight that linearises the loss around it (parameter-free):
/// for the log loss r ≈ cosθi Δf / (1 + cosθi f), so w = (cosθi / (1 + cosθi f))².
pub(super) fn linearised_data(p: &BrdfProblem, loss: Loss) -> (Vec<f64>, Vec<f64>) {
    (0..p.rows.len())
        .map(|i| {
            let r = p.rows.get(i);
            let fd = match loss {
                Loss::Log => r.target.exp_m1() / r.cos_i,
                Loss::Linear => r.target,
                // The sRGB encoding inverted (the smooth clip taken as none).
                Loss::Pixel => {
                    let v = r.target.max(0.0);
                    let c = if v <= 12.92 * 0.003_130_8 {
                        v / 12.92
                    } else {
                        ((v + 0.055) / 1.055).powf(2.4)
                    };
                    c / r.cos_i
                }
            };
            let w = match loss {
                Loss::Log => (r.cos_i / (1.0 + r.cos_i * fd)).powi(2),
                Loss::Linear => 1.0,
                Loss::Pixel => loss.term(fd, r.cos_i).1.powi(2),
            } * r.sw
                * r.sw;
            (fd, w)
        })
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::init::fixtures::{spread_rows, test_rows};
    use crate::fit::init::nnls::linear_solve;
    use crate::fit::init::tables::{basis_free_sums, basis_sums};

    /// The linearised cost from the sums ([`linearised_cost`], the score of the one-lobe grid
    /// search) equals ½ Σ w (a·s + b − f)² summed row by row, at the linear solve's (a, b)
    /// and away from it (where the cross term and the constant matter).
    #[test]
    fn linearised_cost_matches_a_row_sum() {
        let m = 777;
        let (s, fd, w) = test_rows(m);
        let wf: Vec<f64> = w.iter().zip(&fd).map(|(w, f)| w * f).collect();
        let [ss, s1, sf] = basis_sums(&s, &w, &wf);
        let [w1, f1, ff] = basis_free_sums(&w, &fd);
        let solved = linear_solve(&[ss, s1, s1, w1], &[sf, f1], &[0.0, 0.0], &[true, true]);
        for x in [[solved[0], solved[1]], [0.7, 0.05], [0.0, 0.4], [2.5, -0.3]] {
            let want: f64 = (0..m)
                .map(|i| 0.5 * w[i] * (x[0] * s[i] + x[1] - fd[i]).powi(2))
                .sum();
            let got = linearised_cost([ss, s1, w1], [sf, f1], ff, x);
            assert!(
                (got - want).abs() <= 1e-11 * want.max(1e-3),
                "x = {x:?}: {got} against {want}"
            );
        }
    }

    /// The lane cost of several lobes, and the lane pass with its normal equations, equal the
    /// row pass's (library ln_1p) to 1e-13 (cost) and 1e-12 (JᵀJ, Jᵀr), for lengths with and
    /// without a partial last block, weighted or not.
    #[test]
    fn lane_cost_of_several_lobes_matches_the_row_pass() {
        let rows = spread_rows();
        let m = rows.len();
        let s1: Vec<f64> = (0..m)
            .map(|i| (0.37 * i as f64).sin().abs() * 3.0)
            .collect();
        let s2: Vec<f64> = (0..m).map(|i| (0.11 * i as f64).cos().powi(2)).collect();
        let ones = vec![1.0; m];
        let mut rows = rows;
        for (i, t) in rows.target.iter_mut().enumerate() {
            *t = (0.5 + (i % 9) as f64 * 0.1).ln_1p();
        }
        for weighted in [false, true] {
            let mut rows = rows.clone();
            if weighted {
                let mut w = Rows::with_capacity(0, true);
                w.extend(&rows);
                w.sw = (0..m).map(|i| 0.3 + (i % 4) as f64 * 0.4).collect();
                rows = w;
            }
            for len in [1, 7, 8, 9, m] {
                fn basis<'a>(v: &'a [f64], ones: &'a [f64], len: usize) -> Basis<'a> {
                    Basis {
                        a: &v[..len],
                        b: &ones[..len],
                    }
                }
                let bases = [
                    basis(&s1, &ones, len),
                    basis(&s2, &ones, len),
                    basis(&ones, &ones, len),
                ];
                let c = [0.7, 0.2, 0.05];
                let (want, jtj, jtr) = linear_pass_many_rows(&rows, 0..len, &bases, &c, Loss::Log);
                // The lane pass with its Jacobian: the same sums to 1e-12 (relative to the
                // largest of its kind).
                let sw = weights(&rows, 0..len);
                let (cost, gj, gr) =
                    linear_pass_log_many(&rows.nl[..len], &rows.target[..len], sw, &bases, &c);
                let close = |a: &[f64], b: &[f64]| {
                    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-12 * scale)
                };
                assert!(
                    (cost - want).abs() <= 1e-13 * want,
                    "{len} {weighted}: {cost} vs {want}"
                );
                assert!(close(&gj, &jtj), "{len} {weighted}: {gj:?} vs {jtj:?}");
                assert!(close(&gr, &jtr), "{len} {weighted}: {gr:?} vs {jtr:?}");
                let got = linear_cost_log_many(
                    &rows.nl[..len],
                    &rows.target[..len],
                    weights(&rows, 0..len),
                    &bases[..2],
                    &c[..2],
                    c[2],
                );
                assert!(
                    (got - want).abs() <= 1e-13 * want,
                    "{len} {weighted}: {got} vs {want}"
                );
            }
        }
    }
}

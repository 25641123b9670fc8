//! Stage 2 of a fit: the global initialisation by variable projection over a grid of the
//! nonlinear parameters, with the linear parameters solved at each grid point.

use super::*;

/// Torrance–Sparrow's specular basis s = D(c)·F(n)·G/(π N·L N·E) at every point of a grid of
/// n (`ns`) and the distribution's shape parameters (`cs`: each point's values, c for D1–D3,
/// (b, c) for ABC) is a term in n alone times a term in the shape alone: rows of `a`
/// (F(n)·G/(π N·L N·E), one per n) times rows of `b` (D, one per shape point).
pub(super) struct TsFactors {
    /// F(n)·G/(π N·L N·E), one row of m per n, row-major.
    pub(super) a: Vec<f64>,
    /// D(c), one row of m per c, row-major.
    pub(super) b: Vec<f64>,
    pub(super) m: usize,
}

/// Append F(n) at each E·H of `eh` times `geo`, row by row (a plain loop over slices, so it
/// vectorises; compiled for AVX-512 and AVX2 as well and picked at run time).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn fresnel_times(n: f64, eh: &[f64], geo: &[f64], out: &mut Vec<f64>) {
    out.extend(
        eh.iter()
            .zip(geo)
            .map(|(&c, &g)| crate::model::fresnel(n, c) * g),
    );
}

/// Append the distribution's shape term D at each N·H of `nh` for shape point `c` (see
/// [`fresnel_times`]).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn shape_values(dist: Distribution, c: &[f64], nh: &[f64], out: &mut Vec<f64>) {
    out.extend(nh.iter().map(|&x| dist.eval_shape(x, c)));
}

impl TsFactors {
    fn new(rows: &Rows, dist: Distribution, ns: &[f64], cs: &[Vec<f64>]) -> Self {
        let m = rows.len();
        let pi = std::f64::consts::FRAC_1_PI;
        let geo: Vec<f64> = (0..m).map(|r| rows.g_ne[r] * pi / rows.nl[r]).collect();
        // The two factors' tables beside each other.
        let (a, b) = rayon::join(
            || {
                let mut a = Vec::with_capacity(ns.len() * m);
                for &n in ns {
                    fresnel_times(n, &rows.eh, &geo, &mut a);
                }
                a
            },
            || {
                let mut b = Vec::with_capacity(cs.len() * m);
                if dist == Distribution::Abc {
                    // ABC's points (b, c) come in runs of one b: ln(1 + b (1 − N·H)) once per
                    // run.
                    for run in cs.chunk_by(|x, y| x[0].to_bits() == y[0].to_bits()) {
                        let c: Vec<f64> = run.iter().map(|pt| pt[1]).collect();
                        problem::abc_shape_rows(run[0][0], &c, &rows.nh, &mut b);
                    }
                } else {
                    for c in cs {
                        shape_values(dist, c, &rows.nh, &mut b);
                    }
                }
                b
            },
        );
        TsFactors { a, b, m }
    }

    /// GGX–Smith's specular basis s = F(n)·L(α), L = D G1 G1/(4 N·L N·E), at every point of
    /// a grid of α (`alphas`, the slower axis, as the parameters are declared) and n (`ns`):
    /// rows of `a` are L(α), rows of `b` F(n) (0 where N·H ≤ 0 or E·H ≤ 0).
    fn ggx(tables: &LobeTables, alphas: &[f64], ns: &[f64]) -> Option<Self> {
        let mut a = Vec::with_capacity(alphas.len() * tables.m);
        for &v in alphas {
            a.extend_from_slice(tables.lobe(v)?);
        }
        let mut b = Vec::with_capacity(ns.len() * tables.m);
        for &v in ns {
            b.extend_from_slice(tables.fresnel(v)?);
        }
        Some(TsFactors { a, b, m: tables.m })
    }

    /// [`basis_sums`] at every grid point, n-major ([`grid_sums`]).
    fn grid_sums(&self, w: &[f64], wf: &[f64]) -> Vec<[f64; 3]> {
        grid_sums(&self.a, &self.b, self.m, w, wf)
    }

    /// The basis at grid point `index` (n-major), row by row.
    fn basis(&self, index: usize) -> Basis<'_> {
        let (m, nc) = (self.m, self.b.len() / self.m);
        let (i, j) = (index / nc, index % nc);
        Basis {
            a: &self.a[i * m..(i + 1) * m],
            b: &self.b[j * m..(j + 1) * m],
        }
    }
}

/// GGX lobes L(α) = D G1 G1/(4 N·L N·E) at every α of the grid and Fresnel factors F(n)
/// (0 where N·H ≤ 0 or E·H ≤ 0) at every n of the grid, over all rows: a GGX–Smith basis (one
/// lobe or two sharing n) at any grid point is F(n)·L(α), with nothing evaluated per point.
pub(super) struct LobeTables {
    alphas: Vec<f64>,
    lobes: Vec<Vec<f64>>,
    ns: Vec<f64>,
    fres: Vec<Vec<f64>>,
    m: usize,
}

impl LobeTables {
    fn new(rows: &Rows, alphas: &[f64], ns: &[f64]) -> Self {
        let m = rows.len();
        let mut alphas = alphas.to_vec();
        alphas.sort_by(f64::total_cmp);
        alphas.dedup();
        // Each α's lobe and each n's factors on their own (in parallel: the same values on any
        // number of threads).
        use rayon::prelude::*;
        let lobes = alphas
            .par_iter()
            .map(|&a| problem::ggx_lobe_values(a, rows, 0..m))
            .collect();
        let fres = ns
            .par_iter()
            .map(|&n| {
                (0..m)
                    .map(|r| {
                        let ok = rows.nh[r] > 0.0 && rows.eh[r] > 0.0;
                        if ok {
                            crate::model::fresnel(n, rows.eh[r])
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        LobeTables {
            alphas,
            lobes,
            ns: ns.to_vec(),
            fres,
            m,
        }
    }

    /// L(α) on every row, if α is tabulated.
    fn lobe(&self, alpha: f64) -> Option<&[f64]> {
        let i = self
            .alphas
            .iter()
            .position(|a| a.to_bits() == alpha.to_bits())?;
        Some(&self.lobes[i])
    }

    /// F(n) on every row, if n is tabulated.
    fn fresnel(&self, n: f64) -> Option<&[f64]> {
        let j = self.ns.iter().position(|v| v.to_bits() == n.to_bits())?;
        Some(&self.fres[j])
    }

    /// The basis F(n)·L(α) on rows `range`, if both values are tabulated.
    fn basis(&self, alpha: f64, n: f64, range: std::ops::Range<usize>) -> Option<Basis<'_>> {
        Some(Basis {
            a: &self.fresnel(n)?[range.clone()],
            b: &self.lobe(alpha)?[range],
        })
    }
}

/// The Gram sums of [`gram_sums`] for two lobes of the same form sharing the Fresnel factor
/// (ggx-smith-2 on one channel) at every point of a grid α1 × α2 × n, from three matrix
/// products per n: with u = w F(n)², Σ u L(αa) L(αb) for every pair of the grid's α, and
/// Σ w F(n) L(αa), Σ (w f) F(n) L(αa) for every α; nothing evaluated per point.
pub(super) struct TwoLobeGram {
    /// Per n: Σ w F² La Lb, row-major over the α grid.
    ll: Vec<Vec<f64>>,
    /// Per n: Σ w F La.
    l: Vec<Vec<f64>>,
    /// Per n: Σ (w f) F La.
    h: Vec<Vec<f64>>,
    na: usize,
    /// Σ w and Σ w f.
    w1: f64,
    f1: f64,
}

impl TwoLobeGram {
    fn new(tables: &LobeTables, alphas: &[f64], ns: &[f64], w: &[f64], wf: &[f64]) -> Option<Self> {
        use rayon::prelude::*;
        let (m, na) = (tables.m, alphas.len());
        let lobes: Vec<&[f64]> = alphas
            .iter()
            .map(|&a| tables.lobe(a))
            .collect::<Option<_>>()?;
        let lobes = padded_rows(lobes, m);
        // Each n's sums on their own (in parallel: the same values on any number of threads).
        let per_n: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = ns
            .par_iter()
            .map(|&n| Some(two_lobe_sums(&lobes, tables.fresnel(n)?, w, wf)))
            .collect::<Option<_>>()?;
        let (mut ll, mut l, mut h) = (Vec::new(), Vec::new(), Vec::new());
        for (a, b, c) in per_n {
            ll.push(a);
            l.push(b);
            h.push(c);
        }
        let (w1, f1) = (w.iter().sum(), wf.iter().sum());
        Some(TwoLobeGram {
            ll,
            l,
            h,
            na,
            w1,
            f1,
        })
    }

    /// The Gram matrix (row-major) and right-hand side of the bases (lobe at α index `a1`,
    /// lobe at `a2`, ones) at n index `j`, as [`gram_sums`] gives them.
    fn gram(&self, a1: usize, a2: usize, j: usize) -> (Vec<f64>, Vec<f64>) {
        let (g, h) = self.gram3(a1, a2, j);
        (g.to_vec(), h.to_vec())
    }

    /// [`TwoLobeGram::gram`] in fixed-size arrays.
    fn gram3(&self, a1: usize, a2: usize, j: usize) -> ([f64; 9], [f64; 3]) {
        let (ll, l, h, na) = (&self.ll[j], &self.l[j], &self.h[j], self.na);
        let g = [
            ll[a1 * na + a1],
            ll[a1 * na + a2],
            l[a1],
            ll[a2 * na + a1],
            ll[a2 * na + a2],
            l[a2],
            l[a1],
            l[a2],
            self.w1,
        ];
        (g, [h[a1], h[a2], self.f1])
    }
}

/// [Σw, Σwf, Σwf²] of rows with weights w and data f.
pub(super) fn basis_free_sums(w: &[f64], f: &[f64]) -> [f64; 3] {
    let mut k = [0.0; 3];
    for (w, f) in w.iter().zip(f) {
        k[0] += w;
        k[1] += w * f;
        k[2] += w * f * f;
    }
    k
}

/// [Σws², Σws, Σ(wf)s] over the rows. [`LANES`] rows at a time with per-lane sums added in
/// lane order, so it vectorises (and gives the same sums on every instruction set it is
/// compiled for).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn basis_sums(s: &[f64], w: &[f64], wf: &[f64]) -> [f64; 3] {
    basis_sums_body(s, w, wf)
}

/// The body of [`basis_sums`] (no closures: in a multiversioned function they are not always
/// inlined, and then do not vectorise).
#[inline(always)]
pub(super) fn basis_sums_body(s: &[f64], w: &[f64], wf: &[f64]) -> [f64; 3] {
    let n = s.len().min(w.len()).min(wf.len());
    let (s, w, wf) = (&s[..n], &w[..n], &wf[..n]);
    let (mut a0, mut a1, mut a2) = ([0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES]);
    let (sc, wc, fc) = (
        s.chunks_exact(LANES),
        w.chunks_exact(LANES),
        wf.chunks_exact(LANES),
    );
    // The last block: lanes past the end have weight 0.
    let mut tail = [[0.0f64; LANES]; 3];
    tail[0][..sc.remainder().len()].copy_from_slice(sc.remainder());
    tail[1][..wc.remainder().len()].copy_from_slice(wc.remainder());
    tail[2][..fc.remainder().len()].copy_from_slice(fc.remainder());
    let [ts, tw, tf] = &tail;
    for ((s, w), f) in sc
        .zip(wc)
        .zip(fc)
        .chain(std::iter::once(((&ts[..], &tw[..]), &tf[..])))
    {
        // One loop per sum: LLVM then packs lanes, not the sums of one lane.
        let ws: [f64; LANES] = std::array::from_fn(|l| w[l] * s[l]);
        for l in 0..LANES {
            a0[l] += ws[l] * s[l];
        }
        for l in 0..LANES {
            a1[l] += ws[l];
        }
        for l in 0..LANES {
            a2[l] += f[l] * s[l];
        }
    }
    [a0, a1, a2].map(|a| a.iter().sum())
}

/// [`basis_sums`] of the basis a_i·b_j for every row i of `a` and row j of `b` (each of `m`,
/// row-major), i-major: Σw(a_i b_j)², Σw a_i b_j and Σwf a_i b_j are dot products of w a_i²
/// with b_j², and of w a_i and wf a_i with b_j, the products in a_i formed once per i. (Three
/// matrix products, 17 × 408 by 408 × 19 for the default grids on a 10,000-row fit, took
/// 0.13 ms of its 0.6 ms, most of it in packing and allocation.)
fn grid_sums(a: &[f64], b: &[f64], m: usize, w: &[f64], wf: &[f64]) -> Vec<[f64; 3]> {
    use rayon::prelude::*;
    let bp = padded_rows(b.chunks_exact(m), m);
    let b2p: Vec<f64> = bp.iter().map(|x| x * x).collect();
    // The rows of `a` in parallel (each sum is the same on any number of threads).
    a.par_chunks_exact(m)
        .flat_map_iter(|ai| grid_sums_row(ai, (&bp, &b2p), w, wf))
        .collect()
}

/// [`grid_sums`] for one row `ai` of `a` against every row of `b` and of b² (`bp`, `b2p`,
/// rows zero-padded to whole blocks of [`LANES`]).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn grid_sums_row(ai: &[f64], (bp, b2p): (&[f64], &[f64]), w: &[f64], wf: &[f64]) -> Vec<[f64; 3]> {
    let mp = ai.len().next_multiple_of(LANES);
    let (mut wa, mut wa2, mut wfa) = (vec![0.0; mp], vec![0.0; mp], vec![0.0; mp]);
    for ((((x, x2), xf), (&wr, &wfr)), &v) in wa
        .iter_mut()
        .zip(&mut wa2)
        .zip(&mut wfa)
        .zip(w.iter().zip(wf))
        .zip(ai)
    {
        *x = wr * v;
        *x2 = *x * v;
        *xf = wfr * v;
    }
    bp.chunks_exact(mp)
        .zip(b2p.chunks_exact(mp))
        .map(|(bj, b2j)| {
            [
                dot_lanes(&wa2, b2j),
                dot_lanes(&wa, bj),
                dot_lanes(&wfa, bj),
            ]
        })
        .collect()
}

/// One n's sums of [`TwoLobeGram`] from the lobes `lobes` (rows zero-padded to whole blocks
/// of [`LANES`]) and that n's Fresnel factors `f`: Σ w F² La Lb (na × na, symmetric, each
/// pair summed once), Σ w F La and Σ wf F La, as dot products of w F² La, w F and wf F with
/// the lobes. (Three nalgebra products per n did the same at about twice the cost, most of it
/// in packing and allocation, as for [`grid_sums`].)
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn two_lobe_sums(
    lobes: &[f64],
    f: &[f64],
    w: &[f64],
    wf: &[f64],
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let m = f.len();
    let mp = m.next_multiple_of(LANES);
    let na = lobes.len() / mp.max(1);
    let (mut u, mut v, mut q) = (vec![0.0; mp], vec![0.0; mp], vec![0.0; mp]);
    for ((((ur, vr), qr), &fr), (&wr, &wfr)) in u
        .iter_mut()
        .zip(&mut v)
        .zip(&mut q)
        .zip(f)
        .zip(w.iter().zip(wf))
    {
        *vr = wr * fr;
        *ur = *vr * fr;
        *qr = wfr * fr;
    }
    let mut ll = vec![0.0; na * na];
    let mut ua = vec![0.0; mp];
    for (a, la) in lobes.chunks_exact(mp).enumerate() {
        for ((x, &ur), &lr) in ua.iter_mut().zip(&u).zip(la) {
            *x = ur * lr;
        }
        for (b, lb) in lobes.chunks_exact(mp).enumerate().skip(a) {
            let g = dot_lanes(&ua, lb);
            ll[a * na + b] = g;
            ll[b * na + a] = g;
        }
    }
    let l = lobes.chunks_exact(mp).map(|la| dot_lanes(&v, la)).collect();
    let h = lobes.chunks_exact(mp).map(|la| dot_lanes(&q, la)).collect();
    (ll, l, h)
}

/// `rows` (each `m` long) one after another, each padded with zeros to whole blocks of
/// [`LANES`] (0·0 adds nothing to a [`dot_lanes`] sum).
fn padded_rows<'a>(rows: impl IntoIterator<Item = &'a [f64]>, m: usize) -> Vec<f64> {
    let mp = m.next_multiple_of(LANES);
    let mut out = Vec::new();
    for r in rows {
        out.extend_from_slice(&r[..m]);
        out.resize(out.len() + mp - m, 0.0);
    }
    out
}

/// Σ x·y over whole blocks of [`LANES`] (a tail shorter than a block is left out), in
/// [`LANES`] partial sums added in lane order: the same value on every instruction set. One
/// loop, one sum and no tail, so LLVM keeps the sum in a register (with a zero-padded tail
/// chained on, or several sums in one loop, it did not always, and was slower).
#[inline(always)]
fn dot_lanes(x: &[f64], y: &[f64]) -> f64 {
    let mut acc = [0.0f64; LANES];
    for (x, y) in x.chunks_exact(LANES).zip(y.chunks_exact(LANES)) {
        for l in 0..LANES {
            acc[l] += x[l] * y[l];
        }
    }
    acc.iter().sum()
}

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

/// The linear coefficients that minimise ½ cᵀGc − hᵀc (the weighted linear least squares of
/// [`gram_sums`]) with the held coefficients (`free` false) at their values in `c` and the
/// free ones ≥ 0 ([`nnls`]); at most [`LINEAR_MAX`] coefficients.
pub(super) fn linear_solve(g: &[f64], h: &[f64], c: &[f64], free: &[bool]) -> Vec<f64> {
    let k = c.len();
    assert!(
        k <= LINEAR_MAX,
        "linear_solve: {k} unknowns, at most {LINEAR_MAX}"
    );
    // y = f − Σ_held c_j s_j: the right-hand side loses the held columns.
    let mut y = [0.0; LINEAR_MAX];
    for (i, yi) in y[..k].iter_mut().enumerate() {
        *yi = h[i]
            - (0..k)
                .filter(|&j| !free[j])
                .map(|j| g[i * k + j] * c[j])
                .sum::<f64>();
    }
    let x = nnls(g, &y[..k], free);
    (0..k).map(|i| if free[i] { x[i] } else { c[i] }).collect()
}

/// The most unknowns of [`nnls`] and [`linear_solve`]: every linear coefficient is a model
/// parameter. Their work space is on the stack (the initialisation solves one system per grid
/// point it visits, hundreds per fit).
const LINEAR_MAX: usize = crate::model::MAX_PARAMS;

/// Non-negative least squares from the normal equations: minimise ½ xᵀAx − bᵀx over x ≥ 0 (A
/// k × k row-major, symmetric positive semi-definite; k at most [`LINEAR_MAX`]), an unknown
/// that is not `free` held at 0. The active-set method of Lawson & Hanson (1974, "Solving
/// Least Squares Problems", ch. 23, algorithm NNLS), on the normal equations: unknowns enter
/// the passive set by the largest gradient and leave it by interpolating back to
/// feasibility. An unknown whose diagonal is 0 (a basis that vanishes on every row) stays 0.
pub(super) fn nnls(a: &[f64], b: &[f64], free: &[bool]) -> Vec<f64> {
    let k = b.len();
    assert!(k <= LINEAR_MAX, "nnls: {k} unknowns, at most {LINEAR_MAX}");
    let mut x = [0.0; LINEAR_MAX];
    let mut usable = [false; LINEAR_MAX];
    let mut diag = [1.0; LINEAR_MAX];
    for i in 0..k {
        usable[i] = free[i] && a[i * k + i] > 0.0;
        if usable[i] {
            diag[i] = a[i * k + i];
        }
    }
    let mut passive = [false; LINEAR_MAX];
    // The gradient test scale: a tolerance relative to the problem's own size.
    let scale = (0..k)
        .filter(|&i| usable[i])
        .map(|i| b[i].abs() + a[i * k + i].sqrt())
        .fold(0.0, f64::max);
    let tol = 1e-12 * scale.max(1e-300);
    let mut neg = [0.0; LINEAR_MAX];
    for (n, v) in neg.iter_mut().zip(b) {
        *n = -v;
    }
    // The solution of the equations restricted to the passive set (zero elsewhere).
    let solve = |passive: &[bool; LINEAR_MAX]| {
        let held = passive.map(|p| !p);
        lsq::damped_solve(a, &neg[..k], &diag[..k], 0.0, &held[..k])
    };
    for _ in 0..3 * k + 1 {
        // w = b − A x: the descent direction of each unknown.
        let mut w = [0.0; LINEAR_MAX];
        for (i, wi) in w[..k].iter_mut().enumerate() {
            *wi = b[i] - (0..k).map(|j| a[i * k + j] * x[j]).sum::<f64>();
        }
        let Some(j) = (0..k)
            .filter(|&i| usable[i] && !passive[i] && w[i] > tol)
            .max_by(|&p, &q| w[p].total_cmp(&w[q]))
        else {
            break;
        };
        passive[j] = true;
        let mut progressed = false;
        for _ in 0..k + 1 {
            let Some(z) = solve(&passive) else {
                break;
            };
            if (0..k).all(|i| !passive[i] || z[i] > 0.0) {
                x[..k].copy_from_slice(&z);
                progressed = true;
                break;
            }
            // Step from x towards z until the first passive unknown reaches 0.
            let alpha = (0..k)
                .filter(|&i| passive[i] && z[i] <= 0.0)
                .map(|i| x[i] / (x[i] - z[i]))
                .fold(1.0, f64::min);
            for i in 0..k {
                x[i] += alpha * (z[i] - x[i]);
                if passive[i] && x[i] <= 1e-15 * x[i].abs().max(1.0) {
                    x[i] = 0.0;
                    passive[i] = false;
                }
            }
        }
        if !progressed {
            break;
        }
    }
    x[..k].iter().map(|v| v.max(0.0)).collect()
}

/// The linearised cost ½ Σ w (a·s + b − f)² of one lobe's basis s with coefficients
/// x = (a, b) from the sums alone: `g` = [Σws², Σws, Σw], `h` = [Σwfs, Σwf], `ff` = Σwf²
/// (expanded: ½ (a²Σws² + 2abΣws + b²Σw + Σwf²) − aΣwfs − bΣwf).
pub(super) fn linearised_cost(g: [f64; 3], h: [f64; 2], ff: f64, [a, b]: [f64; 2]) -> f64 {
    0.5 * (g[0] * a * a + 2.0 * g[1] * a * b + g[2] * b * b + ff) - (h[0] * a + h[1] * b)
}

/// Gauss–Newton steps on the linear coefficients at the grid points that are refined.
pub(super) const LINEAR_STEPS: usize = 3;

/// Grid points whose (ps, pd) are refined in the declared loss: the best this many by the
/// first score, and as many of the grid's local minima.
pub(super) const REFINED_POINTS: usize = 8;

/// Rows per channel the global initialisation scores its grid on.
pub(super) const INIT_ROWS: usize = 500;

/// How many candidates of distinct basins the global initialisation hands to the local method.
pub(super) const CANDIDATES: usize = 4;

/// A grid minimum whose score is more than this many times the best minimum's is not handed
/// to the local method: its basin ends far above the best. Measured on the 14 bundled and
/// test files and the scipy benchmark's 10,000 synthetic samples, 9 models each (2,484
/// searches, 3,265 candidates after the first): no candidate scored above 15.2 times the
/// best ended within [`super::solve::CONTENDER_RATIO`] of the best cost (the only ones the
/// polish considers), so 30 leaves a factor of 2. It drops 192 of them (2,961 local
/// iterations) and no fit of those files changes. The one it drops on the synthetic
/// dielectric (n = 1.8) is the metal basin at the top of n's grid (F ≈ 1), 45 times the
/// best, 12 iterations where the best basin takes 3.
pub(super) const FAR_BASIN: f64 = 30.0;

/// Grids of more points than this (to score) are searched coarse to fine ([`search_grid`]):
/// Torrance–Sparrow's n × c (17 × 19, 323 points), GGX–Smith's α × n, ABC's n × b × c; except
/// two lobes' (ggx-smith-2's half grid α1 ≤ α2, 3,230 points).
pub(super) const COARSE_ABOVE: usize = 256;

/// Grid points scored in one batch below which the batch runs on the calling thread.
pub(super) const PARALLEL_POINTS: usize = 32;

/// Local minima of the coarse grid whose neighbourhoods are searched on the full grid.
pub(super) const COARSE_SEEDS: usize = 8;

/// The largest starting grid: beyond it the longest axis keeps every other value
/// ([`grid_points`]). Two shapes and an index (α1 × α2 × n, 19 × 19 × 17) stay whole.
pub(super) const GRID_LIMIT: usize = 8192;

/// Variable projection over a grid of the nonlinear parameters that spans each one's whole
/// admissible range ([`crate::model::ParamSpec::grid`]): at each grid point the free linear
/// parameters of each channel (every lobe's ps, and pd) come from a weighted non-negative
/// linear least-squares solve ([`nnls`]; weights that linearise the loss at the data); each
/// point is then scored on the *declared* loss at those values, so a basin ranks by the cost
/// the fit minimises, not by its linearisation. (One lobe with one shape parameter and n
/// free on one channel, Torrance–Sparrow D1–D3 or GGX–Smith: the search visits the grid by
/// the linearised cost, [`linearised_cost`], and only the points it then refines are scored
/// on the declared loss, from which the candidates come; on every bundled file the same
/// minima.) The grid's local minima (distinct basins) are
/// returned best first, at most [`CANDIDATES`] and none scored above [`FAR_BASIN`] times the
/// best, as solver variables. The grid is scored on a subsample of `full`'s rows
/// ([`INIT_ROWS`] per channel; `full` may itself be the local stage's subsample, whose
/// largest values are those of every row).
pub(super) fn global_init(
    full: &BrdfProblem,
    specs: &[&ParamSpec],
    opts: &FitOptions,
) -> Vec<Vec<f64>> {
    let p = full.subsample(INIT_ROWS);

    let nfree = p.transforms.len();
    let kind = opts.kind;
    let model_specs = kind.params(opts.dist);
    // The linear coefficients: each lobe's ps, then pd (as pd/π, its basis being 1).
    let ips: Vec<usize> = (0..model_specs.len())
        .filter(|&i| model_specs[i].role == Role::Specular)
        .collect();
    let ipd = kind
        .index_of(opts.dist, Role::Diffuse)
        .expect("every model has pd");
    let k = ips.len() + 1;
    let (nonlinear, dims, points) = grid_points(specs, nfree);
    let (fdata, wdata) = linearised_data(&p, opts.loss);
    let wf: Vec<f64> = wdata.iter().zip(&fdata).map(|(w, f)| w * f).collect();
    // Per channel, the sums that do not depend on the grid point.
    let free_sums: Vec<[f64; 3]> = (0..p.layout.len())
        .map(|c| {
            let rows = p.starts[c]..p.starts[c + 1];
            basis_free_sums(&wdata[rows.clone()], &fdata[rows])
        })
        .collect();
    // Torrance–Sparrow on one channel with n and every shape parameter free: every point's
    // sums at once.
    let shapes = model_specs.iter().filter(|s| s.role == Role::Shape).count();
    let separable = (kind == ModelKind::TorranceSparrow
        && p.layout.len() == 1
        && ips.len() == 1
        && nonlinear.len() == 1 + shapes
        && specs[nonlinear[0].0].role == Role::Index
        && nonlinear[1..]
            .iter()
            .all(|(k, _)| specs[*k].role == Role::Shape))
    .then(|| {
        // The shape grid points, row-major as in `points` (n is the slowest axis).
        let per_n = points.len() / nonlinear[0].1.len();
        let cs: Vec<Vec<f64>> = (0..per_n).map(|i| points.get(i)[1..].to_vec()).collect();
        let f = TsFactors::new(&p.rows, opts.dist, &nonlinear[0].1, &cs);
        let table = f.grid_sums(&wdata, &wf);
        (f, table)
    });
    // GGX–Smith (one lobe or two): the lobes and Fresnel factors at the grid's α and n, once.
    let ggx = matches!(kind, ModelKind::GgxSmith | ModelKind::GgxSmith2);
    let lobe_tables = ggx.then(|| {
        let grid = |role: Role| -> Vec<f64> {
            nonlinear
                .iter()
                .filter(|(k, _)| specs[*k].role == role)
                .flat_map(|(_, g)| g.iter().copied())
                .collect()
        };
        LobeTables::new(&p.rows, &grid(Role::Shape), &grid(Role::Index))
    });
    // One GGX lobe on one channel with α and n free: every point's sums at once (α is the
    // slower axis, as declared).
    let separable = separable.or_else(|| {
        let t = lobe_tables.as_ref()?;
        (kind == ModelKind::GgxSmith
            && p.layout.len() == 1
            && nonlinear.len() == 2
            && specs[nonlinear[0].0].role == Role::Shape
            && specs[nonlinear[1].0].role == Role::Index)
            .then(|| {
                let f = TsFactors::ggx(t, &nonlinear[0].1, &nonlinear[1].1)?;
                let table = f.grid_sums(&wdata, &wf);
                Some((f, table))
            })
            .flatten()
    });
    // Two GGX lobes on one channel with α1, α2 and n free: every point's Gram sums at once.
    let two_lobes = lobe_tables.as_ref().and_then(|t| {
        let roles: Vec<Role> = nonlinear.iter().map(|(k, _)| specs[*k].role).collect();
        (kind == ModelKind::GgxSmith2
            && p.layout.len() == 1
            && roles == [Role::Shape, Role::Shape, Role::Index]
            && nonlinear[0].1 == nonlinear[1].1)
            .then(|| TwoLobeGram::new(t, &nonlinear[0].1, &nonlinear[2].1, &wdata, &wf))
            .flatten()
    });
    let (ones, zeros) = (vec![1.0; p.rows.len()], vec![0.0; p.rows.len()]);
    // One lobe on one channel with one shape parameter and n free (Torrance–Sparrow D1–D3,
    // GGX–Smith): the grid is searched (coarse to fine) by the linearised cost (below). Not
    // ABC, whose two shape parameters leave flat valleys where the two searches end at
    // different points (acryl_blue, 540–570 nm: up to 5e-6 of the cost higher).
    let linearised = separable.is_some()
        && !(kind == ModelKind::TorranceSparrow && opts.dist == Distribution::Abc);
    let score_point = |index: usize, steps: usize| {
        let pt = points.get(index);
        // Natural values of all free variables at this grid point (linear ones solved).
        let mut theta = vec![f64::NAN; nfree];
        let mut score = 0.0;
        for ((k, _), v) in nonlinear.iter().zip(pt) {
            theta[*k] = *v;
        }
        for c in 0..p.layout.len() {
            let slots = p.layout[c];
            let rows = p.starts[c]..p.starts[c + 1];
            let n = rows.len();
            let mut vals = [0.0; crate::model::MAX_PARAMS];
            for j in 0..model_specs.len() {
                vals[j] = match slots[j] {
                    Slot::Fixed(v) => v,
                    Slot::Free(k) => theta[k],
                };
            }
            let (held, free) = linear_coefficients(&slots, &ips, ipd);
            for &i in ips.iter().chain([&ipd]) {
                vals[i] = 0.0;
            }
            // The specular basis of lobe i: the model with that ps = 1 and every other linear
            // parameter 0.
            let lobe = |i: usize| {
                let mut v = vals;
                v[i] = 1.0;
                problem::brdf_values(&full.template.with_params(&v), &p.rows, rows.clone())
            };
            let (cost, x) = if ips.len() <= 1 {
                // One lobe (or none): the lane kernels, coefficients (ps, pd/π).
                let owned: Vec<f64>;
                let basis = match (&separable, ips.first()) {
                    (Some((f, _)), _) => f.basis(index),
                    (None, Some(&i)) => {
                        owned = lobe(i);
                        Basis {
                            a: &owned,
                            b: &ones[..n],
                        }
                    }
                    (None, None) => Basis {
                        a: &zeros[..n],
                        b: &ones[..n],
                    },
                };
                let [ss, s1, sf] = match &separable {
                    Some((_, table)) => table[index],
                    // Here the basis is its first factor (the second is ones).
                    None => basis_sums(basis.a, &wdata[rows.clone()], &wf[rows.clone()]),
                };
                let [w1, f1, ff] = free_sums[c];
                let (start, free2) = if ips.is_empty() {
                    ([0.0, held[0]], [false, free[0]])
                } else {
                    ([held[0], held[1]], [free[0], free[1]])
                };
                let x0 = linear_solve(&[ss, s1, s1, w1], &[sf, f1], &start, &free2);
                let pass = |x: &[f64]| {
                    let (cost, jtj, jtr) =
                        linear_pass(&p.rows, rows.clone(), basis, (x[0], x[1]), opts.loss);
                    (cost, vec![jtj[0], jtj[1], jtj[1], jtj[2]], jtr.to_vec())
                };
                let cost = |x: &[f64]| match opts.loss {
                    Loss::Log => {
                        let r = rows.clone();
                        linear_cost_log(
                            &p.rows.nl[r.clone()],
                            &p.rows.target[r.clone()],
                            weights(&p.rows, r),
                            basis,
                            (x[0], x[1]),
                        )
                    }
                    Loss::Linear | Loss::Pixel => pass(x).0,
                };
                let (cost, x) = if steps == 0 && linearised {
                    // The search's score: the linearised cost ½ Σ w (s·x − f)² at the linear
                    // solve's (ps, pd), from the grid's sums with no pass over the rows; only
                    // the points then refined are scored on the declared loss (the linear
                    // loss: the same cost). The weights linearise the declared loss at the
                    // data, so its basins lie low in the linearised cost (as for two lobes,
                    // [`two_lobe_prescreen`]).
                    let q = linearised_cost([ss, s1, w1], [sf, f1], ff, [x0[0], x0[1]]);
                    (q, x0)
                } else {
                    refine_linear(&x0, &free2, opts.loss, steps, pass, cost)
                };
                let x = if ips.is_empty() { vec![x[1]] } else { x };
                (cost, x)
            } else {
                // Several lobes: a basis each, and a row loop. GGX–Smith's two lobes come from the
                // tables (lobe i's α is the parameter before its ps), others from the model.
                let tabled = |i: usize| {
                    let t = lobe_tables.as_ref()?;
                    let n_index = kind.index_of(opts.dist, Role::Index)?;
                    t.basis(vals[i - 1], vals[n_index], rows.clone())
                };
                let owned: Vec<Option<Vec<f64>>> = ips
                    .iter()
                    .map(|&i| tabled(i).is_none().then(|| lobe(i)))
                    .collect();
                let mut bases: Vec<Basis> = ips
                    .iter()
                    .zip(&owned)
                    .map(|(&i, s)| match s {
                        Some(s) => Basis {
                            a: s,
                            b: &ones[..n],
                        },
                        None => tabled(i).expect("a tabulated lobe"),
                    })
                    .collect();
                bases.push(Basis {
                    a: &ones[..n],
                    b: &ones[..n],
                });
                let (g, h) = match &two_lobes {
                    Some(t) => {
                        let (d1, d2) = (dims[1] * dims[2], dims[2]);
                        t.gram(index / d1, (index / d2) % dims[1], index % d2)
                    }
                    None => gram_sums(&bases, &wdata[rows.clone()], &wf[rows.clone()]),
                };
                let x0 = linear_solve(&g, &h, &held, &free);
                let pass =
                    |x: &[f64]| linear_pass_many(&p.rows, rows.clone(), &bases, x, opts.loss);
                let cost = |x: &[f64]| match opts.loss {
                    Loss::Log => {
                        let r = rows.clone();
                        linear_cost_log_many(
                            &p.rows.nl[r.clone()],
                            &p.rows.target[r.clone()],
                            weights(&p.rows, r),
                            &bases[..k - 1],
                            &x[..k - 1],
                            x[k - 1],
                        )
                    }
                    Loss::Linear | Loss::Pixel => pass(x).0,
                };
                refine_linear(&x0, &free, opts.loss, steps, pass, cost)
            };
            score += cost;
            for (j, &i) in ips.iter().chain([&ipd]).enumerate() {
                if let Slot::Free(v) = slots[i] {
                    theta[v] = if j == k - 1 {
                        x[j] * std::f64::consts::PI
                    } else {
                        x[j]
                    };
                }
            }
        }
        let x: Vec<f64> = (0..nfree)
            .map(|k| p.transforms[k].invert(theta[k]))
            .collect();
        let score = if score.is_finite() {
            score
        } else {
            f64::INFINITY
        };
        (score, x)
    };
    // Two lobes of the same form with both coefficients free: the point (α1, α2) is the point
    // (α2, α1) with the lobes swapped, so only α1 ≤ α2 is scored.
    let strides: Vec<usize> = (0..dims.len())
        .map(|d| dims[d + 1..].iter().product())
        .collect();
    let mirror = (kind == ModelKind::GgxSmith2)
        .then(|| {
            let axes: Vec<usize> = (0..nonlinear.len())
                .filter(|&d| specs[nonlinear[d].0].role == Role::Shape)
                .collect();
            let both_free = p
                .layout
                .iter()
                .all(|slots| ips.iter().all(|&i| matches!(slots[i], Slot::Free(_))));
            (axes.len() == 2 && both_free && nonlinear[axes[0]].1 == nonlinear[axes[1]].1)
                .then(|| (axes[0], axes[1]))
        })
        .flatten();
    let ordered = |i: usize| {
        mirror.is_none_or(|(d1, d2)| (i / strides[d1]) % dims[d1] <= (i / strides[d2]) % dims[d2])
    };
    // Two GGX lobes: the linearised cost of every ordered point comes from its Gram sums with
    // no pass over the rows, and only the best [`TWO_LOBE_KEEP`] of them by it are scored on
    // the declared loss (a pass over the rows each, most of the grid's cost).
    let kept = two_lobes
        .as_ref()
        .filter(|_| mirror.is_some())
        .map(|t| two_lobe_prescreen(t, &p.layout[0], &ips, ipd, &dims, ordered));
    let admissible = |i: usize| ordered(i) && kept.as_ref().is_none_or(|kept| kept[i]);
    // The points the search asks for, scored at the linear solve's (ps, pd) (on the declared
    // loss, an upper bound of its best score; or the linearised cost, `linearised`), then the
    // promising ones with (ps, pd) minimising the declared loss.
    use rayon::prelude::*;
    let mut scored: Vec<(f64, Vec<f64>)> = vec![(f64::INFINITY, Vec::new()); points.len()];
    // Two lobes: the whole (half) grid, as a lobe a coarse step narrower than its neighbours
    // can carry the basin (vch_golden_yellow b: α1 0.0076 with ps1 9e-4 beside α2 0.12, which
    // coarse to fine missed by 2 %).
    let coarse_above = if mirror.is_some() {
        usize::MAX
    } else {
        COARSE_ABOVE
    };
    let (first, found) = search_grid(&dims, coarse_above, admissible, |idx| {
        // A batch of a few points (a box of the fine search) is not worth waking the pool.
        let s: Vec<(f64, Vec<f64>)> = if idx.len() >= PARALLEL_POINTS {
            idx.par_iter().map(|&i| score_point(i, 0)).collect()
        } else {
            idx.iter().map(|&i| score_point(i, 0)).collect()
        };
        let out = s.iter().map(|s| s.0).collect();
        for (&i, s) in idx.iter().zip(s) {
            scored[i] = s;
        }
        out
    });
    // The grid's local minima by `scores`, best first: searched coarse to fine, those found.
    let minima = |scores: &[f64], limit: usize| match &found {
        None => grid_minima(scores, &dims, limit),
        Some(found) => {
            let mut m = found.clone();
            m.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]).then(a.cmp(&b)));
            m.truncate(limit);
            m
        }
    };
    let mut refine = minima(&first, REFINED_POINTS);
    let mut order: Vec<usize> = (0..first.len()).filter(|&i| first[i].is_finite()).collect();
    order.sort_by(|&a, &b| first[a].total_cmp(&first[b]).then(a.cmp(&b)));
    refine.extend(order.into_iter().take(REFINED_POINTS));
    refine.sort_unstable();
    refine.dedup();
    let better: Vec<(usize, (f64, Vec<f64>))> = refine
        .par_iter()
        .map(|&i| (i, score_point(i, LINEAR_STEPS)))
        .collect();
    // Searched by the linearised cost: only the refined points carry the declared loss.
    if linearised {
        for s in &mut scored {
            s.0 = f64::INFINITY;
        }
    }
    for (i, s) in better {
        if s.0 <= scored[i].0 {
            scored[i] = s;
        }
    }
    let scores: Vec<f64> = scored.iter().map(|s| s.0).collect();
    let found = minima(&scores, CANDIDATES);
    let best = found.first().map_or(f64::INFINITY, |&i| scores[i]);
    found
        .into_iter()
        .filter(|&i| scores[i] <= FAR_BASIN * best)
        .map(|i| scored[i].1.clone())
        .collect()
}

/// A channel's linear coefficients (each lobe's ps at model indices `ips`, then pd/π at
/// `ipd`) from its `slots`: each one's value where held (0 where free; pd divided by π, its
/// basis being 1) and whether it is free.
fn linear_coefficients(slots: &[Slot], ips: &[usize], ipd: usize) -> (Vec<f64>, Vec<bool>) {
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

/// The share of a two-lobe grid's ordered points (α1 ≤ α2) scored on the declared loss: the
/// best by the linearised cost (see [`two_lobe_prescreen`]). A tenth ends every
/// ggx-smith-2 fit of the bundled files (206 channels) at the cost a quarter gave, to 1e-9;
/// a twentieth ends one (mystique 500 nm) 1.3 % higher.
pub(super) const TWO_LOBE_KEEP: f64 = 0.1;

/// Which points of a two-lobe grid (α1 × α2 × n, row-major; `ordered` the points with
/// α1 ≤ α2) are scored on the declared loss: the best [`TWO_LOBE_KEEP`] of the ordered ones
/// by the linearised cost ½ cᵀGc − hᵀc at the linear solve's coefficients c, from the Gram
/// sums `t` alone (the weights linearise the declared loss at the data, so a basin of the
/// declared cost lies low in it; the quantity the linear solve minimises, up to a constant).
fn two_lobe_prescreen(
    t: &TwoLobeGram,
    slots: &[Slot],
    ips: &[usize],
    ipd: usize,
    dims: &[usize],
    ordered: impl Fn(usize) -> bool + Sync,
) -> Vec<bool> {
    let (held, free) = linear_coefficients(slots, ips, ipd);
    let lin = two_lobe_linearised(t, &held, &free, dims, &ordered);
    let total = lin.len();
    let mut finite: Vec<f64> = lin.iter().copied().filter(|v| v.is_finite()).collect();
    let n = ((finite.len() as f64 * TWO_LOBE_KEEP).ceil() as usize).min(finite.len());
    if n == 0 {
        return (0..total).map(&ordered).collect();
    }
    let limit = *finite.select_nth_unstable_by(n - 1, f64::total_cmp).1;
    lin.iter().map(|&v| v <= limit).collect()
}

/// The linearised cost ½ cᵀGc − hᵀc at the linear solve's coefficients c (`held` values
/// where not `free`) at every point of a two-lobe grid (α1 × α2 × n, row-major), from the
/// Gram sums `t`; +∞ where not `ordered` or not finite.
fn two_lobe_linearised(
    t: &TwoLobeGram,
    held: &[f64],
    free: &[bool],
    dims: &[usize],
    ordered: impl Fn(usize) -> bool + Sync,
) -> Vec<f64> {
    let k = held.len();
    let (d1, d2) = (dims[1] * dims[2], dims[2]);
    let total: usize = dims.iter().product();
    // The points in parallel (each value is the same on any number of threads).
    use rayon::prelude::*;
    (0..total)
        .into_par_iter()
        .map(|i| {
            if !ordered(i) {
                return f64::INFINITY;
            }
            let (g, h) = t.gram3(i / d1, (i / d2) % dims[1], i % d2);
            // Every coefficient free: the interior minimum where it is positive (most
            // points), else face by face ([`nnls3`]); some held: the active-set solve.
            let interior = free.iter().all(|&f| f).then(|| positive_solve3(&g, &h));
            let c = match interior {
                Some(Some(c)) => c.to_vec(),
                Some(None) => nnls3(&g, &h).to_vec(),
                None => linear_solve(&g, &h, held, free),
            };
            let mut q = 0.0;
            for a in 0..k {
                q -= h[a] * c[a];
                for b in 0..k {
                    q += 0.5 * c[a] * g[a * k + b] * c[b];
                }
            }
            if q.is_finite() { q } else { f64::INFINITY }
        })
        .collect()
}

/// The minimiser of ½ cᵀGc − hᵀc for a symmetric 3 × 3 `g` (row-major) by Cholesky, when `g`
/// is well inside positive definite (each pivot above 1e-10 of its diagonal) and every
/// coefficient is positive: then it is also [`nnls`]'s answer, as the minimum of a strictly
/// convex quadratic over c ≥ 0 is its interior minimum when that is feasible.
pub(super) fn positive_solve3(g: &[f64; 9], h: &[f64; 3]) -> Option<[f64; 3]> {
    let pivot = |v: f64, diag: f64| (v > 1e-10 * diag).then(|| v.sqrt());
    let l00 = pivot(g[0], g[0])?;
    let (l10, l20) = (g[3] / l00, g[6] / l00);
    let l11 = pivot(g[4] - l10 * l10, g[4])?;
    let l21 = (g[7] - l20 * l10) / l11;
    let l22 = pivot(g[8] - l20 * l20 - l21 * l21, g[8])?;
    let y0 = h[0] / l00;
    let y1 = (h[1] - l10 * y0) / l11;
    let y2 = (h[2] - l20 * y0 - l21 * y1) / l22;
    let c2 = y2 / l22;
    let c1 = (y1 - l21 * c2) / l11;
    let c0 = (y0 - l10 * c1 - l20 * c2) / l00;
    let c = [c0, c1, c2];
    c.iter().all(|v| *v > 0.0 && v.is_finite()).then_some(c)
}

/// The minimiser of ½ cᵀGc − hᵀc over c ≥ 0 for a symmetric 3 × 3 `g` (row-major), by its
/// faces: the minimum of a strictly convex quadratic over the orthant is the interior minimum
/// of the face its positive coefficients span, so it is the lowest of the faces' interior
/// minima that are feasible (each coefficient of the face positive), or 0. A face whose
/// matrix is not well inside positive definite (a pivot at most 1e-10 of its diagonal) is
/// passed over. [`nnls`]'s answer without its allocations, for [`two_lobe_linearised`]'s
/// points where [`positive_solve3`] declines.
pub(super) fn nnls3(g: &[f64; 9], h: &[f64; 3]) -> [f64; 3] {
    let mut best = ([0.0; 3], 0.0);
    let mut consider = |c: [f64; 3]| {
        if c.iter().all(|v| *v >= 0.0 && v.is_finite()) {
            // At a face's interior minimum G_SS c_S = h_S, so the value is −½ hᵀc.
            let q = -0.5 * (h[0] * c[0] + h[1] * c[1] + h[2] * c[2]);
            if q < best.1 {
                best = (c, q);
            }
        }
    };
    for i in 0..3 {
        if g[4 * i] > 0.0 && h[i] > 0.0 {
            let mut c = [0.0; 3];
            c[i] = h[i] / g[4 * i];
            consider(c);
        }
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let (a, b, d) = (g[4 * i], g[3 * i + j], g[4 * j]);
        let det = a * d - b * b;
        if a > 0.0 && d > 0.0 && det > 1e-10 * a * d {
            let (ci, cj) = ((h[i] * d - h[j] * b) / det, (h[j] * a - h[i] * b) / det);
            if ci > 0.0 && cj > 0.0 {
                let mut c = [0.0; 3];
                (c[i], c[j]) = (ci, cj);
                consider(c);
            }
        }
    }
    if let Some(c) = positive_solve3(g, h) {
        consider(c);
    }
    best.0
}

/// The starting grid of the nonlinear free variables: which variables have a grid, the grid
/// sizes, and every grid point (row-major). While the product of their sizes exceeds
/// [`GRID_LIMIT`] (a joint fit with per-channel shape parameters) the longest grid (the first
/// of equals) keeps every other value.
pub(super) fn grid_points(specs: &[&ParamSpec], nfree: usize) -> GridPoints {
    let mut nonlinear: Vec<(usize, Vec<f64>)> = (0..nfree)
        .filter_map(|k| {
            let g = specs[k].grid_values();
            (!g.is_empty()).then_some((k, g))
        })
        .collect();
    // The longest grid is halved first (the first of equals), one at a time.
    while nonlinear.iter().map(|(_, g)| g.len()).product::<usize>() > GRID_LIMIT {
        let longest = (0..nonlinear.len())
            .max_by(|&a, &b| {
                nonlinear[a]
                    .1
                    .len()
                    .cmp(&nonlinear[b].1.len())
                    .then(b.cmp(&a))
            })
            .expect("a product over the limit has a grid");
        let g = &mut nonlinear[longest].1;
        *g = g.iter().step_by(2).copied().collect();
    }
    let dims: Vec<usize> = nonlinear.iter().map(|(_, g)| g.len()).collect();
    let width = nonlinear.len();
    let total: usize = dims.iter().product();
    let mut values = Vec::with_capacity(total * width);
    for i in 0..total {
        // Row-major: the last variable varies fastest.
        let mut rest = i;
        let start = values.len();
        values.resize(start + width, 0.0);
        for (d, (_, g)) in nonlinear.iter().enumerate().rev() {
            values[start + d] = g[rest % dims[d]];
            rest /= dims[d];
        }
    }
    (nonlinear, dims, Points { width, values })
}

/// The points of a grid, row-major, in one buffer (a grid of up to [`GRID_LIMIT`] points
/// allocates once, not once per point).
pub(super) struct Points {
    /// Values per point.
    width: usize,
    /// Every point's values, point after point.
    values: Vec<f64>,
}

impl Points {
    /// The number of points.
    pub(super) fn len(&self) -> usize {
        self.values.len().checked_div(self.width).unwrap_or(1)
    }

    /// Point `i`'s values.
    pub(super) fn get(&self, i: usize) -> &[f64] {
        &self.values[i * self.width..(i + 1) * self.width]
    }
}

/// Gridded variables with their values, the grid sizes, and the grid points.
pub(super) type GridPoints = (Vec<(usize, Vec<f64>)>, Vec<usize>, Points);

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

/// The local minima of a score tabulated on a grid (row-major over `dims`; a point is a
/// minimum when no neighbour along any axis scores lower), best first, at most `limit`; if
/// there are fewer than two, the best other point not next to a kept one is added.
pub(super) fn grid_minima(scores: &[f64], dims: &[usize], limit: usize) -> Vec<usize> {
    let strides: Vec<usize> = (0..dims.len())
        .map(|d| dims[d + 1..].iter().product())
        .collect();
    let coord = |i: usize, d: usize| (i / strides[d]) % dims[d];
    let neighbours = |i: usize| {
        let mut v = Vec::new();
        for d in 0..dims.len() {
            let c = coord(i, d);
            if c > 0 {
                v.push(i - strides[d]);
            }
            if c + 1 < dims[d] {
                v.push(i + strides[d]);
            }
        }
        v
    };
    let mut order: Vec<usize> = (0..scores.len())
        .filter(|&i| scores[i].is_finite())
        .collect();
    order.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]).then(a.cmp(&b)));
    let is_min = |i: usize| neighbours(i).iter().all(|&j| scores[i] <= scores[j]);
    let mut kept: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&i| is_min(i))
        .take(limit)
        .collect();
    for &i in &order {
        if kept.len() >= limit.min(2) {
            break;
        }
        let near = kept
            .iter()
            .any(|&k| (0..dims.len()).all(|d| coord(i, d).abs_diff(coord(k, d)) <= 1));
        if !near {
            kept.push(i);
        }
    }
    kept
}

/// The points of the box of half-width `radius` (in grid steps, clipped at the edges) around
/// point `i` of a grid (row-major over `dims`), `i` included.
pub(super) fn grid_box(i: usize, radius: usize, dims: &[usize]) -> Vec<usize> {
    let mut out = vec![0usize];
    let mut stride = 1;
    for d in (0..dims.len()).rev() {
        let c = (i / stride) % dims[d];
        let (lo, hi) = (c.saturating_sub(radius), (c + radius).min(dims[d] - 1));
        out = out
            .iter()
            .flat_map(|&o| (lo..=hi).map(move |v| o + v * stride))
            .collect();
        stride *= dims[d];
    }
    out.sort_unstable();
    out
}

/// Search a grid (row-major over `dims`) for its local minima, scoring only the points that
/// `admissible` admits, through `score` (the scores of the points asked, in that order).
/// Up to `coarse_above` admissible points, every one is scored. Beyond, coarse to fine:
/// the coarse grid (every other value of each axis, and its last) is scored; around each of
/// its best [`COARSE_SEEDS`] local minima the box of half-width 2 (one coarse step) is scored
/// on the full grid, and from the box's lowest point a descent scores the box of half-width 1
/// around the current point and moves to its lowest point until the current point is the
/// lowest of its box, a minimum of the full grid. Returns every point's score (+∞ where not
/// scored) and, coarse to fine, the minima found, best first: the descents' ends, then the
/// coarse grid's other local minima (basins not searched further, above every searched one).
pub(super) fn search_grid(
    dims: &[usize],
    coarse_above: usize,
    admissible: impl Fn(usize) -> bool,
    mut score: impl FnMut(&[usize]) -> Vec<f64>,
) -> (Vec<f64>, Option<Vec<usize>>) {
    let total: usize = dims.iter().product();
    let mut scores = vec![f64::INFINITY; total];
    let mut done = vec![false; total];
    let mut run = |idx: Vec<usize>, scores: &mut Vec<f64>, done: &mut Vec<bool>| {
        let idx: Vec<usize> = idx
            .into_iter()
            .filter(|&i| !done[i] && admissible(i))
            .collect();
        for (&i, s) in idx.iter().zip(score(&idx)) {
            scores[i] = s;
            done[i] = true;
        }
    };
    let all: Vec<usize> = (0..total).filter(|&i| admissible(i)).collect();
    if all.len() <= coarse_above {
        run(all, &mut scores, &mut done);
        return (scores, None);
    }
    // The coarse grid: coarse coordinate k is fine coordinate min(2k, last).
    let cdims: Vec<usize> = dims.iter().map(|&n| n / 2 + 1).collect();
    let fine = |ci: usize| {
        let (mut i, mut cs, mut fs) = (0, 1, 1);
        for d in (0..dims.len()).rev() {
            let k = (ci / cs) % cdims[d];
            i += (2 * k).min(dims[d] - 1) * fs;
            cs *= cdims[d];
            fs *= dims[d];
        }
        i
    };
    let coarse: Vec<usize> = (0..cdims.iter().product()).map(fine).collect();
    run(coarse.clone(), &mut scores, &mut done);
    let cscores: Vec<f64> = coarse.iter().map(|&i| scores[i]).collect();
    let minima: Vec<usize> = grid_minima(&cscores, &cdims, usize::MAX)
        .into_iter()
        .map(|ci| coarse[ci])
        .collect();
    let lowest = |b: &[usize], scores: &[f64]| {
        b.iter()
            .copied()
            .min_by(|&p, &q| scores[p].total_cmp(&scores[q]).then(p.cmp(&q)))
    };
    let mut found = Vec::new();
    for &seed in minima.iter().take(COARSE_SEEDS) {
        let b = grid_box(seed, 2, dims);
        run(b.clone(), &mut scores, &mut done);
        let mut at = lowest(&b, &scores).unwrap_or(seed);
        // Bounded: each move goes to a strictly lower point.
        for _ in 0..total {
            let b = grid_box(at, 1, dims);
            run(b.clone(), &mut scores, &mut done);
            let next = lowest(&b, &scores).unwrap_or(at);
            if !(scores[next] < scores[at]) {
                break;
            }
            at = next;
        }
        found.push(at);
    }
    found.sort_by(|&p, &q| scores[p].total_cmp(&scores[q]).then(p.cmp(&q)));
    found.dedup();
    found.extend(minima.iter().skip(COARSE_SEEDS));
    found.retain(|&i| scores[i].is_finite());
    (scores, Some(found))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `m` rows of a basis s (0 to 3), data f (0.1 to 1.1) and weights w (1 to 1/5), smooth
    /// and deterministic, for the sums' tests.
    fn test_rows(m: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let s = (0..m)
            .map(|i| (0.37 * i as f64).sin().abs() * 3.0)
            .collect();
        let fd = (0..m)
            .map(|i| 0.1 + (0.11 * i as f64).cos().powi(2))
            .collect();
        let w = (0..m).map(|i| 1.0 / (1.0 + i as f64 % 5.0)).collect();
        (s, fd, w)
    }

    /// The lane sums of the global initialisation equal plain sums written out here, for
    /// lengths with and without a partial last block.
    #[test]
    fn basis_sums_match_plain_sums() {
        for m in [0, 1, 7, 8, 9, 500, 1003] {
            let (s, fd, w) = test_rows(m);
            let mut want = [0.0; 6];
            for i in 0..m {
                let t = [s[i] * s[i], s[i], fd[i] * s[i], 1.0, fd[i], fd[i] * fd[i]];
                for k in 0..6 {
                    want[k] += w[i] * t[k];
                }
            }
            let wf: Vec<f64> = w.iter().zip(&fd).map(|(w, f)| w * f).collect();
            let a = basis_sums(&s, &w, &wf);
            let b = basis_free_sums(&w, &fd);
            let got = [a[0], a[1], a[2], b[0], b[1], b[2]];
            for k in 0..6 {
                let tol = 1e-13 * want[k].abs().max(1e-300);
                assert!(
                    (got[k] - want[k]).abs() <= tol,
                    "m={m} k={k}: {got:?} vs {want:?}"
                );
            }
        }
    }

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

    /// ½ xᵀAx − bᵀx.
    fn quadratic(a: &[f64], b: &[f64], x: &[f64]) -> f64 {
        let k = b.len();
        (0..k)
            .map(|i| 0.5 * x[i] * (0..k).map(|j| a[i * k + j] * x[j]).sum::<f64>() - b[i] * x[i])
            .sum()
    }

    /// The brute-force answer of a non-negative quadratic problem: the unconstrained minimum
    /// on every subset of the free unknowns (Gaussian elimination written here), the best one
    /// that is ≥ 0. The convex problem's minimum is the unconstrained one on its support.
    fn brute_force(a: &[f64], b: &[f64], free: &[bool]) -> Vec<f64> {
        let k = b.len();
        let mut best = (0.0, vec![0.0; k]);
        for mask in 0..1usize << k {
            let set: Vec<usize> = (0..k).filter(|&i| mask >> i & 1 == 1).collect();
            if set.iter().any(|&i| !free[i]) || set.is_empty() {
                continue;
            }
            let n = set.len();
            let mut m: Vec<Vec<f64>> = set
                .iter()
                .map(|&i| {
                    let mut row: Vec<f64> = set.iter().map(|&j| a[i * k + j]).collect();
                    row.push(b[i]);
                    row
                })
                .collect();
            for c in 0..n {
                let piv = (c..n)
                    .max_by(|&p, &q| m[p][c].abs().total_cmp(&m[q][c].abs()))
                    .unwrap();
                m.swap(c, piv);
                for r in 0..n {
                    if r != c {
                        let f = m[r][c] / m[c][c];
                        for j in c..=n {
                            m[r][j] -= f * m[c][j];
                        }
                    }
                }
            }
            let mut x = vec![0.0; k];
            for (r, &i) in set.iter().enumerate() {
                x[i] = m[r][n] / m[r][r];
            }
            if x.iter().all(|&v| v >= 0.0) {
                let q = quadratic(a, b, &x);
                if q < best.0 {
                    best = (q, x);
                }
            }
        }
        best.1
    }

    /// Lawson–Hanson NNLS agrees with the brute force over every subset on 400 random
    /// problems of 1–4 unknowns (Gram matrices of random bases, some unknowns held).
    #[test]
    fn nnls_matches_brute_force() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(22);
        let (mut bound, mut three) = (0, 0);
        for case in 0..400 {
            let k = 1 + case % 4;
            let rows = 6;
            let s: Vec<f64> = (0..rows * k).map(|_| rng.random::<f64>() - 0.3).collect();
            let y: Vec<f64> = (0..rows).map(|_| rng.random::<f64>() - 0.5).collect();
            let a: Vec<f64> = (0..k * k)
                .map(|ij| {
                    (0..rows)
                        .map(|r| s[r * k + ij / k] * s[r * k + ij % k])
                        .sum()
                })
                .collect();
            let b: Vec<f64> = (0..k)
                .map(|i| (0..rows).map(|r| s[r * k + i] * y[r]).sum())
                .collect();
            let free: Vec<bool> = (0..k).map(|i| case % 7 != i).collect();
            let got = nnls(&a, &b, &free);
            let want = brute_force(&a, &b, &free);
            if k == 3 && free.iter().all(|&f| f) {
                // The face-by-face 3 × 3 solve: the same minimum.
                let (g3, h3): ([f64; 9], [f64; 3]) =
                    (a[..].try_into().unwrap(), [b[0], b[1], b[2]]);
                let c = nnls3(&g3, &h3);
                let q3 = quadratic(&a, &b, &c);
                three += 1;
                assert!(c.iter().all(|&v| v >= 0.0), "case {case}: {c:?}");
                assert!(
                    (q3 - quadratic(&a, &b, &want)).abs() <= 1e-10 * q3.abs().max(1e-12),
                    "case {case}: nnls3 {c:?} ({q3}) vs brute force {want:?}"
                );
            }
            bound += got.iter().filter(|&&v| v == 0.0).count();
            let (qg, qw) = (quadratic(&a, &b, &got), quadratic(&a, &b, &want));
            assert!(got.iter().all(|&v| v >= 0.0), "case {case}: {got:?}");
            for i in 0..k {
                assert!(free[i] || got[i] == 0.0, "case {case}: held {i} moved");
            }
            assert!(
                (qg - qw).abs() <= 1e-10 * qw.abs().max(1e-12),
                "case {case}: nnls {got:?} ({qg}) vs brute force {want:?} ({qw})"
            );
        }
        assert!(bound > 100, "the cases must reach the bounds: {bound}");
        assert!(three > 50, "nnls3 must meet enough cases: {three}");
    }

    /// Hand-worked: with A = [[2, 1], [1, 2]] and b = (3, 0) the unconstrained solution is
    /// (2, −1), so NNLS holds the second at 0 and gives 3/2; held at 1, the first's equation
    /// 2x + 1 = 3 gives x = 1; a vanishing basis (A₂₂ = 0) stays 0.
    /// The 3 × 3 interior solve: G = AᵀA for A's columns (1, 1, 0), (0, 1, 1), (1, 1, 1) and
    /// h = G (1, 2, 3), so c = (1, 2, 3) exactly (by hand: G = [[2, 1, 2], [1, 2, 2],
    /// [2, 2, 3]], h = [10, 11, 15]); it agrees with [`nnls`] where the minimum is interior,
    /// and declines a negative coefficient (h = G (1, −2, 3)) and a singular G (two equal
    /// columns), which then go to the active-set solve.
    #[test]
    fn positive_solve3_by_hand() {
        let g = [2.0, 1.0, 2.0, 1.0, 2.0, 2.0, 2.0, 2.0, 3.0];
        let c = positive_solve3(&g, &[10.0, 11.0, 15.0]).expect("an interior minimum");
        for (got, want) in c.iter().zip([1.0, 2.0, 3.0]) {
            assert!((got - want).abs() < 1e-12, "{c:?}");
        }
        let x = nnls(&g, &[10.0, 11.0, 15.0], &[true; 3]);
        for (a, b) in c.iter().zip(&x) {
            assert!((a - b).abs() < 1e-12, "{c:?} vs {x:?}");
        }
        // h = G (1, −2, 3) = (2 − 2 + 6, 1 − 4 + 6, 2 − 4 + 9).
        assert_eq!(positive_solve3(&g, &[6.0, 3.0, 7.0]), None);
        let singular = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 3.0];
        assert_eq!(positive_solve3(&singular, &[1.0, 1.0, 2.0]), None);
    }

    #[test]
    fn nnls_and_held_coefficients_by_hand() {
        let a = [2.0, 1.0, 1.0, 2.0];
        let close = |x: &[f64], want: [f64; 2]| (0..2).all(|i| (x[i] - want[i]).abs() < 1e-14);
        assert!(close(&nnls(&a, &[3.0, 0.0], &[true, true]), [1.5, 0.0]));
        let both = nnls(&a, &[3.0, 3.0], &[true, true]);
        assert!((both[0] - 1.0).abs() < 1e-14 && (both[1] - 1.0).abs() < 1e-14);
        let x = linear_solve(&a, &[3.0, 0.0], &[0.0, 1.0], &[true, false]);
        assert!((x[0] - 1.0).abs() < 1e-14 && x[1] == 1.0, "{x:?}");
        let x = nnls(&[2.0, 0.0, 0.0, 0.0], &[4.0, 1.0], &[true, true]);
        assert!(close(&x, [2.0, 0.0]), "{x:?}");
    }

    /// Two shape parameters and an index (19 × 19 × 17 = 6,137 ≤ 8,192 points) keep the whole
    /// grid; three and an index (116,603) halve the longest axis, the first of equals, one at a
    /// time: 10·19·19·17 = 61,370, 10·10·19·17 = 32,300, 10·10·10·17 = 17,000,
    /// 10·10·10·9 = 9,000, then 5·10·10·9 = 4,500.
    #[test]
    fn two_shapes_and_an_index_keep_the_whole_grid() {
        let specs = ModelKind::TorranceSparrow.params(Distribution::D3);
        let (n, c3) = (&specs[0], &specs[1]);
        let (grids, dims, points) = grid_points(&[c3, c3, n], 3);
        assert_eq!(dims, vec![19, 19, 17]);
        assert_eq!(points.len(), 19 * 19 * 17);
        // Row-major, the last variable fastest: point 1 · 17 + 2 is (c3₀, c3₁, n₂), the
        // last point every grid's last value.
        let (g0, g2) = (&grids[0].1, &grids[2].1);
        assert_eq!(points.get(17 + 2), &[g0[0], g0[1], g2[2]]);
        assert_eq!(points.get(19 * 19 * 17 - 1), &[g0[18], g0[18], g2[16]]);
        let (_, dims, points) = grid_points(&[c3, c3, c3, n], 4);
        assert_eq!(dims, vec![5, 10, 10, 9]);
        assert_eq!(points.len(), 4500);
    }

    /// Hand-worked: on a 3 × 4 grid the box of half-width 1 around (1, 0) is rows 0–2,
    /// columns 0–1; of half-width 2 around (0, 3), rows 0–2, columns 1–3.
    #[test]
    fn grid_box_by_hand() {
        assert_eq!(grid_box(4, 1, &[3, 4]), vec![0, 1, 4, 5, 8, 9]);
        assert_eq!(grid_box(3, 2, &[3, 4]), vec![1, 2, 3, 5, 6, 7, 9, 10, 11]);
        assert_eq!(grid_box(0, 1, &[1]), vec![0]);
    }

    /// Coarse to fine on a 19 × 19 × 17 grid: a broad bowl whose lowest point (5, 11, 7) has
    /// odd coordinates (off the coarse grid), and a narrow deeper well at (13, 3, 9), also odd,
    /// whose coarse neighbours are still lower than the bowl's: both found, the well the
    /// lowest, as the brute-force minimum over every point says; fewer than half the points
    /// scored, none inadmissible (the half i > j below 13), none twice, and every neighbour of
    /// the two minima scored.
    #[test]
    fn coarse_to_fine_finds_the_full_grids_minima() {
        let dims = [19usize, 19, 17];
        let at = |i: usize| [i / (19 * 17), (i / 17) % 19, i % 17];
        let f = |i: usize| {
            let c = at(i).map(|v| v as f64);
            let d2 = |p: [f64; 3]| (0..3).map(|k| (c[k] - p[k]).powi(2)).sum::<f64>();
            10.0 + 0.01 * d2([5.0, 11.0, 7.0]) - 9.0 * (-d2([13.0, 3.0, 9.0]) / 4.0).exp()
        };
        let total: usize = dims.iter().product();
        let admissible = |i: usize| at(i)[0] <= at(i)[1] || at(i)[0] >= 13;
        let mut asked = vec![0usize; total];
        let (scores, minima) = search_grid(&dims, COARSE_ABOVE, admissible, |idx| {
            idx.iter()
                .map(|&i| {
                    asked[i] += 1;
                    f(i)
                })
                .collect()
        });
        let brute = (0..total)
            .filter(|&i| admissible(i))
            .min_by(|&a, &b| f(a).total_cmp(&f(b)))
            .unwrap();
        assert_eq!(at(brute), [13, 3, 9]);
        let minima = minima.expect("searched coarse to fine");
        assert_eq!(minima[0], brute, "{:?}", at(minima[0]));
        assert_eq!(at(minima[1]), [5, 11, 7]);
        for &m in &minima[..2] {
            for j in grid_box(m, 1, &dims) {
                assert!(!admissible(j) || asked[j] == 1, "{:?}", at(j));
            }
        }
        let n: usize = asked.iter().sum();
        assert!(n < total / 2, "{n} of {total} scored");
        assert!((0..total).all(|i| asked[i] <= 1 && (admissible(i) || asked[i] == 0)));
        assert!((0..total).all(|i| (asked[i] == 1) == scores[i].is_finite()));
    }

    /// A small grid is scored whole.
    #[test]
    fn small_grids_are_scored_whole() {
        let (scores, minima) = search_grid(
            &[15, 17],
            COARSE_ABOVE,
            |_| true,
            |idx| vec![1.0; idx.len()],
        );
        assert!(scores.iter().all(|&s| s == 1.0) && minima.is_none());
    }

    /// The two-lobe Gram sums ([`two_lobe_sums`]) equal, point by point, the row loop of
    /// [`gram_sums`] over the tabulated bases (lobe at α1, lobe at α2, ones).
    #[test]
    fn two_lobe_gram_matches_the_row_sums() {
        let rows = spread_rows();
        let m = rows.len();
        let w: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 / 7.0).collect();
        let wf: Vec<f64> = (0..m).map(|i| w[i] * (0.2 + (i % 5) as f64)).collect();
        let specs = ModelKind::GgxSmith2.params(Distribution::D3);
        let (alphas, ns) = (specs[0].grid_values(), specs[4].grid_values());
        let t = LobeTables::new(&rows, &alphas, &ns);
        let g = TwoLobeGram::new(&t, &alphas, &ns, &w, &wf).expect("every value tabulated");
        let ones = vec![1.0; m];
        for (a1, a2, j) in [(0, 0, 0), (2, 9, 5), (9, 2, 16), (18, 18, 3), (4, 17, 11)] {
            let bases = [
                t.basis(alphas[a1], ns[j], 0..m).unwrap(),
                t.basis(alphas[a2], ns[j], 0..m).unwrap(),
                Basis { a: &ones, b: &ones },
            ];
            let (want_g, want_h) = gram_sums(&bases, &w, &wf);
            let (got_g, got_h) = g.gram(a1, a2, j);
            for (got, want) in got_g.iter().chain(&got_h).zip(want_g.iter().chain(&want_h)) {
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs().max(1e-300),
                    "({a1}, {a2}, {j}): {got} vs {want}"
                );
            }
        }
    }

    /// Data made by a two-lobe model at a grid point (α1 = grid α 3, α2 = grid α 10, n = grid
    /// n 7; ps1 0.5, ps2 0.2, pd/π 0.1) are fitted exactly there: its linearised cost is
    /// the least possible, ½ Σ w (f − f)² − ½ Σ w f² = −½ Σ w f², no point is lower, and the
    /// prescreen keeps it among the ⌈3,230/4⌉ = 808 best ordered points (19·20/2 α pairs ×
    /// 17 n, and any tied with the last), none with α1 > α2.
    #[test]
    fn two_lobe_prescreen_keeps_the_generating_point() {
        let rows = spread_rows();
        let m = rows.len();
        let specs = ModelKind::GgxSmith2.params(Distribution::D3);
        let (alphas, ns) = (specs[0].grid_values(), specs[4].grid_values());
        let (na, nn) = (alphas.len(), ns.len());
        assert_eq!((na, nn), (19, 17));
        let t = LobeTables::new(&rows, &alphas, &ns);
        let (l1, l2, fr) = (
            t.lobe(alphas[3]).unwrap(),
            t.lobe(alphas[10]).unwrap(),
            t.fresnel(ns[7]).unwrap(),
        );
        let f: Vec<f64> = (0..m)
            .map(|r| fr[r] * (0.5 * l1[r] + 0.2 * l2[r]) + 0.1)
            .collect();
        let w: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 / 7.0).collect();
        let wf: Vec<f64> = (0..m).map(|i| w[i] * f[i]).collect();
        let g = TwoLobeGram::new(&t, &alphas, &ns, &w, &wf).expect("every value tabulated");
        let dims = [na, na, nn];
        let ordered = |i: usize| i / (na * nn) <= (i / nn) % na;
        let lin = two_lobe_linearised(&g, &[0.0; 3], &[true; 3], &dims, ordered);
        let at = 3 * na * nn + 10 * nn + 7;
        let least = -0.5 * (0..m).map(|r| w[r] * f[r] * f[r]).sum::<f64>();
        assert!(
            (lin[at] - least).abs() <= 1e-9 * least.abs(),
            "{} vs {least}",
            lin[at]
        );
        assert!(lin.iter().all(|&v| v >= least - 1e-9 * least.abs()));
        let slots = [
            Slot::Free(0),
            Slot::Free(1),
            Slot::Free(2),
            Slot::Free(3),
            Slot::Free(4),
            Slot::Free(5),
        ];
        let kept = two_lobe_prescreen(&g, &slots, &[1, 3], 5, &dims, ordered);
        assert!(kept[at]);
        // The best tenth, points tied with its last one included: at least ⌈3,230/10⌉ = 323,
        // and no point kept above one left out.
        let n = kept.iter().filter(|&&k| k).count();
        assert!(n >= 323, "{n} kept");
        assert!((0..kept.len()).all(|i| !kept[i] || ordered(i)));
        let worst_kept = (0..lin.len())
            .filter(|&i| kept[i])
            .map(|i| lin[i])
            .fold(f64::NEG_INFINITY, f64::max);
        let best_left = (0..lin.len())
            .filter(|&i| ordered(i) && !kept[i])
            .map(|i| lin[i])
            .fold(f64::INFINITY, f64::min);
        assert!(worst_kept < best_left, "{worst_kept} ≥ {best_left}");
    }

    /// A dielectric's lobe (the scipy benchmark's truth n = 1.8, c3 = 0.35, ps = 0.667,
    /// pd = 0.333; 10,000 hemisphere samples, 1 % noise): the grid's second minimum, the metal
    /// basin at the top of n's grid (F ≈ 1 at every angle), is not a candidate; the first,
    /// near the truth, is.
    #[test]
    fn far_basins_are_not_candidates() {
        use crate::model::Model;
        use crate::simulate::{Grid, simulate};
        let truth = [1.8, 0.35, 0.667, 0.333];
        let model = Model::new(ModelKind::TorranceSparrow, Distribution::D3, &truth).unwrap();
        let ds = simulate(&model, &Grid::Hemisphere(10_000).directions(1), 0.01, 1);
        let opts = FitOptions::new(ModelKind::TorranceSparrow);
        let rows = super::super::setup::channel_rows(&ds, 0, &opts);
        let lay = super::super::setup::layout(&[ds.channel_label(0)], &opts);
        let full = super::super::setup::problem(vec![rows], &lay, &opts);
        let work = full.subsample(problem::SUBSAMPLE_ROWS);
        let found = global_init(&work, &lay.specs, &opts);
        assert_eq!(lay.names[0], "n");
        let top = *lay.specs[0].grid_values().last().unwrap();
        let n: Vec<f64> = found
            .iter()
            .map(|x| full.transforms[0].apply(x[0]).0)
            .collect();
        assert!(!n.is_empty() && (n[0] - 1.8).abs() < 0.2, "{n:?}");
        assert!(
            n.iter().all(|&v| v < 0.5 * top),
            "{n:?} (top of the grid {top})"
        );
    }

    /// Visible rows spread over the hemisphere, incidence and azimuth varied (in and out of
    /// the plane of incidence).
    fn spread_rows() -> Rows {
        use crate::model::Geometry;
        use problem::Row;
        let mut rows = Vec::new();
        for k in 0..300 {
            let x = k as f64;
            let g = Geometry::from_angles(
                (0.37 * x).sin().abs() * 1.4,
                0.0,
                (0.71 * x).cos().abs() * 1.4,
                2.0 * (0.13 * x).sin() * std::f64::consts::PI,
            );
            if g.visible() {
                rows.push(Row {
                    g,
                    cos_i: g.nl,
                    target: 0.0,
                    sw: 1.0,
                });
            }
        }
        Rows::from(rows)
    }

    /// GGX–Smith's tabulated basis F(n)·L(α) equals, row by row, the model's f_r with ps = 1
    /// and pd = 0 (problem::brdf_values through `Model::brdf`), at every α and n of the grids,
    /// and the tabulated sums of the one-lobe grid equal the sums of that basis.
    #[test]
    fn ggx_tables_match_the_model() {
        let rows = spread_rows();
        let m = rows.len();
        let w: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 / 7.0).collect();
        let wf: Vec<f64> = (0..m).map(|i| w[i] * (0.2 + (i % 5) as f64)).collect();
        let specs = ModelKind::GgxSmith.params(Distribution::D3);
        let (alphas, ns) = (specs[0].grid_values(), specs[1].grid_values());
        let t = LobeTables::new(&rows, &alphas, &ns);
        let f = TsFactors::ggx(&t, &alphas, &ns).expect("every grid value tabulated");
        let table = f.grid_sums(&w, &wf);
        let mut nonzero = 0;
        for (i, &a) in alphas.iter().enumerate() {
            for (j, &n) in ns.iter().enumerate() {
                let model =
                    Model::new(ModelKind::GgxSmith, Distribution::D3, &[a, n, 1.0, 0.0]).unwrap();
                let want = problem::brdf_values(&model, &rows, 0..m);
                let b = t.basis(a, n, 0..m).unwrap();
                for r in 0..m {
                    let got = b.a[r] * b.b[r];
                    assert!(
                        (got - want[r]).abs() <= 1e-12 * want[r].abs(),
                        "α {a} n {n} row {r}: {got} vs {}",
                        want[r]
                    );
                    nonzero += usize::from(want[r] > 0.0);
                }
                let sums = basis_sums(&want, &w, &wf);
                for k in 0..3 {
                    let got = table[i * ns.len() + j][k];
                    assert!(
                        (got - sums[k]).abs() <= 1e-10 * sums[k].abs(),
                        "{got} vs {sums:?}"
                    );
                }
            }
        }
        assert!(nonzero > alphas.len() * ns.len() * m / 2);
        // The two-lobe model: its f_r is the sum of the two tabulated bases.
        let (a1, a2, n) = (alphas[2], alphas[9], ns[5]);
        let model = Model::new(
            ModelKind::GgxSmith2,
            Distribution::D3,
            &[a1, 0.7, a2, 0.2, n, 0.0],
        )
        .unwrap();
        let want = problem::brdf_values(&model, &rows, 0..m);
        let (b1, b2) = (t.basis(a1, n, 0..m).unwrap(), t.basis(a2, n, 0..m).unwrap());
        for r in 0..m {
            let got = 0.7 * b1.a[r] * b1.b[r] + 0.2 * b2.a[r] * b2.b[r];
            assert!(
                (got - want[r]).abs() <= 1e-12 * want[r].abs(),
                "row {r}: {got} vs {}",
                want[r]
            );
        }
        assert!(t.basis(0.123_456, n, 0..m).is_none());
    }

    /// The tabulated sums of Torrance–Sparrow's separable basis equal, point by point, the
    /// sums of the basis evaluated through the model (problem::brdf_values), for D3, D1 and
    /// ABC, on a number of rows that leaves a part-filled last block of lanes.
    #[test]
    fn separable_grid_sums_match_the_model_point_by_point() {
        let rows = spread_rows();
        let m = rows.len();
        assert_ne!(m % crate::lanes::LANES, 0, "{m} rows fill whole blocks");
        let w: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 / 7.0).collect();
        let wf: Vec<f64> = (0..m).map(|i| w[i] * (0.2 + (i % 5) as f64)).collect();
        for dist in [Distribution::D3, Distribution::D1, Distribution::Abc] {
            let specs = ModelKind::TorranceSparrow.params(dist);
            let ns = specs[0].grid_values();
            // The shape points: c for D1–D3, every (b, c) of the two grids for ABC.
            let mut cs: Vec<Vec<f64>> = vec![vec![]];
            for s in specs.iter().filter(|s| s.role == crate::model::Role::Shape) {
                cs = cs
                    .iter()
                    .flat_map(|pt| {
                        s.grid_values()
                            .into_iter()
                            .map(move |v| [&pt[..], &[v]].concat())
                    })
                    .collect();
            }
            let factors = TsFactors::new(&rows, dist, &ns, &cs);
            let table = factors.grid_sums(&w, &wf);
            assert_eq!(table.len(), ns.len() * cs.len());
            for (i, n) in ns.iter().enumerate() {
                for (j, c) in cs.iter().enumerate() {
                    let params = [&[*n][..], c, &[1.0, 0.0]].concat();
                    let model = Model::new(ModelKind::TorranceSparrow, dist, &params).unwrap();
                    let basis = problem::brdf_values(&model, &rows, 0..m);
                    let want = basis_sums(&basis, &w, &wf);
                    let index = i * cs.len() + j;
                    let got = table[index];
                    let fb = factors.basis(index);
                    let got_basis = fb.a.iter().zip(fb.b).map(|(x, y)| x * y);
                    for (r, (a, b)) in got_basis.zip(&basis).enumerate() {
                        assert!(
                            (a - b).abs() <= 1e-12 * b.abs().max(1e-300),
                            "row {r}: {a} vs {b}"
                        );
                    }
                    for k in 0..3 {
                        let tol = 1e-10 * want[k].abs().max(1e-300);
                        assert!(
                            (got[k] - want[k]).abs() <= tol,
                            "{dist:?} n={n} c={c:?} sum {k}: {} vs {}",
                            got[k],
                            want[k]
                        );
                    }
                }
            }
        }
    }
}

//! Sums computed once for a whole grid, so no grid point passes over the rows for them:
//! Torrance–Sparrow's basis as a term in n times a term in the shape ([`TsFactors`]), GGX's
//! lobes and Fresnel factors at the grid's α and n ([`LobeTables`]), two GGX lobes' Gram
//! sums ([`TwoLobeGram`]), and the lane sums they are built from.

use super::linear::Basis;
use crate::fit::problem::{self, Rows};
use crate::model::Distribution;
use crate::support::lanes::LANES;

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
    pub(super) fn new(rows: &Rows, dist: Distribution, ns: &[f64], cs: &[Vec<f64>]) -> Self {
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
    pub(super) fn ggx(tables: &LobeTables, alphas: &[f64], ns: &[f64]) -> Option<Self> {
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
    pub(super) fn grid_sums(&self, w: &[f64], wf: &[f64]) -> Vec<[f64; 3]> {
        grid_sums(&self.a, &self.b, self.m, w, wf)
    }

    /// The basis at grid point `index` (n-major), row by row.
    pub(super) fn basis(&self, index: usize) -> Basis<'_> {
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
    pub(super) fn new(rows: &Rows, alphas: &[f64], ns: &[f64]) -> Self {
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
    pub(super) fn lobe(&self, alpha: f64) -> Option<&[f64]> {
        let i = self
            .alphas
            .iter()
            .position(|a| a.to_bits() == alpha.to_bits())?;
        Some(&self.lobes[i])
    }

    /// F(n) on every row, if n is tabulated.
    pub(super) fn fresnel(&self, n: f64) -> Option<&[f64]> {
        let j = self.ns.iter().position(|v| v.to_bits() == n.to_bits())?;
        Some(&self.fres[j])
    }

    /// The basis F(n)·L(α) on rows `range`, if both values are tabulated.
    pub(super) fn basis(
        &self,
        alpha: f64,
        n: f64,
        range: std::ops::Range<usize>,
    ) -> Option<Basis<'_>> {
        Some(Basis {
            a: &self.fresnel(n)?[range.clone()],
            b: &self.lobe(alpha)?[range],
        })
    }
}

/// The Gram sums of [`super::linear::gram_sums`] for two lobes of the same form sharing the Fresnel
/// factor (ggx-smith-2 on one channel) at every point of a grid α1 × α2 × n, from three matrix
/// products per n: with u = w F(n)², Σ u L(αa) L(αb) for every pair of the grid's α, and Σ w F(n)
/// L(αa), Σ (w f) F(n) L(αa) for every α; nothing evaluated per point.
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
    pub(super) fn new(
        tables: &LobeTables,
        alphas: &[f64],
        ns: &[f64],
        w: &[f64],
        wf: &[f64],
    ) -> Option<Self> {
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
    /// lobe at `a2`, ones) at n index `j`, as [`super::linear::gram_sums`] gives them.
    pub(super) fn gram(&self, a1: usize, a2: usize, j: usize) -> (Vec<f64>, Vec<f64>) {
        let (g, h) = self.gram3(a1, a2, j);
        (g.to_vec(), h.to_vec())
    }

    /// [`TwoLobeGram::gram`] in fixed-size arrays.
    pub(super) fn gram3(&self, a1: usize, a2: usize, j: usize) -> ([f64; 9], [f64; 3]) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::init::fixtures::{spread_rows, test_rows};
    use crate::fit::init::linear::gram_sums;
    use crate::model::{Model, ModelKind};

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

    /// The two-lobe Gram sums ([`two_lobe_sums`]) equal, point by point, the row loop of
    /// [`super::linear::gram_sums`] over the tabulated bases (lobe at α1, lobe at α2, ones).
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
        assert_ne!(
            m % crate::support::lanes::LANES,
            0,
            "{m} rows fill whole blocks"
        );
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

//! Stage 2 of a fit: the global initialisation by variable projection over a grid of the
//! nonlinear parameters, with the linear parameters solved at each grid point.

use super::*;

/// The weighted sums of the two-parameter linear problem y ≈ ps s + pd/π of the global
/// initialisation, y = f_data − ps_fixed s − pd_fixed/π: [Σws², Σws/π, Σw/π², Σwsy, Σwy/π,
/// Σwy²], from the basis sums [Σws², Σws, Σ(wf)s] of [`basis_sums`] (or
/// [`ts_grid_sums`]), the basis-free sums k and the fixed (ps, pd).
pub(super) fn combine_sums([ss, s1, sf]: [f64; 3], k: [f64; 3], fixed: (f64, f64)) -> [f64; 6] {
    let [w1, f1, ff] = k;
    let d = std::f64::consts::FRAC_1_PI;
    let (a, b) = (fixed.0, fixed.1 * d);
    // y = f − a s − b, expanded.
    let sy = sf - a * ss - b * s1;
    let y1 = f1 - a * s1 - b * w1;
    let yy = ff + a * a * ss + b * b * w1 - 2.0 * a * sf - 2.0 * b * f1 + 2.0 * a * b * s1;
    [ss, s1 * d, w1 * d * d, sy, y1 * d, yy]
}

/// Torrance–Sparrow's specular basis s = D(c)·F(n)·G/(π N·L N·E) at every point of a grid of
/// n (`ns`) and the distribution's c (`cs`) is a term in n alone times a term in c alone:
/// rows of `a` (F(n)·G/(π N·L N·E), one per n) times rows of `b` (D(c), one per c).
pub(super) struct TsFactors {
    /// F(n)·G/(π N·L N·E), one row of m per n, row-major.
    pub(super) a: Vec<f64>,
    /// D(c), one row of m per c, row-major.
    pub(super) b: Vec<f64>,
    pub(super) m: usize,
}

impl TsFactors {
    fn new(rows: &Rows, dist: Distribution, ns: &[f64], cs: &[f64]) -> Self {
        let m = rows.len();
        let pi = std::f64::consts::FRAC_1_PI;
        let geo: Vec<f64> = (0..m).map(|r| rows.g_ne[r] * pi / rows.nl[r]).collect();
        let a = ns
            .iter()
            .flat_map(|&n| (0..m).map(move |r| crate::model::fresnel(n, rows.eh[r])))
            .zip(geo.iter().cycle())
            .map(|(f, g)| f * g)
            .collect();
        let b = cs
            .iter()
            .flat_map(|&c| (0..m).map(move |r| dist.eval(rows.nh[r], c)))
            .collect();
        TsFactors { a, b, m }
    }

    /// [`basis_sums`] at every grid point, n-major: three matrix products (17 × m by m × 19
    /// for the default grids) instead of a pass over the rows per grid point.
    fn grid_sums(&self, w: &[f64], wf: &[f64]) -> Vec<[f64; 3]> {
        use nalgebra::DMatrix;
        let m = self.m;
        let (ni, nc) = (self.a.len() / m, self.b.len() / m);
        let rowm = |n: usize, f: &dyn Fn(usize) -> f64| DMatrix::from_fn(n, m, |i, r| f(i * m + r));
        let a = &self.a;
        let wa2 = rowm(ni, &|k| w[k % m] * a[k] * a[k]);
        let wa = rowm(ni, &|k| w[k % m] * a[k]);
        let wfa = rowm(ni, &|k| wf[k % m] * a[k]);
        let bt = DMatrix::from_fn(m, nc, |r, j| self.b[j * m + r]);
        let b2t = bt.map(|x| x * x);
        let ss = wa2 * b2t;
        let s1 = wa * &bt;
        let sf = wfa * &bt;
        (0..ni)
            .flat_map(|i| (0..nc).map(move |j| (i, j)))
            .map(|(i, j)| [ss[(i, j)], s1[(i, j)], sf[(i, j)]])
            .collect()
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
        let w: [f64; LANES] = std::array::from_fn(|l| match (l < len, sw.is_empty()) {
            (false, _) => 0.0,
            (true, true) => 1.0,
            (true, false) => sw[i + l],
        });
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

/// Minimise the declared loss over the linear coefficients (a, b) of f = a·s + b from a
/// start, by `steps` projected Gauss–Newton steps; `lo` holds each one's lower bound, or
/// `None` for one that is held. Returns the cost and (a, b).
pub(super) fn refine_linear(
    rows: &Rows,
    range: std::ops::Range<usize>,
    s: Basis,
    start: (f64, f64),
    lo: (Option<f64>, Option<f64>),
    loss: Loss,
    steps: usize,
) -> (f64, (f64, f64)) {
    let free = (lo.0.is_some(), lo.1.is_some());
    let lo = (lo.0.unwrap_or(f64::MIN), lo.1.unwrap_or(f64::MIN));
    let mut x = start;
    if steps == 0 && loss == Loss::Log {
        let sw = weights(rows, range.clone());
        let cost = linear_cost_log(
            &rows.nl[range.clone()],
            &rows.target[range.clone()],
            sw,
            s,
            x,
        );
        return (cost, x);
    }
    let (mut cost, mut jtj, mut jtr) = linear_pass(rows, range.clone(), s, x, loss);
    if loss == Loss::Linear {
        return (cost, x);
    }
    for _ in 0..steps {
        let ridge = 1e-9;
        let (da, db) = match free {
            (true, true) => {
                let (p, q, r) = (jtj[0] * (1.0 + ridge), jtj[1], jtj[2] * (1.0 + ridge));
                let det = p * r - q * q;
                if !(det > 0.0) {
                    break;
                }
                (
                    -(r * jtr[0] - q * jtr[1]) / det,
                    -(p * jtr[1] - q * jtr[0]) / det,
                )
            }
            (true, false) if jtj[0] > 0.0 => (-jtr[0] / jtj[0], 0.0),
            (false, true) if jtj[2] > 0.0 => (0.0, -jtr[1] / jtj[2]),
            _ => break,
        };
        let mut step = 1.0;
        let mut accepted = false;
        for _ in 0..3 {
            let xn = ((x.0 + step * da).max(lo.0), (x.1 + step * db).max(lo.1));
            let (cn, jn, gn) = linear_pass(rows, range.clone(), s, xn, loss);
            if cn < cost {
                (x, cost, jtj, jtr) = (xn, cn, jn, gn);
                accepted = true;
                break;
            }
            step *= 0.25;
        }
        if !accepted {
            break;
        }
    }
    (cost, x)
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

/// Variable projection over a grid of the nonlinear parameters that spans each one's whole
/// admissible range ([`crate::model::ParamSpec::grid`]): at each grid point the free ps and pd
/// of each channel come from a weighted linear least-squares solve (weights that linearise
/// the loss at the data), clipped to ≥ 0; each point is then scored on the *declared* loss at
/// those (ps, pd), so a basin ranks by the cost the fit minimises, not by its linearisation.
/// The grid's local minima (distinct basins) are returned best first, at most [`CANDIDATES`],
/// as solver variables.
pub(super) fn global_init(
    full: &BrdfProblem,
    specs: &[&ParamSpec],
    opts: &FitOptions,
) -> Vec<Vec<f64>> {
    let p = full.subsample(INIT_ROWS);
    let nfree = p.transforms.len();
    let kind = opts.kind;
    let names = kind.param_names(opts.dist);
    let ips = kind.index_of(opts.dist, Role::Specular);
    let ipd = kind
        .index_of(opts.dist, Role::Diffuse)
        .expect("every model has pd");
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
    // Torrance–Sparrow on one channel with n and c free: every point's sums at once.
    let separable = (kind == ModelKind::TorranceSparrow
        && p.layout.len() == 1
        && ips.is_some()
        && nonlinear.len() == 2
        && specs[nonlinear[0].0].role == Role::Index
        && specs[nonlinear[1].0].role == Role::Shape)
        .then(|| {
            let f = TsFactors::new(&p.rows, opts.dist, &nonlinear[0].1, &nonlinear[1].1);
            let table = f.grid_sums(&wdata, &wf);
            (f, table)
        });
    let (ones, zeros) = (vec![1.0; p.rows.len()], vec![0.0; p.rows.len()]);
    let score_point = |index: usize, steps: usize| {
        let pt = &points[index];
        // Natural values of all free variables at this grid point (linear ones solved).
        let mut theta = vec![f64::NAN; nfree];
        let mut score = 0.0;
        for ((k, _), v) in nonlinear.iter().zip(pt) {
            theta[*k] = *v;
        }
        for c in 0..p.layout.len() {
            let slots = p.layout[c];
            let rows = p.starts[c]..p.starts[c + 1];
            // Model with ps = 1, pd = 0 gives the specular basis; pd's basis is 1/π.
            let mut vals = [0.0; crate::model::MAX_PARAMS];
            for j in 0..names.len() {
                vals[j] = match slots[j] {
                    Slot::Fixed(v) => v,
                    Slot::Free(k) => theta[k],
                };
            }
            if let Some(i) = ips {
                vals[i] = 1.0;
            }
            vals[ipd] = 0.0;
            let spec_model = full.template.with_params(&vals);
            let fixed_ps = ips.and_then(|i| match slots[i] {
                Slot::Fixed(v) => Some(v),
                _ => None,
            });
            let fixed_pd = match slots[ipd] {
                Slot::Fixed(v) => Some(v),
                _ => None,
            };
            let owned: Vec<f64>;
            let basis = match (&separable, ips) {
                (Some((f, _)), _) => f.basis(index),
                (None, Some(_)) => {
                    owned = problem::brdf_values(&spec_model, &p.rows, rows.clone());
                    Basis {
                        a: &owned,
                        b: &ones[..rows.len()],
                    }
                }
                (None, None) => Basis {
                    a: &zeros[..rows.len()],
                    b: &ones[..rows.len()],
                },
            };
            let raw = match &separable {
                Some((_, table)) => table[index],
                // Here the basis is its first factor (the second is ones).
                None => basis_sums(basis.a, &wdata[rows.clone()], &wf[rows.clone()]),
            };
            let [a11, a12, a22, b1, b2, _] = combine_sums(
                raw,
                free_sums[c],
                (fixed_ps.unwrap_or(0.0), fixed_pd.unwrap_or(0.0)),
            );
            let free_ps = ips.is_some() && fixed_ps.is_none();
            let free_pd = fixed_pd.is_none();
            let (ps, pd) = nonnegative_2x2([a11, a12, a22, b1, b2], (free_ps, free_pd));
            // The declared loss, minimised over (ps, pd) from the linear solve.
            let pi = std::f64::consts::FRAC_1_PI;
            let (fps, fpd) = (fixed_ps.unwrap_or(0.0), fixed_pd.unwrap_or(0.0) * pi);
            let (cost, (a, b)) = refine_linear(
                &p.rows,
                rows,
                basis,
                (ps + fps, pd * pi + fpd),
                (free_ps.then_some(fps), free_pd.then_some(fpd)),
                opts.loss,
                steps,
            );
            score += cost;
            let (ps, pd) = (a - fps, (b - fpd) / pi);
            if let (Some(i), true) = (ips, free_ps)
                && let Slot::Free(k) = slots[i]
            {
                theta[k] = ps;
            }
            if free_pd && let Slot::Free(k) = slots[ipd] {
                theta[k] = pd;
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
    // Every point scored at the linear solve's (ps, pd) (an upper bound of its best score),
    // then the promising ones with (ps, pd) minimising the declared loss.
    use rayon::prelude::*;
    let mut scored: Vec<(f64, Vec<f64>)> = (0..points.len())
        .into_par_iter()
        .map(|i| score_point(i, 0))
        .collect();
    let first: Vec<f64> = scored.iter().map(|s| s.0).collect();
    let mut refine = grid_minima(&first, &dims, REFINED_POINTS);
    let mut order: Vec<usize> = (0..first.len()).collect();
    order.sort_by(|&a, &b| first[a].total_cmp(&first[b]).then(a.cmp(&b)));
    refine.extend(order.into_iter().take(REFINED_POINTS));
    refine.sort_unstable();
    refine.dedup();
    let better: Vec<(usize, (f64, Vec<f64>))> = refine
        .par_iter()
        .map(|&i| (i, score_point(i, LINEAR_STEPS)))
        .collect();
    for (i, s) in better {
        if s.0 <= scored[i].0 {
            scored[i] = s;
        }
    }
    let scores: Vec<f64> = scored.iter().map(|s| s.0).collect();
    grid_minima(&scores, &dims, CANDIDATES)
        .into_iter()
        .map(|i| scored[i].1.clone())
        .collect()
}

/// The starting grid of the nonlinear free variables: which variables have a grid, the grid
/// sizes, and every grid point (row-major). Grids are thinned while the product of their
/// sizes exceeds 4,096 (a joint fit with per-channel shape parameters).
pub(super) fn grid_points(specs: &[&ParamSpec], nfree: usize) -> GridPoints {
    let mut nonlinear: Vec<(usize, Vec<f64>)> = (0..nfree)
        .filter_map(|k| {
            let g = specs[k].grid_values();
            (!g.is_empty()).then_some((k, g))
        })
        .collect();
    while nonlinear.iter().map(|(_, g)| g.len()).product::<usize>() > 4096 {
        for (_, g) in nonlinear.iter_mut() {
            *g = g.iter().step_by(2).copied().collect();
        }
    }
    let dims: Vec<usize> = nonlinear.iter().map(|(_, g)| g.len()).collect();
    let mut points: Vec<Vec<f64>> = vec![vec![]];
    for (_, g) in &nonlinear {
        points = points
            .iter()
            .flat_map(|pt| {
                g.iter().map(move |v| {
                    let mut q = pt.clone();
                    q.push(*v);
                    q
                })
            })
            .collect();
    }
    (nonlinear, dims, points)
}

/// Gridded variables with their values, the grid sizes, and the grid points.
pub(super) type GridPoints = (Vec<(usize, Vec<f64>)>, Vec<usize>, Vec<Vec<f64>>);

/// Per row, the data f_r and the weight that linearises the loss around it (parameter-free):
/// for the log loss r ≈ cosθi Δf / (1 + cosθi f), so w = (cosθi / (1 + cosθi f))².
pub(super) fn linearised_data(p: &BrdfProblem, loss: Loss) -> (Vec<f64>, Vec<f64>) {
    (0..p.rows.len())
        .map(|i| {
            let r = p.rows.get(i);
            let fd = match loss {
                Loss::Log => r.target.exp_m1() / r.cos_i,
                Loss::Linear => r.target,
            };
            let w = match loss {
                Loss::Log => (r.cos_i / (1.0 + r.cos_i * fd)).powi(2),
                Loss::Linear => 1.0,
            } * r.sw
                * r.sw;
            (fd, w)
        })
        .unzip()
}

/// Non-negative least squares with two unknowns from the normal equations
/// [a11 a12; a12 a22] x = [b1; b2]: the unconstrained solution if it is non-negative, else
/// the better of the two faces. An unknown that is not free stays 0.
pub(super) fn nonnegative_2x2([a11, a12, a22, b1, b2]: [f64; 5], free: (bool, bool)) -> (f64, f64) {
    let solve1 = |a: f64, b: f64| if a > 0.0 { (b / a).max(0.0) } else { 0.0 };
    match free {
        (true, true) => {
            let det = a11 * a22 - a12 * a12;
            let (x1, x2) = if det > 1e-300 {
                ((b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det)
            } else {
                (-1.0, -1.0)
            };
            if x1 >= 0.0 && x2 >= 0.0 && x1.is_finite() && x2.is_finite() {
                return (x1, x2);
            }
            let c1 = (solve1(a11, b1), 0.0);
            let c2 = (0.0, solve1(a22, b2));
            let q = |(u, v): (f64, f64)| {
                a11 * u * u + 2.0 * a12 * u * v + a22 * v * v - 2.0 * (b1 * u + b2 * v)
            };
            if q(c1) <= q(c2) { c1 } else { c2 }
        }
        (true, false) => (solve1(a11, b1), 0.0),
        (false, true) => (0.0, solve1(a22, b2)),
        (false, false) => (0.0, 0.0),
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The weighted sums of the two-parameter linear problem y ≈ ps s + pd/π of the global
    /// initialisation, y = f_data − ps_fixed s − pd_fixed/π: [Σws², Σws/π, Σw/π², Σwsy, Σwy/π,
    /// Σwy²] of a basis s; `wf` holds w·f_data and `k` the sums free of s ([`basis_free_sums`]).
    fn linear_sums(s: &[f64], w: &[f64], wf: &[f64], k: [f64; 3], fixed: (f64, f64)) -> [f64; 6] {
        combine_sums(basis_sums(s, w, wf), k, fixed)
    }

    /// The lane sums of the global initialisation equal plain sums written out here, for
    /// lengths with and without a partial last block and with fixed ps and pd.
    #[test]
    fn linear_sums_match_plain_sums() {
        let d = std::f64::consts::FRAC_1_PI;
        for m in [0, 1, 7, 8, 9, 500, 1003] {
            let s: Vec<f64> = (0..m)
                .map(|i| (0.37 * i as f64).sin().abs() * 3.0)
                .collect();
            let fd: Vec<f64> = (0..m)
                .map(|i| 0.1 + (0.11 * i as f64).cos().powi(2))
                .collect();
            let w: Vec<f64> = (0..m).map(|i| 1.0 / (1.0 + i as f64 % 5.0)).collect();
            for (ps, pd) in [(0.0, 0.0), (0.4, 0.0), (0.0, 0.6), (0.4, 0.6)] {
                let mut want = [0.0; 6];
                for i in 0..m {
                    let y = fd[i] - ps * s[i] - pd * d;
                    let t = [s[i] * s[i], s[i] * d, d * d, s[i] * y, d * y, y * y];
                    for k in 0..6 {
                        want[k] += w[i] * t[k];
                    }
                }
                let wf: Vec<f64> = w.iter().zip(&fd).map(|(w, f)| w * f).collect();
                let k = basis_free_sums(&w, &fd);
                let got = linear_sums(&s, &w, &wf, k, (ps, pd));
                for k in 0..6 {
                    let tol = 1e-13 * want[k].abs().max(1e-300);
                    assert!(
                        (got[k] - want[k]).abs() <= tol,
                        "m={m} k={k}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    /// The tabulated sums of Torrance–Sparrow's separable basis equal, point by point, the
    /// sums of the basis evaluated through the model (problem::brdf_values), for D3 and D1.
    #[test]
    fn separable_grid_sums_match_the_model_point_by_point() {
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
        let rows = Rows::from(rows);
        let m = rows.len();
        let w: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 / 7.0).collect();
        let wf: Vec<f64> = (0..m).map(|i| w[i] * (0.2 + (i % 5) as f64)).collect();
        for dist in [Distribution::D3, Distribution::D1] {
            let specs = ModelKind::TorranceSparrow.params(dist);
            let (ns, cs) = (specs[0].grid_values(), specs[1].grid_values());
            let factors = TsFactors::new(&rows, dist, &ns, &cs);
            let table = factors.grid_sums(&w, &wf);
            assert_eq!(table.len(), ns.len() * cs.len());
            for (i, n) in ns.iter().enumerate() {
                for (j, c) in cs.iter().enumerate() {
                    let model =
                        Model::new(ModelKind::TorranceSparrow, dist, &[*n, *c, 1.0, 0.0]).unwrap();
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
                            "{dist:?} n={n} c={c} sum {k}: {} vs {}",
                            got[k],
                            want[k]
                        );
                    }
                }
            }
        }
    }
}

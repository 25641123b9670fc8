//! Non-negative linear least squares for the linear coefficients: the active-set solve of
//! ½ cᵀGc − hᵀc over c ≥ 0 with some coefficients held ([`linear_solve`], [`nnls`]), and its
//! allocation-free 3 × 3 forms for two lobes ([`positive_solve3`], [`nnls3`]).

use crate::fit::lsq;

/// The linear coefficients that minimise ½ cᵀGc − hᵀc (the weighted linear least squares of
/// [`super::linear::gram_sums`]) with the held coefficients (`free` false) at their values in `c`
/// and the free ones ≥ 0 ([`nnls`]); at most [`LINEAR_MAX`] coefficients.
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
                // Zero up to the rounding of this step (relative: the data may be of any scale).
                let tiny = 1e-15 * x[i].abs().max(z[i].abs());
                x[i] += alpha * (z[i] - x[i]);
                if passive[i] && x[i] <= tiny {
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
/// passed over. [`nnls`]'s answer without its allocations, for the two-lobe prescreen's
/// points where [`positive_solve3`] declines ([`super::two_lobe`]).
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

#[cfg(test)]
mod tests {
    use super::*;

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
}

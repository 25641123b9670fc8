//! The pieces every step of the bound-constrained methods uses: the damped Cholesky solve,
//! the box with its active set and projection, Marquardt's scaling and the gradient test.

use super::problem::Normal;

/// Solve (A + μ diag(D)) h = −g by Cholesky with Jacobi scaling on the variables not in the
/// active set (whose step is 0); `None` if not positive definite. The factorisation is
/// Cholesky–Banachiewicz in one buffer (Golub & Van Loan, Matrix Computations, 4th ed.,
/// Algorithm 4.2.1), the matrices being a few parameters wide.
pub(crate) fn damped_solve(
    a: &[f64],
    g: &[f64],
    d: &[f64],
    mu: f64,
    active: &[bool],
) -> Option<Vec<f64>> {
    let n = g.len();
    debug_assert!(a.len() == n * n && d.len() == n && active.len() == n);
    // The work space: L (n × n), then h and s; on the stack for a few parameters (the
    // initialisation solves hundreds of small systems per fit), else on the heap.
    let mut small = [0.0; SMALL * SMALL + 2 * SMALL];
    let mut large = Vec::new();
    let work: &mut [f64] = if n <= SMALL {
        &mut small[..n * n + 2 * n]
    } else {
        large.resize(n * n + 2 * n, 0.0);
        &mut large
    };
    let (l, hs) = work.split_at_mut(n * n);
    let (h, s) = hs.split_at_mut(n);
    // Scale by s_i = 1/√d_i so the scaled matrix has a unit-ish diagonal: better conditioned.
    for ((hi, si), v) in h.iter_mut().zip(s.iter_mut()).zip(d) {
        *hi = 1.0 / v.sqrt();
        *si = *hi;
    }
    // The scaled, damped matrix, then its factor L in place (lower triangle, row-major).
    for i in 0..n {
        for j in 0..=i {
            let mut v = if active[i] || active[j] {
                if i == j { 1.0 } else { 0.0 }
            } else {
                a[i * n + j] * s[i] * s[j]
            };
            if i == j {
                v += mu;
            }
            for k in 0..j {
                v -= l[i * n + k] * l[j * n + k];
            }
            l[i * n + j] = if i == j {
                if !(v > 0.0) {
                    return None;
                }
                v.sqrt()
            } else {
                v / l[j * n + j]
            };
        }
    }
    // L y = rhs, then Lᵀ z = y, in place in `h`; the step is s ∘ z.
    for i in 0..n {
        let mut v = if active[i] { 0.0 } else { -g[i] * s[i] };
        for k in 0..i {
            v -= l[i * n + k] * h[k];
        }
        h[i] = v / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut v = h[i];
        for k in i + 1..n {
            v -= l[k * n + i] * h[k];
        }
        h[i] = v / l[i * n + i];
    }
    for (v, si) in h.iter_mut().zip(&*s) {
        *v *= si;
    }
    h.iter().all(|v| v.is_finite()).then(|| h.to_vec())
}

/// Systems of at most this many unknowns are solved by [`damped_solve`] without a heap work
/// space.
const SMALL: usize = crate::model::MAX_PARAMS;

/// Where `x` sits on its box: −1 at the lower bound, +1 at the upper, 0 inside. The
/// tolerance is relative to the bound (a bound of 0 is met only exactly, as the projection
/// puts a variable there): an absolute one took ps = 1e-13 of data scaled by 1e-12 for 0.
pub fn bound_side(x: f64, (lo, hi): (f64, f64)) -> i8 {
    let tol = |b: f64| 1e-12 * b.abs();
    if x <= lo + tol(lo) {
        -1
    } else if x >= hi - tol(hi) {
        1
    } else {
        0
    }
}

/// The active set of Bertsekas' projected Newton method (SIAM J. Control Optim. 20, 1982):
/// the variables at a bound whose cost gradient `g` points out of the box, so that no descent
/// step can move them. A variable at a bound whose gradient points inward is free and leaves it.
pub fn active_set(x: &[f64], g: &[f64], bounds: &[(f64, f64)]) -> Vec<bool> {
    (0..x.len())
        .map(|i| match bound_side(x[i], bounds[i]) {
            -1 => g[i] >= 0.0,
            1 => g[i] <= 0.0,
            _ => false,
        })
        .collect()
}

/// Clamp `x` onto the box.
pub(crate) fn project(x: &mut [f64], bounds: &[(f64, f64)]) {
    for (v, (lo, hi)) in x.iter_mut().zip(bounds) {
        *v = v.clamp(*lo, *hi);
    }
}

/// Marquardt's diagonal scaling: JᵀJ's diagonal, each variable's own; a zero (or non-finite)
/// entry takes the largest (Moré, "The Levenberg–Marquardt algorithm", 1978, §6, takes 1).
/// Not floored relative to the other variables: the columns of a shape parameter and of a
/// linear one differ by the square of the data's scale (10⁻²⁴ for data scaled by 10⁻¹²), and
/// such a floor froze the shape parameter there.
pub(super) fn scale_diag(n: &Normal, dim: usize) -> Vec<f64> {
    let diag = |i: usize| n.jtj[i * dim + i];
    let maxd = (0..dim)
        .map(diag)
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let maxd = if maxd > 0.0 { maxd } else { 1.0 };
    (0..dim)
        .map(|i| {
            let v = diag(i);
            if v > 0.0 && v.is_finite() { v } else { maxd }
        })
        .collect()
}

/// The scaled-gradient convergence test on the free variables (the projected gradient):
/// max |(Jᵀr)_i|/√d_i ≤ gtol·√(2 cost), or a zero cost.
pub(super) fn gradient_small(ne: &Normal, d: &[f64], gtol: f64, active: &[bool]) -> bool {
    let gmax = d
        .iter()
        .zip(&ne.jtr)
        .zip(active)
        .filter(|(_, a)| !**a)
        .map(|((di, g), _)| g.abs() / di.sqrt())
        .fold(0.0f64, f64::max);
    gmax <= gtol * (2.0 * ne.cost).sqrt().max(1e-300) || ne.cost == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `damped_solve` on symmetric positive definite systems of 2 to 12 unknowns (the stack
    /// work space up to 8, the heap beyond), some variables in the active set: its step solves
    /// the free rows of A h = −g with the active variables at 0, to 1e-10 (the residual
    /// computed here, row by row).
    #[test]
    fn damped_solve_solves_the_free_rows_on_the_stack_and_the_heap() {
        for n in [2, 7, 8, 9, 12] {
            // A = BᵀB + I with B's entries spread by a sine (no two rows alike).
            let b: Vec<f64> = (0..n * n).map(|k| (1.7 * k as f64 + 0.3).sin()).collect();
            let a: Vec<f64> = (0..n * n)
                .map(|ij| {
                    let (i, j) = (ij / n, ij % n);
                    let dot: f64 = (0..n).map(|r| b[r * n + i] * b[r * n + j]).sum();
                    dot + if i == j { 1.0 } else { 0.0 }
                })
                .collect();
            let g: Vec<f64> = (0..n).map(|i| (0.9 * i as f64).cos() - 0.2).collect();
            let d: Vec<f64> = (0..n).map(|i| a[i * n + i]).collect();
            for active in [vec![false; n], (0..n).map(|i| i % 3 == 1).collect()] {
                let h = damped_solve(&a, &g, &d, 0.0, &active).expect("positive definite");
                assert_eq!(h.len(), n);
                for i in 0..n {
                    if active[i] {
                        assert_eq!(h[i], 0.0, "n {n}: active {i}");
                        continue;
                    }
                    let row: f64 = (0..n).map(|j| a[i * n + j] * h[j]).sum();
                    assert!(
                        (row + g[i]).abs() <= 1e-10,
                        "n {n} row {i}: {row} against {}",
                        -g[i]
                    );
                }
            }
        }
    }
}

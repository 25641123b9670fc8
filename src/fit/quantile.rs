//! Quantiles of Student's t distribution, for the confidence level of a profile-likelihood
//! interval: the F(1, ν) quantile at level L is the square of t's at (1 + L)/2.

/// ln Γ(x) for x > 0 (Lanczos' approximation, g = 7, n = 9; relative error below 1e-15 on the
/// half-integers used here).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The continued fraction of the regularised incomplete beta function (modified Lentz;
/// Press et al., "Numerical Recipes", 3rd ed., §6.4, `betacf`).
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..400 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularised incomplete beta function I_x(a, b) (Press et al., §6.4, `betai`).
fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

/// P(|T| > t) for Student's t with `nu` degrees of freedom: I_{ν/(ν+t²)}(ν/2, ½)
/// (Abramowitz & Stegun 26.7.1 with 26.5.27).
pub fn t_two_sided(t: f64, nu: f64) -> f64 {
    incomplete_beta(0.5 * nu, 0.5, nu / (nu + t * t))
}

/// The two-sided quantile of Student's t with `nu` (≥ 1) degrees of freedom at `level`
/// (0.95: t with P(|T| ≤ t) = 0.95), by bisection on `t_two_sided` to 1e-12; the normal
/// quantile where ν is not finite or above 1e7.
pub fn t_quantile(level: f64, nu: f64) -> f64 {
    let alpha = 1.0 - level;
    let nu = if nu.is_finite() {
        nu.clamp(1.0, 1e7)
    } else {
        1e7
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while t_two_sided(hi, nu) > alpha && hi < 1e12 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if t_two_sided(mid, nu) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the printed tables of Student's t (Abramowitz & Stegun, Table 26.10, two-sided
    /// 5 %): ν = 1: 12.706, 2: 4.303, 6: 2.447, 10: 2.228, 30: 2.042, 120: 1.980, ∞: 1.960.
    #[test]
    fn t_quantiles_match_the_tables() {
        for (nu, want) in [
            (1.0, 12.706_2),
            (2.0, 4.302_7),
            (6.0, 2.446_9),
            (10.0, 2.228_1),
            (30.0, 2.042_3),
            (120.0, 1.979_9),
            (f64::INFINITY, 1.960_0),
        ] {
            let got = t_quantile(0.95, nu);
            assert!((got - want).abs() < 1e-4, "ν {nu}: {got} vs {want}");
        }
        // ν = 1 is the Cauchy distribution: P(|T| > t) = 1 − (2/π) atan t, exactly.
        for t in [0.3, 1.0, 4.0] {
            let want = 1.0 - 2.0 / std::f64::consts::PI * f64::atan(t);
            assert!((t_two_sided(t, 1.0) - want).abs() < 1e-12, "{t}");
        }
    }
}

//! The exact unpolarised Fresnel reflectance of Blinn's Torrance–Sparrow model (Blinn 1977),
//! its derivative in the index, its trigonometric form, the index ↔ F0 conversions and its GLSL.

/// Exact unpolarized Fresnel reflectance, Blinn's compact form with the factor ½:
/// F = ½ (g−c)²/(g+c)² [1 + (c(g+c)−1)²/(c(g−c)+1)²], g = √(n² + c² − 1), c = E·H.
///
/// Equal to [`fresnel_trig`] (Blinn 1977, "Torrance-Sparrow model"); F(c=1) = ((n−1)/(n+1))²,
/// F(c=0) = 1. Valid for n ≥ 1.
pub fn fresnel(n: f64, c: f64) -> f64 {
    fresnel_dn(n, c).0
}

/// Fresnel reflectance and its derivative with respect to `n` (see [`fresnel`]).
#[inline(always)]
pub fn fresnel_dn(n: f64, c: f64) -> (f64, f64) {
    let c = c.clamp(0.0, 1.0);
    let g = (n * n + c * c - 1.0).max(0.0).sqrt();
    let gp = g + c;
    if gp <= 0.0 {
        return (1.0, 0.0);
    }
    let gm = g - c;
    let igp = 1.0 / gp;
    let q = gm * igp;
    let a = q * q;
    let u = c * gp - 1.0;
    let v = c * gm + 1.0;
    let iv = 1.0 / v;
    let t = u * iv;
    let b = t * t;
    let f = 0.5 * a * (1.0 + b);
    // dA/dg = 4c(g−c)/(g+c)³, dB/dg = 4c(1−c²)u/v³, dg/dn = n/g.
    let da = 4.0 * c * q * igp * igp;
    let db = 4.0 * c * (1.0 - c * c) * t * iv * iv;
    let dn = if g > 0.0 {
        0.5 * (da * (1.0 + b) + a * db) * n / g
    } else {
        0.0
    };
    (f, dn)
}

/// Fresnel reflectance in the trigonometric form Blinn quotes:
/// F = ½ (sin²(φ−θ)/sin²(φ+θ) + tan²(φ−θ)/tan²(φ+θ)), sinθ = sinφ/n, φ = acos(c).
///
/// At normal incidence (0/0) it returns the limit ((n−1)/(n+1))².
pub fn fresnel_trig(n: f64, c: f64) -> f64 {
    let phi = c.clamp(0.0, 1.0).acos();
    if phi < 1e-6 {
        let r = (n - 1.0) / (n + 1.0);
        return r * r;
    }
    let theta = (phi.sin() / n).asin();
    let s = (phi - theta).sin() / (phi + theta).sin();
    let t = (phi - theta).tan() / (phi + theta).tan();
    0.5 * (s * s + t * t)
}

/// Normal-incidence reflectance F0 = ((n−1)/(n+1))².
pub fn f0_from_n(n: f64) -> f64 {
    let r = (n - 1.0) / (n + 1.0);
    r * r
}

/// Inverse of [`f0_from_n`]: n = (1 + √F0)/(1 − √F0) for 0 ≤ F0 < 1.
pub fn n_from_f0(f0: f64) -> f64 {
    let s = f0.clamp(0.0, 1.0).sqrt();
    (1.0 + s) / (1.0 - s)
}

/// GLSL of the exact Fresnel factor `F` of index `n` at `EdotH` ([`fresnel`], Blinn 1977
/// eq. for F), squares written as products: GLSL's `pow` is undefined for a negative base, and
/// (c(g + c) − 1)/(c(g − c) + 1) is negative below E·H ≈ 0.55 at n = 1.5.
pub(crate) const GLSL_FRESNEL: &str = "    float g = sqrt(n * n + EdotH * EdotH - 1.0);\n    float fa = (g - EdotH) / (g + EdotH);\n    float fb = (EdotH * (g + EdotH) - 1.0) / (EdotH * (g - EdotH) + 1.0);\n    float F = 0.5 * fa * fa * (1.0 + fb * fb);\n";

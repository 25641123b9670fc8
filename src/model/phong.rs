//! Phong's model (Phong 1975): i = pd N·L + ps max(0, R·E)^c1, R = 2(N·L)N − L; and Blinn's
//! form of it (Blinn 1977, his D1 as a highlight): i = pd N·L + ps max(0, N·H)^c1.

use super::distribution::alpha_of_power;
use super::param::C1;
use super::{Distribution, Geometry, Material, Model, PD, PS, ParamSpec};
use std::f64::consts::FRAC_1_PI;

/// Which cosine the highlight raises to c1: Phong's or Blinn's (the model kind's dispatch
/// says which, so this file need not know the kinds).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Highlight {
    /// R·E, R = 2(N·L)N − L (`phong`).
    Mirror,
    /// N·H (`blinn-phong`).
    Half,
}

/// A GGX plastic with the Beckmann-matched roughness of c1 (no Fresnel term: index 1.5).
pub(super) fn material(m: &Model) -> Material {
    super::blinn_material(
        Some(alpha_of_power(m.p[0])),
        None,
        m.p[2],
        "Phong's cosine power (alpha = sqrt(2/(c1 + 2)), Walter et al. 2007)",
    )
}

/// The highlight x^c1 with x = R·E or N·H.
pub(super) fn glsl(h: Highlight) -> String {
    if h == Highlight::Mirror {
        "    vec3 R = reflect(-L, N);\n    float s = pow(max(dot(R, V), 0.0), c1);\n    return vec3(pd / PI + ps * s / (PI * NdotL));".into()
    } else {
        "    vec3 H = normalize(L + V);\n    float s = pow(max(dot(N, H), 0.0), c1);\n    return vec3(pd / PI + ps * s / (PI * NdotL));".into()
    }
}

/// The parameters: c1, ps, pd.
pub(super) fn params(_: Distribution) -> &'static [ParamSpec] {
    &[C1, PS, PD]
}

/// f_r = pd/π + ps x^c1/(π N·L) with x = R·E (Phong) or N·H (Blinn–Phong), and its gradient.
#[inline(always)]
pub(super) fn brdf_grad(m: &Model, h: Highlight, g: &Geometry, grad: &mut [f64]) -> f64 {
    let (c1, ps, pd) = (m.p[0], m.p[1], m.p[2]);
    let x = if h == Highlight::Mirror { g.re } else { g.nh };
    let (s, ds) = if x <= 0.0 {
        (0.0, 0.0)
    } else if let (Some(k), Highlight::Mirror) = (m.fast_pow, h) {
        fast_phong_pow_da(x, c1, k)
    } else {
        let s = x.powf(c1);
        (s, s * x.ln())
    };
    let w = FRAC_1_PI / g.nl;
    grad[0] = ps * ds * w;
    grad[1] = s * w;
    grad[2] = FRAC_1_PI;
    pd * FRAC_1_PI + ps * s * w
}

/// Phong's fast power from the Phong article: max(0, x)^α ≈ max(0, 1 − βλ)^γ with λ = 1 − x,
/// γ = 2^k and β = α/γ, computed by squaring k times (Lyon 1993).
///
/// Measured against `powf` for x ∈ [0, 1] and α = 64…1000 (test `fast_phong_error`): the
/// maximum absolute error is 0.074 for k = 2, 0.035 for k = 3, 0.017 for k = 4, 0.0083 for
/// k = 5 and 0.0040 for k = 6 — it halves with each k — provided α ≥ γ (β ≥ 1). It is largest on
/// the flank of the lobe, never at the peak (both are 1 at x = 1). For α < γ the error grows again
/// (k = 6 with α = 16 reaches 0.013), so pick γ ≤ α.
pub fn fast_phong_pow(x: f64, alpha: f64, k: u32) -> f64 {
    fast_phong_pow_da(x, alpha, k).0
}

/// [`fast_phong_pow`] and its derivative with respect to the exponent α.
pub fn fast_phong_pow_da(x: f64, alpha: f64, k: u32) -> (f64, f64) {
    let gamma = (1u64 << k.min(30)) as f64;
    let lambda = 1.0 - x.min(1.0);
    let t = 1.0 - alpha / gamma * lambda;
    if t <= 0.0 {
        return (0.0, 0.0);
    }
    let mut p = t; // t^(2^j)
    for _ in 0..k.min(30) {
        p *= p;
    }
    // d/dα t^γ = γ t^(γ−1) · (−λ/γ) = −λ t^γ / t.
    (p, -lambda * p / t)
}

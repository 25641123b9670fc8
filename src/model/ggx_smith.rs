//! The GGX–Smith microfacet model modern renderers use (Walter, Marschner, Li, Torrance,
//! "Microfacet models for refraction through rough surfaces", EGSR 2007):
//!
//! f_r = pd/π + ps · F(n, E·H) · D(H) · G1(L) · G1(E) / (4 (N·L)(N·E)),
//!
//! with the normalised GGX distribution D(H) = α² / (π (N·H)⁴ (α² + tan²θh)²) (Walter et al.
//! eq. 33), the separable Smith masking G1(v) = 2 / (1 + √(1 + α² tan²θv)) for H·v > 0 (eq. 34)
//! and the same exact unpolarised Fresnel reflectance F as Blinn's Torrance–Sparrow model.
//! D's shape is Blinn's D3 with c3 = α (D3 = π α² D), so the initialisation grid maps lobe
//! half-widths the way D3 does.

use super::{
    Distribution, Geometry, Grid, Material, MaterialKind, Model, PD, PS, ParamSpec, Role, Scale,
    fresnel_dn,
};
use std::f64::consts::{FRAC_1_PI, PI};

pub(super) const ALPHA: ParamSpec = ParamSpec {
    name: "alpha",
    role: Role::Shape,
    meaning: "GGX roughness α (the slope width of the normal distribution)",
    lo: 1e-4,
    hi: 1.0,
    scale: Scale::Log { offset: 0.0 },
    grid: Grid::HalfWidth(Distribution::D3),
    start: 0.3,
    random: (1e-3, 1.0),
    absurd_above: f64::INFINITY,
    slider: (0.001, 1.0),
};

/// The index of the Fresnel term, as in Torrance–Sparrow.
const N: ParamSpec = super::param::N;

/// The parameters: alpha, n, ps, pd.
pub(super) fn params(_: Distribution) -> &'static [ParamSpec] {
    &[ALPHA, N, PS, PD]
}

/// G1(v) = 2/(1 + √(1 + α² tan²θv)) at cosθv = `c`, and dG1/dα.
#[inline(always)]
fn smith_g1(alpha: f64, c: f64) -> (f64, f64) {
    let c2 = c * c;
    let tan2 = (1.0 - c2).max(0.0) / c2;
    let s = (1.0 + alpha * alpha * tan2).sqrt();
    let g = 2.0 / (1.0 + s);
    // dG1/dα = −2/(1 + s)² · α tan²θ / s.
    (g, -g * g * 0.5 * alpha * tan2 / s)
}

/// One normalised GGX–Smith lobe without its Fresnel factor, D(H; α) G1(L; α) G1(E; α) /
/// (4 N·L N·E) (Walter et al. 2007, eqs. 20, 33, 34), and its derivative with respect to α;
/// (0, 0) where N·H ≤ 0 or E·H ≤ 0. The caller makes sure N·L, N·E > 0.
#[inline(always)]
pub(super) fn lobe(alpha: f64, g: &Geometry) -> (f64, f64) {
    let nh = g.nh;
    if nh <= 0.0 || g.eh <= 0.0 {
        return (0.0, 0.0);
    }
    let a2 = alpha * alpha;
    let nh2 = nh * nh;
    let tan2 = (1.0 - nh2).max(0.0) / nh2;
    let q = a2 + tan2;
    let d = a2 / (PI * nh2 * nh2 * q * q);
    let dd = d * (2.0 / alpha - 4.0 * alpha / q);
    let (gl, dgl) = smith_g1(alpha, g.nl);
    let (ge, dge) = smith_g1(alpha, g.ne);
    let w = 1.0 / (4.0 * g.nl * g.ne);
    (
        d * gl * ge * w,
        w * (dd * gl * ge + d * (dgl * ge + gl * dge)),
    )
}

/// f_r and its gradient with respect to (alpha, n, ps, pd).
#[inline(always)]
pub(super) fn brdf_grad(m: &Model, g: &Geometry, grad: &mut [f64]) -> f64 {
    let (alpha, n, ps, pd) = (m.p[0], m.p[1], m.p[2], m.p[3]);
    grad[3] = FRAC_1_PI;
    if g.nh <= 0.0 || g.eh <= 0.0 {
        return pd * FRAC_1_PI;
    }
    let (s, ds) = lobe(alpha, g);
    let (f, df) = fresnel_dn(n, g.eh);
    let spec = f * s;
    grad[0] = ps * f * ds;
    grad[1] = ps * df * s;
    grad[2] = spec;
    pd * FRAC_1_PI + ps * spec
}

/// Exactly Mitsuba 3's sum of `diffuse` and `roughconductor` (GGX, separable Smith G1·G1,
/// eta = n, k = 0 — a conductor with k = 0 has the dielectric Fresnel reflectance).
pub(super) fn material(m: &Model) -> Material {
    Material {
        kind: MaterialKind::DiffusePlusConductor {
            diffuse: m.p[3],
            alpha: m.p[0],
            eta: m.p[1],
            scale: m.p[2],
        },
        exact: true,
        differs: String::new(),
    }
}

/// GLSL shared by the GGX–Smith lobes: H, N·H, E·H and tan² of θh, θl, θv (the exact Fresnel
/// `F` follows from [`super::GLSL_FRESNEL`]).
pub(super) const GLSL_SHARED: &str = "    vec3 H = normalize(L + V);\n    float NdotH = dot(N, H);\n    float EdotH = dot(V, H);\n    float t2 = (1.0 - NdotH * NdotH) / (NdotH * NdotH);\n    float tl = (1.0 - NdotL * NdotL) / (NdotL * NdotL);\n    float tv = (1.0 - NdotV * NdotV) / (NdotV * NdotV);\n";

/// GLSL of one lobe without F ([`lobe`]): `S{tag} = D G1 G1 / (4 N·L N·V)` with roughness
/// uniform `alpha` (after [`GLSL_SHARED`]).
pub(super) fn glsl_lobe(alpha: &str, tag: &str) -> String {
    format!(
        "    float a2{tag} = {alpha} * {alpha};\n    float D{tag} = a2{tag} / (PI * NdotH * NdotH * NdotH * NdotH * (a2{tag} + t2) * (a2{tag} + t2));\n    float G{tag} = 4.0 / ((1.0 + sqrt(1.0 + a2{tag} * tl)) * (1.0 + sqrt(1.0 + a2{tag} * tv)));\n    float S{tag} = D{tag} * G{tag} / (4.0 * NdotL * NdotV);\n"
    )
}

/// F D G1 G1 / (4 N·L N·V).
pub(super) fn glsl(_: &Model) -> String {
    format!(
        "{GLSL_SHARED}{}{}    return vec3(pd / PI + ps * F * S);",
        super::GLSL_FRESNEL,
        glsl_lobe("alpha", "")
    )
}

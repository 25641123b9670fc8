//! Blinn's Torrance–Sparrow model (Blinn 1977, "Torrance-Sparrow model"):
//! i = pd N·L + ps D G F / (N·E), with the facet distributions D1–D3 or Löw et al.'s ABC lobe,
//! Blinn's V-groove G and the exact unpolarized Fresnel reflectance F.

use super::distribution::alpha_of_power;
use super::param::{C1, N};
use super::{
    Distribution, Geometry, Grid, Material, Model, PD, PS, ParamSpec, Role, Scale, abc_half_width,
    fresnel_dn,
};
use std::f64::consts::FRAC_1_PI;

pub(crate) const C2: ParamSpec = ParamSpec {
    name: "c2",
    role: Role::Shape,
    meaning: "inverse width of the Gaussian facet distribution D2 (1/radian)",
    lo: 1e-3,
    hi: 1e6,
    scale: Scale::Log { offset: 0.0 },
    grid: Grid::HalfWidth(Distribution::D2),
    start: 3.0,
    random: (0.6, 800.0),
    absurd_above: f64::INFINITY,
    slider: (0.01, 10.0),
};

pub(crate) const C3: ParamSpec = ParamSpec {
    name: "c3",
    role: Role::Shape,
    meaning: "eccentricity of the facet ellipsoids in D3 (smaller = sharper)",
    lo: 1e-5,
    hi: 1.0,
    scale: Scale::Log { offset: 0.0 },
    grid: Grid::HalfWidth(Distribution::D3),
    start: 0.5,
    random: (1e-3, 1.0),
    absurd_above: f64::INFINITY,
    slider: (0.001, 1.0),
};

/// ABC's b: the lobe's inverse width, D = (1 + b (1 − cos θh))^(−c) (Löw et al. 2012, eq. 6's
/// S(f) = A/(1 + B f)^C with f = 1 − cos θh, A = 1 so D(0) = 1 like D1–D3).
pub(crate) const B: ParamSpec = ParamSpec {
    name: "b",
    role: Role::Shape,
    meaning: "inverse width of the ABC facet distribution (Löw et al. 2012's B)",
    lo: 1e-3,
    hi: 1e9,
    scale: Scale::Log { offset: 0.0 },
    // Lobe half-widths 0.05°–70° at c = 2 (where D(β) = ½ at b (1 − cos β) = √2 − 1); another
    // c shifts them by √((2^(1/c) − 1)/(√2 − 1)), 0.18–4.7× over the grid of c below.
    grid: Grid::HalfWidth(Distribution::Abc),
    start: 100.0,
    random: (1.0, 1e5),
    absurd_above: f64::INFINITY,
    slider: (0.1, 1e4),
};

/// ABC's c: the exponent of the lobe's tail (c = 2 is close to D3; smaller is a heavier tail).
pub(crate) const C_ABC: ParamSpec = ParamSpec {
    name: "c",
    role: Role::Shape,
    meaning: "tail exponent of the ABC facet distribution (Löw et al. 2012's C; 2 ≈ D3)",
    lo: 0.05,
    hi: 50.0,
    scale: Scale::Log { offset: 0.0 },
    // Up to the bound: as c grows with b·c fixed, D tends to e^(−b c (1 − cos θh)), a
    // Gaussian lobe, and a material that wants one (Cornell acryl_blue) has its minimum at
    // c = 50, which a local fit from c ≤ 4 creeps towards for thousands of iterations.
    grid: Grid::Values(&[0.3, 0.5, 0.8, 1.2, 1.6, 2.0, 2.8, 4.0, 8.0, 16.0, 50.0]),
    start: 1.5,
    random: (0.3, 4.0),
    absurd_above: f64::INFINITY,
    slider: (0.1, 4.0),
};

/// The parameters: n, the distribution's shape parameter(s), ps, pd.
pub(super) fn params(dist: Distribution) -> &'static [ParamSpec] {
    match dist {
        Distribution::D1 => &[N, C1, PS, PD],
        Distribution::D2 => &[N, C2, PS, PD],
        Distribution::D3 => &[N, C3, PS, PD],
        Distribution::Abc => &[N, B, C_ABC, PS, PD],
    }
}

/// GGX α of the distribution: c3 for D3 (D3 = π c3² D_GGX); the Beckmann-matched
/// α = √(2/(c1 + 2)) for the cosine power D1 (Walter et al. 2007); √2/c2 for the Gaussian D2
/// (its slope width).
/// (its slope width); for ABC the c3 of D3 with the same half-width.
fn alpha(m: &Model) -> f64 {
    match m.dist {
        Distribution::D3 => m.p[1],
        Distribution::D2 => std::f64::consts::SQRT_2 / m.p[1],
        Distribution::D1 => alpha_of_power(m.p[1]),
        Distribution::Abc => Distribution::D3
            .param_from_beta(abc_half_width(m.p[1], m.p[2]))
            .clamp(1e-5, 1.0),
    }
}

/// A GGX plastic of index n, or aluminium when F0 > 0.5.
pub(super) fn material(m: &Model) -> Material {
    let lobe = match m.dist {
        Distribution::D1 => {
            "Blinn's D1 = cos^c1 (alpha = sqrt(2/(c1 + 2)), Walter et al. 2007)".to_string()
        }
        Distribution::D2 => {
            "Blinn's Gaussian D2 = exp(-(c2 theta_h)^2) (alpha = sqrt(2)/c2)".to_string()
        }
        Distribution::D3 => "Blinn's D3 with peak 1 (D3 = pi c3^2 D_GGX)".to_string(),
        Distribution::Abc => format!(
            "the ABC lobe (1 + b (1 - cos theta_h))^(-c) of Low et al. 2012 (alpha: the GGX with the same half-width; c = {} against GGX's 2, so the {} tail is lost)",
            super::short(m.p[2]),
            if m.p[2] < 2.0 { "heavier" } else { "lighter" }
        ),
    };
    super::blinn_material(Some(alpha(m)), Some(m.p[0]), m.pd(), &lobe)
}

/// D G F with the distribution's D, Blinn's G and the exact Fresnel F.
pub(super) fn glsl(m: &Model) -> String {
    let d = match m.dist {
        Distribution::D1 => "pow(NdotH, c1)",
        Distribution::D2 => "exp(-(acos(min(NdotH, 1.0)) * c2) * (acos(min(NdotH, 1.0)) * c2))",
        Distribution::D3 => {
            "(c3 * c3 / (NdotH * NdotH * (c3 * c3 - 1.0) + 1.0)) * (c3 * c3 / (NdotH * NdotH * (c3 * c3 - 1.0) + 1.0))"
        }
        Distribution::Abc => "pow(1.0 + b * (1.0 - NdotH), -c)",
    };
    format!(
        "    vec3 H = normalize(L + V);\n    float NdotH = dot(N, H);\n    float EdotH = dot(V, H);\n    float D = {d};\n    float G = min(1.0, min(2.0 * NdotH * NdotV / EdotH, 2.0 * NdotH * NdotL / EdotH));\n{}    return vec3(pd / PI + ps * D * G * F / (PI * NdotL * NdotV));",
        super::GLSL_FRESNEL
    )
}

/// f_r = pd/π + ps D F G/(π N·L N·E) and its gradient.
#[inline(always)]
pub(super) fn brdf_grad(m: &Model, g: &Geometry, grad: &mut [f64]) -> f64 {
    if m.dist == Distribution::Abc {
        return abc_brdf_grad(m, g, grad);
    }
    let (n, c, ps, pd) = (m.p[0], m.p[1], m.p[2], m.p[3]);
    let (d, dd) = m.dist.eval_dc(g.nh, c);
    let (f, df) = fresnel_dn(n, g.eh);
    let w = g.g_ne * FRAC_1_PI / g.nl;
    grad[0] = ps * d * df * w;
    grad[1] = ps * dd * f * w;
    grad[2] = d * f * w;
    grad[3] = FRAC_1_PI;
    pd * FRAC_1_PI + ps * d * f * w
}

/// [`brdf_grad`] with ABC's D = (1 + b (1 − cos θh))^(−c) (Löw et al. 2012, eq. 6 with
/// A = 1): parameters (n, b, c, ps, pd); ∂D/∂b = −c (1 − cos θh) D/(1 + b (1 − cos θh)),
/// ∂D/∂c = −ln(1 + b (1 − cos θh)) D.
#[inline(always)]
fn abc_brdf_grad(m: &Model, g: &Geometry, grad: &mut [f64]) -> f64 {
    let (n, b, c, ps, pd) = (m.p[0], m.p[1], m.p[2], m.p[3], m.p[4]);
    let x = 1.0 - g.nh.clamp(0.0, 1.0);
    let u = 1.0 + b * x;
    let lu = u.ln();
    let d = (-c * lu).exp();
    let (f, df) = fresnel_dn(n, g.eh);
    let w = g.g_ne * FRAC_1_PI / g.nl;
    let s = ps * f * w;
    grad[0] = ps * d * df * w;
    grad[1] = -s * c * x * d / u;
    grad[2] = -s * lu * d;
    grad[3] = d * f * w;
    grad[4] = FRAC_1_PI;
    pd * FRAC_1_PI + s * d
}

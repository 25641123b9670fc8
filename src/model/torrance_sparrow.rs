//! Blinn's Torrance–Sparrow model (Blinn 1977, "Torrance-Sparrow model"):
//! i = pd N·L + ps D G F / (N·E), with the facet distributions D1–D3 or Löw et al.'s ABC lobe,
//! Blinn's V-groove G and the exact unpolarized Fresnel reflectance F.

use super::{Geometry, Grid, Material, Model, PD, PS, ParamSpec, Role, Scale};
use std::f64::consts::FRAC_1_PI;

pub(crate) const N: ParamSpec = ParamSpec {
    name: "n",
    role: Role::Index,
    meaning: "index of refraction of the Fresnel term (Blinn 1977, eq. for F)",
    lo: 1.0 + 1e-4,
    hi: 1e7,
    scale: Scale::Log { offset: 1.0 },
    // n − 1 from 0.003 (F0 ≈ 2e-6) to 3000 (F0 ≈ 0.9987, a metal's effective index).
    grid: Grid::Values(&[
        1.003, 1.007, 1.015, 1.03, 1.06, 1.12, 1.25, 1.5, 2.0, 3.0, 5.0, 9.0, 17.0, 41.0, 101.0,
        401.0, 3001.0,
    ]),
    start: 1.5,
    random: (1.01, 101.0),
    absurd_above: 1e6,
    slider: (1.0, 10.0),
};

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
        Distribution::D1 => &[N, super::phong::C1, PS, PD],
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
        Distribution::D1 => super::phong::alpha_of_power(m.p[1]),
        Distribution::Abc => Distribution::D3
            .param_from_beta(abc_half_width(m.p[1], m.p[2]))
            .clamp(1e-5, 1.0),
    }
}

/// The half-angle β (radians) where ABC's D = (1 + b (1 − cos β))^(−c) falls to ½:
/// cos β = 1 − (2^(1/c) − 1)/b (π/2 where that is below 0).
pub fn abc_half_width(b: f64, c: f64) -> f64 {
    (1.0 - (2f64.powf(1.0 / c) - 1.0) / b)
        .clamp(0.0, 1.0)
        .acos()
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

/// Micro-facet distribution of Blinn 1977 ("Facet distribution functions"), or Löw et al.
/// 2012's ABC lobe in the same form; each with peak 1.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Distribution {
    /// D1 = cos^c1 α (Phong's distribution).
    D1,
    /// D2 = exp(−(α c2)²) (Gaussian, Torrance–Sparrow).
    D2,
    /// D3 = (c3² / (cos²α (c3² − 1) + 1))² (Trowbridge–Reitz; GGX with α = c3).
    #[default]
    D3,
    /// ABC = (1 + b (1 − cos α))^(−c) (Löw, Kronander, Ynnerman & Unger 2012, "BRDF models for
    /// accurate and efficient rendering of glossy surfaces", ACM TOG 31(1), eq. 6 with A = 1);
    /// two shape parameters, b and c.
    Abc,
}

impl Distribution {
    /// Name of the distribution's (first) shape parameter: `c1`, `c2`, `c3` or `b`.
    pub fn param_name(self) -> &'static str {
        match self {
            Distribution::D1 => "c1",
            Distribution::D2 => "c2",
            Distribution::D3 => "c3",
            Distribution::Abc => "b",
        }
    }

    /// Lower-case name (`d1`, `d2`, `d3`, `abc`).
    pub fn name(self) -> &'static str {
        match self {
            Distribution::D1 => "d1",
            Distribution::D2 => "d2",
            Distribution::D3 => "d3",
            Distribution::Abc => "abc",
        }
    }

    /// D at cos α = `nh` for the shape parameters `shape` in declared order (one for D1–D3;
    /// b and c for ABC). Inlined, so a loop over rows at one shape point (the initialisation's
    /// tables) sees one distribution's formula.
    #[inline]
    pub fn eval_shape(self, nh: f64, shape: &[f64]) -> f64 {
        match self {
            Distribution::Abc => {
                let x = 1.0 - nh.clamp(0.0, 1.0);
                (1.0 + shape[0] * x).powf(-shape[1])
            }
            _ => self.eval(nh, shape[0]),
        }
    }

    /// Parse `d1`, `d2`, `d3` or `abc`.
    pub fn parse(s: &str) -> Option<Self> {
        <Self as clap::ValueEnum>::from_str(s, true).ok()
    }

    /// D(α) at cos α = `nh` for shape parameter `c` (for ABC, c is b with the exponent 2; see
    /// [`Distribution::eval_shape`]).
    #[inline]
    pub fn eval(self, nh: f64, c: f64) -> f64 {
        self.eval_dc(nh, c).0
    }

    /// D and dD/dc at cos α = `nh`.
    #[inline(always)]
    pub fn eval_dc(self, nh: f64, c: f64) -> (f64, f64) {
        let nh = nh.clamp(0.0, 1.0);
        match self {
            Distribution::D1 => {
                if nh <= 0.0 {
                    return (0.0, 0.0);
                }
                let d = nh.powf(c);
                (d, d * nh.ln())
            }
            Distribution::D2 => {
                let a = nh.acos();
                let d = (-(a * c) * (a * c)).exp();
                (d, -2.0 * a * a * c * d)
            }
            Distribution::D3 => {
                let s = c * c;
                let x = nh * nh;
                let den = x * (s - 1.0) + 1.0;
                if den <= 0.0 {
                    return (0.0, 0.0);
                }
                let q = s / den;
                // dD/dc = 4 c³ (1 − x) / den³.
                (q * q, 4.0 * c * s * (1.0 - x) / (den * den * den))
            }
            Distribution::Abc => {
                let x = 1.0 - nh;
                let u = 1.0 + c * x;
                (1.0 / (u * u), -2.0 * x / (u * u * u))
            }
        }
    }

    /// The shape parameter for which D falls to ½ at half-angle `beta` (radians), Blinn's
    /// c1(β) = −ln2/ln cosβ, c2(β) = √ln2/β, c3(β) = ((cos²β − 1)/(cos²β − √2))^½; for ABC
    /// b(β) = (√2 − 1)/(1 − cosβ), the b whose lobe with c = 2 has half-width β.
    pub fn param_from_beta(self, beta: f64) -> f64 {
        let cb = beta.cos();
        match self {
            Distribution::D1 => -std::f64::consts::LN_2 / cb.ln(),
            Distribution::D2 => std::f64::consts::LN_2.sqrt() / beta,
            Distribution::D3 => {
                let x = cb * cb;
                ((x - 1.0) / (x - std::f64::consts::SQRT_2)).sqrt()
            }
            Distribution::Abc => (std::f64::consts::SQRT_2 - 1.0) / (1.0 - cb),
        }
    }
}

/// Blinn's texture-modulated D3 (Figure 8): C3 = Cmin + (1 − Cmin) t,
/// D3 = [Cmin C3 / (cos²α (C3² − 1) + 1)]², normalized by the surface's minimum `cmin`
/// so that the peak never exceeds 1 however the texture value `t` ∈ [0, 1] varies.
pub fn d3_textured(nh: f64, cmin: f64, t: f64) -> f64 {
    let c3 = cmin + (1.0 - cmin) * t.clamp(0.0, 1.0);
    let x = nh.clamp(0.0, 1.0).powi(2);
    let den = x * (c3 * c3 - 1.0) + 1.0;
    if den <= 0.0 {
        return 0.0;
    }
    let q = cmin * c3 / den;
    q * q
}

/// Blinn's Phong ((N·H)^c1, `blinn-phong`) with the same half-angle β as a torrance-sparrow
/// model's distribution, its ps set to ps·F0 so both highlights agree at normal incidence,
/// and the same pd: the "equal β" comparison of Blinn's Figures 5–7.
pub fn equal_beta_phong(ts: &Model) -> Model {
    let c = ts.p[1];
    let ps = ts.role(super::Role::Specular).unwrap_or(0.0);
    // β where the distribution falls to ½.
    let beta = match ts.dist {
        Distribution::D1 => (0.5f64).powf(1.0 / c).acos(),
        Distribution::D2 => std::f64::consts::LN_2.sqrt() / c,
        Distribution::D3 => {
            let s = c * c;
            ((s * std::f64::consts::SQRT_2 - 1.0) / (s - 1.0))
                .clamp(0.0, 1.0)
                .sqrt()
                .acos()
        }
        Distribution::Abc => abc_half_width(ts.p[1], ts.p[2]),
    };
    let c1 = Distribution::D1.param_from_beta(beta);
    Model {
        kind: super::ModelKind::BlinnPhong,
        dist: Distribution::D3,
        p: [
            c1,
            ps * f0_from_n(ts.p[0]),
            ts.pd(),
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ],
        fast_pow: None,
    }
}

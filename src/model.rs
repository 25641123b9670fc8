//! Reflection models of Phong (1975) and Blinn (1977), with analytic parameter gradients.
//!
//! # Conventions (fixed for the whole crate)
//! - θ is measured from the surface normal N = +z, φ is the azimuth.
//!   L = (sinθi cosφi, sinθi sinφi, cosθi); E likewise from (θo, φo); H = (L+E)/|L+E|.
//!   The mirror direction of (θi, φi) is (θi, φi + 180°).
//! - A model is Blinn's reflected intensity `i(L, E)` for a unit light; the BRDF is
//!   `f_r = i / (π N·L)`, so `pd` is the diffuse albedo. `f_r = 0` where N·L ≤ 0 or N·E ≤ 0.
//! - `lambert`: i = pd N·L.
//! - `phong`: i = pd N·L + ps max(0, R·E)^c1, R = 2(N·L)N − L (Phong's reflection model).
//! - `blinn-phong`: i = pd N·L + ps max(0, N·H)^c1 (Blinn's form of Phong, his D1).
//! - `torrance-sparrow`: i = pd N·L + ps D G F / (N·E) (Blinn 1977, "Torrance-Sparrow model"),
//!   with D3 (Trowbridge–Reitz, `c3`) by default, D2 (Gaussian, `c2`) or D1 (cosine power, `c1`);
//!   G the V-groove masking of Blinn's Figures 1–4 in his division-safe form; F the exact
//!   unpolarized Fresnel reflectance for index `n` at c = E·H, *with* the factor ½ of the
//!   trigonometric form (Blinn prints the compact form without it), so F(0) = ((n−1)/(n+1))².
//!
//! Blinn's `c3` equals the GGX roughness α of modern renderers: D3 = π c3² D_GGX.

use std::f64::consts::{FRAC_1_PI, PI};
use std::fmt;

/// Unit direction for polar angle `theta` and azimuth `phi` (radians), N = +z.
pub fn direction(theta: f64, phi: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [st * cp, st * sp, ct]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The parameter-independent dot products of one light/eye configuration.
///
/// Computed once per sample (fit) or per shading point (render); every model evaluates from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// N·L, cosine of the incidence angle.
    pub nl: f64,
    /// N·E, cosine of the viewing angle.
    pub ne: f64,
    /// N·H, cosine of the angle α between the normal and the half vector.
    pub nh: f64,
    /// E·H (= L·H), cosine of the incidence angle on the micro-facet.
    pub eh: f64,
    /// R·E with R = 2(N·L)N − L, Phong's mirror-direction cosine.
    pub re: f64,
    /// G/(N·E), Blinn's masking over the viewing cosine in his division-safe form
    /// ([`g_over_ne`]), cached because it does not depend on any model parameter.
    pub g_ne: f64,
}

impl Geometry {
    /// Geometry from the cosines N·L, N·E and L·E of unit vectors (N the surface normal).
    #[inline]
    pub fn from_cosines(nl: f64, ne: f64, le: f64) -> Self {
        // |L+E|² = 2 + 2 L·E; H·E = (1 + L·E)/|L+E|; N·H = (N·L + N·E)/|L+E|.
        // Written with selects rather than branches, so loops over many samples vectorise.
        let len2 = (2.0 + 2.0 * le).max(0.0);
        let ok = len2 > 1e-300;
        let inv = if ok {
            1.0 / (if ok { len2 } else { 1.0 }).sqrt()
        } else {
            0.0
        };
        let (nh, eh) = ((nl + ne) * inv, ((1.0 + le) * inv).max(0.0));
        let mut g = Geometry {
            nl,
            ne,
            nh: nh.clamp(-1.0, 1.0),
            eh: eh.min(1.0),
            re: 2.0 * nl * ne - le,
            g_ne: 0.0,
        };
        g.g_ne = g_over_ne(&g);
        g
    }

    /// Geometry from unit vectors: normal `n`, light `l` and eye `e`.
    pub fn from_vectors(n: [f64; 3], l: [f64; 3], e: [f64; 3]) -> Self {
        Self::from_cosines(dot(n, l), dot(n, e), dot(l, e))
    }

    /// Geometry for incidence (θi, φi) and view (θo, φo), in radians.
    pub fn from_angles(theta_i: f64, phi_i: f64, theta_o: f64, phi_o: f64) -> Self {
        // L·E = sinθi sinθo cos(φo − φi) + cosθi cosθo: three trigonometric calls.
        let (si, ci) = theta_i.sin_cos();
        let (so, co) = theta_o.sin_cos();
        Self::from_cosines(ci, co, si * so * (phi_o - phi_i).cos() + ci * co)
    }

    /// True where the BRDF is defined: light and eye both above the surface.
    #[inline]
    pub fn visible(&self) -> bool {
        self.nl > 0.0 && self.ne > 0.0
    }
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
#[inline]
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

/// Blinn's geometrical attenuation G = min(1, 2(N·H)(N·E)/(E·H), 2(N·H)(N·L)/(E·H)).
pub fn geometric_attenuation(g: &Geometry) -> f64 {
    if g.eh <= 0.0 {
        return 0.0;
    }
    let gb = 2.0 * g.nh * g.ne / g.eh;
    let gc = 2.0 * g.nh * g.nl / g.eh;
    1.0f64.min(gb).min(gc).max(0.0)
}

/// G/(N·E) in Blinn's division-safe form ("Computational considerations"): the minimum of
/// Ga, Gb, Gc is chosen before any division, so N·E → 0 never divides by zero where G → 0.
#[inline]
pub fn g_over_ne(g: &Geometry) -> f64 {
    let (nl, ne, nh, eh) = (g.nl, g.ne, g.nh, g.eh);
    // Pick the numerator and denominator of the smallest term first, then divide once:
    // Gb/N·E = 1/N·E; Ga/N·E = 2 N·H/E·H where N·E < N·L; Gc/N·E = 2 N·H N·L/(E·H N·E).
    let masked = 2.0 * ne.min(nl) * nh < eh;
    let (num, den) = match (masked, ne < nl) {
        (false, _) => (1.0, ne),
        (true, true) => (2.0 * nh, eh),
        (true, false) => (2.0 * nh * nl, eh * ne),
    };
    let ok = ne > 0.0 && nl > 0.0 && eh > 0.0;
    if ok {
        num / if ok { den } else { 1.0 }
    } else {
        0.0
    }
}

/// Micro-facet distribution of Blinn 1977 ("Facet distribution functions"), each with peak 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Distribution {
    /// D1 = cos^c1 α (Phong's distribution).
    D1,
    /// D2 = exp(−(α c2)²) (Gaussian, Torrance–Sparrow).
    D2,
    /// D3 = (c3² / (cos²α (c3² − 1) + 1))² (Trowbridge–Reitz; GGX with α = c3).
    #[default]
    D3,
}

impl Distribution {
    /// Name of the distribution's shape parameter: `c1`, `c2` or `c3`.
    pub fn param_name(self) -> &'static str {
        match self {
            Distribution::D1 => "c1",
            Distribution::D2 => "c2",
            Distribution::D3 => "c3",
        }
    }

    /// Lower-case name (`d1`, `d2`, `d3`).
    pub fn name(self) -> &'static str {
        match self {
            Distribution::D1 => "d1",
            Distribution::D2 => "d2",
            Distribution::D3 => "d3",
        }
    }

    /// Parse `d1`, `d2` or `d3`.
    pub fn parse(s: &str) -> Option<Self> {
        match s.to_ascii_lowercase().as_str() {
            "d1" => Some(Distribution::D1),
            "d2" => Some(Distribution::D2),
            "d3" => Some(Distribution::D3),
            _ => None,
        }
    }

    /// D(α) at cos α = `nh` for shape parameter `c`.
    pub fn eval(self, nh: f64, c: f64) -> f64 {
        self.eval_dc(nh, c).0
    }

    /// D and dD/dc at cos α = `nh`.
    #[inline]
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
        }
    }

    /// The shape parameter for which D falls to ½ at half-angle `beta` (radians), Blinn's
    /// c1(β) = −ln2/ln cosβ, c2(β) = √ln2/β, c3(β) = ((cos²β − 1)/(cos²β − √2))^½.
    pub fn param_from_beta(self, beta: f64) -> f64 {
        let cb = beta.cos();
        match self {
            Distribution::D1 => -std::f64::consts::LN_2 / cb.ln(),
            Distribution::D2 => std::f64::consts::LN_2.sqrt() / beta,
            Distribution::D3 => {
                let x = cb * cb;
                ((x - 1.0) / (x - std::f64::consts::SQRT_2)).sqrt()
            }
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

/// Which reflection model; the parameter set is [`ModelKind::param_names`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    /// Lambertian diffuse: i = pd N·L.
    Lambert,
    /// Phong: i = pd N·L + ps max(0, R·E)^c1.
    Phong,
    /// Blinn's form of Phong: i = pd N·L + ps max(0, N·H)^c1.
    BlinnPhong,
    /// Blinn's Torrance–Sparrow: i = pd N·L + ps D G F/(N·E).
    TorranceSparrow,
}

impl ModelKind {
    /// All model kinds, simplest first.
    pub const ALL: [ModelKind; 4] = [
        ModelKind::Lambert,
        ModelKind::Phong,
        ModelKind::BlinnPhong,
        ModelKind::TorranceSparrow,
    ];

    /// Command-line name: `lambert`, `phong`, `blinn-phong`, `torrance-sparrow`.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Lambert => "lambert",
            ModelKind::Phong => "phong",
            ModelKind::BlinnPhong => "blinn-phong",
            ModelKind::TorranceSparrow => "torrance-sparrow",
        }
    }

    /// Parse a command-line name (also accepts `ts`).
    pub fn parse(s: &str) -> Option<Self> {
        match s.to_ascii_lowercase().as_str() {
            "lambert" => Some(ModelKind::Lambert),
            "phong" => Some(ModelKind::Phong),
            "blinn-phong" | "blinnphong" => Some(ModelKind::BlinnPhong),
            "torrance-sparrow" | "ts" => Some(ModelKind::TorranceSparrow),
            _ => None,
        }
    }

    /// The parameters' declarations in their fixed order (see [`ParamSpec`]).
    pub fn params(self, dist: Distribution) -> &'static [ParamSpec] {
        match self {
            ModelKind::Lambert => &[PD],
            ModelKind::Phong | ModelKind::BlinnPhong => &[C1, PS, PD],
            ModelKind::TorranceSparrow => match dist {
                Distribution::D1 => &[N, C1, PS, PD],
                Distribution::D2 => &[N, C2, PS, PD],
                Distribution::D3 => &[N, C3, PS, PD],
            },
        }
    }

    /// Parameter names in their fixed order; for torrance-sparrow the shape parameter is
    /// named after the distribution (`c3` for D3).
    pub fn param_names(self, dist: Distribution) -> &'static [&'static str] {
        match self {
            ModelKind::Lambert => &["pd"],
            ModelKind::Phong | ModelKind::BlinnPhong => &["c1", "ps", "pd"],
            ModelKind::TorranceSparrow => match dist {
                Distribution::D1 => &["n", "c1", "ps", "pd"],
                Distribution::D2 => &["n", "c2", "ps", "pd"],
                Distribution::D3 => &["n", "c3", "ps", "pd"],
            },
        }
    }
}

impl fmt::Display for ModelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// How the fitter maps a parameter θ to its free solver variable u.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    /// θ = u: the parameter enters the model linearly (ps, pd) and its bounds are handled by
    /// the bound-constrained solver, so a value at a bound can leave it.
    Linear,
    /// θ = offset + e^u: a positive shape parameter spanning decades (c1, c2, c3 with offset 0;
    /// n with offset 1, so n − 1 is fitted on a log scale). dθ/du = θ − offset never vanishes
    /// inside the box.
    Log {
        /// The value θ approaches as u → −∞.
        offset: f64,
    },
}

/// Where the global initialisation's grid of a parameter comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Grid {
    /// No grid: the parameter enters linearly and is solved for at each grid point.
    Linear,
    /// Lobe half-widths [`HALF_WIDTHS_DEG`] mapped by a distribution's c(β) (Blinn 1977).
    HalfWidth(Distribution),
    /// Fixed values.
    Values(&'static [f64]),
}

/// The lobe half-widths (degrees) the initialisation grid spans, from mirror-sharp (well below
/// a goniometer's 1° step) to nearly diffuse.
pub const HALF_WIDTHS_DEG: [f64; 19] = [
    0.05, 0.1, 0.18, 0.3, 0.5, 0.8, 1.2, 1.8, 2.7, 4.0, 6.0, 9.0, 13.0, 18.0, 25.0, 33.0, 43.0,
    55.0, 70.0,
];

/// Everything the fitter, the CLI and the reports need to know about one model parameter,
/// declared once ([`ModelKind::params`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    /// Name as in `--set`, `--fix` and the JSON.
    pub name: &'static str,
    /// What it means, for help and reports.
    pub meaning: &'static str,
    /// Admissible range for fitting (natural units, inclusive).
    pub lo: f64,
    /// Upper end of the admissible range.
    pub hi: f64,
    /// Solver variable.
    pub scale: Scale,
    /// Global-initialisation grid.
    pub grid: Grid,
    /// Default start.
    pub start: f64,
    /// Range random starts are drawn from (log-uniform when both ends are positive).
    pub random: (f64, f64),
    /// A fitted value at or above this is not physically usable (e.g. n ≥ 1e6).
    pub absurd_above: f64,
}

impl ParamSpec {
    /// The grid values of the global initialisation (empty for linear parameters).
    pub fn grid_values(&self) -> Vec<f64> {
        match self.grid {
            Grid::Linear => vec![],
            Grid::Values(v) => v.to_vec(),
            Grid::HalfWidth(d) => HALF_WIDTHS_DEG
                .iter()
                .map(|b| d.param_from_beta(b.to_radians()).clamp(self.lo, self.hi))
                .collect(),
        }
    }
}

const PS: ParamSpec = ParamSpec {
    name: "ps",
    meaning: "specular coefficient",
    lo: 0.0,
    hi: f64::INFINITY,
    scale: Scale::Linear,
    grid: Grid::Linear,
    start: 0.5,
    random: (1e-2, 1e3),
    absurd_above: f64::INFINITY,
};
const PD: ParamSpec = ParamSpec {
    name: "pd",
    meaning: "diffuse coefficient (albedo of the Lambertian part)",
    lo: 0.0,
    hi: f64::INFINITY,
    scale: Scale::Linear,
    grid: Grid::Linear,
    start: 0.5,
    random: (1e-3, 1.0),
    absurd_above: f64::INFINITY,
};
const N: ParamSpec = ParamSpec {
    name: "n",
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
};
/// Exponent of a cosine lobe: Phong's and Blinn–Phong's c1, and D1's.
const C1: ParamSpec = ParamSpec {
    name: "c1",
    meaning: "exponent of the cosine lobe (larger = sharper)",
    lo: 1e-3,
    hi: 1e8,
    scale: Scale::Log { offset: 0.0 },
    grid: Grid::HalfWidth(Distribution::D1),
    start: 10.0,
    random: (0.3, 3e4),
    absurd_above: f64::INFINITY,
};
const C2: ParamSpec = ParamSpec {
    name: "c2",
    meaning: "inverse width of the Gaussian facet distribution D2 (1/radian)",
    lo: 1e-3,
    hi: 1e6,
    scale: Scale::Log { offset: 0.0 },
    grid: Grid::HalfWidth(Distribution::D2),
    start: 3.0,
    random: (0.6, 800.0),
    absurd_above: f64::INFINITY,
};
const C3: ParamSpec = ParamSpec {
    name: "c3",
    meaning: "eccentricity of the facet ellipsoids in D3 (smaller = sharper)",
    lo: 1e-5,
    hi: 1.0,
    scale: Scale::Log { offset: 0.0 },
    grid: Grid::HalfWidth(Distribution::D3),
    start: 0.5,
    random: (1e-3, 1.0),
    absurd_above: f64::INFINITY,
};

/// An invalid model specification, with the fix.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModelError {
    /// A parameter is missing from `--set`.
    #[error("model {model} needs parameter {name}: add --set {name}=VALUE")]
    Missing {
        /// Model name.
        model: &'static str,
        /// Parameter name.
        name: &'static str,
    },
    /// A parameter name the model does not have.
    #[error("model {model} has no parameter {name}; its parameters are {expected}")]
    Unknown {
        /// Model name.
        model: &'static str,
        /// Given name.
        name: String,
        /// Comma-separated valid names.
        expected: String,
    },
    /// A parameter value outside its bounds.
    #[error("parameter {name} = {value} is out of bounds: {bounds}")]
    OutOfBounds {
        /// Parameter name.
        name: &'static str,
        /// Given value.
        value: f64,
        /// Human-readable bounds.
        bounds: &'static str,
    },
}

/// Human-readable bounds of a parameter, and whether `v` satisfies them.
pub fn param_bounds(name: &str, v: f64) -> (bool, &'static str) {
    match name {
        "n" => (v >= 1.0 && v.is_finite(), "n ≥ 1 (index of refraction)"),
        "c3" => (v > 0.0 && v <= 1.0, "0 < c3 ≤ 1"),
        "c1" | "c2" => (v > 0.0 && v.is_finite(), "a positive finite number"),
        "ps" | "pd" => (v >= 0.0 && v.is_finite(), "a finite number ≥ 0"),
        _ => (v.is_finite(), "finite"),
    }
}

/// A reflection model with its parameter values: a small value type evaluated per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    /// Which model.
    pub kind: ModelKind,
    /// Facet distribution (used by torrance-sparrow only).
    pub dist: Distribution,
    /// Parameters in the order of [`ModelKind::param_names`]; unused trailing slots are 0.
    pub p: [f64; 4],
    /// Phong only: use the fast power approximation with γ = 2^k.
    pub fast_pow: Option<u32>,
}

impl Model {
    /// Model from parameter values in [`ModelKind::param_names`] order, checked against bounds.
    pub fn new(kind: ModelKind, dist: Distribution, params: &[f64]) -> Result<Self, ModelError> {
        let names = kind.param_names(dist);
        let mut p = [0.0; 4];
        for (i, name) in names.iter().enumerate() {
            let Some(&v) = params.get(i) else {
                return Err(ModelError::Missing {
                    model: kind.name(),
                    name,
                });
            };
            let (ok, bounds) = param_bounds(name, v);
            if !ok {
                return Err(ModelError::OutOfBounds {
                    name,
                    value: v,
                    bounds,
                });
            }
            p[i] = v;
        }
        Ok(Model {
            kind,
            dist,
            p,
            fast_pow: None,
        })
    }

    /// Model from `name=value` pairs; every parameter must be given exactly once.
    pub fn from_named(
        kind: ModelKind,
        dist: Distribution,
        set: &[(String, f64)],
    ) -> Result<Self, ModelError> {
        let names = kind.param_names(dist);
        for (k, _) in set {
            if !names.contains(&k.as_str()) {
                return Err(ModelError::Unknown {
                    model: kind.name(),
                    name: k.clone(),
                    expected: names.join(", "),
                });
            }
        }
        let mut vals = Vec::with_capacity(names.len());
        for name in names {
            match set.iter().rev().find(|(k, _)| k == name) {
                Some((_, v)) => vals.push(*v),
                None => {
                    return Err(ModelError::Missing {
                        model: kind.name(),
                        name,
                    });
                }
            }
        }
        Self::new(kind, dist, &vals)
    }

    /// Blinn's aluminium (Figure 7a): ps .4, pd .6, n 200, c3 .5.
    pub fn blinn_aluminium() -> Self {
        Self::new(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[200.0, 0.5, 0.4, 0.6],
        )
        .expect("valid constants")
    }

    /// Blinn's magnesium oxide (Figure 7b): ps .667, pd .333, n 1.8, c3 .35.
    pub fn blinn_mgo() -> Self {
        Self::new(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[1.8, 0.35, 0.667, 0.333],
        )
        .expect("valid constants")
    }

    /// Parameter names in order.
    pub fn param_names(&self) -> &'static [&'static str] {
        self.kind.param_names(self.dist)
    }

    /// Parameter values in order.
    pub fn params(&self) -> &[f64] {
        &self.p[..self.param_names().len()]
    }

    /// The diffuse coefficient pd (every model's last parameter).
    #[inline]
    pub fn pd(&self) -> f64 {
        self.p[self.param_names().len() - 1]
    }

    /// Value of the parameter `name`, if the model has it.
    pub fn get(&self, name: &str) -> Option<f64> {
        let i = self.param_names().iter().position(|n| *n == name)?;
        Some(self.p[i])
    }

    /// Same model with new parameter values (not bounds-checked; the fitter keeps them in bounds).
    pub fn with_params(&self, params: &[f64]) -> Self {
        let mut m = *self;
        let k = self.param_names().len();
        m.p[..k].copy_from_slice(&params[..k]);
        m
    }

    /// Blinn's reflected intensity i(L, E) for a unit light (0 where the BRDF is 0).
    pub fn intensity(&self, g: &Geometry) -> f64 {
        self.brdf(g) * PI * g.nl.max(0.0)
    }

    /// The BRDF f_r = i / (π N·L) in 1/sr.
    #[inline]
    pub fn brdf(&self, g: &Geometry) -> f64 {
        let mut scratch = [0.0; 4];
        self.brdf_grad(g, &mut scratch)
    }

    /// The BRDF and its gradient with respect to each parameter (written to `grad`, which must
    /// hold at least as many entries as the model has parameters).
    #[inline]
    pub fn brdf_grad(&self, g: &Geometry, grad: &mut [f64]) -> f64 {
        let k = self.param_names().len();
        grad[..k].iter_mut().for_each(|x| *x = 0.0);
        if !g.visible() {
            return 0.0;
        }
        let p = &self.p;
        match self.kind {
            ModelKind::Lambert => {
                grad[0] = FRAC_1_PI;
                p[0] * FRAC_1_PI
            }
            ModelKind::Phong | ModelKind::BlinnPhong => {
                let (c1, ps, pd) = (p[0], p[1], p[2]);
                let x = if self.kind == ModelKind::Phong {
                    g.re
                } else {
                    g.nh
                };
                let (s, ds) = if x <= 0.0 {
                    (0.0, 0.0)
                } else if let (Some(k), ModelKind::Phong) = (self.fast_pow, self.kind) {
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
            ModelKind::TorranceSparrow => {
                let (n, c, ps, pd) = (p[0], p[1], p[2], p[3]);
                let (d, dd) = self.dist.eval_dc(g.nh, c);
                let (f, df) = fresnel_dn(n, g.eh);
                let w = g.g_ne * FRAC_1_PI / g.nl;
                grad[0] = ps * d * df * w;
                grad[1] = ps * dd * f * w;
                grad[2] = d * f * w;
                grad[3] = FRAC_1_PI;
                pd * FRAC_1_PI + ps * d * f * w
            }
        }
    }
}
/// A number as a person reads it: 4 significant digits, in scientific notation (`3.554e7`)
/// when it is ≥ 1e5 or below 1e-3 in magnitude, never hundreds of digits.
pub fn readable(v: f64) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            "undefined".into()
        } else if v > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.3e}");
        // 3.500e7 → 3.5e7
        match s.split_once('e') {
            Some((m, e)) if m.contains('.') => {
                format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => s,
        }
    } else {
        short(v)
    }
}

/// A number with at most 4 significant digits, without trailing zeros (for labels).
pub fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Blinn's Phong ((N·H)^c1, `blinn-phong`) with the same half-angle β as a torrance-sparrow
/// model's distribution, its ps set to ps·F0 so both highlights agree at normal incidence,
/// and the same pd: the "equal β" comparison of Blinn's Figures 5–7.
pub fn equal_beta_phong(ts: &Model) -> Model {
    let c = ts.p[1];
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
    };
    let c1 = Distribution::D1.param_from_beta(beta);
    Model {
        kind: ModelKind::BlinnPhong,
        dist: Distribution::D3,
        p: [c1, ts.p[2] * f0_from_n(ts.p[0]), ts.p[3], 0.0],
        fast_pow: None,
    }
}

impl fmt::Display for Model {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.kind)?;
        if self.kind == ModelKind::TorranceSparrow {
            write!(f, " ({})", self.dist.name())?;
        }
        for (n, v) in self.param_names().iter().zip(self.params()) {
            write!(f, " {n}={}", short(*v))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * (1.0 + b.abs())
    }

    #[test]
    fn fresnel_forms_agree_and_limits_hold() {
        for &n in &[1.01, 1.33, 1.5, 1.8, 2.4, 6.3, 200.0] {
            // Normal incidence: ((n-1)/(n+1))², worked by hand.
            let r = (n - 1.0) / (n + 1.0);
            assert!(close(fresnel(n, 1.0), r * r, 1e-12), "F0 for n={n}");
            // Grazing: total reflection.
            assert!(close(fresnel(n, 0.0), 1.0, 1e-12));
            for i in 1..100 {
                let c = i as f64 / 100.0;
                let a = fresnel(n, c);
                let b = fresnel_trig(n, c);
                assert!(close(a, b, 1e-9), "n={n} c={c}: compact {a} trig {b}");
            }
        }
        // Glass at 45°: textbook value Rs = 0.0920, Rp = 0.00846 -> 0.0502.
        assert!(close(
            fresnel(1.5, (45f64).to_radians().cos()),
            0.0502,
            2e-3
        ));
    }

    #[test]
    fn half_angle_gives_one_half_for_every_distribution() {
        for deg in [3.0, 10.0, 25.0, 40.0, 60.0] {
            let beta = f64::to_radians(deg);
            for d in [Distribution::D1, Distribution::D2, Distribution::D3] {
                let c = d.param_from_beta(beta);
                assert!(close(d.eval(beta.cos(), c), 0.5, 1e-12), "{d:?} at {deg}°");
                assert!(close(d.eval(1.0, c), 1.0, 1e-12), "{d:?} peak");
            }
        }
    }

    #[test]
    fn d3_is_pi_c3_squared_times_ggx() {
        for &a in &[0.05, 0.2, 0.35, 0.5, 1.0] {
            for i in 0..=20 {
                let t = i as f64 / 20.0 * 1.5;
                let cos = t.cos();
                // GGX as written by Walter et al. 2007: α² / (π cos⁴θ (α² + tan²θ)²).
                let tan2 = t.tan() * t.tan();
                let ggx = a * a / (PI * cos.powi(4) * (a * a + tan2).powi(2));
                let d3 = Distribution::D3.eval(cos, a);
                assert!(close(d3, PI * a * a * ggx, 1e-9), "α={a} θ={t}");
            }
        }
    }

    #[test]
    fn textured_d3_matches_plain_d3_scaled() {
        // With t = 0, C3 = Cmin and the normalisation is the plain D3.
        for &cmin in &[0.1, 0.35, 0.8] {
            for &nh in &[1.0, 0.9, 0.5] {
                assert!(close(
                    d3_textured(nh, cmin, 0.0),
                    Distribution::D3.eval(nh, cmin),
                    1e-12
                ));
                // With t = 1, C3 = 1: D = Cmin² for every α (a flat distribution).
                assert!(close(d3_textured(nh, cmin, 1.0), cmin * cmin, 1e-12));
            }
        }
    }

    #[test]
    fn g_division_safe_form_matches_definition() {
        let mut count = 0;
        for ti in 0..18 {
            for to in 0..18 {
                for po in 0..12 {
                    let g = Geometry::from_angles(
                        ti as f64 * 5.0f64.to_radians(),
                        0.0,
                        to as f64 * 5.0f64.to_radians(),
                        po as f64 * 30.0f64.to_radians(),
                    );
                    let a = g_over_ne(&g) * g.ne;
                    let b = geometric_attenuation(&g);
                    assert!(close(a, b, 1e-12), "{g:?}: {a} vs {b}");
                    count += (b < 1.0) as usize;
                }
            }
        }
        assert!(count > 50, "the test must reach the masked cases");
    }

    #[test]
    fn normal_incidence_torrance_sparrow_is_pd_plus_ps_f0() {
        let m = Model::blinn_mgo();
        let g = Geometry::from_angles(0.0, 0.0, 0.0, 0.0);
        let want = (0.333 + 0.667 * f0_from_n(1.8)) / PI;
        assert!(close(m.brdf(&g), want, 1e-12));
        // Hand-worked: F0(1.8) = (0.8/2.8)² = 0.0816327.
        assert!(close(f0_from_n(1.8), 0.081_632_653, 1e-8));
    }

    #[test]
    fn lambert_and_phong_by_hand() {
        let lam = Model::new(ModelKind::Lambert, Distribution::D3, &[0.5]).unwrap();
        let g = Geometry::from_angles(0.3, 0.0, 1.0, 2.0);
        assert!(close(lam.brdf(&g), 0.5 / PI, 1e-15));
        // Phong at θi = 30°, view in the mirror direction rotated 10° further: R·E = cos 10°.
        let ph = Model::new(ModelKind::Phong, Distribution::D3, &[20.0, 0.5, 0.2]).unwrap();
        let ti = 30f64.to_radians();
        let g = Geometry::from_angles(ti, 0.0, 40f64.to_radians(), PI);
        let want = 0.2 / PI + 0.5 * 10f64.to_radians().cos().powf(20.0) / (PI * ti.cos());
        assert!(close(ph.brdf(&g), want, 1e-12));
        // Blinn-Phong in the mirror direction: N·H = 1, i = pd cosθi + ps.
        let bp = Model::new(ModelKind::BlinnPhong, Distribution::D3, &[20.0, 0.5, 0.2]).unwrap();
        let g = Geometry::from_angles(ti, 0.0, ti, PI);
        assert!(close(bp.intensity(&g), 0.2 * ti.cos() + 0.5, 1e-12));
        // Below the horizon everything is 0.
        let g = Geometry::from_angles(ti, 0.0, 100f64.to_radians(), PI);
        assert_eq!(bp.brdf(&g), 0.0);
    }

    #[test]
    fn mirror_direction_convention() {
        let (ti, pi) = (0.7, 0.4);
        let l = direction(ti, pi);
        let r = [-l[0], -l[1], l[2]]; // 2(N·L)N − L
        let m = direction(ti, pi + PI);
        for k in 0..3 {
            assert!((r[k] - m[k]).abs() < 1e-15);
        }
        let g = Geometry::from_angles(ti, pi, ti, pi + PI);
        assert!(close(g.re, 1.0, 1e-12) && close(g.nh, 1.0, 1e-12));
        assert!(close(g.eh, ti.cos(), 1e-12));
    }

    #[test]
    fn torrance_sparrow_is_reciprocal() {
        for dist in [Distribution::D1, Distribution::D2, Distribution::D3] {
            let m =
                Model::new(ModelKind::TorranceSparrow, dist, &[1.8, 0.35, 0.667, 0.333]).unwrap();
            for k in 0..200 {
                let a = [
                    (k * 37 % 89) as f64 * 0.017,
                    (k * 11 % 360) as f64 * 0.0174,
                    (k * 53 % 89) as f64 * 0.017,
                    (k * 71 % 360) as f64 * 0.0174,
                ];
                let f1 = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
                let f2 = m.brdf(&Geometry::from_angles(a[2], a[3], a[0], a[1]));
                assert!(close(f1, f2, 1e-12), "{a:?}: {f1} vs {f2}");
            }
        }
    }

    #[test]
    fn fast_phong_error() {
        // Maximum absolute error of the approximation over x in [0, 1], exponents α ≥ γ.
        let worst = |k: u32| {
            let mut e: f64 = 0.0;
            for &alpha in &[64.0, 100.0, 200.0, 1000.0] {
                for i in 0..=20000 {
                    let x = i as f64 / 20000.0;
                    e = e.max((fast_phong_pow(x, alpha, k) - x.powf(alpha)).abs());
                }
            }
            e
        };
        let e: Vec<f64> = (2..=6).map(worst).collect();
        let stated = [0.074, 0.035, 0.017, 0.0083, 0.0040];
        for (k, (got, want)) in e.iter().zip(stated).enumerate() {
            assert!(
                (got - want).abs() < 0.1 * want,
                "k={}: {got} vs stated {want}",
                k + 2
            );
        }
        assert_eq!(fast_phong_pow(1.0, 50.0, 3), 1.0);
        // Below γ the approximation degrades: k = 6 (γ = 64) with α = 16.
        let bad = (0..=2000)
            .map(|i| i as f64 / 2000.0)
            .map(|x| (fast_phong_pow(x, 16.0, 6) - x.powf(16.0)).abs())
            .fold(0.0, f64::max);
        assert!(bad > e[4], "α < γ is worse: {bad}");
    }

    #[test]
    fn blinn_parameters_check() {
        let m = Model::from_named(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[
                ("n".into(), 1.8),
                ("c3".into(), 0.35),
                ("ps".into(), 0.667),
                ("pd".into(), 0.333),
            ],
        )
        .unwrap();
        assert_eq!(m, Model::blinn_mgo());
        let e = Model::from_named(ModelKind::Phong, Distribution::D3, &[("c1".into(), 2.0)]);
        assert!(matches!(e, Err(ModelError::Missing { name: "ps", .. })));
        let e = Model::new(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[1.5, 1.5, 0.1, 0.1],
        );
        assert!(matches!(e, Err(ModelError::OutOfBounds { name: "c3", .. })));
    }
}

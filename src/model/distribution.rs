//! Blinn's micro-facet distributions D1–D3 and Löw et al.'s ABC lobe: their values, shape
//! derivatives and half-widths, Blinn's texture-modulated D3, and the GGX roughness matched
//! to a cosine power.

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

/// The half-angle β (radians) where ABC's D = (1 + b (1 − cos β))^(−c) falls to ½:
/// cos β = 1 − (2^(1/c) − 1)/b (π/2 where that is below 0).
pub fn abc_half_width(b: f64, c: f64) -> f64 {
    (1.0 - (2f64.powf(1.0 / c) - 1.0) / b)
        .clamp(0.0, 1.0)
        .acos()
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

/// GGX roughness matched to a cosine power c: α = √(2/(c + 2)) (Walter et al. 2007).
pub(super) fn alpha_of_power(c: f64) -> f64 {
    (2.0 / (c + 2.0)).sqrt()
}

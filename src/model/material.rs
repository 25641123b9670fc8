//! How a model maps onto the materials of Mitsuba 3 and pbrt-v4.

use super::fresnel::f0_from_n;

/// How a model maps onto the materials of Mitsuba 3 and pbrt-v4: the nearest one, with every
/// value in the target's own terms, and whether the target's model is the same (`exact`) or
/// what differs (`differs`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Material {
    /// The target material.
    pub kind: MaterialKind,
    /// True when Mitsuba 3 evaluates the same f_r (pbrt-v4 too, except for
    /// [`MaterialKind::DiffusePlusConductor`], which pbrt can only approximate).
    pub exact: bool,
    /// What differs from the model where it is not exact (empty when exact).
    pub differs: String,
}

/// The materials brdfit exports to.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum MaterialKind {
    /// Lambertian reflectance (Mitsuba `diffuse`, pbrt `diffuse`).
    Diffuse {
        /// Albedo.
        reflectance: f64,
    },
    /// A GGX dielectric coat over a diffuse base (Mitsuba `roughplastic`, pbrt `coateddiffuse`).
    Plastic {
        /// GGX roughness α.
        alpha: f64,
        /// Index of the coat.
        ior: f64,
        /// Albedo of the base.
        diffuse: f64,
    },
    /// A GGX metal with the target's aluminium optical constants (Mitsuba `roughconductor`
    /// material Al, pbrt `conductor` metal-Al).
    Aluminium {
        /// GGX roughness α.
        alpha: f64,
    },
    /// pd/π plus a GGX–Smith lobe with the unpolarised Fresnel of index `eta` (k = 0) scaled by
    /// `scale`: Mitsuba `blendbsdf` (weight ½) of `diffuse` (2 pd) and `roughconductor`
    /// (eta, k = 0, specular_reflectance 2 ps); pbrt `mix` (amount ½) of the same.
    DiffusePlusConductor {
        /// pd.
        diffuse: f64,
        /// GGX roughness α.
        alpha: f64,
        /// Index of the Fresnel term.
        eta: f64,
        /// ps.
        scale: f64,
    },
    /// pd/π plus two GGX–Smith lobes sharing the Fresnel of index `eta` (k = 0), scaled by
    /// `scale1` and `scale2`: Mitsuba `blendbsdf` (weight ⅔) of `diffuse` (3 pd) and a
    /// `blendbsdf` (weight ½) of two `roughconductor`s (specular_reflectance 3 ps1, 3 ps2), so
    /// each part enters with weight ⅓.
    DiffusePlusTwoConductors {
        /// pd.
        diffuse: f64,
        /// GGX roughness α of the first (sharper) lobe.
        alpha1: f64,
        /// ps1.
        scale1: f64,
        /// GGX roughness α of the second (broader) lobe.
        alpha2: f64,
        /// ps2.
        scale2: f64,
        /// Index of the Fresnel term.
        eta: f64,
    },
}

/// What differs between a Blinn-style model (its lobe described by `lobe`, with how α was
/// matched to it) and the GGX materials of Mitsuba 3 and pbrt-v4.
pub(crate) fn differs_blinn(lobe: &str) -> String {
    format!(
        "What differs from brdfit's model: Mitsuba and pbrt use Smith masking instead of Blinn's V-groove G, a normalised GGX instead of {lobe}, and energy from the Fresnel term instead of the free scale ps; pd maps to the diffuse reflectance directly."
    )
}

/// The nearest material for a Blinn model with GGX roughness `alpha` (None: no lobe), Fresnel
/// index `n` (None: no Fresnel term; 1.5 is used) and diffuse albedo `pd`: a metal-like fit
/// (F0 > 0.5) is exported as aluminium, any other as a plastic. `lobe` says what the GGX
/// replaces ([`differs_blinn`]).
pub(crate) fn blinn_material(alpha: Option<f64>, n: Option<f64>, pd: f64, lobe: &str) -> Material {
    let kind = match (alpha, n) {
        (None, _) => MaterialKind::Diffuse { reflectance: pd },
        (Some(alpha), Some(n)) if f0_from_n(n) > 0.5 => MaterialKind::Aluminium { alpha },
        (Some(alpha), n) => MaterialKind::Plastic {
            alpha,
            ior: n.unwrap_or(1.5),
            diffuse: pd,
        },
    };
    Material {
        kind,
        exact: false,
        differs: differs_blinn(lobe),
    }
}

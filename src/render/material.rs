//! Materials: a reflection model with Whitted's mirror and transmission weights, and the
//! textures on its colour and roughness.

use super::measured;
use crate::model::{Distribution, Geometry, Model, ModelKind};
use glam::DVec3;

/// A checker texture on the diffuse colour: squares of side `size` in texture units.
#[derive(Clone, Copy, Debug)]
pub struct Checker {
    /// Square size.
    pub size: f64,
    /// Colour of even squares.
    pub color0: DVec3,
    /// Colour of odd squares.
    pub color1: DVec3,
}

impl Checker {
    /// Indices (i, j) of the square holding texture coordinates (u, v).
    pub fn cell(&self, (u, v): (f64, f64)) -> (i64, i64) {
        (
            (u / self.size).floor() as i64,
            (v / self.size).floor() as i64,
        )
    }

    /// Colour at texture coordinates (u, v).
    pub fn at(&self, uv: (f64, f64)) -> DVec3 {
        let (i, j) = self.cell(uv);
        let k = i + j;
        if k.rem_euclid(2) == 0 {
            self.color0
        } else {
            self.color1
        }
    }
}

/// Blinn's texture-modulated roughness (Figure 8): t(u, v) = ½ + ½ sin(2π u f) sin(2π v f),
/// C3 = Cmin + (1 − Cmin) t, D3 normalised by Cmin ([`crate::model::d3_textured`]).
#[derive(Clone, Copy, Debug)]
pub struct RoughnessTexture {
    /// Minimum c3 over the surface.
    pub cmin: f64,
    /// Spatial frequency of the pattern (cycles per texture unit).
    pub frequency: f64,
}

/// A material: a reflection model plus Whitted's mirror and transmission coefficients.
#[derive(Clone, Debug)]
pub struct Material {
    /// Name.
    pub name: String,
    /// The local reflection model (f_r, with its pd).
    pub model: Model,
    /// Diffuse colour (multiplies the pd term).
    pub color: DVec3,
    /// Specular colour (multiplies the ps term; white but for a colour fit, whose channels'
    /// ps it holds).
    pub specular: DVec3,
    /// Optional checker on the diffuse colour.
    pub checker: Option<Checker>,
    /// Whitted's ks: weight of the mirror ray.
    pub ks: f64,
    /// Whitted's kt: weight of the refracted ray.
    pub kt: f64,
    /// Index of refraction for the refracted ray.
    pub ior: f64,
    /// Optional roughness texture (torrance-sparrow D3 only).
    pub roughness: Option<RoughnessTexture>,
    /// Optional measured BRDF: when set, the surface reflects by this table (times `color`)
    /// instead of `model`, which then gives only the ambient term's pd.
    pub measured: Option<std::sync::Arc<measured::Tabulated>>,
}

impl Material {
    pub(super) fn pd(&self) -> f64 {
        self.model.pd()
    }

    /// Blinn's specular intensity for a unit light (the model with pd = 0).
    pub(super) fn specular(&self, g: &Geometry, uv: (f64, f64)) -> f64 {
        if let (Some(rt), ModelKind::TorranceSparrow, Distribution::D3) =
            (self.roughness, self.model.kind, self.model.dist)
        {
            if !g.visible() {
                return 0.0;
            }
            let t = 0.5
                + 0.5
                    * (std::f64::consts::TAU * uv.0 * rt.frequency).sin()
                    * (std::f64::consts::TAU * uv.1 * rt.frequency).sin();
            let d = crate::model::d3_textured(g.nh, rt.cmin, t);
            let n = self.model.role(crate::model::Role::Index).unwrap_or(1.5);
            let ps = self.model.role(crate::model::Role::Specular).unwrap_or(0.0);
            return ps * d * crate::model::fresnel(n, g.eh) * g.g_ne;
        }
        let pd = self.pd();
        (self.model.intensity(g) - pd * g.nl.max(0.0)).max(0.0)
    }
}

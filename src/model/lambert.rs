//! Lambert's diffuse model: i = pd N·L, f_r = pd/π.

use super::{Distribution, Geometry, Material, MaterialKind, Model, PD, ParamSpec};
use std::f64::consts::FRAC_1_PI;

/// The parameters: pd alone.
pub(super) fn params(_: Distribution) -> &'static [ParamSpec] {
    &[PD]
}

/// f_r = pd/π and its gradient.
#[inline(always)]
pub(super) fn brdf_grad(m: &Model, _: &Geometry, grad: &mut [f64]) -> f64 {
    grad[0] = FRAC_1_PI;
    m.p[0] * FRAC_1_PI
}

/// Exactly the targets' diffuse material.
pub(super) fn material(m: &Model) -> Material {
    Material {
        kind: MaterialKind::Diffuse {
            reflectance: m.p[0],
        },
        exact: true,
        differs: String::new(),
    }
}

/// f_r = pd/π.
pub(super) fn glsl(_: &Model) -> String {
    "    return vec3(pd / PI);".into()
}

//! Blinn's equal-β comparison (Figures 5–7): the Blinn–Phong model with the same highlight
//! half-angle as a Torrance–Sparrow one.

use super::{Distribution, Model, ModelKind, Role, abc_half_width, f0_from_n};

/// Blinn's Phong ((N·H)^c1, `blinn-phong`) with the same half-angle β as a torrance-sparrow
/// model's distribution, its ps set to ps·F0 so both highlights agree at normal incidence,
/// and the same pd: the "equal β" comparison of Blinn's Figures 5–7.
pub fn equal_beta_phong(ts: &Model) -> Model {
    let c = ts.p[1];
    let ps = ts.role(Role::Specular).unwrap_or(0.0);
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
    let mut p = [0.0; super::MAX_PARAMS];
    p[..3].copy_from_slice(&[c1, ps * f0_from_n(ts.p[0]), ts.pd()]);
    Model {
        kind: ModelKind::BlinnPhong,
        dist: Distribution::D3,
        p,
        fast_pow: None,
    }
}

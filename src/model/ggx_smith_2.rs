//! Two GGX–Smith lobes sharing one Fresnel index (a sharp lobe and its broader glow, as
//! measured metals and coated materials show):
//!
//! f_r = pd/π + Σₖ psₖ · F(n, E·H) · D(H; αₖ) · G1(L; αₖ) · G1(E; αₖ) / (4 (N·L)(N·E)), k = 1, 2,
//!
//! with D and G1 exactly as in `ggx-smith` (Walter et al. 2007, eqs. 33, 34; the same code,
//! [`super::ggx_smith::lobe`]). α1 ≤ α2, so the lobes cannot swap: the first is the sharper one.

use super::ggx_smith::{ALPHA, GLSL_SHARED, glsl_lobe, lobe};
use super::{Distribution, ModelError};
use super::{Geometry, Material, MaterialKind, Model, PD, PS, ParamSpec, fresnel_dn};
use std::f64::consts::FRAC_1_PI;

const ALPHA1: ParamSpec = ParamSpec {
    name: "alpha1",
    meaning: "GGX roughness α of the first lobe (the sharper one: alpha1 ≤ alpha2)",
    start: 0.1,
    ..ALPHA
};

const ALPHA2: ParamSpec = ParamSpec {
    name: "alpha2",
    meaning: "GGX roughness α of the second lobe (the broader one: alpha2 ≥ alpha1)",
    start: 0.4,
    ..ALPHA
};

const PS1: ParamSpec = ParamSpec {
    name: "ps1",
    meaning: "specular coefficient of the first lobe",
    ..PS
};

const PS2: ParamSpec = ParamSpec {
    name: "ps2",
    meaning: "specular coefficient of the second lobe",
    ..PS
};

/// The index of the Fresnel term, as in Torrance–Sparrow, shared by both lobes.
const N: ParamSpec = super::param::N;

/// Positions of alpha1, ps1, alpha2, ps2, n, pd.
const A1: usize = 0;
const S1: usize = 1;
const A2: usize = 2;
const S2: usize = 3;
const IN: usize = 4;
const PDI: usize = 5;

/// The parameters: alpha1, ps1, alpha2, ps2, n, pd.
pub(super) fn params(_: Distribution) -> &'static [ParamSpec] {
    &[ALPHA1, PS1, ALPHA2, PS2, N, PD]
}

/// The lobes' order: alpha1 > alpha2 is refused, with the fix (the same material with the
/// lobes swapped).
pub(super) fn check_order(p: &[f64]) -> Result<(), ModelError> {
    if p[A1] > p[A2] {
        return Err(ModelError::Order {
            model: "ggx-smith-2",
            what: format!(
                "alpha1 = {} > alpha2 = {}: the first lobe is the sharper one",
                super::readable(p[A1]),
                super::readable(p[A2])
            ),
            fix: format!(
                "swap the lobes (the same material): alpha1={}, ps1={}, alpha2={}, ps2={}",
                p[A2], p[S2], p[A1], p[S1]
            ),
        });
    }
    Ok(())
}

/// The same f_r with the lobes in canonical order (alpha1 ≤ alpha2): swaps (alpha1, ps1) and
/// (alpha2, ps2) where alpha1 > alpha2 (the fitter's variables may end either way round).
pub(super) fn canonical(p: &mut [f64]) {
    if p[A1] > p[A2] {
        p.swap(A1, A2);
        p.swap(S1, S2);
    }
}

/// f_r and its gradient with respect to (alpha1, ps1, alpha2, ps2, n, pd).
#[inline(always)]
pub(super) fn brdf_grad(m: &Model, g: &Geometry, grad: &mut [f64]) -> f64 {
    let p = &m.p;
    grad[PDI] = FRAC_1_PI;
    if g.nh <= 0.0 || g.eh <= 0.0 {
        return p[PDI] * FRAC_1_PI;
    }
    let (l1, dl1) = lobe(p[A1], g);
    let (l2, dl2) = lobe(p[A2], g);
    let (f, df) = fresnel_dn(p[IN], g.eh);
    let spec = p[S1] * l1 + p[S2] * l2;
    grad[A1] = p[S1] * f * dl1;
    grad[S1] = f * l1;
    grad[A2] = p[S2] * f * dl2;
    grad[S2] = f * l2;
    grad[IN] = df * spec;
    p[PDI] * FRAC_1_PI + f * spec
}

/// Exactly Mitsuba 3's nested `blendbsdf` of a `diffuse` and two `roughconductor`s (GGX,
/// separable Smith G1·G1, eta = n, k = 0).
pub(super) fn material(m: &Model) -> Material {
    let p = &m.p;
    Material {
        kind: MaterialKind::DiffusePlusTwoConductors {
            diffuse: p[PDI],
            alpha1: p[A1],
            scale1: p[S1],
            alpha2: p[A2],
            scale2: p[S2],
            eta: p[IN],
        },
        exact: true,
        differs: String::new(),
    }
}

/// F (ps1 D1 G1 G1 + ps2 D2 G1 G1) / (4 N·L N·V).
pub(super) fn glsl(_: &Model) -> String {
    format!(
        "{GLSL_SHARED}{}{}{}    return vec3(pd / PI + F * (ps1 * S1 + ps2 * S2));",
        super::GLSL_FRESNEL,
        glsl_lobe("alpha1", "1"),
        glsl_lobe("alpha2", "2")
    )
}

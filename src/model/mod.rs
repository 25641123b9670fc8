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

pub mod albedo;
pub mod fitfile;
mod ggx_smith;
mod ggx_smith_2;
mod lambert;
mod phong;
pub mod tabulated_ndf;
mod torrance_sparrow;

pub use distribution::{Distribution, abc_half_width, d3_textured};
pub use equal_beta::equal_beta_phong;
pub(crate) use fresnel::GLSL_FRESNEL;
pub use fresnel::{f0_from_n, fresnel, fresnel_dn, fresnel_trig, n_from_f0};
use phong::Highlight;
pub use phong::{fast_phong_pow, fast_phong_pow_da};

use std::f64::consts::PI;
use std::fmt;

mod distribution;
mod equal_beta;
mod fresnel;
mod geometry;
mod kind;
mod material;
mod param;
mod text;

pub use geometry::{Geometry, direction, g_over_ne, geometric_attenuation};
pub use kind::{ModelKind, catalogue};
pub(crate) use material::blinn_material;
pub use material::{Material, MaterialKind};
pub use param::{Grid, HALF_WIDTHS_DEG, ParamSpec, Role, Scale};
pub(crate) use param::{PD, PS};
pub use text::{exact, readable, short, significant};

impl ModelError {
    /// The setting that fixes the error, if it is one value.
    pub fn setting(&self) -> Option<crate::support::setting::Setting> {
        match self {
            ModelError::Missing { name, .. } | ModelError::OutOfBounds { name, .. } => {
                Some(crate::support::setting::Setting::Value(name.to_string()))
            }
            ModelError::Unknown { .. } | ModelError::Order { .. } => None,
        }
    }
}

/// An invalid model specification, with the fix.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModelError {
    /// A parameter is missing from `--set`.
    #[error("model {model} needs parameter {name}: give it a value")]
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
    /// Parameters in an order the model refuses (ggx-smith-2's alpha1 > alpha2).
    #[error("model {model}: {what}; {fix}")]
    Order {
        /// Model name.
        model: &'static str,
        /// What is out of order.
        what: String,
        /// The same material in order.
        fix: String,
    },
    /// A parameter value outside its bounds.
    #[error("parameter {name} = {value} is out of bounds: {bounds}")]
    OutOfBounds {
        /// Parameter name.
        name: &'static str,
        /// Given value.
        value: f64,
        /// Human-readable bounds.
        bounds: String,
    },
}

/// The most parameters a model may declare (the size of [`Model::p`]).
pub const MAX_PARAMS: usize = tabulated_ndf::TABLE + 3;

/// A reflection model with its parameter values: a small value type evaluated per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    /// Which model.
    pub kind: ModelKind,
    /// Facet distribution (used by torrance-sparrow only).
    pub dist: Distribution,
    /// Parameters in the order of [`ModelKind::param_names`]; unused trailing slots are 0.
    pub p: [f64; MAX_PARAMS],
    /// Phong only: use the fast power approximation with γ = 2^k.
    pub fast_pow: Option<u32>,
}

impl Model {
    /// Model from parameter values in [`ModelKind::param_names`] order, checked against bounds.
    pub fn new(kind: ModelKind, dist: Distribution, params: &[f64]) -> Result<Self, ModelError> {
        let mut p = [0.0; MAX_PARAMS];
        for (i, spec) in kind.params(dist).iter().enumerate() {
            let Some(&v) = params.get(i) else {
                return Err(ModelError::Missing {
                    model: kind.name(),
                    name: spec.name,
                });
            };
            if !spec.admits(v) {
                return Err(ModelError::OutOfBounds {
                    name: spec.name,
                    value: v,
                    bounds: spec.bounds_text(),
                });
            }
            p[i] = v;
        }
        Self::check_order(kind, &p)?;
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

    /// The parameters' declarations in order.
    pub fn specs(&self) -> &'static [ParamSpec] {
        self.kind.params(self.dist)
    }

    /// Parameter names in order.
    pub fn param_names(&self) -> Vec<&'static str> {
        self.kind.param_names(self.dist)
    }

    /// Parameter values in order.
    pub fn params(&self) -> &[f64] {
        &self.p[..self.specs().len()]
    }

    /// The value of the parameter with `role`, if the model has one.
    pub fn role(&self, role: Role) -> Option<f64> {
        self.kind.index_of(self.dist, role).map(|i| self.p[i])
    }

    /// The diffuse coefficient pd (every model has one).
    #[inline]
    pub fn pd(&self) -> f64 {
        self.role(Role::Diffuse).unwrap_or(0.0)
    }

    /// Value of the parameter `name`, if the model has it.
    pub fn get(&self, name: &str) -> Option<f64> {
        let i = self.specs().iter().position(|s| s.name == name)?;
        Some(self.p[i])
    }

    /// Same model with new parameter values (not bounds-checked; the fitter keeps them in bounds).
    pub fn with_params(&self, params: &[f64]) -> Self {
        let mut m = *self;
        let k = self.specs().len();
        m.p[..k].copy_from_slice(&params[..k]);
        m
    }

    /// The same f_r with its parameters in canonical order (ggx-smith-2: the lobes swapped
    /// where alpha1 > alpha2; every other model as it is). The fitter returns this.
    pub fn canonical(&self) -> Self {
        let mut m = *self;
        if m.kind == ModelKind::GgxSmith2 {
            ggx_smith_2::canonical(&mut m.p);
        }
        m
    }

    /// Why the parameter values are out of order for the model (ggx-smith-2: alpha1 > alpha2),
    /// with the fix; Ok for every other model.
    pub fn check_order(kind: ModelKind, params: &[f64]) -> Result<(), ModelError> {
        if kind == ModelKind::GgxSmith2 && params.len() >= 4 {
            ggx_smith_2::check_order(params)?;
        }
        Ok(())
    }

    /// Blinn's reflected intensity i(L, E) for a unit light (0 where the BRDF is 0).
    pub fn intensity(&self, g: &Geometry) -> f64 {
        self.brdf(g) * PI * g.nl.max(0.0)
    }

    /// The BRDF f_r = i / (π N·L) in 1/sr.
    #[inline]
    pub fn brdf(&self, g: &Geometry) -> f64 {
        let mut scratch = [0.0; MAX_PARAMS];
        self.eval(g, &mut scratch)
    }

    /// The BRDF and its gradient with respect to each parameter (written to `grad`, which must
    /// hold at least as many entries as the model has parameters).
    #[inline]
    pub fn brdf_grad(&self, g: &Geometry, grad: &mut [f64]) -> f64 {
        self.eval(g, grad)
    }

    /// [`Model::brdf_grad`], inlined (with each model's formulas) into it and into
    /// [`Model::brdf`], where the gradient is never read and the compiler drops its arithmetic
    /// (the value is the same expression either way, so the same bits; the directional albedo
    /// of every fit's physical check evaluates only values).
    #[inline(always)]
    fn eval(&self, g: &Geometry, grad: &mut [f64]) -> f64 {
        let k = self.specs().len();
        grad[..k].iter_mut().for_each(|x| *x = 0.0);
        if !g.visible() {
            return 0.0;
        }
        match self.kind {
            ModelKind::Lambert => lambert::brdf_grad(self, g, grad),
            ModelKind::Phong => phong::brdf_grad(self, Highlight::Mirror, g, grad),
            ModelKind::BlinnPhong => phong::brdf_grad(self, Highlight::Half, g, grad),
            ModelKind::TorranceSparrow => torrance_sparrow::brdf_grad(self, g, grad),
            ModelKind::GgxSmith => ggx_smith::brdf_grad(self, g, grad),
            ModelKind::GgxSmith2 => ggx_smith_2::brdf_grad(self, g, grad),
            ModelKind::TabulatedNdf => tabulated_ndf::brdf_grad(self, g, grad),
        }
    }

    /// How the model maps onto other renderers' materials (see [`Material`]).
    pub fn material(&self) -> Material {
        match self.kind {
            ModelKind::Lambert => lambert::material(self),
            ModelKind::Phong | ModelKind::BlinnPhong => phong::material(self),
            ModelKind::TorranceSparrow => torrance_sparrow::material(self),
            ModelKind::GgxSmith => ggx_smith::material(self),
            ModelKind::GgxSmith2 => ggx_smith_2::material(self),
            ModelKind::TabulatedNdf => tabulated_ndf::material(self),
        }
    }

    /// The BRDF as the body of a GLSL function of N, L, V (NdotL, NdotV > 0 and PI defined;
    /// the parameters are uniforms of their own names), for Disney's BRDF Explorer.
    pub fn glsl(&self) -> String {
        match self.kind {
            ModelKind::Lambert => lambert::glsl(self),
            ModelKind::Phong => phong::glsl(Highlight::Mirror),
            ModelKind::BlinnPhong => phong::glsl(Highlight::Half),
            ModelKind::TorranceSparrow => torrance_sparrow::glsl(self),
            ModelKind::GgxSmith => ggx_smith::glsl(self),
            ModelKind::GgxSmith2 => ggx_smith_2::glsl(self),
            ModelKind::TabulatedNdf => tabulated_ndf::glsl(self),
        }
    }
}
impl fmt::Display for Model {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.kind.label(self.dist))?;
        for (n, v) in self.param_names().iter().zip(self.params()) {
            write!(f, " {n}={}", short(*v))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// GLSL's `pow(x, y)` is undefined for x < 0 (and for x = 0, y ≤ 0): every `pow` in every
    /// model's Explorer shader takes a base that is positive by construction (N·H > 0 where L
    /// and V are above the surface, a max(…, 0) clamp, or 1 + b(1 − N·H) with b > 0).
    #[test]
    fn glsl_pow_bases_are_never_negative() {
        let safe = [
            "NdotH",
            "max(dot(R, V), 0.0)",
            "max(dot(N, H), 0.0)",
            "1.0 + b * (1.0 - NdotH)",
        ];
        for (kind, dist) in catalogue().into_iter().chain([
            (ModelKind::GgxSmith2, Distribution::D3),
            (ModelKind::TorranceSparrow, Distribution::Abc),
        ]) {
            let m = Model::new(
                kind,
                dist,
                &kind
                    .params(dist)
                    .iter()
                    .map(|s| s.start)
                    .collect::<Vec<_>>(),
            )
            .unwrap();
            let text = m.glsl();
            let mut rest = text.as_str();
            while let Some(i) = rest.find("pow(") {
                rest = &rest[i + 4..];
                let mut depth = 0;
                let end = rest
                    .char_indices()
                    .find(|&(_, ch)| {
                        match ch {
                            '(' => depth += 1,
                            ')' => depth -= 1,
                            _ => {}
                        }
                        ch == ',' && depth == 0
                    })
                    .map(|(j, _)| j)
                    .unwrap();
                let base = &rest[..end];
                assert!(
                    safe.contains(&base),
                    "{}: pow base {base:?} may be negative:\n{text}",
                    kind.label(dist)
                );
            }
        }
    }

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

//! GGX–Smith (Walter et al. 2007), the model added through its own file: values worked by
//! hand from the paper's equations, energy conservation, a fit round trip and its export.
//! (Gradients against finite differences and reciprocity are in `model_props.rs`.)

use brdfit::export;
use brdfit::fit::{self, FitOptions};
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use brdfit::simulate::{Grid, simulate};
use std::f64::consts::PI;

fn ggx(alpha: f64, n: f64, ps: f64, pd: f64) -> Model {
    Model::new(ModelKind::GgxSmith, Distribution::D3, &[alpha, n, ps, pd]).unwrap()
}

/// Hand-worked from Walter et al. eqs. 20, 33, 34 and the exact Fresnel reflectance:
/// - normal incidence and view (H = N, tan θ = 0): D = 1/(π α²), G1 = 1, F(1.5, 1) = 0.04, so
///   f_r = 0.04 / (4 π 0.25) = 0.0127324;
/// - the mirror configuration θi = θo = 60° (H = N): D = 1/(π α²) = 1.2732395; F(1.5, c = ½):
///   g = √1.5, ((g − c)/(g + c))² = 0.1765713, ((c(g + c) − 1)/(c(g − c) + 1))² = 0.0102052,
///   F = 0.0891867; G1(60°) = 2/(1 + √(1 + 0.25 · 3)) = 0.8610017;
///   f_r = F D G1² / (4 · ½ · ½) = 0.0841818;
/// - off the mirror (θi 30°, θo 50°, φo 200°), α 0.3, n 2, ps 0.7, pd 0.2: 0.1198822 (the same
///   equations evaluated with numpy's vectors for L, E and H).
#[test]
fn values_worked_by_hand() {
    let m = ggx(0.5, 1.5, 1.0, 0.0);
    let f0 = m.brdf(&Geometry::from_angles(0.0, 0.0, 0.0, 0.0));
    assert!((f0 - 0.04 / (4.0 * PI * 0.25)).abs() < 1e-12, "{f0}");
    let t = 60f64.to_radians();
    let f60 = m.brdf(&Geometry::from_angles(t, 0.0, t, PI));
    assert!((f60 - 0.084_181_826_076).abs() < 1e-9, "{f60}");
    let m = ggx(0.3, 2.0, 0.7, 0.2);
    let f = m.brdf(&Geometry::from_angles(
        30f64.to_radians(),
        0.0,
        50f64.to_radians(),
        200f64.to_radians(),
    ));
    assert!((f - 0.119_882_202_760).abs() < 1e-9, "{f}");
}

/// Directional albedo ∫ f_r cosθo dω by the midpoint rule over the hemisphere.
fn albedo(m: &Model, theta_i: f64) -> f64 {
    midpoint_albedo(m, theta_i, 1200, 600)
}

/// Directional albedo ∫ f_r cosθo dω by the midpoint rule on `nt` × `np` cells in (θo, φo)
/// over the whole hemisphere: a quadrature independent of `model::albedo`'s.
pub fn midpoint_albedo(m: &Model, theta_i: f64, nt: usize, np: usize) -> f64 {
    let (dt, dp) = (0.5 * PI / nt as f64, 2.0 * PI / np as f64);
    let mut sum = 0.0;
    for i in 0..nt {
        let to = (i as f64 + 0.5) * dt;
        for j in 0..np {
            let po = (j as f64 + 0.5) * dp;
            let f = m.brdf(&Geometry::from_angles(theta_i, 0.0, to, po));
            sum += f * to.cos() * to.sin() * dt * dp;
        }
    }
    sum
}

/// Energy: with ps ≤ 1 and pd = 0 the albedo never exceeds 1; with F ≈ 1 (a huge index) at
/// normal incidence and a smooth surface it approaches 1 (D is normalised, G1 ≈ 1), so the
/// normalisation of D is checked too.
#[test]
fn energy_is_at_most_one() {
    for alpha in [0.15, 0.4, 1.0] {
        for n in [1.5, 1e4] {
            for ti in [0.0f64, 45.0, 75.0] {
                let a = albedo(&ggx(alpha, n, 1.0, 0.0), ti.to_radians());
                assert!(a <= 1.0 + 2e-3, "α {alpha} n {n} θi {ti}: albedo {a}");
            }
        }
    }
    let a = albedo(&ggx(0.15, 1e6, 1.0, 0.0), 0.0);
    assert!((0.97..=1.002).contains(&a), "{a}");
}

/// Simulated from known parameters with 1 % noise, the default pipeline recovers them.
#[test]
fn fit_round_trip() {
    let truth = ggx(0.25, 1.7, 0.8, 0.3);
    let ds = simulate(&truth, &Grid::Hemisphere(6000).directions(5), 0.01, 5);
    let mut o = FitOptions::new(ModelKind::GgxSmith);
    o.verify = 8;
    let f = fit::fit(&ds, &o).unwrap().remove(0);
    assert!(f.usable(), "{:?}", f.unusable);
    for (name, want) in [("alpha", 0.25), ("n", 1.7), ("ps", 0.8), ("pd", 0.3)] {
        let got = f.get(name).unwrap();
        assert!(
            (got - want).abs() <= 0.03 * want,
            "{name}: {got} vs {want}\n{}",
            fit::format_fit(&f)
        );
    }
}

/// Mitsuba 3 has the same model: the mean of `diffuse` (2 pd) and `roughconductor` (GGX, α,
/// eta = n, k = 0, specular_reflectance 2 ps), weight ½; the export says exact. pbrt-v4's
/// conductor has the height-correlated Smith G, so its export says what differs.
#[test]
fn exports_state_the_mapping() {
    let m = ggx(0.25, 1.7, 0.8, 0.3);
    let x = export::mitsuba(&brdfit::fit::Colour::grey(&m), "g").unwrap();
    for want in [
        "blendbsdf",
        "\"weight\" value=\"0.5\"",
        "<spectrum name=\"reflectance\" value=\"0.6\"/>",
        "\"alpha\" value=\"0.25\"",
        "<spectrum name=\"eta\" value=\"1.7\"/>",
        "<spectrum name=\"k\" value=\"0\"/>",
        "<spectrum name=\"specular_reflectance\" value=\"1.6\"/>",
        "(exact)",
    ] {
        assert!(x.contains(want), "lacks {want}:\n{x}");
    }
    assert_eq!(x.matches("<bsdf").count(), x.matches("</bsdf>").count());
    let p = export::pbrt(&brdfit::fit::Colour::grey(&m));
    assert!(
        p.contains("height-correlated") && !p.contains("(exact)") && p.contains("\"mix\""),
        "{p}"
    );
    let b = export::brdf_explorer(&brdfit::fit::Colour::grey(&m)).unwrap();
    assert!(b.contains("float alpha 0.001 1 0.25"), "{b}");
    assert!(b.contains("float G = 4.0 /"), "{b}");
}

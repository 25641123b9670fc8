//! ggx-smith-2, two GGX–Smith lobes sharing the Fresnel index: values worked by hand, energy
//! conservation, the lobes' order, and its exports. (Gradients against finite differences and
//! reciprocity are in `model_props.rs`.)

use brdfit::export;
use brdfit::fit::Colour;
use brdfit::model::albedo::{ALBEDO_THETA_I_DEG, directional_albedo};
use brdfit::model::{Distribution, Geometry, Model, ModelError, ModelKind};
use std::f64::consts::PI;

fn ggx2(a1: f64, ps1: f64, a2: f64, ps2: f64, n: f64, pd: f64) -> Model {
    Model::new(
        ModelKind::GgxSmith2,
        Distribution::D3,
        &[a1, ps1, a2, ps2, n, pd],
    )
    .unwrap()
}

fn deg(d: f64) -> f64 {
    d.to_radians()
}

/// Hand-worked from Walter et al. 2007, eqs. 20, 33, 34 and the exact Fresnel reflectance:
/// - normal incidence and view (H = N): D = 1/(π α²), G1 = 1, F(1.5, 1) = 0.04, so with
///   α1 0.1, ps1 0.3, α2 0.5, ps2 0.6, pd 0.2: f_r = 0.2/π + 0.04 (30/π + 2.4/π)/4
///   = 0.524/π = 0.16679438;
/// - three other configurations (off the mirror, near it, and grazing at 75°/70°) evaluated by
///   a separate 20-line Python script from the same equations (vectors L, E, H from the angles,
///   the `math` module only): 0.0738738713121918, 2.171027120484836, 35.82996296782159.
#[test]
fn values_worked_by_hand() {
    let m = ggx2(0.1, 0.3, 0.5, 0.6, 1.5, 0.2);
    let f = m.brdf(&Geometry::from_angles(0.0, 0.0, 0.0, 0.0));
    assert!((f - 0.524 / PI).abs() < 1e-12, "{f}");
    let m = ggx2(0.05, 0.4, 0.35, 0.5, 2.0, 0.1);
    for (a, want) in [
        ([30.0, 0.0, 50.0, 200.0], 0.073_873_871_312_191_8),
        ([40.0, 10.0, 41.0, 192.0], 2.171_027_120_484_836),
    ] {
        let f = m.brdf(&Geometry::from_angles(
            deg(a[0]),
            deg(a[1]),
            deg(a[2]),
            deg(a[3]),
        ));
        assert!(((f - want) / want).abs() < 1e-10, "{a:?}: {f} vs {want}");
    }
    let m = ggx2(0.02, 1.0, 0.3, 0.25, 8.0, 0.05);
    let f = m.brdf(&Geometry::from_angles(deg(75.0), 0.0, deg(70.0), PI));
    let want = 35.829_962_967_821_59;
    assert!(((f - want) / want).abs() < 1e-10, "{f} vs {want}");
}

/// Energy: with ps1 + ps2 ≤ 1, pd = 0 and F ≤ 1 (n up to 1e6, F ≈ 1 everywhere) the
/// directional albedo stays ≤ 1 at every θi of the physical check (the quadrature is checked
/// against hand-worked values in `albedo.rs`); with F ≈ 1, smooth lobes and ps1 + ps2 = 1 at
/// normal incidence it approaches 1 (each D is normalised, G1 ≈ 1).
#[test]
fn albedo_is_at_most_one() {
    for (a1, a2) in [(0.01, 0.1), (0.05, 0.5), (0.3, 1.0)] {
        for n in [1.5, 1e6] {
            for (ps1, ps2) in [(0.5, 0.5), (0.9, 0.1), (0.2, 0.8)] {
                let m = ggx2(a1, ps1, a2, ps2, n, 0.0);
                for &t in &ALBEDO_THETA_I_DEG {
                    let a = directional_albedo(&m, deg(t));
                    assert!(a <= 1.0 + 1e-3, "{m} θi {t}: albedo {a}");
                }
            }
        }
    }
    let a = directional_albedo(&ggx2(0.01, 0.5, 0.1, 0.5, 1e6, 0.0), 0.0);
    assert!((0.98..=1.001).contains(&a), "{a}");
}

/// alpha1 > alpha2 is refused with the fix (the same material, lobes swapped); `canonical`
/// swaps them and leaves f_r unchanged.
#[test]
fn lobes_cannot_swap() {
    let e = Model::new(
        ModelKind::GgxSmith2,
        Distribution::D3,
        &[0.5, 0.6, 0.1, 0.3, 1.5, 0.2],
    )
    .unwrap_err();
    assert!(matches!(e, ModelError::Order { .. }), "{e:?}");
    let text = e.to_string();
    assert!(
        text.contains("alpha1 = 0.5 > alpha2 = 0.1")
            && text.contains("alpha1=0.1, ps1=0.3, alpha2=0.5, ps2=0.6"),
        "{text}"
    );
    let good = ggx2(0.1, 0.3, 0.5, 0.6, 1.5, 0.2);
    let swapped = good.with_params(&[0.5, 0.6, 0.1, 0.3, 1.5, 0.2]);
    assert_eq!(swapped.canonical(), good);
    assert_eq!(good.canonical(), good);
    let g = Geometry::from_angles(0.4, 0.0, 0.6, 2.9);
    assert!((swapped.brdf(&g) - good.brdf(&g)).abs() < 1e-12 * good.brdf(&g));
    // alpha1 = alpha2 is allowed (one lobe of ps1 + ps2).
    ggx2(0.2, 0.3, 0.2, 0.6, 1.5, 0.2);
}

/// The Mitsuba export: a `blendbsdf` (weight ⅔) of `diffuse` (3 pd) and an even `blendbsdf` of
/// two `roughconductor`s (3 ps1, 3 ps2), so each part enters with ⅓: the sum is f_r. Checked
/// here for its numbers; `tests/it/export.rs` evaluates it in Mitsuba.
#[test]
fn mitsuba_export_weights() {
    let m = ggx2(0.05, 0.25, 0.4, 0.125, 1.8, 0.2);
    let x = export::mitsuba(&Colour::grey(&m), "mat").unwrap();
    assert!(x.contains("exact"), "{x}");
    assert_eq!(x.matches("type=\"roughconductor\"").count(), 2, "{x}");
    assert_eq!(x.matches("type=\"blendbsdf\"").count(), 2, "{x}");
    for v in [
        "name=\"weight\" value=\"0.6666666666666666\"",
        "name=\"reflectance\" value=\"0.6000000000000001\"",
        "name=\"alpha\" value=\"0.05\"",
        "name=\"alpha\" value=\"0.4\"",
        "name=\"specular_reflectance\" value=\"0.75\"",
        "name=\"specular_reflectance\" value=\"0.375\"",
        "name=\"eta\" value=\"1.8\"",
    ] {
        assert!(x.contains(v), "{v} missing from\n{x}");
    }
    let p = export::pbrt(&Colour::grey(&m));
    assert!(
        p.contains("Not exact in pbrt-v4") && p.contains("brdfit-lobe2"),
        "{p}"
    );
    let b = export::brdf_explorer(&Colour::grey(&m)).unwrap();
    for u in [
        "float alpha1",
        "float ps1",
        "float alpha2",
        "float ps2",
        "float n",
    ] {
        assert!(b.contains(u), "{u} missing from\n{b}");
    }
    assert!(b.contains("ps1 * S1 + ps2 * S2"), "{b}");
}

/// The truth of the recovery tests: a sharp lobe and a broad glow four times wider.
const TRUTH: [f64; 6] = [0.08, 0.4, 0.32, 0.8, 1.8, 0.2];
const NAMES: [&str; 6] = ["alpha1", "ps1", "alpha2", "ps2", "n", "pd"];

fn simulated() -> brdfit::data::Dataset {
    use brdfit::simulate::{Grid, simulate};
    let t = TRUTH;
    simulate(
        &ggx2(t[0], t[1], t[2], t[3], t[4], t[5]),
        &Grid::Hemisphere(10_000).directions(7),
        0.01,
        7,
    )
}

/// On data simulated from known parameters (10,000 hemisphere samples, 1 % noise), the default
/// fit recovers every parameter within 2 %, lobes in order.
#[test]
fn fit_recovers_known_parameters() {
    use brdfit::fit::{self, FitOptions};
    let f = &fit::fit(&simulated(), &FitOptions::new(ModelKind::GgxSmith2)).unwrap()[0];
    for (name, want) in NAMES.iter().zip(TRUTH) {
        let got = f.get(name).unwrap();
        assert!(
            (got - want).abs() <= 0.02 * want,
            "{name}: {got} vs {want} ({:?})",
            f.params
        );
    }
    assert!(f.usable(), "{:?}", f.unusable);
}

/// A local fit started with the lobes swapped (the broad one first) converges to the swapped
/// solution, and the fit returns it in canonical order: alpha1 ≤ alpha2, each ps with its own
/// lobe, standard errors and ranges following their parameters.
#[test]
fn fit_returns_the_lobes_in_order() {
    use brdfit::fit::{self, FitOptions};
    let mut o = FitOptions::new(ModelKind::GgxSmith2);
    o.local_only = true;
    let t = TRUTH;
    o.start = [t[2], t[3], t[0], t[1], t[4], t[5]]
        .iter()
        .zip(NAMES)
        .map(|(v, n)| (n.to_string(), *v))
        .collect();
    let f = &fit::fit(&simulated(), &o).unwrap()[0];
    let (a1, a2) = (f.get("alpha1").unwrap(), f.get("alpha2").unwrap());
    assert!(a1 <= a2, "{:?}", f.params);
    for (name, want) in NAMES.iter().zip(TRUTH) {
        let got = f.get(name).unwrap();
        assert!((got - want).abs() <= 0.02 * want, "{name}: {got} vs {want}");
    }
    // Standard errors and ranges follow their parameters: as in a fit started in order.
    o.start = TRUTH
        .iter()
        .zip(NAMES)
        .map(|(v, n)| (n.to_string(), *v))
        .collect();
    let g = &fit::fit(&simulated(), &o).unwrap()[0];
    for (i, name) in NAMES.iter().enumerate() {
        let (a, b) = (f.stderr[i], g.stderr[i]);
        assert!((a - b).abs() <= 1e-3 * b, "stderr of {name}: {a} vs {b}");
    }
    assert_eq!(f.ranges.len(), g.ranges.len());
    for (a, b) in f.ranges.iter().zip(&g.ranges) {
        assert_eq!(a.0, b.0);
        assert!(
            (a.1 - b.1).abs() <= 1e-3 * b.1,
            "range of {}: {a:?} vs {b:?}",
            a.0
        );
        assert!(
            (a.2 - b.2).abs() <= 1e-3 * b.2,
            "range of {}: {a:?} vs {b:?}",
            a.0
        );
    }
    // The fitted model reads back (Model::new refuses alpha1 > alpha2).
    Model::new(
        ModelKind::GgxSmith2,
        Distribution::D3,
        &f.model_for(0).p[..6],
    )
    .unwrap();
}

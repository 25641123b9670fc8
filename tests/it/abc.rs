//! Torrance–Sparrow with Löw et al. 2012's ABC lobe, D = (1 + b (1 − cos θh))^(−c): values
//! worked by hand, the analytic gradient against finite differences, reciprocity, albedo ≤ 1
//! and the fit's recovery of known parameters.

use brdfit::fit::{self, FitOptions};
use brdfit::model::albedo::max_albedo;
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use brdfit::simulate::{Grid, simulate};
use std::f64::consts::PI;

fn abc(p: &[f64]) -> Model {
    Model::new(ModelKind::TorranceSparrow, Distribution::Abc, p).unwrap()
}

/// Unpolarised Fresnel reflectance from the textbook Rs, Rp (Born & Wolf §1.5).
fn fresnel_textbook(n: f64, c: f64) -> f64 {
    let s = (1.0 - c * c).sqrt() / n;
    let ct = (1.0 - s * s).sqrt();
    let rs = (c - n * ct) / (c + n * ct);
    let rp = (n * c - ct) / (n * c + ct);
    0.5 * (rs * rs + rp * rp)
}

/// (n, b, c, ps, pd) = (1.5, 100, 1.5, 0.8, 0.2).
/// Normal incidence and view: θh = 0 so D = 1, G = 1, N·L = N·E = 1, F = F0 = (0.5/2.5)² =
/// 0.04: f_r = (pd + ps·0.04)/π = (0.2 + 0.032)/π = 0.232/π = 0.0738479.
/// θi = 20°, θo = 40° in the plane of incidence (opposite azimuths): the angle between L and E
/// is 60°, so θd = 30° (E·H = cos 30° = 0.866025) and θh = (40° − 20°)/2 = 10°;
/// 1 − cos 10° = 0.0151922, 1 + 100·0.0151922 = 2.51922, D = 2.51922^−1.5 = 0.250092;
/// G = min(1, 2 cos10° cos40°/cos30° = 1.7422, 2 cos10° cos20°/cos30° = 2.1371) = 1;
/// F(1.5, cos 30°) = ½ (Rs + Rp) = ½ (0.057796 + 0.025249) = 0.041523 (sin θt = 0.5/1.5);
/// f_r = 0.2/π + 0.8·0.250092·0.041523·1/(π cos20° cos40°) = 0.063662 + 0.0036735 = 0.0673355.
#[test]
fn values_worked_by_hand() {
    let m = abc(&[1.5, 100.0, 1.5, 0.8, 0.2]);
    let g = Geometry::from_angles(0.0, 0.0, 0.0, 0.0);
    let f = m.brdf(&g);
    assert!((f - 0.232 / PI).abs() < 1e-12, "{f}");
    assert!((0.232 / PI - 0.073_847_9).abs() < 1e-7);
    let g = Geometry::from_angles(20f64.to_radians(), 0.0, 40f64.to_radians(), PI);
    let d = (1.0 + 100.0 * (1.0 - 10f64.to_radians().cos())).powf(-1.5);
    assert!((d - 0.250_092).abs() < 2e-6, "D {d}");
    let fr = fresnel_textbook(1.5, 30f64.to_radians().cos());
    assert!((fr - 0.041_523).abs() < 1e-6, "F {fr}");
    let want = 0.2 / PI + 0.8 * d * fr / (PI * 20f64.to_radians().cos() * 40f64.to_radians().cos());
    assert!((want - 0.067_335_5).abs() < 2e-7, "{want}");
    let got = m.brdf(&g);
    assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
}

/// c = 2 is close to D3: D3 = (1 + (1 − cos²θh)(1 − c3²)/c3²)^−2 ≈ (1 + 2 (1/c3² − 1)(1 − cos θh))^−2
/// near the peak, so ABC with b = 2 (1/c3² − 1), c = 2 agrees with D3 to within 1 % of the
/// peak for c3 = 0.1 (b = 198).
#[test]
fn c_two_is_close_to_d3() {
    let c3: f64 = 0.1;
    let b = 2.0 * (1.0 / (c3 * c3) - 1.0);
    for i in 0..=90 {
        let nh = (i as f64).to_radians().cos();
        let a = Distribution::Abc.eval_shape(nh, &[b, 2.0]);
        let d3 = Distribution::D3.eval(nh, c3);
        assert!((a - d3).abs() < 0.01, "θh {i}°: abc {a} d3 {d3}");
    }
}

/// The analytic gradient in all five parameters against central differences.
#[test]
fn gradient_matches_finite_differences() {
    let mut count = 0;
    for p in [
        [1.5, 100.0, 1.5, 0.8, 0.2],
        [3.0, 5.0, 0.4, 0.3, 0.05],
        [40.0, 2000.0, 3.5, 2.0, 0.5],
    ] {
        let m = abc(&p);
        for k in 0..120 {
            let a = [
                (k * 37 % 89) as f64 * 0.017,
                0.0,
                (k * 53 % 89) as f64 * 0.017,
                (k * 71 % 360) as f64 * 0.0174,
            ];
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            if !g.visible() {
                continue;
            }
            let mut grad = [0.0; 8];
            let f = m.brdf_grad(&g, &mut grad);
            for j in 0..5 {
                let h = 1e-6 * p[j].abs().max(1e-3);
                let (mut lo, mut hi) = (p, p);
                lo[j] -= h;
                hi[j] += h;
                let fd = (abc(&hi).brdf(&g) - abc(&lo).brdf(&g)) / (2.0 * h);
                assert!(
                    (fd - grad[j]).abs() <= 1e-6 * (fd.abs() + f.abs()),
                    "{p:?} {a:?} ∂{j}: analytic {} vs {fd}",
                    grad[j]
                );
            }
            count += 1;
        }
    }
    assert!(count > 200);
}

/// f_r(L, E) = f_r(E, L).
#[test]
fn reciprocal() {
    let m = abc(&[2.0, 300.0, 0.9, 0.7, 0.3]);
    for k in 0..200 {
        let a = [
            (k * 37 % 89) as f64 * 0.017,
            (k * 11 % 360) as f64 * 0.0174,
            (k * 53 % 89) as f64 * 0.017,
            (k * 71 % 360) as f64 * 0.0174,
        ];
        let f1 = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        let f2 = m.brdf(&Geometry::from_angles(a[2], a[3], a[0], a[1]));
        assert!((f1 - f2).abs() <= 1e-12 * f1.abs().max(1e-300), "{a:?}");
    }
}

/// With ps ≤ 1, pd = 0 and a Fresnel factor ≤ 1 (here F → 1, n = 1e7) the directional
/// albedo stays ≤ 1 at every θi the physical check uses, for sharp to broad lobes and light
/// to heavy tails (c 0.3–4). The lobe's peak is 1, so ρ ≤ (1/(π cos θi)) ∫ G dω only: a broad
/// heavy-tailed lobe (b 30, c 0.3) reaches 2.06 at θi = 85°, as broad D1–D3 lobes can; the
/// physical check marks such fits not usable (asserted here, so the check is needed).
#[test]
fn albedo_at_most_one() {
    let broad = abc(&[1e7, 30.0, 0.3, 1.0, 0.0]);
    assert!(max_albedo(&broad).1 > 1.5);
    for (b, c) in [
        (1e5, 0.3),
        (1e5, 2.0),
        (1e5, 4.0),
        (1e3, 0.3),
        (1e3, 1.0),
        (1e3, 4.0),
        (30.0, 2.0),
        (30.0, 4.0),
        (3.0, 4.0),
    ] {
        {
            let m = abc(&[1e7, b, c, 1.0, 0.0]);
            let (at, worst) = max_albedo(&m);
            assert!(
                worst <= 1.0 + 1e-3,
                "b {b} c {c}: albedo {worst} at θi {at}"
            );
        }
    }
}

/// On data simulated from known parameters (10,000 hemisphere samples, 1 % noise), the fit
/// recovers every parameter within 2 %.
#[test]
fn fit_recovers_known_parameters() {
    let truth = [1.8, 400.0, 1.2, 0.6, 0.3];
    let ds = simulate(
        &abc(&truth),
        &Grid::Hemisphere(10_000).directions(7),
        0.01,
        7,
    );
    let mut o = FitOptions::new(ModelKind::TorranceSparrow);
    o.dist = Distribution::Abc;
    let f = &fit::fit(&ds, &o).unwrap()[0];
    for (name, want) in ["n", "b", "c", "ps", "pd"].iter().zip(truth) {
        let got = f.get(name).unwrap();
        assert!(
            (got - want).abs() <= 0.02 * want,
            "{name}: {got} vs {want} ({:?})",
            f.params
        );
    }
    assert!(f.usable(), "{:?}", f.unusable);
}

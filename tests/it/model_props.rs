//! Property tests of the reflection models: analytic gradients against central finite
//! differences, non-negativity and finiteness in bounds, reciprocity.

use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use proptest::prelude::*;

fn model_strategy() -> impl Strategy<Value = Model> {
    prop_oneof![
        (0.0..1.0f64)
            .prop_map(|pd| Model::new(ModelKind::Lambert, Distribution::D3, &[pd]).unwrap()),
        (1.0..200.0f64, 0.0..2.0f64, 0.0..1.0f64).prop_map(|(c1, ps, pd)| Model::new(
            ModelKind::Phong,
            Distribution::D3,
            &[c1, ps, pd]
        )
        .unwrap()),
        (1.0..200.0f64, 0.0..2.0f64, 0.0..1.0f64).prop_map(|(c1, ps, pd)| {
            Model::new(ModelKind::BlinnPhong, Distribution::D3, &[c1, ps, pd]).unwrap()
        }),
        (1.01..300.0f64, 0.02..1.0f64, 0.0..2.0f64, 0.0..1.0f64).prop_map(|(n, c, ps, pd)| {
            Model::new(
                ModelKind::TorranceSparrow,
                Distribution::D3,
                &[n, c, ps, pd],
            )
            .unwrap()
        }),
        (1.01..300.0f64, 0.5..20.0f64, 0.0..2.0f64, 0.0..1.0f64).prop_map(|(n, c, ps, pd)| {
            Model::new(
                ModelKind::TorranceSparrow,
                Distribution::D2,
                &[n, c, ps, pd],
            )
            .unwrap()
        }),
        (1.01..300.0f64, 1.0..200.0f64, 0.0..2.0f64, 0.0..1.0f64).prop_map(|(n, c, ps, pd)| {
            Model::new(
                ModelKind::TorranceSparrow,
                Distribution::D1,
                &[n, c, ps, pd],
            )
            .unwrap()
        }),
        (0.02..1.0f64, 1.01..300.0f64, 0.0..2.0f64, 0.0..1.0f64).prop_map(|(a, n, ps, pd)| {
            Model::new(ModelKind::GgxSmith, Distribution::D3, &[a, n, ps, pd]).unwrap()
        }),
        (
            0.02..1.0f64,
            0.02..1.0f64,
            1.01..300.0f64,
            0.0..2.0f64,
            0.0..2.0f64,
            0.0..1.0f64
        )
            .prop_map(|(a, b, n, ps1, ps2, pd)| ggx2(a.min(b), ps1, a.max(b), ps2, n, pd)),
    ]
}

/// ggx-smith-2 with alpha1 ≤ alpha2.
fn ggx2(a1: f64, ps1: f64, a2: f64, ps2: f64, n: f64, pd: f64) -> Model {
    Model::new(
        ModelKind::GgxSmith2,
        Distribution::D3,
        &[a1, ps1, a2, ps2, n, pd],
    )
    .unwrap()
}

fn angles() -> impl Strategy<Value = [f64; 4]> {
    (0.0..1.55f64, -3.2..3.2f64, 0.0..1.55f64, -3.2..3.2f64).prop_map(|(a, b, c, d)| [a, b, c, d])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn gradient_matches_central_differences(m in model_strategy(), a in angles()) {
        let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
        let mut grad = [0.0; brdfit::model::MAX_PARAMS];
        let f = m.brdf_grad(&g, &mut grad);
        prop_assert!((f - m.brdf(&g)).abs() <= 1e-12 * (1.0 + f.abs()));
        let p = m.params().to_vec();
        for i in 0..p.len() {
            let h = 1e-6 * p[i].abs().max(1e-2);
            let mut up = p.clone();
            let mut dn = p.clone();
            up[i] += h;
            dn[i] -= h;
            let fd = (m.with_params(&up).brdf(&g) - m.with_params(&dn).brdf(&g)) / (2.0 * h);
            let tol = 1e-5 * (1.0 + grad[i].abs() + f.abs() / p[i].abs().max(1e-2));
            prop_assert!((fd - grad[i]).abs() <= tol,
                "{} d/d{}: analytic {} vs finite difference {} at {:?}", m, m.param_names()[i], grad[i], fd, a);
        }
    }

    #[test]
    fn brdf_is_finite_and_non_negative(m in model_strategy(), a in angles()) {
        let f = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        prop_assert!(f.is_finite() && f >= 0.0, "{} at {:?}: {}", m, a, f);
    }

    #[test]
    fn ggx_smith_reciprocal(alpha in 0.02..1.0f64, n in 1.01..300.0f64, a in angles()) {
        let m = Model::new(ModelKind::GgxSmith, Distribution::D3, &[alpha, n, 0.7, 0.3]).unwrap();
        let f1 = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        let f2 = m.brdf(&Geometry::from_angles(a[2], a[3], a[0], a[1]));
        prop_assert!((f1 - f2).abs() <= 1e-10 * (1.0 + f1.abs()));
    }

    #[test]
    fn ggx_smith_2_reciprocal(a in 0.02..1.0f64, b in 0.02..1.0f64, n in 1.01..300.0f64, x in angles()) {
        let m = ggx2(a.min(b), 0.6, a.max(b), 0.3, n, 0.1);
        let f1 = m.brdf(&Geometry::from_angles(x[0], x[1], x[2], x[3]));
        let f2 = m.brdf(&Geometry::from_angles(x[2], x[3], x[0], x[1]));
        prop_assert!((f1 - f2).abs() <= 1e-10 * (1.0 + f1.abs()));
    }

    #[test]
    fn torrance_sparrow_reciprocal(n in 1.01..300.0f64, c in 0.02..1.0f64, a in angles()) {
        let m = Model::new(ModelKind::TorranceSparrow, Distribution::D3, &[n, c, 0.7, 0.3]).unwrap();
        let f1 = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        let f2 = m.brdf(&Geometry::from_angles(a[2], a[3], a[0], a[1]));
        prop_assert!((f1 - f2).abs() <= 1e-10 * (1.0 + f1.abs()));
    }
}

#[test]
fn fast_phong_gradient_matches_finite_differences() {
    let mut m = Model::new(ModelKind::Phong, Distribution::D3, &[50.0, 0.5, 0.2]).unwrap();
    m.fast_pow = Some(3);
    let g = Geometry::from_angles(0.5, 0.0, 0.55, 3.1);
    let mut grad = [0.0; 4];
    m.brdf_grad(&g, &mut grad);
    let h = 1e-5;
    let fd = (m.with_params(&[50.0 + h, 0.5, 0.2]).brdf(&g)
        - m.with_params(&[50.0 - h, 0.5, 0.2]).brdf(&g))
        / (2.0 * h);
    assert!(
        grad[0] != 0.0 && (fd - grad[0]).abs() < 1e-6 * (1.0 + fd.abs()),
        "{fd} vs {}",
        grad[0]
    );
}

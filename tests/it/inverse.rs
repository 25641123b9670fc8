//! Inverse Phong: a cylinder and a sphere rendered by brdfit (Lambert, ambient + diffuse, known
//! light) are inverted along a row; normals and heights are compared with the true geometry.

use brdfit::inverse::{self, Prior};
use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::render::{AntiAlias, Camera, Light, Material, Mesh, Object, Scene, Shape};
use glam::DVec3;
use rand::SeedableRng;
use rand_distr::{Distribution as _, Normal};

const R: f64 = 1.0;
const W: u32 = 241;
const EYE_Z: f64 = 400.0;

fn light() -> DVec3 {
    DVec3::new(0.45, 0.2, 1.0).normalize()
}

fn scene(shape: Shape, light: DVec3) -> Scene {
    // A distant camera with a narrow field: nearly orthographic, so the view is along −z.
    let half = 1.2 * R;
    let fov = 2.0 * (half / EYE_Z).atan().to_degrees();
    Scene {
        camera: Camera {
            eye: DVec3::new(0.0, 0.0, EYE_Z),
            target: DVec3::ZERO,
            up: DVec3::Y,
            fov_deg: fov,
            width: W,
            height: W,
        },
        objects: vec![Object::new(shape, 0)],
        materials: vec![Material {
            name: "white".into(),
            model: Model::new(ModelKind::Lambert, Distribution::D3, &[1.0]).unwrap(),
            color: DVec3::ONE,
            specular: DVec3::ONE,
            checker: None,
            ks: 0.0,
            kt: 0.0,
            ior: 1.5,
            roughness: None,
            measured: None,
        }],
        // Irradiance π and pd = 1: Cd = pd·E/π = 1; ambient radiance 0.1: Ca = 0.1.
        lights: vec![Light::Directional {
            direction: light,
            irradiance: DVec3::splat(std::f64::consts::PI),
        }],
        ambient: DVec3::splat(0.1),
        background: DVec3::ZERO,
        max_depth: 1,
        min_weight: 1e-3,
        antialias: AntiAlias::None,
    }
}

fn cylinder() -> Shape {
    // Axis along y, 1440 facets around: flat facets deviate ≤ 0.125° from the true normal.
    let n = 1440;
    let mut tris = Vec::new();
    for k in 0..n {
        let (a0, a1) = (
            k as f64 / n as f64 * std::f64::consts::TAU,
            (k + 1) as f64 / n as f64 * std::f64::consts::TAU,
        );
        let p = |a: f64, y: f64| DVec3::new(R * a.cos(), y, R * a.sin());
        tris.push([p(a0, -5.0), p(a1, -5.0), p(a1, 5.0)]);
        tris.push([p(a0, -5.0), p(a1, 5.0), p(a0, 5.0)]);
    }
    Shape::Mesh(Mesh::new(tris))
}

/// World x of pixel column `x` (at the object's distance).
fn world_x(x: u32) -> f64 {
    ((x as f64 + 0.5) / W as f64 * 2.0 - 1.0) * 1.2 * R
}

struct Outcome {
    median_normal_err_deg: f64,
    max_normal_err_deg: f64,
    height_err_frac: f64,
    flagged: usize,
}

fn invert(shape: Shape, noise: f64, seed: u64) -> Outcome {
    invert_lit(shape, noise, seed, light())
}

/// [`invert`] under the directional light `l` (unit, toward the light).
fn invert_lit(shape: Shape, noise: f64, seed: u64, l: DVec3) -> Outcome {
    let img = scene(shape, l).render(&|| {});
    let row = W / 2;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let gauss = Normal::new(0.0, 1.0).unwrap();
    let vals: Vec<f64> = (0..W)
        .map(|x| {
            let v = img.at(x, row)[0] as f64;
            v * (1.0 + noise * gauss.sample(&mut rng))
        })
        .collect();
    let pixel = 2.4 * R / W as f64;
    let px = inverse::invert_line(&vals, [l.x, l.z], 0.1, 1.0, pixel, Prior::Convex);
    // Truth on the object: x = world_x, z = √(R² − x²), N = (x, z)/R.
    let (mut max_err, mut pairs, mut flagged, mut errs) = (0.0f64, Vec::new(), 0, Vec::new());
    for (x, p) in px.iter().enumerate() {
        let wx = world_x(x as u32);
        if wx.abs() >= R * 0.999 {
            continue;
        }
        let z = (R * R - wx * wx).sqrt();
        let n = [wx / R, z / R];
        // Where the surface faces the light (N·L clearly positive).
        if n[0] * l.x + n[1] * l.z > 0.15 {
            if p.flagged {
                // Noise can push a value past the model's range: flagged, never invented.
                assert!(noise > 0.0, "pixel {x} flagged on a clean image");
                flagged += 1;
                continue;
            }
            let err = (p.normal[0] * n[0] + p.normal[1] * n[1])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees();
            max_err = max_err.max(err);
            errs.push(err);
            pairs.push((p.height, z));
        }
    }
    // Heights are relative: compare after removing the mean offset.
    let off = pairs.iter().map(|(e, t)| e - t).sum::<f64>() / pairs.len() as f64;
    let range = pairs.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max)
        - pairs.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let herr = pairs
        .iter()
        .map(|(e, t)| (e - off - t).abs())
        .fold(0.0, f64::max)
        / range;
    errs.sort_by(f64::total_cmp);
    Outcome {
        median_normal_err_deg: errs[errs.len() / 2],
        max_normal_err_deg: max_err,
        height_err_frac: herr,
        flagged,
    }
}

#[test]
fn cylinder_and_sphere_rows_invert_to_the_true_normals_and_profile() {
    for (name, shape) in [
        ("cylinder", cylinder()),
        (
            "sphere",
            Shape::Sphere {
                center: DVec3::ZERO,
                radius: R,
            },
        ),
    ] {
        let o = invert(shape, 0.0, 1);
        println!(
            "{name}: max normal error {:.3}°, height error {:.3} % of range",
            o.max_normal_err_deg,
            100.0 * o.height_err_frac
        );
        assert!(
            o.max_normal_err_deg < 1.0,
            "{name}: {}°",
            o.max_normal_err_deg
        );
        assert!(o.height_err_frac < 0.01, "{name}: {}", o.height_err_frac);
    }
}

#[test]
fn noise_degrades_gracefully() {
    let clean = invert(
        Shape::Sphere {
            center: DVec3::ZERO,
            radius: R,
        },
        0.0,
        1,
    );
    let n1 = invert(
        Shape::Sphere {
            center: DVec3::ZERO,
            radius: R,
        },
        0.01,
        2,
    );
    let n5 = invert(
        Shape::Sphere {
            center: DVec3::ZERO,
            radius: R,
        },
        0.05,
        3,
    );
    for (label, o) in [("0 %", &clean), ("1 %", &n1), ("5 %", &n5)] {
        println!(
            "sphere row, noise {label}: normal error median {:.2}° max {:.2}°, height error {:.2} % of range, {} pixels flagged",
            o.median_normal_err_deg,
            o.max_normal_err_deg,
            100.0 * o.height_err_frac,
            o.flagged
        );
    }
    // Errors grow with the noise; the worst pixels are next to the brightest point, where
    // acos(s/|L|) is ill-conditioned.
    assert!(
        clean.median_normal_err_deg <= n1.median_normal_err_deg
            && n1.median_normal_err_deg <= n5.median_normal_err_deg
    );
    assert!(
        clean.height_err_frac <= n1.height_err_frac && n1.height_err_frac <= n5.height_err_frac
    );
    // Graceful: the typical normal stays within a few degrees and the profile within 20 %.
    assert!(
        n1.median_normal_err_deg < 2.0 && n5.median_normal_err_deg < 6.0,
        "{} {}",
        n1.median_normal_err_deg,
        n5.median_normal_err_deg
    );
    assert!(n1.height_err_frac < 0.05 && n5.height_err_frac < 0.20);
}

#[test]
fn values_outside_the_model_range_are_flagged_and_two_lights_remove_the_ambiguity() {
    let l = [0.6, 0.8];
    // (I − Ca)/Cd = 1.5 > |L|: no normal explains it.
    let px = inverse::invert_line(&[0.5, 1.6, 0.5], l, 0.1, 1.0, 1.0, Prior::Convex);
    assert!(px[1].flagged && px[1].normal[0].is_nan() && !px[0].flagged);
    // Two lights: a known normal is recovered exactly.
    let n = [0.3f64, (1.0f64 - 0.09).sqrt()];
    let l2 = [-0.5, 0.866];
    let v = |l: [f64; 2]| 0.1 + (l[0] * n[0] + l[1] * n[1]);
    let px = inverse::invert_line_two_lights(&[v(l)], &[v(l2)], l, l2, 0.1, 1.0, 1.0);
    assert!((px[0].normal[0] - n[0]).abs() < 1e-12 && (px[0].normal[1] - n[1]).abs() < 1e-12);
}

/// An exact cylinder cross-section (no renderer): I = Ca + Cd·max(0, L·N) with N = (u, √(1 − u²))
/// along the line, the light from 75° on one side of the view axis to 60° on the other. Every
/// pixel the light reaches (N·L ≥ 0.15) gets its true normal, before and past the brightest
/// pixel, where the two solution branches meet (the prior picks the first pixel's branch,
/// continuity the rest).
#[test]
fn an_exact_cylinder_inverts_with_the_light_off_the_view_axis() {
    let n = 401;
    let us: Vec<f64> = (0..n)
        .map(|k| -0.999 + 1.998 * k as f64 / (n - 1) as f64)
        .collect();
    for deg in [0.0f64, 10.0, 24.0, 45.0, 60.0, 75.0, -30.0, -60.0] {
        let (lu, lz) = (deg.to_radians().sin(), deg.to_radians().cos());
        let truth = |u: f64| [u, (1.0 - u * u).sqrt()];
        let vals: Vec<f64> = us
            .iter()
            .map(|&u| 0.1 + (lu * truth(u)[0] + lz * truth(u)[1]).max(0.0))
            .collect();
        let px = inverse::invert_line(&vals, [lu, lz], 0.1, 1.0, 1.0, Prior::Convex);
        let mut lit = 0;
        for (p, &u) in px.iter().zip(&us) {
            let t = truth(u);
            if lu * t[0] + lz * t[1] < 0.15 {
                continue;
            }
            lit += 1;
            assert!(!p.flagged, "light {deg}°: u {u} flagged");
            let err = (p.normal[0] * t[0] + p.normal[1] * t[1])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees();
            assert!(err < 0.01, "light {deg}°: u {u}: normal off by {err}°");
        }
        assert!(lit > n / 3, "light {deg}°: only {lit} lit pixels");
    }
}

/// A sphere rendered by brdfit under a light far off the view axis (60° and 45° from it, on
/// either side, one with a component across the line): past the brightest pixel the two
/// solution branches cross, and the kept one must follow the true sphere there too. The truth
/// is the sphere's own normal (x, √(R² − x²))/R along the middle row.
#[test]
fn a_sphere_rendered_with_the_light_off_axis_inverts_past_the_brightest_pixel() {
    let sphere = || Shape::Sphere {
        center: DVec3::ZERO,
        radius: R,
    };
    for (deg, y) in [(60.0f64, 0.0), (-45.0, 0.3)] {
        let t = deg.to_radians();
        let l = DVec3::new(t.sin(), y, t.cos()).normalize();
        let o = invert_lit(sphere(), 0.0, 1, l);
        assert!(o.flagged == 0, "light {deg}°: {} flagged", o.flagged);
        assert!(
            o.max_normal_err_deg < 1.0,
            "light {deg}°: max normal error {}° (median {}°)",
            o.max_normal_err_deg,
            o.median_normal_err_deg
        );
        assert!(
            o.height_err_frac < 0.01,
            "light {deg}°: {}",
            o.height_err_frac
        );
    }
}

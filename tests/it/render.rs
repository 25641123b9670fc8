//! Renderer: geometry and light transport against values computed independently here, and
//! Blinn's Figure 7 findings measured on the linear images.

use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::render::{self, AntiAlias, Image, refract};
use brdfit::render::{Lighting, fig7_scene};
use brdfit::scene::parse_scene;
use glam::DVec3;
use std::path::Path;

fn lambert(pd: f64) -> Model {
    Model::new(ModelKind::Lambert, Distribution::D3, &[pd]).unwrap()
}

pub(crate) fn scene(text: &str) -> render::Scene {
    parse_scene(text, Path::new(".")).unwrap()
}

/// The pinhole ray through the centre of pixel (x, y), written out independently of the renderer.
fn pixel_ray(eye: DVec3, target: DVec3, fov_deg: f64, w: u32, h: u32, x: u32, y: u32) -> DVec3 {
    let f = (target - eye).normalize();
    let r = f.cross(DVec3::Y).normalize();
    let u = r.cross(f);
    let t = (fov_deg.to_radians() / 2.0).tan();
    let px = ((x as f64 + 0.5) / w as f64 * 2.0 - 1.0) * t;
    let py = (1.0 - (y as f64 + 0.5) / h as f64 * 2.0) * t * h as f64 / w as f64;
    (f + px * r + py * u).normalize()
}

fn sphere_hit(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<f64> {
    let b = (o - c).dot(d);
    let disc = b * b - ((o - c).length_squared() - r * r);
    (disc >= 0.0).then(|| {
        let s = disc.sqrt();
        if -b - s > 1e-9 { -b - s } else { -b + s }
    })
}

pub(crate) fn lum(p: [f32; 3]) -> f64 {
    (p[0] + p[1] + p[2]) as f64 / 3.0
}

#[test]
fn sphere_lit_from_the_eye_is_brightest_at_its_centre() {
    let mut s = fig7_scene(lambert(0.8), Lighting::Front, 101);
    s.lights = vec![render::Light::Directional {
        direction: DVec3::Z,
        irradiance: DVec3::splat(1.0),
    }];
    s.antialias = AntiAlias::None;
    let img = s.render(&|| {});
    let (mut best, mut at) = (0.0, (0, 0));
    for y in 0..101 {
        for x in 0..101 {
            if lum(img.at(x, y)) > best {
                best = lum(img.at(x, y));
                at = (x, y);
            }
        }
    }
    assert_eq!(at, (50, 50));
    // Radiance there: ambient·pd + pd·E·cos0/π with E = 1.
    assert!(
        (best - (0.03 * 0.8 + 0.8 / std::f64::consts::PI)).abs() < 1e-3,
        "{best}"
    );
}

const SHADOW: &str = r#"
ambient = 0.1
[camera]
eye = [0.0, 3.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
width = 81
height = 81
[antialias]
mode = "none"
[[lights]]
kind = "directional"
direction = [0.0, 1.0, 0.0]
intensity = 2.0
[materials.white]
model = "lambert"
params = { pd = 0.5 }
[[objects]]
kind = "sphere"
center = [0.0, 1.0, 0.0]
radius = 0.5
material = "white"
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
material = "white"
"#;

#[test]
fn a_point_in_the_shadow_gets_only_ambient_light() {
    let img = scene(SHADOW).render(&|| {});
    // The centre pixel looks at (0, 0, 0), right under the sphere: ambient × pd only.
    let c = img.at(40, 40);
    assert!((lum(c) - 0.1 * 0.5).abs() < 1e-6, "{c:?}");
    // A lit floor point: ambient·pd + pd·E/π (light straight down, N·L = 1).
    let lit = 0.1 * 0.5 + 0.5 * 2.0 / std::f64::consts::PI;
    let corner = img.at(2, 78);
    assert!((lum(corner) - lit).abs() < 1e-6, "{corner:?} vs {lit}");
    // One shadow ray per lit-side hit, no mirror or refraction rays in this scene.
    assert_eq!(img.rays[2] + img.rays[3], 0);
    assert!(img.rays[1] > 0 && img.rays[1] <= img.rays[0]);
}

const MIRROR: &str = r#"
ambient = 1.0
max_depth = 3
[camera]
eye = [0.0, 1.5, 5.0]
target = [0.0, 1.0, 0.0]
fov = 30.0
width = 64
height = 64
[antialias]
mode = "none"
[materials.mirror]
model = "lambert"
params = { pd = 0.0 }
ks = 1.0
[materials.floor]
model = "lambert"
params = { pd = 1.0 }
checker = { size = 0.5, color0 = [0.2, 0.2, 0.2], color1 = [0.9, 0.9, 0.9] }
[[objects]]
kind = "sphere"
center = [0.0, 1.0, 0.0]
radius = 1.0
material = "mirror"
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
size = 20.0
material = "floor"
"#;

#[test]
fn mirror_sphere_shows_the_checker_hit_by_the_analytic_reflected_ray() {
    let img = scene(MIRROR).render(&|| {});
    let (eye, c) = (DVec3::new(0.0, 1.5, 5.0), DVec3::new(0.0, 1.0, 0.0));
    let mut checked = 0;
    for y in 0..64 {
        for x in 0..64 {
            let d = pixel_ray(eye, c, 30.0, 64, 64, x, y);
            let Some(t) = sphere_hit(eye, d, c, 1.0) else {
                continue;
            };
            let p = eye + t * d;
            let n = (p - c).normalize();
            let r = d - 2.0 * d.dot(n) * n;
            if r.y >= -1e-3 {
                continue; // reflected ray goes up to the black sky (or grazes)
            }
            let q = p + (-p.y / r.y) * r;
            if q.x.abs() > 19.0 || q.z.abs() > 19.0 {
                continue; // beyond the 20-unit floor
            }
            // Skip rays landing near a square's edge.
            let (fu, fv) = ((q.x / 0.5).fract().abs(), (q.z / 0.5).fract().abs());
            if fu.min(1.0 - fu) < 0.05 || fv.min(1.0 - fv) < 0.05 {
                continue;
            }
            // A floor's checker runs along world x and z (scene::plane_axes).
            let k = (q.x / 0.5).floor() as i64 + (q.z / 0.5).floor() as i64;
            let want = [0.2, 0.9][k.rem_euclid(2) as usize];
            let got = lum(img.at(x, y));
            assert!(
                (got - want).abs() < 1e-6,
                "pixel ({x}, {y}): {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert!(checked > 100, "only {checked} pixels checked");
}

#[test]
fn snell_and_total_internal_reflection() {
    let n = DVec3::Y;
    for deg in [0.0f64, 20.0, 40.0, 60.0, 80.0] {
        let a = deg.to_radians();
        let d = DVec3::new(a.sin(), -a.cos(), 0.0);
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        // Snell: sinθt = sinθi / 1.5, ray continues downward on the same side.
        assert!((t.x - a.sin() / 1.5).abs() < 1e-12 && t.y < 0.0);
    }
    // From glass to air: critical angle asin(1/1.5) = 41.81°.
    let crit = (1.0f64 / 1.5).asin();
    let inside = |a: f64| DVec3::new(a.sin(), -a.cos(), 0.0);
    assert!(refract(inside(crit - 1e-3), n, 1.5).is_some());
    assert!(refract(inside(crit + 1e-3), n, 1.5).is_none());
}

const GLASS: &str = r#"
ambient = 1.0
max_depth = 4
min_weight = 0.0
[camera]
eye = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
width = 48
height = 48
[antialias]
mode = "none"
[materials.glass]
model = "lambert"
params = { pd = 0.0 }
kt = 1.0
ior = 1.5
[materials.wall]
model = "lambert"
params = { pd = 1.0 }
checker = { size = 0.25, color0 = [0.1, 0.1, 0.1], color1 = [0.7, 0.7, 0.7] }
[[objects]]
kind = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "glass"
[[objects]]
kind = "plane"
point = [0.0, 0.0, -3.0]
normal = [0.0, 0.0, 1.0]
size = 50.0
material = "wall"
"#;

#[test]
fn glass_sphere_refracts_per_snell() {
    let s = scene(GLASS);
    let img = s.render(&|| {});
    // A wall's checker runs along world x and y (scene::plane_axes).
    let eye = DVec3::new(0.0, 0.0, 5.0);
    let snell = |d: DVec3, n: DVec3, eta: f64| -> Option<DVec3> {
        // Vector form written out from n1 sinθ1 = n2 sinθ2.
        let ci = -d.dot(n);
        let k = 1.0 - eta * eta * (1.0 - ci * ci);
        (k >= 0.0).then(|| eta * d + (eta * ci - k.sqrt()) * n)
    };
    let mut checked = 0;
    for y in 0..48 {
        for x in 0..48 {
            let d = pixel_ray(eye, DVec3::ZERO, 30.0, 48, 48, x, y);
            let Some(t) = sphere_hit(eye, d, DVec3::ZERO, 1.0) else {
                continue;
            };
            let p = eye + t * d;
            let Some(d1) = snell(d, p.normalize(), 1.0 / 1.5) else {
                continue;
            };
            let d1 = d1.normalize();
            // Exit: the far intersection from inside.
            let b = p.dot(d1);
            let t2 = -b + (b * b - (p.length_squared() - 1.0)).sqrt();
            let q = p + t2 * d1;
            let Some(d2) = snell(d1, -q.normalize(), 1.5) else {
                continue;
            };
            let d2 = d2.normalize();
            if d2.z >= 0.0 {
                continue;
            }
            let w = q + ((-3.0 - q.z) / d2.z) * d2;
            let (fu, fv) = ((w.x / 0.25).fract().abs(), (w.y / 0.25).fract().abs());
            if fu.min(1.0 - fu) < 0.08 || fv.min(1.0 - fv) < 0.08 {
                continue;
            }
            let k = (w.x / 0.25).floor() as i64 + (w.y / 0.25).floor() as i64;
            let want = [0.1, 0.7][k.rem_euclid(2) as usize];
            let got = lum(img.at(x, y));
            assert!(
                (got - want).abs() < 1e-6,
                "pixel ({x}, {y}): {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert!(checked > 200, "only {checked} pixels checked");
    assert!(img.rays[3] > 0, "refraction rays were traced");
}

pub(crate) fn sphere_pixels(img: &Image) -> Vec<f64> {
    img.pixels
        .iter()
        .map(|p| lum(*p))
        .filter(|v| *v > 1e-6)
        .collect()
}

fn top_mean(v: &[f64], frac: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| b.total_cmp(a));
    let k = ((s.len() as f64 * frac) as usize).max(1);
    s[..k].iter().sum::<f64>() / k as f64
}

#[test]
fn figure_7_findings_on_linear_images() {
    let imgs = render::fig7_images(
        &Model::blinn_aluminium(),
        &Model::blinn_mgo(),
        160,
        AntiAlias::None,
    );
    let get = |name: &str| &imgs.iter().find(|(n, _)| n == name).unwrap().1;
    for mat in ["aluminium", "mgo"] {
        // Front lit: the two models differ little (mean over the object within 10 %).
        let (p, t) = (
            sphere_pixels(get(&format!("{mat}-front-phong"))),
            sphere_pixels(get(&format!("{mat}-front-ts"))),
        );
        let (mp, mt) = (
            p.iter().sum::<f64>() / p.len() as f64,
            t.iter().sum::<f64>() / t.len() as f64,
        );
        assert!(
            (mt / mp - 1.0).abs() < 0.10,
            "{mat} front: TS {mt} vs Phong {mp}"
        );
    }
    // Edge lit MgO: the highlight (brightest 1 % of the object) is several times brighter
    // under Torrance–Sparrow than under Phong.
    let hp = top_mean(&sphere_pixels(get("mgo-edge-phong")), 0.01);
    let ht = top_mean(&sphere_pixels(get("mgo-edge-ts")), 0.01);
    assert!(ht > 3.0 * hp, "MgO edge highlight: TS {ht} vs Phong {hp}");
}

/// A scene material `fit = ` an RGB fit file renders in colour: each
/// channel of the image equals that channel of the same scene rendered with the channel's
/// own model (`model = "ggx-smith"`, its ps and pd), so the colour decomposition (one lobe,
/// per-channel ps and pd) is exact. `fit_model` and `fit_channel` pick from the file.
#[test]
fn a_colour_fit_renders_each_channel_with_its_own_model() {
    let dir = tempfile::tempdir().unwrap();
    let chans = [("r", 0.2, 0.8), ("g", 0.4, 0.4), ("b", 0.6, 0.1)];
    let obj = |model: &str, c: &str, params: String, bic: f64| {
        format!(
            r#"{{"model": "{model}", "distribution": "d3", "channel": "{c}", "params": {params}, "cost": 1, "rmse": 0.1, "samples_used": 10, "bic": {bic}, "aic": 1, "n_free": 4}}"#
        )
    };
    let mut fits: Vec<String> = chans
        .iter()
        .map(|(c, ps, pd)| {
            obj(
                "ggx-smith",
                c,
                format!(r#"{{"alpha": 0.3, "n": 1.5, "ps": {ps}, "pd": {pd}}}"#),
                -100.0,
            )
        })
        .collect();
    fits.extend(
        chans
            .iter()
            .map(|(c, _, pd)| obj("lambert", c, format!(r#"{{"pd": {pd}}}"#), 50.0)),
    );
    std::fs::write(
        dir.path().join("rgb.json"),
        format!(r#"{{"fits": [{}]}}"#, fits.join(",")),
    )
    .unwrap();
    let text = |material: &str| {
        format!(
            r#"
[camera]
eye = [0.0, 1.0, 4.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
width = 33
height = 33
[antialias]
mode = "none"
[[lights]]
kind = "directional"
direction = [0.3, 1.0, 1.0]
intensity = 2.0
[materials.m]
{material}
[[objects]]
kind = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "m"
"#
        )
    };
    let render = |material: &str| {
        parse_scene(&text(material), dir.path())
            .unwrap()
            .render(&|| {})
    };
    let colour = render(r#"fit = "rgb.json""#);
    let mut lit = 0;
    for (k, (_, ps, pd)) in chans.iter().enumerate() {
        let own = render(&format!(
            "model = \"ggx-smith\"\nparams = {{ alpha = 0.3, n = 1.5, ps = {ps}, pd = {pd} }}"
        ));
        for (a, b) in colour.pixels.iter().zip(&own.pixels) {
            assert!(
                (a[k] - b[k]).abs() <= 1e-6 * b[k].abs().max(1e-3),
                "channel {k}: {} against {}",
                a[k],
                b[k]
            );
            lit += (b[k] > 0.0) as usize;
        }
    }
    assert!(lit > 500, "the sphere is lit: {lit}");
    // The file's lambert fits on request, one channel on request.
    let lam = render("fit = \"rgb.json\"\nfit_model = \"lambert\"\nfit_channel = \"b\"");
    let own = render("model = \"lambert\"\nparams = { pd = 0.1 }");
    assert_eq!(lam.pixels, own.pixels);
    // A channel the file lacks is refused with the key named.
    let e = parse_scene(&text("fit = \"rgb.json\"\nfit_channel = \"y\""), dir.path())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("no fit of channel y") && e.contains("fit_channel"),
        "{e}"
    );
    // The fix's command line keeps its real flag; the scene key is named where a key is meant.
    assert!(
        e.contains("pick one of them with fit_channel")
            && e.contains("brdfit fit DATA --channel y --json OUT"),
        "{e}"
    );
    // A model the file lacks names the command that fits it.
    let e = parse_scene(
        &text("fit = \"rgb.json\"\nfit_model = \"phong\""),
        dir.path(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("with fit_model") && e.contains("brdfit fit DATA --model phong --json OUT"),
        "{e}"
    );
    // A distribution that does not exist is refused, not ignored, beside a fit file too.
    let e = parse_scene(
        &text("fit = \"rgb.json\"\ndistribution = \"banana\""),
        dir.path(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("unknown distribution 'banana'") && e.contains("d1, d2, d3 or abc"),
        "{e}"
    );
}

/// A mesh of many copies of one triangle keeps it once (no BVH split separates coincident
/// triangles, so every ray would visit them all) and still renders it; the other winding is
/// another triangle.
#[test]
fn repeated_triangles_are_kept_once() {
    use brdfit::render::{Mesh, Ray};
    use glam::DVec3;
    let a = DVec3::new(0.0, 0.0, 0.0);
    let b = DVec3::new(1.0, 0.0, 0.0);
    let c = DVec3::new(0.0, 1.0, 0.0);
    let mut tris = vec![[a, b, c]; 5000];
    tris.extend(vec![[b, c, a]; 5000]);
    tris.push([a, c, b]);
    let m = Mesh::new(tris);
    assert_eq!(m.len(), 2);
    let r = Ray {
        o: DVec3::new(0.25, 0.25, 1.0),
        d: DVec3::new(0.0, 0.0, -1.0),
    };
    let (t, _) = m
        .intersect(&r, f64::INFINITY)
        .expect("the ray hits the triangle");
    assert!((t - 1.0).abs() < 1e-12);
}

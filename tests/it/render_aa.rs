//! Anti-aliasing and sampling: adaptive subdivision at pixel corners (Whitted 1980), block
//! interpolation, jitter, and progress counts, against supersampled references and images
//! worked out here.

use super::render::{lum, scene, sphere_pixels};
use brdfit::model::Model;
use brdfit::render::{self, AntiAlias};
use brdfit::render::{Lighting, fig7_scene};
use brdfit::scene::parse_scene;
use std::path::Path;

#[test]
fn adaptive_antialiasing_traces_fewer_rays_and_renders_deterministically() {
    let mut s = fig7_scene(Model::blinn_mgo(), Lighting::Edge, 96);
    s.antialias = AntiAlias::Adaptive {
        threshold: 0.02,
        max_level: 3,
        block: 1,
        jitter: false,
    };
    let a = s.render(&|| {});
    let b = s.render(&|| {});
    assert_eq!(a.pixels, b.pixels);
    s.antialias = AntiAlias::Uniform(4);
    let u = s.render(&|| {});
    assert_eq!(u.rays[0], 16 * 96 * 96);
    assert!(
        a.rays[0] < u.rays[0] / 2,
        "adaptive {} vs uniform {} primary rays",
        a.rays[0],
        u.rays[0]
    );
    // No refraction or mirror rays in a scene without kt or ks.
    assert_eq!(a.rays[2] + a.rays[3] + u.rays[2] + u.rays[3], 0);
}

#[test]
fn bundled_scenes_render() {
    for f in [
        "data/scenes/mitsuba-front.toml",
        "data/scenes/showcase.toml",
    ] {
        let mut s = brdfit::scene::load_scene(Path::new(f)).unwrap();
        s.camera.width = 64;
        s.camera.height = 40;
        let img = s.render(&|| {});
        assert!(
            img.pixels
                .iter()
                .all(|p| p.iter().all(|v| v.is_finite() && *v >= 0.0))
        );
        assert!(sphere_pixels(&img).len() > 500, "{f}");
    }
}

#[test]
fn adaptive_reaches_uniform_error_with_fewer_rays() {
    let rows = brdfit::study::render_study(64);
    let u4 = rows
        .iter()
        .find(|r| r.mode == "uniform" && r.setting == 4.0)
        .unwrap();
    let (u, a) = brdfit::study::rays_at_error(&rows, u4.rmse * 1.05);
    let (u, a) = (
        u.unwrap(),
        a.expect("some adaptive setting reaches the uniform 4×4 error"),
    );
    assert!(a < u, "adaptive needs {a} rays/pixel, uniform {u}");
}

/// The render study's progress counts every image row once (each scene's 16 rows for its
/// reference and for each of the 12 settings, weighted by samples per pixel: 256, n² for
/// n = 1…6, 2 for each of the six adaptive thresholds), ends at its total, names the render
/// under way, and leaves the study's numbers as they are without it.
#[test]
fn render_study_progress_counts_every_row_once() {
    let calls = std::sync::Mutex::new(Vec::new());
    let rows = brdfit::study::render_study_with_progress(16, &|done, total, what: &str| {
        calls.lock().unwrap().push((done, total, what.to_string()));
    });
    let calls = calls.into_inner().unwrap();
    let total = 4 * 16 * (256 + (1 + 4 + 9 + 16 + 25 + 36) + 6 * 2);
    assert!(calls.iter().all(|c| c.1 == total));
    assert_eq!(calls.last().map(|c| c.0), Some(total));
    // Each row's call carries a distinct running count (in any order across threads); a
    // render announces itself at the count so far (0 for the first, else a row's count).
    let mut counts: Vec<usize> = calls
        .iter()
        .filter(|c| c.2 != "done")
        .map(|c| c.0)
        .collect();
    counts.sort_unstable();
    counts.dedup();
    assert_eq!((counts.len(), counts[0]), (1 + 4 * 16 * 13, 0));
    assert_eq!(counts.last(), Some(&total));
    assert!(calls.iter().any(|c| c.2 == "16×16 reference, scene 1 of 4"));
    assert!(calls.iter().any(|c| c.2 == "adaptive 0.05, scene 4 of 4"));
    let plain = brdfit::study::render_study(16);
    let strip = |r: &[brdfit::study::RenderRow]| {
        r.iter()
            .map(|r| {
                (
                    r.mode.clone(),
                    r.setting,
                    r.rays_per_pixel,
                    r.all_rays_per_pixel,
                    r.rmse,
                )
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&rows), strip(&plain));
}

/// `render fig7`'s progress counts every row of its eight images once (8 × the resolution, in
/// the adaptive mode the command uses) and leaves the images as they are without it.
#[test]
fn fig7_progress_counts_every_row_once() {
    let aa = AntiAlias::Adaptive {
        threshold: 0.02,
        max_level: 3,
        block: 1,
        jitter: false,
    };
    let (al, mgo) = (Model::blinn_aluminium(), Model::blinn_mgo());
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let counted = render::fig7_images_with_progress(&al, &mgo, 40, aa, &|| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    });
    assert_eq!(calls.into_inner(), 8 * 40);
    let plain = render::fig7_images(&al, &mgo, 40, aa);
    assert_eq!(counted.len(), 8);
    for ((a, x), (b, y)) in counted.iter().zip(&plain) {
        assert_eq!((a, &x.pixels, x.rays), (b, &y.pixels, y.rays));
    }
}

#[test]
fn small_objects_between_corners_are_found() {
    // A sphere far smaller than a pixel, centred between pixel corners: a single centre or
    // corner sample misses it; Whitted's minimum-radius test subdivides until it is found.
    let text = r#"
ambient = 1.0
[camera]
eye = [0.0, 0.0, 10.0]
target = [0.0, 0.0, 0.0]
fov = 20.0
width = 16
height = 16
[antialias]
mode = "adaptive"
threshold = 0.05
max_level = 6
[materials.white]
model = "lambert"
params = { pd = 1.0 }
[[objects]]
kind = "sphere"
center = [0.055, 0.055, 0.0]
radius = 0.02
material = "white"
"#;
    let img = scene(text).render(&|| {});
    let total: f64 = img.pixels.iter().map(|p| lum(*p)).sum();
    assert!(total > 0.0, "the small sphere was missed");
    let mut s = scene(text);
    s.antialias = AntiAlias::None;
    let none: f64 = s.render(&|| {}).pixels.iter().map(|p| lum(*p)).sum();
    assert_eq!(
        none, 0.0,
        "centre samples miss it (the test needs a sphere between samples)"
    );
}

/// A floor filling the view under a low point light: radiance varies smoothly (1/r² and N·L),
/// with no edges inside the image.
const GRADIENT: &str = r#"
[camera]
eye = [0.0, 3.0, 0.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov = 40.0
width = 66
height = 50
[antialias]
mode = "adaptive"
threshold = 1.0
max_level = 0
block = 4
[[lights]]
kind = "point"
position = [0.8, 2.0, 0.3]
intensity = 1.0
[materials.floor]
model = "lambert"
params = { pd = 1.0 }
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
size = 100.0
material = "floor"
"#;

#[test]
fn block_interpolation_matches_centre_samples_on_a_smooth_image() {
    // Where a block's corners agree it is filled by bilinear interpolation: each pixel gets
    // the patch's value at its own centre. On a smooth image that is close to the radiance of
    // the pixel's centre ray (mode none), with an error of second order in the block size:
    // halving the block quarters it (a misplaced weight would leave a first-order error).
    // Width and height are not multiples of the block.
    let mut s = scene(GRADIENT);
    s.antialias = AntiAlias::None;
    let centre = s.render(&|| {});
    let mut worst = Vec::new();
    for block in [2, 4] {
        s.antialias = AntiAlias::Adaptive {
            threshold: 1.0,
            max_level: 0,
            block,
            jitter: false,
        };
        let img = s.render(&|| {});
        assert!(
            img.pixels.iter().all(|p| lum(*p) > 0.0),
            "a pixel was left unwritten"
        );
        let w = img
            .pixels
            .iter()
            .zip(&centre.pixels)
            .map(|(a, b)| (lum(*a) - lum(*b)).abs() / lum(*b))
            .fold(0.0, f64::max);
        // Corners on a lattice of `block` pixels, nothing split: about 1/block² rays per
        // pixel (bands of rows repeat a corner row at their top edge).
        let b = block as u64;
        let lattice = (66u64.div_ceil(b) + 1) * (50u64.div_ceil(b) + 1);
        assert!(
            (lattice..lattice * 3 / 2).contains(&img.rays[0]),
            "block {block}: {} primary rays, lattice {lattice}",
            img.rays[0]
        );
        worst.push(w);
    }
    assert!(
        worst[1] < 0.01,
        "block 4: bilinear fill differs from centre rays by {}",
        worst[1]
    );
    let ratio = worst[1] / worst[0];
    assert!(
        (3.0..5.5).contains(&ratio),
        "error ratio block 4 / block 2 = {ratio} ({worst:?})"
    );
}

#[test]
fn block_mode_at_threshold_zero_is_whitteds_pixel_corner_scheme() {
    // With threshold 0 every block whose corners are not identical splits down to pixels,
    // whose corners are then the very samples of block = 1: the same image, and no more rays
    // (identical corners, as on the black background, are not split).
    let mut s = fig7_scene(Model::blinn_mgo(), Lighting::Edge, 90);
    let aa = |block| AntiAlias::Adaptive {
        threshold: 0.0,
        max_level: 2,
        block,
        jitter: false,
    };
    s.antialias = aa(1);
    let whitted = s.render(&|| {});
    for block in [2, 4] {
        s.antialias = aa(block);
        let img = s.render(&|| {});
        let worst = img
            .pixels
            .iter()
            .zip(&whitted.pixels)
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0f32, f32::max))
            .fold(0.0f32, f32::max);
        assert!(
            worst <= 1e-6,
            "block {block}: differs from block 1 by {worst}"
        );
        assert!(
            img.rays[0] <= whitted.rays[0],
            "block {block}: {:?}",
            img.rays
        );
        assert_eq!(
            s.render(&|| {}).pixels,
            img.pixels,
            "block {block} is not deterministic"
        );
    }
}

#[test]
fn block_mode_renders_the_bundled_scene_close_to_a_supersampled_one_with_fewer_rays() {
    let base = std::fs::read_to_string("data/scenes/mitsuba-front.toml").unwrap();
    let mut s = scene(&base);
    s.camera.width = 256;
    s.camera.height = 256;
    s.antialias = AntiAlias::Uniform(8);
    let reference = s.render(&|| {});
    s.antialias = AntiAlias::None;
    let none = s.render(&|| {});
    s.antialias = AntiAlias::Adaptive {
        threshold: 0.05,
        max_level: 1,
        block: 2,
        jitter: false,
    };
    let block = s.render(&|| {});
    let (e_none, e_block) = (
        render::rmse(&none, &reference),
        render::rmse(&block, &reference),
    );
    assert!(
        e_block < e_none,
        "block {e_block} vs one centre ray {e_none}"
    );
    assert!(
        block.rays[0] < none.rays[0],
        "block: {} primary rays, none: {}",
        block.rays[0],
        none.rays[0]
    );
}

#[test]
fn block_sizes_other_than_1_2_4_are_refused_with_the_fix() {
    let text = GRADIENT.replace("block = 4", "block = 3");
    let Err(err) = parse_scene(&text, Path::new(".")) else {
        panic!("block = 3 was accepted");
    };
    let msg = format!("{err:#}");
    assert!(
        msg.contains("`antialias.block` = 3") && msg.contains("use 1, 2 or 4"),
        "{msg}"
    );
    assert!(parse_scene(GRADIENT, Path::new(".")).is_ok());
}

/// A floor seen straight down (image plane parallel to it), so pixel (x, y) covers the floor
/// square [ex − h + x·p, … + p] × [ez − h·H/W + y·p, … + p] with p = 2·h/W (field of view
/// 90°); `extra` adds lights, materials and objects.
fn top_down(
    eye: (f64, f64, f64),
    (w, h): (u32, u32),
    ambient: f64,
    aa: &str,
    extra: &str,
) -> String {
    format!(
        r#"
max_depth = 3
ambient = {ambient}
[camera]
eye = [{x}, {y}, {z}]
target = [{x}, 0.0, {z}]
up = [0.0, 0.0, -1.0]
fov = 90.0
width = {w}
height = {h}
[antialias]
{aa}
{extra}
"#,
        x = eye.0,
        y = eye.1,
        z = eye.2
    )
}

/// A Lambert floor (pd = 1) with a checker of `size`-unit squares, colours c0 / c1, under a
/// directional light of irradiance π straight down: radiance = albedo.
fn checker_floor_under_sun(size: f64, c0: f64, c1: f64) -> String {
    format!(
        r#"
[[lights]]
kind = "directional"
direction = [0.0, 1.0, 0.0]
intensity = 3.141592653589793
[materials.floor]
model = "lambert"
params = {{ pd = 1.0 }}
checker = {{ size = {size}, color0 = [{c0}, {c0}, {c0}], color1 = [{c1}, {c1}, {c1}] }}
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
size = 1000.0
material = "floor"
"#
    )
}

/// Mean albedo of a checker (1-unit squares, `c0` where ⌊x⌋ + ⌊z⌋ is even) over the floor
/// rectangle [x0, x1] × [z0, z1], from the overlap of each square.
fn checker_mean(c0: f64, c1: f64, (x0, x1): (f64, f64), (z0, z1): (f64, f64)) -> f64 {
    let mut sum = 0.0;
    for i in (x0.floor() as i64)..=(x1.floor() as i64) {
        for j in (z0.floor() as i64)..=(z1.floor() as i64) {
            let lx = (x1.min(i as f64 + 1.0) - x0.max(i as f64)).max(0.0);
            let lz = (z1.min(j as f64 + 1.0) - z0.max(j as f64)).max(0.0);
            sum += lx * lz * if (i + j).rem_euclid(2) == 0 { c0 } else { c1 };
        }
    }
    sum / ((x1 - x0) * (z1 - z0))
}

#[test]
fn corners_on_two_squares_of_one_colour_subdivide_directly_and_in_a_mirror() {
    // A pixel 2 units wide over a checker corner, [−0.9, 1.1]²: its four corners fall on four
    // different squares that all have colour 0.2, while half the pixel is 0.8. The corner
    // intensities agree, so only the ray-tree test (different squares) can subdivide it; the
    // same must hold when the checker is seen in a mirror, where the primary hits agree too.
    let aa = "mode = \"adaptive\"\nthreshold = 0.02\nmax_level = 4";
    let expect = checker_mean(0.2, 0.8, (-0.9, 1.1), (-0.9, 1.1));
    assert!((expect - 0.5).abs() < 1e-12);
    let direct = top_down(
        (0.1, 5.0, 0.1),
        (5, 5),
        0.0,
        aa,
        &checker_floor_under_sun(1.0, 0.2, 0.8),
    );
    // In a mirror: a black mirror floor (ks = 1) under a checker ceiling at height 10 lit by
    // ambient 1; the ceiling is 5 + 10 = 15 units from the eye along the reflected rays, so
    // with a 15-pixel image each pixel again covers 2 × 2 units, mirrored in y only.
    let mirror = top_down(
        (0.1, 5.0, 0.1),
        (15, 15),
        1.0,
        aa,
        r#"
[materials.mirror]
model = "lambert"
params = { pd = 0.0 }
ks = 1.0
[materials.ceiling]
model = "lambert"
params = { pd = 1.0 }
checker = { size = 1.0, color0 = [0.2, 0.2, 0.2], color1 = [0.8, 0.8, 0.8] }
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
size = 100.0
material = "mirror"
[[objects]]
kind = "plane"
point = [0.0, 10.0, 0.0]
normal = [0.0, -1.0, 0.0]
size = 100.0
material = "ceiling"
"#,
    );
    for (name, text, centre) in [("direct", direct, 2), ("mirror", mirror, 7)] {
        let img = scene(&text).render(&|| {});
        let got = lum(img.at(centre, centre));
        assert!(
            (got - expect).abs() < 0.03,
            "{name}: centre pixel {got}, area mean {expect}"
        );
    }
}

#[test]
fn over_range_corners_still_subdivide() {
    // A white floor 0.5 below a point light of intensity 10: every corner of the pixel
    // [0, 1]² is brighter than 1 (so a test on clamped display values sees four equal
    // corners), the radiance peaks inside it, and the pixel's true value is the light's
    // solid angle over the square: mean L = (I/π)·Ω/A, Ω = Σ ± atan(x z / (h √(x²+z²+h²))).
    let (lx, lz, h, i) = (0.6, 0.45, 0.5, 10.0);
    let text = top_down(
        (0.0, 5.0, 0.0),
        (10, 10),
        0.0,
        "mode = \"adaptive\"\nthreshold = 0.02\nmax_level = 4",
        &format!(
            r#"
[[lights]]
kind = "point"
position = [{lx}, {h}, {lz}]
intensity = {i}
[materials.floor]
model = "lambert"
params = {{ pd = 1.0 }}
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
size = 100.0
material = "floor"
"#
        ),
    );
    let f = |x: f64, z: f64| (x * z / (h * (x * x + z * z + h * h).sqrt())).atan();
    let (x0, x1, z0, z1) = (-lx, 1.0 - lx, -lz, 1.0 - lz);
    let omega = f(x1, z1) - f(x0, z1) - f(x1, z0) + f(x0, z0);
    let expect = i / std::f64::consts::PI * omega;
    let corner = |x: f64, z: f64| i * h / (x * x + z * z + h * h).powf(1.5) / std::f64::consts::PI;
    let corners = [
        corner(x0, z0),
        corner(x1, z0),
        corner(x0, z1),
        corner(x1, z1),
    ];
    assert!(corners.iter().all(|&c| c > 1.0), "{corners:?}");
    let img = scene(&text).render(&|| {});
    let got = lum(img.at(5, 5));
    assert!(
        (got / expect - 1.0).abs() < 0.02,
        "pixel {got}, area mean {expect}, corner mean {}",
        corners.iter().sum::<f64>() / 4.0
    );
}

#[test]
fn jittered_samples_remove_the_regular_grids_bias_on_an_aligned_edge() {
    // A checker edge (0 above, 1 below, 100-unit squares) along a pixel row, crossing every
    // pixel of row 32 at 30 % of its height: the true value there is 0.3. A regular 4 × 4 grid
    // sees it at 1/4 in every pixel, and Whitted's corners on a 4 × 4 lattice at 3/8: errors
    // of one sign all along the row. One sample at a fixed random point per stratum, or per
    // lattice square, is right on average: the row mean must be within 0.02 (the stratified
    // row mean's spread is ≈ 0.006), and the regular ones must not be.
    let p = 10.0 / 64.0;
    let eye = (50.0, 5.0, 5.0 - (32.0 + 0.3) * p);
    let extra = checker_floor_under_sun(100.0, 0.0, 1.0);
    let row_error = |aa: &str| {
        let s = scene(&top_down(eye, (64, 64), 0.0, aa, &extra));
        let img = s.render(&|| {});
        assert_eq!(
            img.pixels,
            s.render(&|| {}).pixels,
            "{aa}: not deterministic"
        );
        let above = lum(img.at(10, 31)) + lum(img.at(10, 33));
        assert!((above - 1.0).abs() < 1e-9, "{aa}: rows 31/33 {above}");
        (0..64).map(|x| lum(img.at(x, 32)) - 0.3).sum::<f64>() / 64.0
    };
    for (aa, jittered) in [
        ("mode = \"uniform\"\nsamples = 4", false),
        ("mode = \"stratified\"\nsamples = 4", true),
        (
            "mode = \"adaptive\"\nthreshold = 0.02\nmax_level = 2",
            false,
        ),
        (
            "mode = \"adaptive\"\nthreshold = 0.02\nmax_level = 2\njitter = true",
            true,
        ),
    ] {
        let e = row_error(aa);
        assert_eq!(e.abs() < 0.02, jittered, "{aa}: row mean error {e}");
    }
}

//! Mutated scene files (a fixed seed): each is read, rendered small and written, and given to
//! `choose`; counted are panics, images with a NaN or infinite pixel that were written, and
//! values outside the ranges README.md states ("Scene files") that were accepted. The oracle
//! is this file's own table of those ranges, not the reader's code.
//!
//! `BRDFIT_SCENE_MUTATIONS=300 cargo test --release --test it scene_mutations:: -- --nocapture`
//! runs the 300 of the README; CI runs the default, 40.

use brdfit::choose::{self, Case, ChooseOptions};
use brdfit::model::Model;
use brdfit::scene::parse_scene;
use rand::{Rng, SeedableRng};

/// Values a mutation puts in place of one number.
const HOSTILE: &[&str] = &[
    "nan", "inf", "-inf", "1e308", "-1e308", "1e300", "-1", "0", "2", "0.5", "1e-300", "1e13",
    "1e7", "-0.5", "16385", "3", "65", "9", "1e-4", "-2e6",
];

/// The stated range of a key in its section: (lo, hi, lo excluded). `None`: not a number
/// with a range of its own here (a direction component, a boolean, …).
fn stated_range(section: &str, key: &str) -> Option<(f64, f64, bool)> {
    let light = section == "lights";
    Some(match key {
        "width" | "height" => (1.0, 16384.0, false),
        "fov" => (0.0, 180.0, true), // (0, 180): 180 itself is checked below
        "eye" | "target" | "center" | "point" | "position" => (-1e6, 1e6, false),
        "max_depth" => (1.0, 64.0, false),
        "min_weight" => (0.0, 1.0, false),
        "ambient" | "background" => (0.0, 1e6, false),
        "threshold" => (0.0, 100.0, false),
        "max_level" => (0.0, 6.0, false),
        "samples" => (1.0, 64.0, false),
        "intensity" => (0.0, 1e12, false),
        "color" if light => (0.0, 1e6, false),
        "color" | "color0" | "color1" => (0.0, 1.0, false),
        "size" | "radius" => (0.0, 1e6, true),
        "ks" | "kt" => (0.0, 1.0, false),
        "ior" => (0.01, 100.0, false),
        "cmin" => (1e-3, 1.0, false),
        "frequency" => (0.0, 1e6, false),
        // Model parameters: the admissible values of the model's declaration (`ps ≥ 0`,
        // `n > 1`, `0 < c3 ≤ 1`; the fitter's box is narrower).
        "ps" | "pd" => (0.0, f64::INFINITY, false),
        "n" => (1.0, f64::INFINITY, true),
        "c3" => (0.0, 1.0, true),
        _ => return None,
    })
}

fn in_range(section: &str, key: &str, v: f64) -> Option<bool> {
    let (lo, hi, open) = stated_range(section, key)?;
    let upper_ok = if key == "fov" { v < hi } else { v <= hi };
    Some(v.is_finite() && upper_ok && if open { v > lo } else { v >= lo })
}

/// The number literals of a line outside comments and strings, with the key each belongs to
/// (the last `NAME =` before it on the line).
fn numbers(line: &str) -> Vec<(usize, usize, String)> {
    let code = line.split('#').next().unwrap_or("");
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut k = 0;
    let mut in_str = false;
    while k < b.len() {
        let c = b[k];
        if c == b'"' {
            in_str = !in_str;
            k += 1;
            continue;
        }
        let starts = !in_str
            && (c.is_ascii_digit() || (c == b'-' && b.get(k + 1).is_some_and(u8::is_ascii_digit)))
            && (k == 0 || !(b[k - 1].is_ascii_alphanumeric() || b[k - 1] == b'_'));
        if starts {
            let s = k;
            k += 1;
            while k < b.len() && (b[k].is_ascii_alphanumeric() || b"+-.".contains(&b[k])) {
                k += 1;
            }
            let before = &code[..s];
            let key = before
                .rfind('=')
                .map(|e| {
                    before[..e]
                        .trim_end()
                        .rsplit(|ch: char| !(ch.is_ascii_alphanumeric() || ch == '_'))
                        .next()
                        .unwrap_or("")
                        .to_string()
                })
                .unwrap_or_default();
            out.push((s, k, key));
        } else {
            k += 1;
        }
    }
    out
}

/// The section a line is in: `camera`, `antialias`, `lights`, `materials`, `objects`, or
/// empty at the top.
fn section_of(lines: &[String], at: usize) -> String {
    lines[..at]
        .iter()
        .rev()
        .find(|l| l.trim_start().starts_with('['))
        .map(|l| {
            l.trim()
                .trim_matches(|c| c == '[' || c == ']')
                .split('.')
                .next()
                .unwrap_or("")
                .to_string()
        })
        .unwrap_or_default()
}

/// One mutation of `text`: a number replaced by a hostile value (then the expected verdict:
/// whether that value is in its stated range), or a line deleted, duplicated or swapped, or
/// a key misspelt (no verdict).
fn mutate(text: &str, rng: &mut rand_chacha::ChaCha8Rng) -> (String, Option<(String, bool)>) {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let n = lines.len();
    match rng.random_range(0..10) {
        0..=5 => {
            let spots: Vec<(usize, usize, usize, String)> = (0..n)
                .flat_map(|i| {
                    numbers(&lines[i])
                        .into_iter()
                        .map(move |(s, e, k)| (i, s, e, k))
                })
                .collect();
            let (i, s, e, key) = spots[rng.random_range(0..spots.len())].clone();
            let v = HOSTILE[rng.random_range(0..HOSTILE.len())];
            let section = section_of(&lines, i);
            let verdict = in_range(&section, &key, v.parse().unwrap())
                .map(|ok| (format!("{section}: {key} = {v}"), ok));
            lines[i].replace_range(s..e, v);
            (lines.join("\n"), verdict)
        }
        6 => {
            lines.remove(rng.random_range(0..n));
            (lines.join("\n"), None)
        }
        7 => {
            let i = rng.random_range(0..n);
            let l = lines[i].clone();
            lines.insert(i, l);
            (lines.join("\n"), None)
        }
        8 => {
            let (a, b) = (rng.random_range(0..n), rng.random_range(0..n));
            lines.swap(a, b);
            (lines.join("\n"), None)
        }
        _ => {
            let i = rng.random_range(0..n);
            if let Some(p) = lines[i].find(" =") {
                lines[i].insert(p, 'x');
            }
            (lines.join("\n"), None)
        }
    }
}

/// A scene with a plane, a checker, Blinn's roughness texture, a point and a directional
/// light and every antialias key, besides the bundled ones.
const SMALL: &str = r#"max_depth = 3
min_weight = 0.01
ambient = [0.02, 0.02, 0.02]
background = 0.1
test_object = "ball"
[camera]
eye = [0.0, 1.0, 5.0]
target = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 24
height = 16
[antialias]
mode = "adaptive"
threshold = 0.05
max_level = 2
block = 2
jitter = true
[[lights]]
kind = "point"
position = [2.0, 4.0, 5.0]
color = [1.0, 0.9, 0.8]
intensity = 40.0
[[lights]]
kind = "directional"
direction = [-0.5, 0.6, 0.7]
intensity = 1.5
[materials.floor]
model = "lambert"
params = { pd = 0.8 }
checker = { size = 0.5, color0 = [0.2, 0.2, 0.2], color1 = 0.9 }
ks = 0.2
[materials.ball]
model = "torrance-sparrow"
distribution = "d3"
params = { n = 1.8, c3 = 0.3, ps = 0.6, pd = 0.4 }
color = [0.9, 0.5, 0.3]
kt = 0.1
ior = 1.4
roughness = { cmin = 0.2, frequency = 2.0 }
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
size = 4.0
material = "floor"
[[objects]]
kind = "sphere"
center = [0.0, 0.7, 0.0]
radius = 0.7
material = "ball"
"#;

#[derive(Default, Debug)]
struct Counts {
    scenes: usize,
    accepted: usize,
    rendered: usize,
    refused_nonfinite: usize,
    nonfinite_written: usize,
    chosen: usize,
    choose_refused: usize,
    choose_nonfinite: usize,
    panics: usize,
    out_of_range_accepted: Vec<String>,
    in_range_checked: usize,
    out_of_range_checked: usize,
}

#[test]
fn mutated_scenes_render_and_choose_without_panic_or_nonfinite_image() {
    let count: usize = std::env::var("BRDFIT_SCENE_MUTATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(40);
    let root = crate::common::root();
    let scenes_dir = root.join("data/scenes");
    let mut bases = vec![SMALL.to_string()];
    for f in ["showcase.toml", "mitsuba-front.toml"] {
        bases.push(std::fs::read_to_string(scenes_dir.join(f)).unwrap());
    }
    // A small measurement for choose: Blinn's MgO at 1,500 directions.
    let dirs = brdfit::simulate::Grid::parse("hemisphere:1500")
        .unwrap()
        .directions(3);
    let ds = brdfit::simulate(&Model::blinn_mgo(), &dirs, 0.01, 3);
    let opts = ChooseOptions {
        verify: 0,
        ..Default::default()
    };
    let out = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(26);
    let mut c = Counts::default();
    let prev_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    for k in 0..count {
        let base = &bases[k % bases.len()];
        let (text, verdict) = mutate(base, &mut rng);
        c.scenes += 1;
        let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let parsed = parse_scene(&text, &scenes_dir);
            if let Some((what, in_range)) = &verdict {
                if *in_range {
                    c.in_range_checked += 1;
                } else {
                    c.out_of_range_checked += 1;
                    if parsed.is_ok() {
                        c.out_of_range_accepted.push(what.clone());
                    }
                }
            }
            let Ok(mut s) = parsed else { return };
            c.accepted += 1;
            // Small renders: at most 24 pixels on a side, two levels of subdivision.
            let scale = 24.0 / s.camera.width.max(s.camera.height) as f64;
            if scale < 1.0 {
                s.camera.width = ((s.camera.width as f64 * scale) as u32).max(1);
                s.camera.height = ((s.camera.height as f64 * scale) as u32).max(1);
            }
            s.antialias = match s.antialias {
                brdfit::render::AntiAlias::Adaptive {
                    threshold,
                    max_level,
                    block,
                    jitter,
                } => brdfit::render::AntiAlias::Adaptive {
                    threshold,
                    max_level: max_level.min(2),
                    block,
                    jitter,
                },
                brdfit::render::AntiAlias::Uniform(n) => {
                    brdfit::render::AntiAlias::Uniform(n.min(3))
                }
                brdfit::render::AntiAlias::Stratified(n) => {
                    brdfit::render::AntiAlias::Stratified(n.min(3))
                }
                a => a,
            };
            let img = s.render(&|| {});
            c.rendered += 1;
            let finite = img.pixels.iter().flatten().all(|v| v.is_finite());
            match brdfit::render::save(&img, &out.path().join(format!("m{k}"))) {
                Ok(_) if !finite => c.nonfinite_written += 1,
                Err(_) if !finite => c.refused_nonfinite += 1,
                _ => {}
            }
            if choose::check_test_object(&s).is_err() {
                c.choose_refused += 1;
                return;
            }
            let cases = [Case {
                name: format!("m{k}"),
                scene: s,
            }];
            if let Ok((_, images)) = choose::choose(&ds, &cases, &opts, &|_| {}) {
                c.chosen += 1;
                if images
                    .iter()
                    .flat_map(|i| &i.renders)
                    .any(|(_, im)| im.pixels.iter().flatten().any(|v| !v.is_finite()))
                {
                    c.choose_nonfinite += 1;
                }
            }
        }));
        if run.is_err() {
            c.panics += 1;
            eprintln!("panic on mutation {k}:\n{text}");
        }
    }
    std::panic::set_hook(prev_hook);
    println!(
        "{} mutated scenes: {} read, {} rendered, {} panics, {} non-finite images written \
         ({} refused by the writer), {} out-of-range values accepted (of {} out-of-range \
         mutations checked, {} in range); choose: {} ran, {} refused (no lit test object), \
         {} with a non-finite render",
        c.scenes,
        c.accepted,
        c.rendered,
        c.panics,
        c.nonfinite_written,
        c.refused_nonfinite,
        c.out_of_range_accepted.len(),
        c.out_of_range_checked,
        c.in_range_checked,
        c.chosen,
        c.choose_refused,
        c.choose_nonfinite
    );
    assert_eq!(c.panics, 0);
    assert_eq!(c.nonfinite_written, 0);
    assert!(
        c.out_of_range_accepted.is_empty(),
        "accepted: {:?}",
        c.out_of_range_accepted
    );
    // The run must exercise the renderer and choose, not only the reader's refusals.
    assert!(c.rendered * 4 >= c.scenes && c.chosen > 0, "{c:?}");
}

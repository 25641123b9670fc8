//! Bad input never crashes brdfit: mutated real files, a catalogue of hostile cases, property
//! tests of the fitter, and named failure modes of the fitter and renderer.

use crate::common::root;
use brdfit::data::{self, Dataset, Format, LoadOptions, NegativePolicy, Quantity};
use brdfit::fit::{self, FitOptions};
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use std::path::Path;

/// Load a byte string as `name` (its extension picks the reader) under every negative policy;
/// it must return, not panic.
fn load_bytes(dir: &Path, name: &str, bytes: &[u8]) -> usize {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    let mut ok = 0;
    for negative in [
        NegativePolicy::Mask,
        NegativePolicy::Clamp,
        NegativePolicy::Error,
    ] {
        if let Ok(ds) = data::load(
            &p,
            &LoadOptions {
                format: None,
                negative,
            },
        ) {
            let _ = data::summary(&ds);
            ok += 1;
        }
    }
    ok
}

fn mutations(bytes: &[u8], seed: u64) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    // Truncation at every 1/16 of the file.
    for k in 0..16 {
        out.push(bytes[..bytes.len() * k / 16].to_vec());
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // Single bit flips.
    for _ in 0..48 {
        let mut b = bytes.to_vec();
        let i = rng.random_range(0..b.len());
        b[i] ^= 1 << rng.random_range(0..8);
        out.push(b);
    }
    // Duplicated, deleted and swapped lines, swapped columns.
    let text = String::from_utf8_lossy(bytes);
    let lines: Vec<&str> = text.lines().collect();
    for _ in 0..8 {
        let mut l = lines.clone();
        let i = rng.random_range(0..l.len());
        l.insert(i, lines[rng.random_range(0..lines.len())]);
        out.push(l.join("\n").into_bytes());
        let mut l = lines.clone();
        l.remove(rng.random_range(0..l.len()));
        out.push(l.join("\n").into_bytes());
    }
    for (a, b) in [(0usize, 2usize), (1, 3), (0, 4)] {
        let swapped: Vec<String> = lines
            .iter()
            .map(|l| {
                let sep = if l.contains(',') { ',' } else { ' ' };
                let mut f: Vec<&str> = l.split(sep).collect();
                if f.len() > a.max(b) {
                    f.swap(a, b);
                }
                f.join(&sep.to_string())
            })
            .collect();
        out.push(swapped.join("\n").into_bytes());
    }
    out
}

#[test]
fn mutated_real_files_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let files = [
        ("data/cayman.astm", "m.astm"),
        ("tests/data/cayman.brdf", "m.brdf"),
        ("tests/data/vch_golden_yellow_rgb.csv", "m.csv"),
        ("data/merl-alumina-oxide.csv", "m2.csv"),
    ];
    let mut loaded = 0;
    let mut total = 0;
    for (k, (src, name)) in files.iter().enumerate() {
        let bytes = std::fs::read(root().join(src)).unwrap();
        for m in mutations(&bytes, k as u64) {
            loaded += load_bytes(dir.path(), name, &m);
            total += 3;
        }
    }
    // A MERL table: truncations and header flips.
    let mut merl = Vec::new();
    for d in [90i32, 90, 180] {
        merl.extend(d.to_le_bytes());
    }
    merl.extend(std::iter::repeat_n(1.0f64.to_le_bytes(), 3 * 90 * 90 * 180).flatten());
    for k in [0, 1, 8, 15] {
        load_bytes(dir.path(), "m.binary", &merl[..merl.len() * k / 16]);
    }
    for i in 0..12 {
        let mut b = merl.clone();
        b[i] ^= 0x40;
        load_bytes(dir.path(), "m.binary", &b);
    }
    println!("{loaded} of {total} mutated loads succeeded; none panicked");
    assert!(loaded > 0 && loaded < total);
}

#[test]
fn catalogue_of_hostile_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let load = |name: &str, bytes: &[u8]| {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        data::load(&p, &LoadOptions::default())
    };
    // A line of 1 MB: a number of a million digits is not a number.
    let mut big = b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n10,0,10,180,".to_vec();
    big.extend(std::iter::repeat_n(b'7', 1 << 20));
    big.push(b'\n');
    let e = load("long.csv", &big).unwrap_err();
    assert_eq!(e.line, Some(2));
    // A 1 MB comment line is fine.
    let mut c = b"# ".to_vec();
    c.extend(std::iter::repeat_n(b'x', 1 << 20));
    c.extend(b"\ntheta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n10,0,10,180,0.5\n");
    assert_eq!(load("comment.csv", &c).unwrap().len(), 1);
    // Binary garbage with a .csv name.
    let garbage: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    assert!(load("garbage.csv", &garbage).is_err());
    // All cells of a channel missing: loads, and the fit says there is nothing to fit.
    let ds = load(
        "empty-ch.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n10,0,10,180,\n20,0,10,180,\n",
    )
    .unwrap();
    assert_eq!(ds.missing(), 2);
    assert!(fit::fit(&ds, &FitOptions::new(ModelKind::Lambert)).is_err());
    // A hostile ASTM NUM_POINTS is a count to check, not an allocation.
    let e = load(
        "h.astm",
        b"NUM_POINTS 99999999999999\nVARS theta_i,phi_i,theta_s,phi_s,v\n0.1,0,0.1,3,1\n",
    )
    .unwrap_err();
    assert!(e.message.contains("NUM_POINTS"), "{e}");
    // A hostile Cornell wavelength count.
    assert!(load("h.brdf", b"4000000000\n400 500\n").is_err());
    // Unreadable files (root reads everything, so this case needs an ordinary user).
    let p = d.join("secret.csv");
    std::fs::write(
        &p,
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n1,0,1,0,1\n",
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o000)).unwrap();
    match data::load(&p, &LoadOptions::default()) {
        Err(e) => assert!(e.fix.contains("permissions"), "{e}"),
        Ok(_) => println!("note: running as root, the unreadable-file case cannot be exercised"),
    }
}

#[test]
fn two_million_rows_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("big.csv");
    {
        use std::io::Write;
        let mut w = std::io::BufWriter::new(std::fs::File::create(&p).unwrap());
        writeln!(w, "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf").unwrap();
        for k in 0..2_000_000u32 {
            writeln!(
                w,
                "{},0,{},{},{}",
                k % 89,
                (k / 89) % 89,
                k % 360,
                0.1 + (k % 1000) as f64 * 1e-4
            )
            .unwrap();
        }
    }
    // Run the binary and watch its peak resident memory.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(["info", p.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let status = format!("/proc/{}/status", child.id());
    let t = std::time::Instant::now();
    let mut peak_kb = 0u64;
    loop {
        if let Ok(s) = std::fs::read_to_string(&status)
            && let Some(l) = s.lines().find(|l| l.starts_with("VmHWM:"))
        {
            peak_kb = peak_kb.max(
                l.split_whitespace()
                    .nth(1)
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(0),
            );
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        assert!(t.elapsed().as_secs() < 120, "reading 2M rows hangs");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("samples:     2000000"));
    println!(
        "2M rows (63 MB): {:.2} s, peak resident {} MB",
        t.elapsed().as_secs_f64(),
        peak_kb / 1024
    );
    // Struct-of-arrays: 5 f64 per row = 80 MB; the reader streams the file.
    assert!(peak_kb < 400 * 1024, "peak {peak_kb} kB");
}

fn small_dataset(rows: &[(f64, f64, f64, f64)]) -> Dataset {
    let mut ds = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
    for (k, &(ti, to, po, v)) in rows.iter().enumerate() {
        let _ = k;
        ds.push([ti, 0.0, to, po], &[v]);
    }
    ds
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn any_data_gives_a_finite_fit_or_an_error(
        rows in prop::collection::vec((0.0..1.55f64, 0.0..1.55f64, 0.0..6.2f64, prop_oneof![Just(0.0), 1e-6..1e-3f64, 0.01..10.0f64, 1e3..1e6f64]), 0..60),
        kind in prop_oneof![Just(ModelKind::Lambert), Just(ModelKind::Phong), Just(ModelKind::BlinnPhong), Just(ModelKind::TorranceSparrow)],
    ) {
        let ds = small_dataset(&rows);
        let mut o = FitOptions::new(kind);
        o.profile = rows.len() % 2 == 0;
        match fit::fit(&ds, &o) {
            Ok(fits) => {
                for f in fits {
                    prop_assert!(f.cost.is_finite() && f.params.iter().all(|(_, v)| v.is_finite()));
                    prop_assert!(f.iterations <= 4 * o.limits.max_iter * 8);
                }
            }
            Err(e) => prop_assert!(!e.message.is_empty() && !e.fix.is_empty()),
        }
    }
}

#[test]
fn named_fitter_cases() {
    let mgo = Model::blinn_mgo();
    let dirs = brdfit::simulate::Grid::Hemisphere(800).directions(5);
    let ds = brdfit::simulate::simulate(&mgo, &dirs, 0.01, 5);
    // Starts on a bound (c3 = 1, n = 1, ps = pd = 0) still reach the minimum.
    let reference = fit::fit(&ds, &FitOptions::new(ModelKind::TorranceSparrow)).unwrap()[0].cost;
    let mut o = FitOptions::new(ModelKind::TorranceSparrow);
    o.start = vec![
        ("n".into(), 1.0),
        ("c3".into(), 1.0),
        ("ps".into(), 0.0),
        ("pd".into(), 0.0),
    ];
    let f = &fit::fit(&ds, &o).unwrap()[0];
    assert!((f.cost - reference).abs() <= 1e-9 * reference);
    o.local_only = true;
    assert!(fit::fit(&ds, &o).unwrap()[0].cost.is_finite());
    // The limits of the formulas: n → 1 (F → 0) and c3 → 0 (a mirror) stay finite and ≥ 0.
    for (n, c3) in [(1.0, 0.35), (1.0 + 1e-12, 1e-9), (1e9, 1e-6), (1.8, 1.0)] {
        let m = Model::new(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[n, c3, 1.0, 0.1],
        )
        .unwrap();
        for a in dirs.iter().take(200) {
            let v = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
            assert!(v.is_finite() && v >= 0.0, "n={n} c3={c3}: {v}");
        }
    }
    // Data spanning ten decades.
    let wide = small_dataset(
        &(0..200)
            .map(|k| {
                (
                    0.5,
                    0.01 * k as f64,
                    3.1,
                    10f64.powf(-5.0 + 10.0 * k as f64 / 200.0),
                )
            })
            .collect::<Vec<_>>(),
    );
    for kind in [ModelKind::Lambert, ModelKind::BlinnPhong] {
        let f = &fit::fit(&wide, &FitOptions::new(kind)).unwrap()[0];
        assert!(f.cost.is_finite());
    }
    // All samples identical (and at one incidence angle): an honest error for torrance-sparrow,
    // a fit for lambert.
    let same = small_dataset(&vec![(0.5, 0.5, 3.0, 0.2); 40]);
    assert!(fit::fit(&same, &FitOptions::new(ModelKind::TorranceSparrow)).is_err());
    let f = &fit::fit(&same, &FitOptions::new(ModelKind::Lambert)).unwrap()[0];
    assert!((f.get("pd").unwrap() - 0.2 * std::f64::consts::PI).abs() < 1e-6);
    // Duplicate samples: the data set twice gives the same parameters.
    let mut twice = ds.clone();
    for k in 0..ds.len() {
        twice.push(ds.angles(k), &[ds.channels[0].values[k]]);
    }
    let a = &fit::fit(&ds, &FitOptions::new(ModelKind::TorranceSparrow)).unwrap()[0];
    let b = &fit::fit(&twice, &FitOptions::new(ModelKind::TorranceSparrow)).unwrap()[0];
    assert!((a.get("c3").unwrap() - b.get("c3").unwrap()).abs() < 1e-6);
    assert!((2.0 * a.cost - b.cost).abs() < 1e-9 * b.cost);
    // A fixed parameter that makes the data unreachable (ps = pd = 0: the model is zero):
    // the fit returns the best it can, finite, rather than failing or looping.
    let mut o = FitOptions::new(ModelKind::TorranceSparrow);
    o.fix = vec![("ps".into(), 0.0), ("pd".into(), 0.0)];
    let f = &fit::fit(&ds, &o).unwrap()[0];
    assert!(f.cost.is_finite() && f.cost > reference);
}

#[test]
fn named_renderer_cases() {
    use brdfit::scene::parse_scene;
    let base = |extra: &str| {
        format!(
            "{extra}\n[materials.m]\nmodel = \"lambert\"\nparams = {{ pd = 0.5 }}\n[[objects]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n"
        )
    };
    // No lights: ambient only.
    let s = parse_scene(&base("ambient = 0.2\n[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 30.0\nwidth = 9\nheight = 9\n[antialias]\nmode = \"none\""), Path::new(".")).unwrap();
    let img = s.render(&|| {});
    assert!((img.at(4, 4)[0] - 0.1).abs() < 1e-6);
    // Camera inside the sphere: it sees the inside, lit by nothing but ambient.
    let s = parse_scene(&base("ambient = 0.2\n[camera]\neye = [0.0, 0.0, 0.5]\ntarget = [0.0, 0.0, 0.0]\nfov = 60.0\nwidth = 9\nheight = 9"), Path::new(".")).unwrap();
    let img = s.render(&|| {});
    assert!(img.pixels.iter().all(|p| (p[0] - 0.1).abs() < 1e-6));
    // Zero resolution and a degenerate camera are errors.
    let e = parse_scene(&base("[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 30.0\nwidth = 0\nheight = 9"), Path::new(".")).unwrap_err();
    assert!(e.to_string().contains("`camera.width` = 0"), "{e}");
    let e = parse_scene(&base("[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 5.0]\nfov = 30.0\nwidth = 9\nheight = 9"), Path::new(".")).unwrap_err();
    assert!(e.to_string().contains("camera"), "{e}");
    // Unknown material, unknown keys.
    let e = parse_scene("[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 30.0\nwidth = 9\nheight = 9\n[[objects]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nmaterial = \"x\"\n", Path::new(".")).unwrap_err();
    assert!(e.to_string().contains("material 'x'"), "{e}");
    assert!(parse_scene("[camera]\nwho = 1\n", Path::new(".")).is_err());
    // A degenerate triangle is dropped; the mesh still renders.
    let m = brdfit::render::Mesh::new(vec![
        [glam::DVec3::ZERO, glam::DVec3::X, glam::DVec3::X * 2.0],
        [glam::DVec3::ZERO, glam::DVec3::X, glam::DVec3::Y],
    ]);
    assert_eq!(m.tris.len(), 1);
    let r = brdfit::render::Ray {
        o: glam::DVec3::new(0.2, 0.2, 1.0),
        d: -glam::DVec3::Z,
    };
    assert!(m.intersect(&r, f64::INFINITY).is_some());
    // An OBJ with a face index past its vertices is an error naming the line.
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("bad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    let e = brdfit::scene::read_obj(&obj).unwrap_err();
    assert!(e.to_string().contains("bad.obj:3"), "{e}");
    let _ = Format::Csv;
}

/// A scene for the catalogue: a Torrance–Sparrow sphere `m` (with roughness texture) on a
/// checkered plane `floor`, under a point light; `edits` replace text in it.
fn catalogue_scene(edits: &[(&str, &str)]) -> String {
    let mut s = r#"ambient = 0.02
background = 0.0
min_weight = 0.001
[camera]
eye = [0.0, 1.0, 5.0]
target = [0.0, 0.5, 0.0]
fov = 40.0
width = 16
height = 12
[antialias]
mode = "adaptive"
threshold = 0.05
[[lights]]
kind = "point"
position = [2.0, 4.0, 5.0]
intensity = 40.0
[materials.m]
model = "torrance-sparrow"
params = { n = 1.8, c3 = 0.3, ps = 0.6, pd = 0.4 }
color = [0.9, 0.5, 0.3]
ks = 0.1
kt = 0.1
roughness = { cmin = 0.2, frequency = 2.0 }
[materials.floor]
model = "lambert"
params = { pd = 0.8 }
checker = { size = 0.5, color0 = [0.2, 0.2, 0.2], color1 = [0.8, 0.8, 0.8] }
[[objects]]
kind = "sphere"
center = [0.0, 0.7, 0.0]
radius = 0.7
material = "m"
[[objects]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
size = 4.0
material = "floor"
"#
    .to_string();
    for (from, to) in edits {
        assert!(s.contains(from), "{from}");
        s = s.replacen(from, to, 1);
    }
    s
}

fn run_brdfit(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(args)
        .output()
        .unwrap()
}

/// Exit 1 (not a panic, not success) with each fragment on stderr.
fn refused(args: &[&str], fragments: &[&str]) {
    let o = run_brdfit(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    for f in fragments {
        assert!(err.contains(f), "{args:?}: stderr lacks '{f}':\n{err}");
    }
}

/// Scene files: every hostile value is refused naming its key, nothing is written.
#[test]
fn scene_catalogue_refuses_each_case_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out.png");
    let cases: Vec<(Vec<(&str, &str)>, &str)> = vec![
        (
            vec![("ambient = 0.02", "ambient = nan")],
            "`ambient` = [NaN, NaN, NaN] is out of range",
        ),
        (
            vec![("color = [0.9, 0.5, 0.3]", "color = [nan, 0, 0]")],
            "`materials.m.color`",
        ),
        (
            vec![("frequency = 2.0", "frequency = 1e308")],
            "`materials.m.roughness.frequency`",
        ),
        (
            vec![("color1 = [0.8, 0.8, 0.8]", "color1 = [inf, 0.8, 0.8]")],
            "`materials.floor.checker.color1`",
        ),
        (
            vec![("background = 0.0", "background = [inf, 0, 0]")],
            "`background`",
        ),
        (
            vec![("color = [0.9, 0.5, 0.3]", "color = 1e308")],
            "`materials.m.color`",
        ),
        (
            vec![("intensity = 40.0", "intensity = 1e308")],
            "light 1 (point): `intensity` = 1e308",
        ),
        (
            vec![("min_weight = 0.001", "min_weight = inf")],
            "`min_weight` = inf",
        ),
        (
            vec![("threshold = 0.05", "threshold = nan")],
            "`antialias.threshold` = NaN",
        ),
        (vec![("ks = 0.1", "ks = nan")], "`materials.m.ks` = NaN"),
        (vec![("kt = 0.1", "kt = inf")], "`materials.m.kt` = inf"),
        (vec![("ks = 0.1", "ks = 2")], "`materials.m.ks` = 2"),
        (
            vec![("size = 0.5", "size = nan")],
            "`materials.floor.checker.size` = NaN",
        ),
        (
            vec![("size = 4.0", "size = nan")],
            "object 2 (plane): `size` = NaN",
        ),
        (
            vec![("size = 4.0", "size = 0")],
            "object 2 (plane): `size` = 0",
        ),
        (
            vec![("size = 4.0", "size = -inf")],
            "object 2 (plane): `size` = -inf",
        ),
        (
            vec![("eye = [0.0, 1.0, 5.0]", "eye = [0.0, 1.0, 1e300]")],
            "`camera.eye`",
        ),
        (
            vec![("radius = 0.7", "radius = inf")],
            "object 1 (sphere): `radius` = inf is out of range",
        ),
        (
            vec![(
                "center = [0.0, 0.7, 0.0]\nradius = 0.7",
                "path = \"/dev/null\"",
            )],
            "/dev/null: is a character device, not a regular file",
        ),
        (
            vec![
                ("kind = \"sphere\"", "kind = \"mesh\""),
                (
                    "center = [0.0, 0.7, 0.0]\nradius = 0.7",
                    "path = \"/dev/zero\"",
                ),
            ],
            "/dev/zero: is a character device, not a regular file",
        ),
        (
            vec![(
                "model = \"torrance-sparrow\"\nparams = { n = 1.8, c3 = 0.3, ps = 0.6, pd = 0.4 }",
                "fit = \"/dev/zero\"",
            )],
            "/dev/zero: is a character device, not a regular file",
        ),
        (
            vec![("intensity = 40.0", "intensity = 40.0\nintensity = 41.0")],
            "`intensity` is given twice",
        ),
        (
            vec![("fov = 40.0", "fov = 40.0\nfocus = 2.0")],
            "unknown field `focus`",
        ),
        (vec![("fov = 40.0\n", "")], "missing field `fov`"),
        (
            vec![(
                "frequency = 2.0 }",
                "frequency = 2.0 }\ntest_object = \"none\"",
            )],
            "unknown field `test_object`",
        ),
        (
            vec![("ambient = 0.02", "ambient = 0.02\ntest_object = \"none\"")],
            "`test_object` = \"none\" names no material",
        ),
    ];
    for (k, (edits, fragment)) in cases.iter().enumerate() {
        let mut edits = edits.clone();
        if edits.iter().any(|(_, to)| to.contains("/dev/null")) {
            edits.insert(0, ("kind = \"sphere\"", "kind = \"mesh\""));
        }
        let p = d.join(format!("case{k}.toml"));
        std::fs::write(&p, catalogue_scene(&edits)).unwrap();
        refused(
            &["render", p.to_str().unwrap(), "-o", out.to_str().unwrap()],
            &[&format!("case{k}.toml"), fragment, "fix:"],
        );
        assert!(
            !out.exists() && !d.join("out.exr").exists(),
            "case {k} wrote an image"
        );
    }
    // The message for an infinite radius is not "must be positive".
    let p = d.join("r.toml");
    std::fs::write(&p, catalogue_scene(&[("radius = 0.7", "radius = inf")])).unwrap();
    let o = run_brdfit(&["render", p.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("positive"));
    // The unchanged scene renders.
    let p = d.join("ok.toml");
    std::fs::write(&p, catalogue_scene(&[])).unwrap();
    let o = run_brdfit(&["render", p.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A 16384² image asks for the flag; the scene reader itself allows up to 16384.
    let p = d.join("big.toml");
    std::fs::write(
        &p,
        catalogue_scene(&[
            ("width = 16", "width = 16384"),
            ("height = 12", "height = 16384"),
        ]),
    )
    .unwrap();
    refused(
        &["render", p.to_str().unwrap(), "-o", out.to_str().unwrap()],
        &["16384×16384", "--allow-large-image"],
    );
    refused(
        &[
            "render",
            "fig7",
            "--res",
            "8192",
            "-o",
            d.join("f7").to_str().unwrap(),
        ],
        &["--allow-large-image"],
    );
}

/// Readers stop at their size limit: /dev/zero (metadata length 0) and files one byte over;
/// --max-input-mb changes the limit.
#[test]
fn size_limits_stop_devices_and_large_files() {
    // A device is refused unopened (it is not a regular file), whatever the format.
    refused(
        &["render", "/dev/zero", "-o", "/nonexistent/x.png"],
        &["/dev/zero", "scene file", "not a regular file", "fix:"],
    );
    refused(
        &["info", "/dev/zero", "--format", "csv"],
        &["/dev/zero", "data file", "not a regular file"],
    );
    refused(
        &["info", "/dev/zero", "--format", "astm"],
        &["not a regular file"],
    );
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("two-mb.csv");
    let mut body = b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n".to_vec();
    while body.len() < 2 << 20 {
        body.extend_from_slice(b"10,0,10,180,0.5\n");
    }
    std::fs::write(&p, &body).unwrap();
    let ps = p.to_str().unwrap();
    assert!(run_brdfit(&["info", ps]).status.success());
    refused(
        &["info", ps, "--max-input-mb", "1"],
        &["two-mb.csv", "above the limit of 1048576 bytes"],
    );
    assert!(
        run_brdfit(&["info", ps, "--max-input-mb", "3"])
            .status
            .success()
    );
}

/// `choose` refuses a scene whose test object has no lit pixel, saying why.
#[test]
fn choose_refuses_a_test_object_with_no_lit_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = root().join("data/blinn-mgo.csv");
    let cases = [
        // The camera looks away from everything.
        (
            catalogue_scene(&[("target = [0.0, 0.5, 0.0]", "target = [0.0, 1.0, 10.0]")]),
            "the camera sees no object of that material",
        ),
        // The only light inside the sphere.
        (
            catalogue_scene(&[("position = [2.0, 4.0, 5.0]", "position = [0.0, 0.7, 0.0]")]),
            "no light reaches them",
        ),
        // The only light under the floor: it faces the sphere's lower side, which the camera
        // sees, but the floor shadows all of it.
        (
            catalogue_scene(&[("position = [2.0, 4.0, 5.0]", "position = [0.0, -3.0, 1.0]")]),
            "cast their shadow",
        ),
    ];
    for (k, (text, fragment)) in cases.iter().enumerate() {
        let p = d.join(format!("dark{k}.toml"));
        std::fs::write(&p, text).unwrap();
        refused(
            &[
                "choose",
                data.to_str().unwrap(),
                "--scene",
                p.to_str().unwrap(),
                "-o",
                d.join("c").to_str().unwrap(),
            ],
            &[
                &format!("dark{k}.toml"),
                "has no lit pixel",
                fragment,
                "fix:",
            ],
        );
        assert!(!d.join("c").exists());
    }
}

/// The test object is the first material in file order (not by name), or `test_object`.
#[test]
fn the_test_object_is_first_in_file_order_or_named() {
    use brdfit::scene::parse_scene;
    // `zfloor` comes first in the file and last by name.
    let text = catalogue_scene(&[]).replace("floor", "zfloor");
    let text = text.replacen(
        "[materials.m]",
        "[materials.zfloor0]\nmodel = \"lambert\"\nparams = { pd = 0.1 }\n[materials.m]",
        1,
    );
    let s = parse_scene(&text, Path::new(".")).unwrap();
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["zfloor0", "m", "zfloor"]);
    let s = parse_scene(&format!("test_object = \"zfloor\"\n{text}"), Path::new(".")).unwrap();
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["zfloor", "zfloor0", "m"]);
    // Objects still reach their own materials after the reordering.
    assert_eq!(s.materials[s.objects[0].material].name, "m");
    assert_eq!(s.materials[s.objects[1].material].name, "zfloor");
}

/// An image with a NaN or infinite pixel is an error, not a file.
#[test]
fn a_non_finite_pixel_is_never_written() {
    let dir = tempfile::tempdir().unwrap();
    let mut img = brdfit::render::Image {
        width: 3,
        height: 2,
        pixels: vec![[0.5; 3]; 6],
        rays: [6, 0, 0, 0],
    };
    img.pixels[4] = [0.1, f32::INFINITY, 0.2];
    let base = dir.path().join("img");
    let e = brdfit::render::save(&img, &base).unwrap_err().to_string();
    assert!(
        e.contains("1 pixels that are not finite") && e.contains("x = 1, y = 1"),
        "{e}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    img.pixels[4] = [0.1, 0.2, 0.3];
    assert_eq!(brdfit::render::save(&img, &base).unwrap().len(), 2);
}

//! The Neural-BRDF evaluator against the tables its authors' networks produced (the excerpts
//! in tests/data/nbrdf/ of the Neural-BRDF tables of github.com/asztr/Neural-BRDF, made by an
//! independent evaluator), its
//! symmetrised form, its errors, and `brdfit simulate --nbrdf`.

use brdfit::data::nbrdf::{Nbrdf, material_names};
use std::path::PathBuf;

fn weights() -> PathBuf {
    crate::common::root().join("tests/data/nbrdf/weights-merl8.json")
}

/// Rows of a published table: (θi, φi, θo, φo) in degrees and RGB f_r.
fn table(name: &str) -> Vec<([f64; 4], [f64; 3])> {
    let text =
        std::fs::read_to_string(crate::common::root().join("tests/data/nbrdf").join(name)).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("theta"))
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            ([v[0], v[1], v[2], v[3]], [v[4], v[5], v[6]])
        })
        .collect()
}

/// The tables print angles rounded to float32 (67.9998 for the 68° of the grid): the grid's
/// angles, to 0.001°.
fn grid_angles(a: [f64; 4]) -> [f64; 4] {
    a.map(|d| ((d * 1000.0).round() / 1000.0).to_radians())
}

/// Every row of the steel and blue-acrylic excerpts (652 rows, near the mirror included) to
/// 1e-4 relative in every channel.
#[test]
fn reproduces_the_published_tables() {
    for (mat, file) in [
        ("merl/steel", "merl-steel-excerpt.csv"),
        ("merl/blue-acrylic", "merl-blue-acrylic-excerpt.csv"),
    ] {
        let net = Nbrdf::load(&weights(), mat).unwrap();
        let rows = table(file);
        assert!(rows.len() > 300, "{file}: {} rows", rows.len());
        let mut worst: f64 = 0.0;
        for (a, want) in &rows {
            let got = net.eval(grid_angles(*a));
            for c in 0..3 {
                worst = worst.max((got[c] - want[c]).abs() / want[c].abs().max(1e-12));
            }
        }
        assert!(worst < 1e-4, "{mat}: worst relative error {worst}");
    }
}

/// Names: the full key, the last part when unambiguous; a wrong one names the nearest.
#[test]
fn material_names_and_errors() {
    let names = material_names(&weights()).unwrap();
    assert_eq!(names.len(), 8);
    assert!(names.contains(&"merl/steel".to_string()));
    assert_eq!(Nbrdf::load(&weights(), "steel").unwrap().name, "merl/steel");
    let e = Nbrdf::load(&weights(), "steal").unwrap_err().to_string();
    assert!(
        e.contains("weights-merl8.json") && e.contains("--material merl/steel"),
        "{e}"
    );
    // Broken files: an error naming the file and the line or key, never a panic.
    let dir = tempfile::tempdir().unwrap();
    let bad = crate::common::write(dir.path(), "bad.json", b"{\"materials\": {\n  \"a\": [1,\n");
    let e = Nbrdf::load(&bad, "a").unwrap_err().to_string();
    assert!(
        e.contains("bad.json:") && e.contains("not valid JSON"),
        "{e}"
    );
    let shape = crate::common::write(
        dir.path(),
        "shape.json",
        br#"{"materials": {"x/a": {"W1": [[1,2]], "b1": [0,0], "W2": [], "b2": [], "W3": [], "b3": []}}}"#,
    );
    let e = Nbrdf::load(&shape, "a").unwrap_err().to_string();
    assert!(
        e.contains("materials.x/a.W1") && e.contains("expected 6"),
        "{e}"
    );
    let none = crate::common::write(dir.path(), "none.json", b"{\"format\": 1}");
    let e = Nbrdf::load(&none, "a").unwrap_err().to_string();
    assert!(e.contains("key `materials`"), "{e}");
}

/// The symmetrised network is reciprocal and mirror-symmetric, and differs from the network
/// (which is neither exactly), so the symmetrisation does something.
#[test]
fn symmetrised_network_is_reciprocal_and_mirror_symmetric() {
    let net = Nbrdf::load(&weights(), "merl/blue-acrylic").unwrap();
    let mut asym: f64 = 0.0;
    for &(ti, to, dp) in &[
        (0.3, 0.9, 2.0),
        (1.1, 0.4, 3.0),
        (0.7, 0.75, 3.1),
        (0.2, 1.3, 0.5),
    ] {
        let a = [ti, 0.4, to, 0.4 + dp];
        let s = net.eval_symmetric(a);
        let swapped = net.eval_symmetric([to, 0.4 + dp, ti, 0.4]);
        let mirrored = net.eval_symmetric([ti, 0.4, to, 0.4 - dp]);
        for c in 0..3 {
            assert!((s[c] - swapped[c]).abs() <= 1e-12 * s[c]);
            assert!((s[c] - mirrored[c]).abs() <= 1e-12 * s[c]);
        }
        let raw = net.eval(a);
        let raw_swapped = net.eval([to, 0.4 + dp, ti, 0.4]);
        asym = asym.max((raw[1] - raw_swapped[1]).abs() / raw[1]);
    }
    assert!(asym > 1e-4, "the network looks exactly reciprocal: {asym}");
}

/// `simulate --nbrdf --grid goniometer` writes the published grid (16,512 rows) with the
/// published values; `--grid merl` a MERL table that reads back as the network at its cells.
#[test]
fn simulate_samples_a_network_on_a_goniometer_and_a_merl_grid() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("steel.csv");
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(["simulate", "--nbrdf"])
        .arg(weights())
        .args(["--material", "steel", "--grid", "goniometer", "-o"])
        .arg(&csv)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    assert!(String::from_utf8_lossy(&st.stderr).contains(&format!("wrote {}", csv.display())));
    let ds = brdfit::load(&csv, &Default::default()).unwrap();
    assert_eq!(ds.len(), 8 * 86 * 24);
    assert_eq!(ds.channels.len(), 3);
    // Rows at the published rows' angles hold the published values.
    let published = table("merl-steel-excerpt.csv");
    let mut matched = 0;
    for (a, want) in &published {
        let g = grid_angles(*a);
        let k = (0..ds.len())
            .find(|&k| {
                ds.angles(k)
                    .iter()
                    .zip(&g)
                    .all(|(x, y)| (x - y).abs() < 1e-9)
            })
            .expect("every published row is on the grid");
        for (ch, w) in ds.channels.iter().zip(want) {
            let v = ch.values[k];
            assert!((v - w).abs() <= 1e-4 * w, "{a:?}: {v} vs {w}");
        }
        matched += 1;
    }
    assert_eq!(matched, published.len());

    let bin = dir.path().join("steel.binary");
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(["simulate", "--nbrdf"])
        .arg(weights())
        .args([
            "--material",
            "merl/steel",
            "--symmetric",
            "--grid",
            "merl",
            "-o",
        ])
        .arg(&bin)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    assert_eq!(
        std::fs::metadata(&bin).unwrap().len(),
        12 + 3 * 8 * 90 * 90 * 180
    );
    let merl = brdfit::load(&bin, &Default::default()).unwrap();
    assert!(merl.len() > 1_000_000, "{} cells", merl.len());
    let net = Nbrdf::load(&weights(), "merl/steel").unwrap();
    for k in (0..merl.len()).step_by(9973) {
        let want = net.eval_symmetric(merl.angles(k));
        for (ch, w) in merl.channels.iter().zip(want) {
            let v = ch.values[k];
            assert!((v - w).abs() <= 1e-9 * w.max(1e-9), "cell {k}: {v} vs {w}");
        }
    }
    // A model name and a network together are a usage error.
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(["simulate", "--model", "lambert", "--nbrdf"])
        .arg(weights())
        .args(["--material", "steel", "-o"])
        .arg(dir.path().join("x.csv"))
        .output()
        .unwrap();
    assert_eq!(st.status.code(), Some(2));
}

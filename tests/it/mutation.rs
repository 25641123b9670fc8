//! Fit files a person edits by hand: seeded mutations of real fit JSON, each fed to
//! every consumer of fit files. Counted: panics (exit 101 or "panicked"), mutations that make
//! the file invalid but are accepted (exit 0), valid in-range edits that are refused, and
//! written outputs holding a non-finite number. All four must be 0.
//!
//! The number of mutated files is `BRDFIT_MUTATIONS` (default 24, the CI run; the README's
//! figures are from 300: `BRDFIT_MUTATIONS=300 cargo test --release --test it mutation:: --
//! --nocapture`).

use rand::{Rng, SeedableRng};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn brdfit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run brdfit")
}

/// What a mutation does to the file, and whether the result is still a valid fit file.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Mutation {
    /// A parameter scaled by 1.01 (kept inside its bounds): valid.
    InRange,
    /// A parameter set negative (every parameter of every model is ≥ 0, n ≥ 1).
    Negative,
    /// A shape parameter or index set to 1e300 (beyond its declared bound).
    Huge,
    /// ps or pd set to 1e300 in a file of one model (inside the declared [0, ∞), but no
    /// material reflects so much: the physical check refuses it where the fit is used).
    HugeReflectance,
    /// A parameter set to `null` (read back as not a number).
    Null,
    /// A parameter set to a string.
    Text,
    /// A parameter removed.
    Missing,
    /// An unknown parameter added.
    Unknown,
    /// A parameter's key written twice with two values.
    Duplicate,
    /// The distribution renamed to one that does not exist.
    BadDistribution,
    /// The model renamed to one that does not exist.
    BadModel,
    /// The list of fits emptied.
    NoFits,
    /// The file cut at a random byte.
    Truncated,
    /// Every fit of the file marked not usable (a file of several models whose others are
    /// usable stays usable: consumers take a usable recommended one).
    Unusable,
}

const ALL: [Mutation; 14] = [
    Mutation::InRange,
    Mutation::Negative,
    Mutation::Huge,
    Mutation::HugeReflectance,
    Mutation::Null,
    Mutation::Text,
    Mutation::Missing,
    Mutation::Unknown,
    Mutation::Duplicate,
    Mutation::BadDistribution,
    Mutation::BadModel,
    Mutation::NoFits,
    Mutation::Truncated,
    Mutation::Unusable,
];

/// The fits of a file (a list under `fits`, or the file itself).
fn fits_mut(v: &mut Value) -> Vec<&mut Value> {
    if v.get("fits").is_some() {
        v["fits"].as_array_mut().unwrap().iter_mut().collect()
    } else {
        vec![v]
    }
}

/// Apply `m` to the JSON text `src`; `None` when the file offers nothing to mutate that way.
/// Also returns the channel of the parameter changed (its `_r`, `_g`, `_b` suffix), if any.
fn mutate(src: &str, m: Mutation, rng: &mut impl Rng) -> Option<(String, Option<String>)> {
    let mut v: Value = serde_json::from_str(src).unwrap();
    if m == Mutation::Truncated {
        let cut = rng.random_range(1..src.len() - 1);
        return Some((src[..cut].to_string(), None));
    }
    if m == Mutation::NoFits {
        return Some((r#"{"fits": []}"#.into(), None));
    }
    if m == Mutation::Unusable {
        for f in fits_mut(&mut v) {
            f["unusable"] = Value::from(vec!["edited by hand: not usable"]);
        }
        return Some((serde_json::to_string_pretty(&v).unwrap(), None));
    }
    let mut fits = fits_mut(&mut v);
    let models: std::collections::BTreeSet<String> = fits
        .iter()
        .map(|f| format!("{} {}", f["model"], f["distribution"]))
        .collect();
    if m == Mutation::HugeReflectance && models.len() > 1 {
        return None;
    }
    let k = rng.random_range(0..fits.len());
    let fit = &mut *fits[k];
    let fit_channel = fit["channel"].as_str().unwrap_or("").to_string();
    let params = fit["params"].as_object_mut()?;
    let reflectance = |n: &str| matches!(n.split('_').next(), Some("ps" | "pd"));
    let names: Vec<String> = params
        .keys()
        .filter(|n| match m {
            Mutation::Huge => !reflectance(n),
            Mutation::HugeReflectance => reflectance(n),
            _ => true,
        })
        .cloned()
        .collect();
    if names.is_empty() {
        return None;
    }
    let name = names[rng.random_range(0..names.len())].clone();
    let channel = name
        .split_once('_')
        .map(|(_, c)| c.to_string())
        .or_else(|| (!fit_channel.contains(',')).then_some(fit_channel));
    match m {
        Mutation::InRange => {
            let x = params[&name].as_f64()?;
            // Inside every declared bound: shape parameters and reflectances away from 0
            // and from their upper bounds, n away from 1.
            let ok = match name.split('_').next().unwrap() {
                "n" => x > 1.01 && x < 1e5,
                "c3" | "alpha" => x > 1e-4 && x < 0.9,
                "pd" => x > 1e-6 && x < 0.9,
                _ => x > 1e-6 && x < 1e5,
            };
            if !ok {
                return None;
            }
            params[&name] = Value::from(x * 1.01);
        }
        Mutation::Negative => params[&name] = Value::from(-0.5),
        Mutation::Huge | Mutation::HugeReflectance => params[&name] = Value::from(1e300),
        Mutation::Null => params[&name] = Value::Null,
        Mutation::Text => params[&name] = Value::from("0.5"),
        Mutation::Missing => {
            params.remove(&name);
        }
        Mutation::Unknown => {
            params.insert("roughness_extra".into(), Value::from(0.5));
        }
        Mutation::Duplicate => {
            // serde_json's map cannot hold a key twice: mark the key and double it in text.
            let marker = "__brdfit_duplicate__";
            let x = params.remove(&name)?;
            params.insert(marker.into(), x.clone());
            let text = serde_json::to_string_pretty(&v).unwrap();
            let other = if x.as_f64().is_some_and(|y| y > 0.0) {
                "0.123"
            } else {
                "1.5"
            };
            return Some((
                text.replace(
                    &format!("\"{marker}\": {x}"),
                    &format!("\"{name}\": {x},\n\"{name}\": {other}"),
                ),
                channel,
            ));
        }
        Mutation::BadDistribution => fit["distribution"] = Value::from("d9"),
        Mutation::BadModel => fit["model"] = Value::from("torrance-sparow"),
        Mutation::Truncated | Mutation::NoFits | Mutation::Unusable => unreachable!(),
    }
    Some((serde_json::to_string_pretty(&v).unwrap(), channel))
}

/// The consumers of a fit file `fit` whose data file is `data`: argument lists writing under
/// `out`, and the output files to scan for non-finite numbers.
fn consumers(
    fit: &Path,
    data: &str,
    channel: Option<&str>,
    image: &Path,
    out: &Path,
) -> Vec<(Vec<String>, Vec<PathBuf>)> {
    let f = fit.to_str().unwrap().to_string();
    let o = |name: &str| out.join(name);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let scene = out.join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            "[camera]\neye = [0, 0, 4]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov = 35\nwidth = 24\nheight = 24\n\
             [antialias]\nmode = \"none\"\n[[lights]]\nkind = \"directional\"\n\
             direction = [0.3, 0.3, 1]\nintensity = 3.14\n[materials.m]\nfit = {f:?}\n\
             [[objects]]\nkind = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
        ),
    )
    .unwrap();
    let mut v: Vec<(Vec<String>, Vec<PathBuf>)> = Vec::new();
    let mut add = |args: Vec<String>, outs: Vec<PathBuf>| v.push((args, outs));
    for to in ["mitsuba", "pbrt", "brdf-explorer"] {
        let p = o(&format!("export.{to}"));
        let mut args = vec![
            "export".into(),
            f.clone(),
            "--to".into(),
            to.into(),
            "-o".into(),
            s(&p),
        ];
        // BRDF Explorer's file holds one channel's model: an RGB fit needs one named (the
        // one whose parameter was changed).
        if to == "brdf-explorer" && data.contains("_rgb") {
            args.extend(["--channel".into(), channel.unwrap_or("g").into()]);
        }
        add(args, vec![p]);
    }
    let p = o("export.csv");
    add(
        vec![
            "export".into(),
            f.clone(),
            "--to".into(),
            "csv".into(),
            "-o".into(),
            s(&p),
        ],
        vec![p],
    );
    add(
        vec![
            "plot".into(),
            "lobe".into(),
            "--fit".into(),
            f.clone(),
            "--data".into(),
            data.into(),
            "-o".into(),
            s(&o("lobe")),
        ],
        vec![],
    );
    for kind in ["residuals", "slice"] {
        add(
            vec![
                "plot".into(),
                kind.into(),
                data.into(),
                "--fit".into(),
                f.clone(),
                "-o".into(),
                s(&o(kind)),
            ],
            vec![],
        );
    }
    add(
        vec![
            "plot".into(),
            "albedo".into(),
            "--fit".into(),
            f.clone(),
            "-o".into(),
            s(&o("albedo")),
        ],
        vec![],
    );
    add(
        vec![
            "render".into(),
            "fig7".into(),
            "--mgo".into(),
            f.clone(),
            "--res".into(),
            "16".into(),
            "-o".into(),
            s(&o("fig7")),
        ],
        vec![],
    );
    let png = o("scene.png");
    add(
        vec!["render".into(), s(&scene), "-o".into(), s(&png)],
        vec![o("scene.exr")],
    );
    add(
        vec![
            "inverse".into(),
            s(image),
            "--row".into(),
            "12".into(),
            "--light".into(),
            "0.3,0.3,1".into(),
            "--pixel-size".into(),
            "0.1".into(),
            "--fit".into(),
            f.clone(),
            "-o".into(),
            s(&o("inverse")),
        ],
        vec![o("inverse.csv")],
    );
    // Consumers of one channel take the channel of the fit that was changed (an RGB file's
    // other channels, or the data's first channel, would not show the change).
    if let Some(c) = channel.filter(|c| ["r", "g", "b"].contains(c)) {
        for (args, _) in &mut v {
            let one = matches!(args[0].as_str(), "plot" | "inverse")
                || (args[0] == "render" && args[1] == "fig7");
            if one {
                args.extend(["--channel".into(), c.into()]);
            }
        }
    }
    v
}

/// A 24² render of a grey Lambertian sphere under one directional light (the image `inverse`
/// reads), written as `dir/sphere.exr`.
fn sphere_image(dir: &Path) -> PathBuf {
    let scene = dir.join("sphere.toml");
    std::fs::write(
        &scene,
        "[camera]\neye = [0, 0, 4]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov = 35\nwidth = 24\n\
         height = 24\n[antialias]\nmode = \"none\"\n[[lights]]\nkind = \"directional\"\n\
         direction = [0.3, 0.3, 1]\nintensity = 3.14\n[materials.m]\nmodel = \"lambert\"\n\
         params = { pd = 0.5 }\n[[objects]]\nkind = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n\
         material = \"m\"\n",
    )
    .unwrap();
    let png = dir.join("sphere.png");
    let out = brdfit(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir.join("sphere.exr")
}

/// Whether a written file holds a non-finite number: text files by their words, EXR by its
/// pixels.
fn non_finite(p: &Path) -> bool {
    let Ok(bytes) = std::fs::read(p) else {
        return false;
    };
    if p.extension().is_some_and(|e| e == "exr") {
        let Ok(img) = image::open(p) else {
            return true;
        };
        return img
            .to_rgba32f()
            .pixels()
            .any(|px| px.0.iter().any(|c| !c.is_finite()));
    }
    let text = String::from_utf8_lossy(&bytes).to_ascii_lowercase();
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '-'))
        .any(|w| matches!(w, "nan" | "inf" | "-inf" | "infinity" | "-nan"))
}

#[test]
fn mutated_fit_files_are_refused_or_used_never_misused() {
    let n: usize = std::env::var("BRDFIT_MUTATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(24);
    let dir = tempfile::tempdir().unwrap();
    // Seed files: one model, every model (the recommended one is used), an RGB fit.
    let seeds = [
        ("data/blinn-mgo.csv", vec!["--model", "torrance-sparrow"]),
        (
            "data/merl-alumina-oxide.csv",
            vec!["--model", "all", "--channel", "g"],
        ),
        ("tests/data/vch_golden_yellow_rgb.csv", vec![]),
    ];
    let mut sources = Vec::new();
    for (i, (data, extra)) in seeds.iter().enumerate() {
        let p = dir.path().join(format!("seed{i}.json"));
        let mut args = vec!["fit", data, "--json", p.to_str().unwrap(), "--quiet"];
        args.extend(extra.iter());
        let out = brdfit(&args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        sources.push((std::fs::read_to_string(&p).unwrap(), *data));
    }
    let image = sphere_image(dir.path());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(26);
    let (mut runs, mut panics, mut accepted_invalid, mut refused_valid, mut nonfinite) =
        (0, 0, 0, 0, 0);
    let mut examples: Vec<String> = Vec::new();
    let mut made = 0;
    while made < n {
        let m = ALL[made % ALL.len()];
        let (src, data) = &sources[rng.random_range(0..sources.len())];
        let Some((text, channel)) = mutate(src, m, &mut rng) else {
            continue;
        };
        made += 1;
        let case = dir.path().join(format!("case{made}"));
        std::fs::create_dir_all(&case).unwrap();
        let fit = case.join("fit.json");
        std::fs::write(&fit, &text).unwrap();
        let valid = m == Mutation::InRange;
        for (args, outs) in consumers(&fit, data, channel.as_deref(), &image, &case) {
            let a: Vec<&str> = args.iter().map(String::as_str).collect();
            let out = brdfit(&a);
            runs += 1;
            let err = String::from_utf8_lossy(&out.stderr);
            let line = err
                .lines()
                .find(|l| l.contains("error") || l.contains("panicked"))
                .or_else(|| err.lines().next())
                .unwrap_or("");
            let what = format!("{m:?} {}: {line}", a[..2].join(" "));
            if out.status.code() == Some(101) || err.contains("panicked") {
                panics += 1;
                examples.push(format!("panic: {what}"));
            } else if out.status.success() && !valid {
                accepted_invalid += 1;
                examples.push(format!("accepted: {what}"));
            } else if !out.status.success() && valid {
                refused_valid += 1;
                examples.push(format!("refused: {what}"));
            }
            if out.status.success() && outs.iter().any(|p| non_finite(p)) {
                nonfinite += 1;
                examples.push(format!("non-finite output: {what}"));
            }
        }
    }
    println!(
        "{n} mutated fit files, {runs} consumer runs: {panics} panics, {accepted_invalid} invalid \
         files accepted, {refused_valid} valid files refused, {nonfinite} non-finite outputs"
    );
    examples.sort();
    examples.dedup();
    for kind in ["panic:", "accepted:", "refused:", "non-finite"] {
        for e in examples.iter().filter(|e| e.starts_with(kind)).take(12) {
            println!("  {e}");
        }
    }
    assert_eq!(
        (panics, accepted_invalid, refused_valid, nonfinite),
        (0, 0, 0, 0),
        "see the list above"
    );
}

//! brdfit used as a dependency: a crate of its own, in a temporary folder, depending on brdfit
//! by path with no `[patch]` (so with the registry's plotters, as any dependent gets it),
//! draws Blinn's Figure 6 and writes the same PNG and SVG bytes as brdfit itself draws here.
//! Its text (tick labels with full stops, the title) is what differed when brdfit's charts
//! relied on a patched plotters a dependent does not inherit.
//!
//! The crate is built with the cargo running these tests, offline (the dependencies are the
//! ones these tests were built with), in the same target folder and release profile; the
//! features of a dependent differ from the tests' (no dev-dependencies), so brdfit and much of
//! its dependencies are compiled again: minutes, hence `#[ignore]` (run it with `cargo test
//! --release --test it dependent:: -- --ignored`). The cheap guard beside it holds what makes
//! it pass: brdfit's own build patches no dependency, so a dependent compiles the same code.

use crate::common::root;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The target folder these tests were built in (`…/target/release/deps/it-…` → `…/target`).
fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.ancestors().nth(3).unwrap().to_path_buf()
}

/// brdfit's own `[profile.release]` section, so the dependent builds the dependencies alike.
fn release_profile() -> String {
    let toml = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
    let start = toml.find("[profile.release]").unwrap();
    let rest = &toml[start..];
    let end = rest.find("\n\n").unwrap_or(rest.len());
    rest[..end].to_string()
}

/// Write the dependent crate into `dir`: it saves Blinn's Figure 6 at θi = 30° to the base
/// path given as its argument.
fn write_dependent(dir: &Path) {
    let manifest = format!(
        "[package]\nname = \"uses-brdfit\"\nversion = \"0.0.0\"\nedition = \"2024\"\npublish = \
         false\n\n[dependencies]\nbrdfit = {{ path = {:?} }}\n\n{}\n\n[workspace]\n",
        root().display().to_string(),
        release_profile()
    );
    std::fs::write(dir.join("Cargo.toml"), manifest).unwrap();
    // The versions brdfit was tested with.
    std::fs::copy(root().join("Cargo.lock"), dir.join("Cargo.lock")).unwrap();
    std::fs::create_dir_all(dir.join("src")).unwrap();
    std::fs::write(
        dir.join("src/main.rs"),
        "fn main() {\n    let base = std::env::args().nth(1).expect(\"an output base\");\n    \
         brdfit::plot::save(&brdfit::plot::blinn_figure(30.0, 6), std::path::Path::new(&base))\n        \
         .unwrap();\n}\n",
    )
    .unwrap();
}

/// The crate patches no dependency (`[patch]` or `[replace]` in Cargo.toml), so its charts
/// are drawn by the same code in its own build and in a dependent's.
#[test]
fn no_dependency_is_patched() {
    let toml = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
    for section in ["[patch", "[replace"] {
        assert!(
            !toml.lines().any(|l| l.trim_start().starts_with(section)),
            "Cargo.toml has a {section}] section: a crate using brdfit does not inherit it"
        );
    }
}

/// A crate depending on brdfit by path draws Blinn's Figure 6 to the same PNG and SVG bytes
/// as brdfit draws it here.
#[test]
#[ignore = "builds a crate depending on brdfit (minutes); run with --ignored"]
fn a_dependent_draws_the_same_charts() {
    let tmp = tempfile::tempdir().unwrap();
    let krate = tmp.path().join("uses-brdfit");
    std::fs::create_dir_all(&krate).unwrap();
    write_dependent(&krate);
    assert!(
        !std::fs::read_to_string(krate.join("Cargo.toml"))
            .unwrap()
            .contains("[patch"),
        "the dependent must take brdfit's dependencies as published"
    );
    let theirs = tmp.path().join("theirs");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    // The profile these tests were built with (`cargo test --release`: release).
    let release = target_dir().join("release").exists()
        && std::env::current_exe().unwrap().ancestors().nth(2)
            == Some(&target_dir().join("release"));
    let mut cmd = Command::new(cargo);
    cmd.args(["run", "--offline", "--quiet"]);
    if release {
        cmd.arg("--release");
    }
    let out = cmd
        .arg("--manifest-path")
        .arg(krate.join("Cargo.toml"))
        .arg("--")
        .arg(&theirs)
        .env("CARGO_TARGET_DIR", target_dir())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "the dependent failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ours = tmp.path().join("ours");
    brdfit::plot::save(&brdfit::plot::blinn_figure(30.0, 6), &ours).unwrap();
    for ext in ["png", "svg"] {
        let a = std::fs::read(ours.with_extension(ext)).unwrap();
        let b = std::fs::read(theirs.with_extension(ext)).unwrap();
        assert!(a == b, "{ext}: brdfit's and the dependent's charts differ");
    }
}

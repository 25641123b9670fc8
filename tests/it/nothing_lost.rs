//! Outputs never destroy what is already there: an output naming an input is refused (also
//! by `inverse`), an existing output that is not a regular file (a device, a named pipe) is
//! refused and left as it was, and a table whose values the output format cannot hold is
//! refused before anything is written.

use crate::cli::{brdfit, expect_error};
use crate::common::write;
use std::path::Path;

const DIRS: &[u8] = b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n0,0,0,0\n30,0,30,180\n";

/// A small grey image, written as `dir/photo.png` (and `photo.exr`).
fn photo(dir: &Path) -> std::path::PathBuf {
    let img = brdfit::render::Image {
        width: 8,
        height: 4,
        pixels: vec![[0.5; 3]; 32],
        rays: [0; 4],
    };
    brdfit::render::save(&img, &dir.join("photo")).unwrap();
    dir.join("photo.png")
}

fn inverse_args<'a>(image: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "inverse", image, "--row", "1", "--light", "0,0,1", "--cd", "1",
    ];
    a.extend_from_slice(extra);
    a.extend_from_slice(&["-o", out]);
    a
}

#[test]
fn inverse_refuses_an_output_that_names_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let img = photo(dir.path());
    let before = std::fs::read(&img).unwrap();
    let second = dir.path().join("b.png");
    std::fs::copy(&img, &second).unwrap();
    let (i, s) = (img.to_str().unwrap(), second.to_str().unwrap());
    let base = dir.path().join("photo");
    let base_b = dir.path().join("b");
    let two = ["--image2", s, "--light2", "0.5,0,1"];
    for (out, extra) in [
        (base.to_str().unwrap(), &[][..]),
        (i, &[][..]),
        (base_b.to_str().unwrap(), &two[..]),
    ] {
        expect_error(
            &inverse_args(i, out, extra),
            &["the output would overwrite an input", "fix:", ".png"],
        );
        assert_eq!(
            std::fs::read(&img).unwrap(),
            before,
            "-o {out}: image changed"
        );
        assert_eq!(
            std::fs::read(&second).unwrap(),
            before,
            "-o {out}: image2 changed"
        );
        // Refused before the work: not even the CSV is written.
        for ext in ["csv", "svg"] {
            assert!(
                !Path::new(out).with_extension(ext).exists(),
                "-o {out}: wrote .{ext}"
            );
        }
    }
    // Another name works.
    let ok = dir.path().join("profile");
    let o = brdfit(&inverse_args(i, ok.to_str().unwrap(), &[]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(ok.with_extension("csv").exists() && ok.with_extension("png").exists());
}

fn mkfifo(p: &Path) {
    let st = std::process::Command::new("mkfifo")
        .arg(p)
        .status()
        .unwrap();
    assert!(st.success(), "mkfifo {}", p.display());
}

fn is_fifo(p: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_fifo())
}

#[test]
fn an_output_that_is_not_a_regular_file_is_refused_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let dirs = write(d, "dirs.csv", DIRS);
    let data = write(
        d,
        "data.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n0,0,0,0,0.3\n30,0,30,180,0.4\n",
    );
    let fifo = d.join("pipe");
    mkfifo(&fifo);
    let f = fifo.to_str().unwrap();
    let eval = [
        "eval",
        "--model",
        "lambert",
        "--set",
        "pd=0.5",
        dirs.to_str().unwrap(),
        "-o",
        f,
    ];
    let convert = ["convert", data.to_str().unwrap(), "-o", f];
    let fit = [
        "fit",
        data.to_str().unwrap(),
        "--model",
        "lambert",
        "--json",
        f,
    ];
    for args in [&eval[..], &convert[..], &fit[..]] {
        expect_error(
            args,
            &[
                f,
                "named pipe",
                "not a regular file",
                "fix: give a path to a regular file or a new name",
            ],
        );
        let err = String::from_utf8_lossy(&brdfit(args).stderr).into_owned();
        assert!(!err.contains("cannot read"), "{args:?}: {err}");
        assert!(is_fifo(&fifo), "{args:?}: the FIFO was replaced");
    }
    // The library's writers refuse too, worded as a write failure with the fix.
    let ds = crate::common::load("data/blinn-mgo.csv");
    let e = brdfit::data::write_csv(&ds, &fifo).unwrap_err().to_string();
    assert!(
        e.contains("not a regular file") && e.contains("fix:"),
        "{e}"
    );
    assert!(!e.contains("cannot read"), "{e}");
    assert!(is_fifo(&fifo));
    // No temporary file is left beside it.
    let names: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");
}

#[test]
fn dev_null_stays_a_device() {
    use std::os::unix::fs::FileTypeExt;
    let null = Path::new("/dev/null");
    let is_char = || std::fs::symlink_metadata(null).is_ok_and(|m| m.file_type().is_char_device());
    if !is_char() {
        // Nothing to check where /dev/null is not a device.
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let dirs = write(dir.path(), "dirs.csv", DIRS);
    let args = [
        "eval",
        "--model",
        "lambert",
        "--set",
        "pd=0.5",
        dirs.to_str().unwrap(),
        "-o",
        "/dev/null",
    ];
    expect_error(
        &args,
        &[
            "/dev/null",
            "character device",
            "fix: give a path to a regular file",
        ],
    );
    assert!(is_char(), "/dev/null is no longer a character device");
}

#[test]
fn convert_refuses_a_value_that_merl_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = write(
        d,
        "big.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n20,0,20,180,0.5\n30,0,30,180,1e306\n",
    );
    let out = d.join("big.binary");
    expect_error(
        &[
            "convert",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &[input.to_str().unwrap(), "sample 2", "1e306", "MERL", "fix:"],
    );
    assert!(!out.exists(), "wrote {}", out.display());
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 1);
    // CSV holds it, and a value MERL can hold converts and reads back.
    let csv = d.join("big-copy.csv");
    let o = brdfit(&[
        "convert",
        input.to_str().unwrap(),
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fine = write(
        d,
        "fine.csv",
        b"theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf\n20,0,20,180,0.5\n30,0,30,180,1e300\n",
    );
    let o = brdfit(&[
        "convert",
        fine.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let back = d.join("back.csv");
    let o = brdfit(&[
        "convert",
        out.to_str().unwrap(),
        "-o",
        back.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

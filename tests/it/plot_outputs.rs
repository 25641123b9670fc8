//! `plot` checks its outputs before its work, as every other command does: an output that is
//! a folder, a device or a named pipe, or one of the inputs, is refused first, and kept.

use crate::cli::{brdfit, expect_error};
use crate::common::write;
use std::path::Path;

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
fn plot_refuses_an_output_that_is_its_input() {
    // The data file is named lobe.svg (read as CSV): `-o lobe` would write lobe.svg over it.
    let dir = tempfile::tempdir().unwrap();
    let body = std::fs::read(crate::common::root().join("data/blinn-mgo.csv")).unwrap();
    let data = write(dir.path(), "lobe.svg", &body);
    let base = dir.path().join("lobe");
    for cmd in ["lobe", "albedo"] {
        let args = [
            "plot",
            cmd,
            "--model",
            "lambert",
            "--set",
            "pd=0.5",
            "--data",
            data.to_str().unwrap(),
            "--format",
            "csv",
            "-o",
            base.to_str().unwrap(),
        ];
        expect_error(
            &args,
            &["overwrite an input", "fix: choose another output path"],
        );
        assert_eq!(
            std::fs::read(&data).unwrap(),
            body,
            "{cmd}: the input changed"
        );
    }
}

#[test]
fn plot_refuses_a_pipe_or_a_file_before_reading_its_inputs() {
    // The inputs do not exist: an output checked only after the work would be reported as a
    // missing input instead, and the pipe met only once every chart was drawn.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let missing_fit = d.join("missing.json");
    let missing_data = d.join("missing.csv");
    let (fit, data) = (
        missing_fit.to_str().unwrap(),
        missing_data.to_str().unwrap(),
    );
    let lobe = d.join("lobe");
    mkfifo(&d.join("lobe.png"));
    let res = d.join("res");
    std::fs::create_dir(&res).unwrap();
    mkfifo(&res.join("residual-theta-d.svg"));
    let slice = d.join("slice");
    mkfifo(&d.join("slice.svg"));
    let (l, r, s) = (
        lobe.to_str().unwrap(),
        res.to_str().unwrap(),
        slice.to_str().unwrap(),
    );
    let cases: [&[&str]; 3] = [
        &["plot", "lobe", "--fit", fit, "--data", data, "-o", l],
        &["plot", "residuals", "--fit", fit, data, "-o", r],
        &["plot", "slice", "--fit", fit, data, "-o", s],
    ];
    for args in cases {
        expect_error(args, &["named pipe", "not a regular file", "fix:"]);
        let err = String::from_utf8_lossy(&brdfit(args).stderr).into_owned();
        assert!(!err.contains("missing"), "{args:?}: {err}");
    }
    assert!(is_fifo(&d.join("lobe.png")) && is_fifo(&d.join("slice.svg")));
    assert!(is_fifo(&res.join("residual-theta-d.svg")));
    // A folder of charts that is a file is refused, and the file kept.
    let file = write(d, "figures", b"keep");
    expect_error(
        &["plot", "blinn-figures", "-o", file.to_str().unwrap()],
        &["is not a folder", "fix:"],
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"keep");
    // An output base that is a folder is refused before the inputs are read.
    expect_error(
        &["plot", "slice", "--fit", fit, data, "-o", r],
        &["is a folder", "fix:"],
    );
}

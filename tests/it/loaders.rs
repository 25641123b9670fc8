//! Loaders against the real files, cross-format identity, round trips, policies.

use crate::common::{root, write};
use brdfit::data::{
    self, ChannelSelect, Dataset, Format, LoadOptions, NegativePolicy, Quantity, merl,
};
use brdfit::model::{Geometry, Model};
use std::path::Path;

fn load(p: &Path) -> Dataset {
    data::load(p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn load_with(p: &Path, negative: NegativePolicy) -> Result<Dataset, data::DataError> {
    data::load(
        p,
        &LoadOptions {
            format: None,
            negative,
        },
    )
}

#[test]
fn every_bundled_file_loads() {
    let cases: [(&str, usize, usize); 7] = [
        ("data/cayman.astm", 1439, 31),
        ("tests/data/cayman.brdf", 1439, 31),
        ("data/merl-aluminium.csv", 16512, 3),
        ("data/merl-alumina-oxide.csv", 16512, 3),
        ("data/blinn-mgo.csv", 10000, 1),
        ("data/blinn-aluminium.csv", 10000, 1),
        ("tests/data/vch_golden_yellow_rgb.csv", 18576, 3),
    ];
    for (f, n, c) in cases {
        let ds = load(&root().join(f));
        assert_eq!((ds.len(), ds.channels.len()), (n, c), "{f}");
        assert_eq!(ds.quantity, Quantity::Brdf);
        assert!(
            ds.theta_i
                .iter()
                .all(|t| (0.0..=std::f64::consts::FRAC_PI_2).contains(t))
        );
    }
}

#[test]
fn cornell_text_and_astm_give_identical_samples() {
    let a = load(&root().join("data/cayman.astm"));
    let b = load(&root().join("tests/data/cayman.brdf"));
    assert_eq!(a.theta_i, b.theta_i);
    assert_eq!(a.phi_i, b.phi_i);
    assert_eq!(a.theta_o, b.theta_o);
    assert_eq!(a.phi_o, b.phi_o);
    assert_eq!(a.channels, b.channels);
    // Spot values read off the file by eye: first row, 400 nm and 700 nm.
    assert_eq!(a.theta_i[0], 0.872665);
    assert_eq!(a.channels[0].values[0], 0.000874);
    // Peak f_r of cayman (data README): 646 at θi = 80°, mirror direction.
    let peak = a
        .channels
        .iter()
        .flat_map(|c| &c.values)
        .cloned()
        .fold(0.0, f64::max);
    assert!((peak - 646.0).abs() < 1.0, "peak {peak}");
}

fn assert_same(a: &Dataset, b: &Dataset, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: sample count");
    for (x, y) in [
        (&a.theta_i, &b.theta_i),
        (&a.phi_i, &b.phi_i),
        (&a.theta_o, &b.theta_o),
        (&a.phi_o, &b.phi_o),
    ] {
        for (u, v) in x.iter().zip(y) {
            assert!((u - v).abs() <= 1e-12, "{what}: angle {u} vs {v}");
        }
    }
    assert_eq!(a.quantity, b.quantity);
    assert_eq!(a.channels.len(), b.channels.len());
    for (c, d) in a.channels.iter().zip(&b.channels) {
        assert_eq!(c.name, d.name, "{what}");
        assert_eq!(c.wavelength_nm, d.wavelength_nm, "{what}");
        for (u, v) in c.values.iter().zip(&d.values) {
            assert!(u == v || (u.is_nan() && v.is_nan()), "{what}: {u} vs {v}");
        }
    }
}

#[test]
fn every_format_round_trips_through_csv() {
    // A whole MERL table as CSV is 147 MB, above the 64 MiB default data limit.
    brdfit::support::input::set_max_input_bytes(Some(256 << 20));
    let dir = tempfile::tempdir().unwrap();
    let merl_file = dir.path().join("mgo.binary");
    write_model_merl(&Model::blinn_mgo(), &merl_file);
    for f in [
        root().join("data/cayman.astm"),
        root().join("tests/data/cayman.brdf"),
        root().join("data/merl-aluminium.csv"),
        root().join("tests/data/vch_golden_yellow_rgb.csv"),
        merl_file.clone(),
    ] {
        let a = load(&f);
        let out = dir.path().join("rt.csv");
        data::write_csv(&a, &out).unwrap();
        let b = load(&out);
        assert_same(&a, &b, &f.display().to_string());
    }
}

/// A MERL table of a model, tabulated at the cell centres, through the writer.
fn write_model_merl(m: &Model, path: &Path) -> Dataset {
    let mut ds = Dataset::new(
        Quantity::Brdf,
        vec![("r".into(), None), ("g".into(), None), ("b".into(), None)],
    );
    for cell in 0..merl::CELLS {
        let a = merl::cell_center(cell);
        if a[0] < std::f64::consts::FRAC_PI_2 && a[2] < std::f64::consts::FRAC_PI_2 {
            let f = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
            ds.push(a, &[f, 0.5 * f, 0.25 * f]);
        }
    }
    merl::write_merl(&ds, path).unwrap();
    ds
}

#[test]
fn merl_round_trips_through_its_writer() {
    // A whole MERL table as CSV is 147 MB, above the 64 MiB default data limit.
    brdfit::support::input::set_max_input_bytes(Some(256 << 20));
    let dir = tempfile::tempdir().unwrap();
    let p1 = dir.path().join("a.binary");
    let p2 = dir.path().join("b.binary");
    let orig = write_model_merl(&Model::blinn_mgo(), &p1);
    let bytes = std::fs::read(&p1).unwrap();
    assert_eq!(bytes.len(), 12 + 3 * 8 * merl::CELLS);
    assert_eq!(&bytes[..12], &[90, 0, 0, 0, 90, 0, 0, 0, 180, 0, 0, 0]);
    let a = load(&p1);
    assert_eq!(a.len(), orig.len());
    for k in 0..a.len() {
        let f = Model::blinn_mgo().brdf(&Geometry::from_angles(
            a.theta_i[k],
            a.phi_i[k],
            a.theta_o[k],
            a.phi_o[k],
        ));
        for (c, s) in [1.0, 0.5, 0.25].iter().enumerate() {
            let v = a.channels[c].values[k];
            assert!(
                (v - s * f).abs() <= 1e-12 * (1.0 + f),
                "cell {k} ch {c}: {v} vs {}",
                s * f
            );
        }
    }
    // Stored value = f_r / scale: the green plane of a cell holding f_r = 1.15/1500 is 1.0.
    data::write_csv(&a, &dir.path().join("a.csv")).unwrap();
    let c = load(&dir.path().join("a.csv"));
    merl::write_merl(&c, &p2).unwrap();
    let b2 = std::fs::read(&p2).unwrap();
    let max_rel = bytes[12..]
        .chunks(8)
        .zip(b2[12..].chunks(8))
        .map(|(x, y)| {
            let (x, y) = (
                f64::from_le_bytes(x.try_into().unwrap()),
                f64::from_le_bytes(y.try_into().unwrap()),
            );
            (x - y).abs() / (1.0 + x.abs())
        })
        .fold(0.0, f64::max);
    assert!(
        max_rel < 1e-12,
        "MERL -> CSV -> MERL changed a cell by {max_rel}"
    );
}

#[test]
fn merl_scale_is_applied_on_read() {
    // One cell, hand-built: raw value 1500 in every plane -> f_r = 1, 1.15, 1.66.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("one.binary");
    let cell = merl::cell_index([0.5, 0.0, 0.5, std::f64::consts::PI]);
    let mut bytes = Vec::new();
    for d in [90i32, 90, 180] {
        bytes.extend(d.to_le_bytes());
    }
    for _ in 0..3 {
        for i in 0..merl::CELLS {
            bytes.extend((if i == cell { 1500.0f64 } else { -1.0 }).to_le_bytes());
        }
    }
    std::fs::write(&p, &bytes).unwrap();
    let ds = load(&p);
    assert_eq!(ds.len(), 1);
    let v: Vec<f64> = ds.channels.iter().map(|c| c.values[0]).collect();
    assert!(
        (v[0] - 1.0).abs() < 1e-12 && (v[1] - 1.15).abs() < 1e-12 && (v[2] - 1.66).abs() < 1e-12
    );
    assert_eq!(ds.negatives, 3 * (merl::CELLS - 1));
    // The sample sits in the mirror configuration's cell: θi = θo.
    assert!((ds.theta_i[0] - ds.theta_o[0]).abs() < 0.03);
}

#[test]
fn negative_policies() {
    let p = root().join("tests/data/vch_golden_yellow_rgb.csv");
    let m = load_with(&p, NegativePolicy::Mask).unwrap();
    assert_eq!((m.negatives, m.missing()), (417, 417));
    let c = load_with(&p, NegativePolicy::Clamp).unwrap();
    assert_eq!((c.negatives, c.missing()), (417, 0));
    assert!(
        c.channels
            .iter()
            .all(|ch| ch.values.iter().all(|v| *v >= 0.0))
    );
    let e = load_with(&p, NegativePolicy::Error).unwrap_err();
    assert!(
        e.line.is_some()
            && e.message.contains("negative")
            && e.fix.contains("mask")
            && e.setting == Some(brdfit::support::setting::Setting::NegativePolicy),
        "{e}"
    );
    // The first negative is on line 4 of the file (first data row, blue -0.354828).
    assert_eq!(e.line, Some(4));
}

#[test]
fn quantities_are_converted_to_brdf() {
    let dir = tempfile::tempdir().unwrap();
    let pi = std::f64::consts::PI;
    let c60 = 60f64.to_radians().cos();
    let body = format!(
        "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,rfactor\n60,0,10,0,{}\n",
        0.8 * pi
    );
    let d = load(&write(dir.path(), "r.csv", body.as_bytes()));
    assert!((d.into_brdf().channels[0].values[0] - 0.8).abs() < 1e-15);
    let body = format!(
        "theta_i_rad,phi_i_deg,theta_o_deg,phi_o_deg,brdf_cos\n{},0,10,0,{}\n",
        60f64.to_radians(),
        0.8 * c60
    );
    let d = load(&write(dir.path(), "c.csv", body.as_bytes()));
    assert!((d.brdf_values(0)[0] - 0.8).abs() < 1e-12);
}

#[test]
fn crlf_and_bom_are_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let plain = "# c\ntheta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf,weight\n10,0,20,180,0.5,1\n30,0,40,0,0.25,2\n";
    let crlf = format!("\u{feff}{}", plain.replace('\n', "\r\n"));
    let a = load(&write(dir.path(), "a.csv", plain.as_bytes()));
    let b = load(&write(dir.path(), "b.csv", crlf.as_bytes()));
    assert_same(&a, &b, "crlf+bom");
    assert_eq!(b.weights, Some(vec![1.0, 2.0]));
    // ASTM with CRLF and BOM.
    let astm = std::fs::read_to_string(root().join("data/cayman.astm")).unwrap();
    let c = load(&write(
        dir.path(),
        "c.astm",
        format!("\u{feff}{}", astm.replace('\n', "\r\n")).as_bytes(),
    ));
    assert_same(&load(&root().join("data/cayman.astm")), &c, "astm crlf");
}

#[test]
fn padded_fields_read_as_plain_ones() {
    // Spaces and tabs around header names and fields are not part of them; a padded empty
    // value field is a missing value, a padded empty angle is an error naming its line.
    let dir = tempfile::tempdir().unwrap();
    let plain = "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf_r,brdf_g,weight\n10,0,20,180,0.5,,1\n30,0,40,0,0.25,0.125,2\n";
    let padded = " theta_i_deg ,\tphi_i_deg,theta_o_deg , phi_o_deg,brdf_r ,  brdf_g,weight \n 10 ,0,\t20,180 , 0.5,  ,1\n30,0 ,40,0,0.25 ,0.125, 2\n";
    let a = load(&write(dir.path(), "a.csv", plain.as_bytes()));
    let b = load(&write(dir.path(), "b.csv", padded.as_bytes()));
    assert_same(&a, &b, "padded");
    assert!(b.channels[1].values[0].is_nan());
    assert_eq!(b.weights, Some(vec![1.0, 2.0]));
    let bad =
        "theta_i_deg, phi_i_deg ,theta_o_deg,phi_o_deg,brdf\n10,0,20,180,0.5\n30,  ,40,0,0.25\n";
    let e = load_with(
        &write(dir.path(), "c.csv", bad.as_bytes()),
        NegativePolicy::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("c.csv:3: column phi_i_deg: empty angle"), "{e}");
}

#[test]
fn spectral_reduction() {
    let ds = load(&root().join("data/cayman.astm"));
    let s550 = ds.select(&ChannelSelect::parse("550nm")).unwrap();
    assert_eq!(s550.channels[0].values, ds.channels[15].values);
    let s555 = ds.select(&ChannelSelect::Wavelength(555.0)).unwrap();
    let k = 100;
    let mid = 0.5 * (ds.channels[15].values[k] + ds.channels[16].values[k]);
    assert!((s555.channels[0].values[k] - mid).abs() < 1e-15);
    // CIE Y of a flat spectrum is the flat value; of the 550-nm-only spectrum it is ȳ(550)/Σȳ.
    let mut flat = ds.clone();
    for c in &mut flat.channels {
        c.values.iter_mut().for_each(|v| *v = 0.7);
    }
    let y = flat.select(&ChannelSelect::CieY).unwrap();
    assert!(y.channels[0].values.iter().all(|v| (v - 0.7).abs() < 1e-12));
    // CIE: Σȳ(λ)Δλ over 360–830 nm is 106.857 (1 nm steps); at 10 nm steps the sum is 10.6857.
    let ysum: f64 = (36..=83).map(|i| data::cie_ybar(10.0 * i as f64)).sum();
    assert!(
        (ysum - 10.6857).abs() < 1e-3,
        "Σȳ 360–830 nm at 10 nm = {ysum}"
    );
    // ȳ(555 nm) = 1.0000 in the 1-nm table; linear interpolation of the 10-nm table gives 0.99497.
    assert!((data::cie_ybar(555.0) - 1.0).abs() < 0.006 && data::cie_ybar(550.0) == 0.9949501);
    assert!(ds.select(&ChannelSelect::parse("g")).is_err());
    let rgb = load(&root().join("data/merl-aluminium.csv"));
    assert!(rgb.select(&ChannelSelect::CieY).is_err());
    assert_eq!(
        rgb.select(&ChannelSelect::parse("g")).unwrap().channels[0].values,
        rgb.channels[1].values
    );
}

#[test]
fn format_detection_by_content() {
    let dir = tempfile::tempdir().unwrap();
    let astm = std::fs::read(root().join("data/cayman.astm")).unwrap();
    let p = write(dir.path(), "cayman.txt", &astm);
    assert_eq!(load(&p).meta.format, "astm");
    let brdf = std::fs::read(root().join("tests/data/cayman.brdf")).unwrap();
    let p = write(dir.path(), "cayman.dat", &brdf);
    assert_eq!(load(&p).meta.format, "cornell");
    let csv = std::fs::read(root().join("data/blinn-mgo.csv")).unwrap();
    let p = write(dir.path(), "mgo.txt", &csv);
    assert_eq!(load(&p).meta.format, "csv");
    // --format overrides
    let d = data::load(
        &p,
        &LoadOptions {
            format: Some(Format::Csv),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(d.len(), 10000);
}

#[test]
fn inputs_are_never_modified() {
    let files = [
        "data/cayman.astm",
        "data/blinn-mgo.csv",
        "tests/data/cayman.brdf",
    ];
    let before: Vec<Vec<u8>> = files
        .iter()
        .map(|f| std::fs::read(root().join(f)).unwrap())
        .collect();
    for f in files {
        let ds = load(&root().join(f));
        let dir = tempfile::tempdir().unwrap();
        data::write_csv(&ds, &dir.path().join("x.csv")).unwrap();
    }
    let after: Vec<Vec<u8>> = files
        .iter()
        .map(|f| std::fs::read(root().join(f)).unwrap())
        .collect();
    assert!(before == after);
}

/// Grid angles stored in radians are written as the degrees they came from (`30`, `255`), not
/// as the binary rounding of the radian value (`29.999999999999996`).
#[test]
fn csv_writes_grid_angles_as_their_degrees() {
    let mut ds = Dataset::new(Quantity::Brdf, vec![("".into(), None)]);
    for (ti, po) in [(30.0f64, 255.0f64), (70.0, 15.0), (10.0, 345.0)] {
        ds.push(
            [ti.to_radians(), 0.0, ti.to_radians(), po.to_radians()],
            &[0.5],
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("grid.csv");
    data::write_csv(&ds, &out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    for line in ["30,0,30,255,0.5", "70,0,70,15,0.5", "10,0,10,345,0.5"] {
        assert!(text.lines().any(|l| l == line), "{line} not in\n{text}");
    }
}

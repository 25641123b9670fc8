//! Plots: the data behind each chart (Blinn's Figures 5–6 on the computed curves, the in-plane
//! selection, curve maxima, albedo), file validity and byte-for-byte determinism.

use brdfit::data::{Dataset, Quantity};
use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::plot::{self, LobeQuantity};

#[test]
fn blinn_figures_5_and_6_hold_on_the_curves() {
    let (phong, ts) = plot::blinn_figure_models();
    // Equal half-angle β: both distributions fall to ½ at the same angle.
    let beta = (0.5f64).powf(1.0 / phong.p[0]).acos();
    assert!((Distribution::D3.eval(beta.cos(), ts.p[1]) - 0.5).abs() < 1e-12);
    let peak =
        |m: &Model, t: f64| plot::curve_max(&plot::lobe_curve(m, t, LobeQuantity::Intensity));
    let diffuse = |t: f64| 0.333 * f64::to_radians(t).cos();
    // 30°: nearly identical — peaks within 10 % of each other, both at the mirror direction.
    let (p30, t30) = (peak(&phong, 30.0), peak(&ts, 30.0));
    assert!(
        (t30.1 / p30.1 - 1.0).abs() < 0.10,
        "30°: TS {} vs Phong {}",
        t30.1,
        p30.1
    );
    assert!(
        (p30.0 + 30.0).abs() <= 0.5 && (t30.0 + 30.0).abs() <= 3.0,
        "30°: peaks at {} and {}",
        p30.0,
        t30.0
    );
    // 70°: the Torrance–Sparrow bump is much larger and off-specular (beyond the mirror direction).
    let (p70, t70) = (peak(&phong, 70.0), peak(&ts, 70.0));
    let (bp, bt) = (p70.1 - diffuse(70.0), t70.1 - diffuse(70.0));
    assert!(bt > 5.0 * bp, "70°: TS bump {bt} vs Phong bump {bp}");
    assert!(
        (p70.0 + 70.0).abs() <= 0.5,
        "Phong peaks at the mirror direction: {}",
        p70.0
    );
    assert!(
        t70.0 < -75.0,
        "TS peak is off-specular, toward grazing: {}",
        t70.0
    );
}

#[test]
fn curve_maximum_of_blinn_phong_is_pd_cos_plus_ps_at_the_mirror() {
    let m = Model::new(ModelKind::BlinnPhong, Distribution::D3, &[80.0, 0.4, 0.5]).unwrap();
    for t in [10.0, 45.0, 60.0] {
        let (at, v) = plot::curve_max(&plot::lobe_curve(&m, t, LobeQuantity::Intensity));
        assert_eq!(at, -t);
        assert!((v - (0.5 * f64::to_radians(t).cos() + 0.4)).abs() < 1e-12);
        // As f_r: (pd/π + ps/(π cosθi)) at the mirror.
        let (_, f) = plot::curve_max(&plot::lobe_curve(&m, t, LobeQuantity::Brdf));
        let c = f64::to_radians(t).cos();
        assert!(
            (f - (0.5 / std::f64::consts::PI + 0.4 / (std::f64::consts::PI * c))).abs() < 1e-12
        );
    }
}

#[test]
fn in_plane_selection() {
    let mut ds = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
    let d = f64::to_radians;
    // θi = 30°: mirror side (φo = 180°), light side (φo = 0° and 360°), out of plane (90°),
    // within tolerance (180.8°), another θi (40°), and φi = 20° with φo = 200° (in plane).
    ds.push([d(30.0), 0.0, d(20.0), d(180.0)], &[1.0]);
    ds.push([d(30.0), 0.0, d(25.0), 0.0], &[2.0]);
    ds.push([d(30.0), 0.0, d(26.0), d(360.0)], &[3.0]);
    ds.push([d(30.0), 0.0, d(20.0), d(90.0)], &[4.0]);
    ds.push([d(30.0), 0.0, d(45.0), d(180.8)], &[5.0]);
    ds.push([d(40.0), 0.0, d(20.0), d(180.0)], &[6.0]);
    ds.push([d(30.0), d(20.0), d(50.0), d(200.0)], &[7.0]);
    let s = plot::in_plane_samples(&ds, 0, 30.0, 1.0, LobeQuantity::Brdf);
    let got: Vec<(i64, i64)> = s.iter().map(|p| (p.0.round() as i64, p.1 as i64)).collect();
    assert_eq!(got, vec![(-50, 7), (-45, 5), (-20, 1), (25, 2), (26, 3)]);
    // Intensity is π f cosθi.
    let s = plot::in_plane_samples(&ds, 0, 30.0, 1.0, LobeQuantity::Intensity);
    assert!((s[2].1 - std::f64::consts::PI * d(30.0).cos()).abs() < 1e-12);
}

#[test]
fn albedo_flags_energy_creation() {
    let mgo = Model::blinn_mgo();
    for t in [0.0, 30.0, 60.0] {
        let a = plot::albedo(&mgo, t);
        assert!(a > 0.333 && a < 1.0, "MgO albedo at {t}° = {a}");
    }
    let hot = Model::new(ModelKind::Phong, Distribution::D3, &[5.0, 3.0, 0.5]).unwrap();
    let (_, pts) = plot::albedo_chart("hot", &hot);
    assert!(pts.iter().any(|p| p.1 > 1.0));
}

#[test]
fn files_are_valid_and_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let chart = plot::blinn_figure(70.0, 6);
    let (svg, png) = plot::save(&chart, &dir.path().join("a")).unwrap();
    let (svg2, png2) = plot::save(&chart, &dir.path().join("b")).unwrap();
    assert_eq!(std::fs::read(&svg).unwrap(), std::fs::read(&svg2).unwrap());
    assert_eq!(std::fs::read(&png).unwrap(), std::fs::read(&png2).unwrap());
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("Figure 6") && text.contains("Torrance"));
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), chart.size_px());
    // The PNG is not blank: the curve colour appears.
    let rgb = img.to_rgb8();
    assert!(rgb.pixels().any(|p| p.0 == [0, 90, 181]));
    let ds = brdfit::data::load(
        std::path::Path::new("data/blinn-mgo.csv"),
        &Default::default(),
    )
    .unwrap();
    let (d, f) = plot::slice_grids(&ds, 0, &Model::blinn_mgo(), 30);
    assert_eq!((d.len(), f.len()), (900, 900));
    // Data and the true model agree where both exist (1 % noise → log10 within 0.05).
    let both: Vec<(f64, f64)> = d
        .iter()
        .zip(&f)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    assert!(both.len() > 300);
    let med = {
        let mut e: Vec<f64> = both.iter().map(|(a, b)| (a - b).abs()).collect();
        e.sort_by(f64::total_cmp);
        e[e.len() / 2]
    };
    assert!(med < 0.05, "median |Δ log10 f| = {med}");
}

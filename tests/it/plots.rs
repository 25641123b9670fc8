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
    let s = plot::in_plane_samples(
        &ds,
        0,
        30.0,
        plot::InPlane {
            theta_i: 0.5,
            azimuth: 1.0,
        },
        LobeQuantity::Brdf,
    );
    let got: Vec<(i64, i64)> = s.iter().map(|p| (p.0.round() as i64, p.1 as i64)).collect();
    assert_eq!(got, vec![(-50, 7), (-45, 5), (-20, 1), (25, 2), (26, 3)]);
    // Intensity is π f cosθi.
    let s = plot::in_plane_samples(
        &ds,
        0,
        30.0,
        plot::InPlane {
            theta_i: 0.5,
            azimuth: 1.0,
        },
        LobeQuantity::Intensity,
    );
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
    let (chart, pts) = plot::albedo_chart("hot", &hot, &[]);
    assert!(pts.iter().any(|p| p.1 > 1.0));
    // Near or above 1 the energy limit is drawn; for MgO (0.35–0.43) the axis follows the
    // curve alone, so it does not lie on the bottom edge of an axis running to 1.
    assert!(chart.hline.is_some());
    let (chart, pts) = plot::albedo_chart("mgo", &mgo, &[]);
    assert!(chart.hline.is_none() && chart.title.contains("far above"));
    assert!(pts.iter().all(|p| p.1 < 0.5));
}

/// Tick labels: no trailing zeros, no "-0", enough digits for small steps.
#[test]
fn tick_labels() {
    assert_eq!(plot::tick(10.0), "10");
    assert_eq!(plot::tick(0.25), "0.25");
    assert_eq!(plot::tick(-0.0), "0");
    assert_eq!(plot::tick(-1e-17), "0");
    assert_eq!(plot::tick(0.0251188), "0.0251188");
    assert_eq!(plot::tick(2.0), "2");
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

/// PNG text: in "1.0" drawn at 13 px (the size of tick labels), the full stop sits on the
/// digits' baseline and between the digits, on the bitmap brdfit draws its PNGs on
/// (`plot::bitmap_area`; plotters 0.3.7's own text drawing puts it up to 2 px high).
#[test]
fn png_text_full_stop_sits_on_the_baseline() {
    use plotters::prelude::*;
    brdfit::plot::register_font_once();
    for size in [11.0, 12.0, 13.0, 14.0, 16.0] {
        let (w, h) = (80u32, 40u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = plot::bitmap_area(&mut buf, (w, h));
            root.draw(&Text::new(
                "1.0",
                (10, 10),
                ("sans-serif", size).into_font(),
            ))
            .unwrap();
            root.present().unwrap();
        }
        let dark = |x: u32, y: u32| buf[((y * w + x) * 3) as usize] < 128;
        // Columns with ink, grouped into glyphs.
        let cols: Vec<u32> = (0..w).filter(|&x| (0..h).any(|y| dark(x, y))).collect();
        let mut glyphs: Vec<Vec<u32>> = Vec::new();
        for x in cols {
            match glyphs.last_mut() {
                Some(g) if *g.last().unwrap() + 1 == x => g.push(x),
                _ => glyphs.push(vec![x]),
            }
        }
        assert_eq!(glyphs.len(), 3, "size {size}: {glyphs:?}");
        let bottom = |g: &Vec<u32>| {
            g.iter()
                .flat_map(|&x| (0..h).filter(move |&y| dark(x, y)))
                .max()
                .unwrap()
        };
        let (one, dot, zero) = (bottom(&glyphs[0]), bottom(&glyphs[1]), bottom(&glyphs[2]));
        assert!(
            dot == one && dot == zero,
            "size {size}: bottoms 1 at {one}, . at {dot}, 0 at {zero}"
        );
    }
}

/// SVG text is converted to glyph outlines: no `<text>` is left, the string is kept as the
/// path's title, and the outline of "1.0" at 20 px has the font's proportions: the digit
/// reaches about 0.73 em above the baseline, the full stop no higher than 0.2 em.
#[test]
fn svg_text_becomes_paths() {
    let svg = r##"<svg><text x="10" y="50" font-size="20" fill="#000000">1.0</text></svg>"##;
    let out = plot::svg_text_to_paths(svg);
    assert!(!out.contains("<text"), "{out}");
    assert!(out.contains("<title>1.0</title>"));
    let d = out.split("d=\"").nth(1).unwrap().split('"').next().unwrap();
    // Each subpath ("M…") with its points.
    let subpaths: Vec<Vec<(f64, f64)>> = d
        .split('M')
        .filter(|s| !s.is_empty())
        .map(|s| {
            let nums: Vec<f64> = s
                .split(|c: char| c.is_ascii_alphabetic() || c == ' ')
                .filter_map(|t| t.parse().ok())
                .collect();
            nums.chunks(2).map(|p| (p[0], p[1])).collect()
        })
        .collect();
    let top = subpaths
        .iter()
        .flatten()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min);
    assert!((50.0 - top - 0.729 * 20.0).abs() < 0.6, "digit top {top}");
    // The full stop: the subpath whose points all lie within 0.2 em of the baseline.
    let dot = subpaths
        .iter()
        .filter(|s| s.iter().all(|p| p.1 >= 50.0 - 0.2 * 20.0 && p.1 <= 50.01))
        .count();
    assert_eq!(dot, 1, "{d}");
    // The real charts carry no <text> either.
    let dir = tempfile::tempdir().unwrap();
    let (svg, _) = plot::save(&plot::blinn_figure(30.0, 5), &dir.path().join("f")).unwrap();
    let text = std::fs::read_to_string(svg).unwrap();
    assert!(!text.contains("<text") && text.contains("<path"));
}

/// Binned quantiles by hand: each of 4 bins holds y = 1…10 (shifted by the bin), so its
/// nearest-rank 10 %, 50 % and 90 % are 1, 5 and 9 (plus the shift); a bin of 4 points is
/// left out.
#[test]
fn binned_quantiles_by_hand() {
    let mut xy = Vec::new();
    for bin in 0..4 {
        for y in 1..=10 {
            xy.push((
                bin as f64 * 10.0 + 0.5 + y as f64 * 0.1,
                y as f64 + 100.0 * bin as f64,
            ));
        }
    }
    xy.extend((0..4).map(|i| (45.0 + i as f64, 0.0)));
    let q = plot::binned_quantiles(&xy, 5);
    assert_eq!(q.len(), 4, "{q:?}");
    for (bin, b) in q.iter().enumerate() {
        let s = 100.0 * bin as f64;
        assert_eq!([b[1], b[2], b[3]], [1.0 + s, 5.0 + s, 9.0 + s], "{b:?}");
    }
}

/// The albedo estimated from the samples: exact for a constant BRDF (ρ = pd), close to the
/// model's integral for Blinn's MgO file (10,000 samples with 1 % noise), and absent where the
/// samples do not cover the hemisphere.
#[test]
fn measured_albedo_from_the_samples() {
    use brdfit::simulate::{Grid, simulate};
    let lambert = Model::new(ModelKind::Lambert, Distribution::D3, &[0.5]).unwrap();
    let ds = simulate(&lambert, &Grid::Hemisphere(40_000).directions(2), 0.0, 2);
    let est = plot::measured_albedo(&ds, 0);
    assert!(est.len() >= 12, "{est:?}");
    for (t, rho) in &est {
        assert!((rho - 0.5).abs() < 1e-12, "θi {t}: {rho}");
    }
    let ds = brdfit::data::load(
        std::path::Path::new("data/blinn-mgo.csv"),
        &brdfit::data::LoadOptions::default(),
    )
    .unwrap();
    let est = plot::measured_albedo(&ds, 0);
    assert!(est.len() >= 6, "{est:?}");
    let mgo = Model::blinn_mgo();
    for (t, rho) in est.iter().filter(|(t, _)| *t <= 60.0) {
        let truth = plot::albedo(&mgo, *t);
        assert!(
            (rho - truth).abs() < 0.05 * truth,
            "θi {t}: {rho} against {truth}"
        );
    }
    // MERL's 15° azimuth grid catches a highlight in one column of samples, which would stand
    // in for far more than the peak's area (estimates of 2.7 for aluminium and 2.5 for
    // alumina-oxide at θi = 80°, above the energy limit, before the checks): none.
    let merl = brdfit::data::load(
        std::path::Path::new("data/merl-aluminium.csv"),
        &brdfit::data::LoadOptions::default(),
    )
    .unwrap();
    assert!(plot::measured_albedo(&merl, 0).is_empty());
    let merl = brdfit::data::load(
        std::path::Path::new("data/merl-alumina-oxide.csv"),
        &brdfit::data::LoadOptions::default(),
    )
    .unwrap();
    for c in 0..3 {
        assert!(plot::measured_albedo(&merl, c).is_empty(), "channel {c}");
    }
    // The plane of incidence alone covers 2 of 8 azimuth sectors: no estimate.
    let plane = simulate(&mgo, &Grid::Plane(vec![30.0, 60.0]).directions(1), 0.0, 1);
    assert!(plot::measured_albedo(&plane, 0).is_empty());
}

/// Log-axis tick labels only at 1, 2 and 5 × 10^k, so that dense minor ticks do not run
/// into each other.
#[test]
fn log_tick_labels() {
    assert_eq!(plot::log_tick(0.001), "0.001");
    assert_eq!(plot::log_tick(0.002), "0.002");
    assert_eq!(plot::log_tick(0.005), "0.005");
    assert_eq!(plot::log_tick(20.0), "20");
    assert_eq!(plot::log_tick(0.003), "");
    assert_eq!(plot::log_tick(0.007), "");
    assert_eq!(plot::log_tick(0.0), "");
}

/// Builds a one-panel lobe chart whose largest value is `vmax`.
fn lobe_chart_with_max(vmax: f64, log: bool) -> plot::LobeChart {
    plot::LobeChart {
        title: String::new(),
        panels: vec![plot::LobePanel {
            title: String::new(),
            theta_i_deg: 30.0,
            series: vec![plot::LobeSeries {
                label: "curve".into(),
                points: vec![(-30.0, vmax), (0.0, 0.5 * vmax), (40.0, 0.0)],
                markers: false,
            }],
        }],
        quantity: LobeQuantity::Intensity,
        log,
        shared_scale: false,
    }
}

/// On a log radius the centre is the floor, 4 decades below the outer circle, and its tick
/// reads that value, not "0": worked by hand, 60.8 × 10⁻⁴ = 0.00608 at the centre,
/// 60.8 × 10⁻² = 0.608 at half the radius (either side), 60.8 at the rim; 0.05 × 10⁻⁴ = 5e-6.
/// On a linear radius the centre is 0 and half the radius 30.4.
#[test]
fn log_lobe_centre_is_labelled_with_the_floor() {
    let chart = lobe_chart_with_max(60.8, true);
    let vmax = chart.vmax_of(&chart.panels[0]);
    assert_eq!(vmax, 60.8);
    assert_eq!(chart.tick_label(0.0, vmax), "0.00608");
    assert!((chart.floor(vmax) - 0.00608).abs() < 1e-15);
    assert_eq!(chart.tick_label(0.5, vmax), "0.608");
    assert_eq!(chart.tick_label(-0.5, vmax), "0.608");
    assert_eq!(chart.tick_label(1.0, vmax), "60.8");
    // A value at the floor is drawn at the centre, one decade up at a quarter of the radius.
    assert!(chart.radius(0.00608, vmax).abs() < 1e-12);
    assert!((chart.radius(0.0608, vmax) - 0.25).abs() < 1e-12);
    let small = lobe_chart_with_max(0.05, true);
    assert_eq!(small.tick_label(0.0, 0.05), "5e-6");
    let linear = lobe_chart_with_max(60.8, false);
    assert_eq!(linear.tick_label(0.0, 60.8), "0");
    assert_eq!(linear.tick_label(0.5, 60.8), "30.4");
}

/// Blinn's Figure 6 draws both panels on one radial scale (the Torrance–Sparrow lobe's
/// maximum, several times Phong's), so the brighter lobe is the bigger one; each panel's title
/// names the model as its legend does.
#[test]
fn blinn_figure_panels_share_one_scale_and_name_their_model() {
    let chart = plot::blinn_figure(70.0, 6);
    assert!(chart.shared_scale);
    let (phong, ts) = (&chart.panels[0], &chart.panels[1]);
    let own = |p: &plot::LobePanel| plot::LobeChart::vmax(p);
    assert!(own(ts) > 3.0 * own(phong), "{} {}", own(ts), own(phong));
    assert_eq!(chart.vmax_of(phong), own(ts));
    assert_eq!(chart.vmax_of(ts), own(ts));
    for p in &chart.panels {
        let legend = p.series[0].label.split(' ').next().unwrap();
        assert!(p.title.contains(legend), "{} / {legend}", p.title);
    }
    assert!(chart.panels[0].title.contains("blinn-phong"));
}

/// Model curves are told apart by their stroke as well as their colour (the second is
/// dashed), and the in-plane tolerance is stated in the legend with the count drawn.
#[test]
fn lobe_curves_differ_in_stroke_and_the_legend_states_the_tolerance() {
    assert_eq!(plot::line_style(0).2, 0);
    assert!(plot::line_style(1).2 > 0 && plot::line_style(1) != plot::line_style(2));
    let mut ds = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
    let d = f64::to_radians;
    // θi 31° is within 2.5° of the 30° panel, 33° is not; azimuth 182° is within 2.5°.
    ds.push([d(31.0), 0.0, d(20.0), d(182.0)], &[1.0]);
    ds.push([d(33.0), 0.0, d(20.0), d(180.0)], &[1.0]);
    let m = Model::new(ModelKind::Lambert, Distribution::D3, &[0.5]).unwrap();
    let chart = plot::lobe_chart(
        "t",
        &[("lambert".into(), m)],
        Some((&ds, 0)),
        &[30.0],
        LobeQuantity::Intensity,
        false,
        plot::InPlane::both(2.5),
    );
    let measured = &chart.panels[0].series[1];
    assert_eq!(measured.points.len(), 1);
    assert_eq!(measured.label, "measured (1), θi ± 2.5°, azimuth ± 2.5°");
}

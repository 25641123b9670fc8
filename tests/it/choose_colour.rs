//! `choose` on RGB data renders the reference in colour: each channel's measurement on its
//! own table, joined per pixel. Checked on a synthetic material whose channels differ (known
//! truth): Lambertian channels of pd 0.6, 0.3 and 0.1 give every lit pixel of the test object
//! the ratios r/g = 2 and b/g = 1/3 of the channels' model values, whatever the geometry.

use brdfit::data::{Dataset, Quantity};
use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::simulate::{Grid, simulate};

/// An RGB data set of three models on the same directions.
fn rgb(models: [Model; 3]) -> Dataset {
    let dirs = Grid::parse("hemisphere:4000").unwrap().directions(3);
    let chans: Vec<Dataset> = models.iter().map(|m| simulate(m, &dirs, 0.0, 1)).collect();
    let mut ds = Dataset::new(
        Quantity::Brdf,
        ["r", "g", "b"]
            .iter()
            .map(|n| (n.to_string(), None))
            .collect(),
    );
    for k in 0..chans[0].len() {
        let v: Vec<f64> = chans.iter().map(|c| c.channels[0].values[k]).collect();
        ds.push(chans[0].angles(k), &v);
    }
    ds
}

#[test]
fn colour_reference_keeps_the_channels_ratios() {
    let lambert = |pd: f64| Model::new(ModelKind::Lambert, Distribution::D3, &[pd]).unwrap();
    let ds = rgb([lambert(0.6), lambert(0.3), lambert(0.1)]);
    assert_eq!(brdfit::choose::rgb_channels(&ds), Some([0, 1, 2]));
    for case in brdfit::choose::fig7_cases(48) {
        let img = brdfit::choose::colour_reference(&ds, &case).unwrap();
        let mask = crate::common::sphere::mask(&case.scene);
        let lit: Vec<[f32; 3]> = img
            .pixels
            .iter()
            .zip(&mask)
            .filter(|(p, m)| **m && p[1] > 1e-3)
            .map(|(p, _)| *p)
            .collect();
        assert!(lit.len() > 20, "{}: {} lit pixels", case.name, lit.len());
        for p in &lit {
            let (rg, bg) = (p[0] / p[1], p[2] / p[1]);
            assert!((rg - 2.0).abs() < 0.02, "{}: r/g {rg} of {p:?}", case.name);
            assert!(
                (bg - 1.0 / 3.0).abs() < 0.01,
                "{}: b/g {bg} of {p:?}",
                case.name
            );
        }
    }
    // One channel (or not r, g, b): no colour image.
    let one = ds.select(&brdfit::data::ChannelSelect::Index(1)).unwrap();
    assert!(brdfit::choose::colour_reference(&one, &brdfit::choose::fig7_cases(16)[0]).is_none());
}

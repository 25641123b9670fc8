//! Exports: tabulated formats load back and agree with the model; text formats carry the
//! fitted values with the documented mapping.

use brdfit::data::{self, LoadOptions};
use brdfit::export;
use brdfit::model::{Distribution, Geometry, MaterialKind, Model, ModelKind};

#[test]
fn merl_and_csv_exports_load_back_equal_to_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let m = Model::blinn_mgo();
    let p = dir.path().join("mgo.binary");
    data::merl::write_merl(&export::merl_dataset(&m), &p).unwrap();
    let ds = data::load(&p, &LoadOptions::default()).unwrap();
    assert!(ds.len() > 500_000);
    for k in (0..ds.len()).step_by(101) {
        let a = ds.angles(k);
        let f = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        for c in 0..3 {
            assert!((ds.channels[c].values[k] - f).abs() <= 1e-12 * (1.0 + f));
        }
    }
    let p = dir.path().join("mgo.csv");
    data::write_csv(&export::grid_dataset(&m), &p).unwrap();
    let ds = data::load(&p, &LoadOptions::default()).unwrap();
    assert_eq!(ds.len(), 18 * 18 * 24);
    for k in (0..ds.len()).step_by(37) {
        let a = ds.angles(k);
        let f = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        assert!((ds.channels[0].values[k] - f).abs() <= 1e-9 * (1.0 + f));
    }
}

#[test]
fn text_exports_carry_the_mapping() {
    let mgo = Model::blinn_mgo();
    let x = export::mitsuba(&mgo, "mgo");
    assert!(
        x.contains("roughplastic")
            && x.contains("\"alpha\" value=\"0.35\"")
            && x.contains("\"int_ior\" value=\"1.8\"")
    );
    assert!(x.contains("diffuse_reflectance\" value=\"0.333, 0.333, 0.333\""));
    assert_eq!(x.matches("<bsdf").count(), x.matches("</bsdf>").count());
    assert!(x.contains("Smith masking"));
    let al = Model::blinn_aluminium();
    assert!(export::mitsuba(&al, "al").contains("roughconductor"));
    assert!(export::pbrt(&al).contains("\"conductor\" \"float roughness\" [ 0.5 ]"));
    assert!(
        export::pbrt(&mgo).contains("coateddiffuse")
            && export::pbrt(&mgo).contains("\"float eta\" [ 1.8 ]")
    );
    let b = export::brdf_explorer(&mgo);
    assert!(
        b.starts_with("analytic")
            && b.contains("float c3 0.001 1 0.35")
            && b.contains("float n 1 20 1.8")
    );
    assert!(b.contains("::begin shader") && b.contains("::end shader"));
    // Beckmann-matched α of a cosine power: √(2/(c1+2)).
    let bp = Model::new(ModelKind::BlinnPhong, Distribution::D3, &[98.0, 0.5, 0.5]).unwrap();
    // The mapping is a serde value (tagged by material type), read back equal.
    let mat = bp.material();
    let text = serde_json::to_string(&mat).unwrap();
    assert!(text.contains("\"type\":\"plastic\""), "{text}");
    assert_eq!(
        serde_json::from_str::<brdfit::model::Material>(&text).unwrap(),
        mat
    );
    match bp.material().kind {
        MaterialKind::Plastic { alpha, .. } => {
            assert!((alpha - (2.0f64 / 100.0).sqrt()).abs() < 1e-15)
        }
        other => panic!("{other:?}"),
    }
}

//! A metal's Fresnel factor: with n = 1e7 the Torrance–Sparrow F is 1 to 4e-7 at every angle
//! (F is smallest at normal incidence, ((n − 1)/(n + 1))² = 1 − 4/n + …; Blinn 1977), so the data
//! fix the lobe and leave n open above some value. The fit must say so and stay usable.

use brdfit::fit::{self, FitOptions};
use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::simulate::{Grid, simulate};

#[test]
fn a_metal_index_is_reported_not_refused() {
    // Truth n 1e7, c3 0.3, ps 0.5, pd 0.1 (D3), no noise (with 0.2 % the
    // fit ends near n = 3e4, a value the data then determine); seeds 5 and 9.
    let truth = [1e7, 0.3, 0.5, 0.1];
    let m = Model::new(ModelKind::TorranceSparrow, Distribution::D3, &truth).unwrap();
    for seed in [5, 9] {
        let ds = simulate(&m, &Grid::Hemisphere(4000).directions(seed), 0.0, seed);
        let f = fit::fit(&ds, &FitOptions::new(ModelKind::TorranceSparrow))
            .unwrap()
            .remove(0);
        assert!(f.usable(), "seed {seed}: {:?}", f.unusable);
        for (name, want) in [("c3", 0.3), ("ps", 0.5), ("pd", 0.1)] {
            let got = f.get(name).unwrap();
            assert!(
                (got - want).abs() <= 0.01 * want,
                "seed {seed} {name}: {got}"
            );
        }
        let n = f.get("n").unwrap();
        assert!(
            f.warnings
                .iter()
                .any(|w| w.starts_with("n is not determined: F ≈ 1 at every angle (a metal)")),
            "seed {seed}: n {n}, {:?}",
            f.warnings
        );
        let text = fit::format_fit(&f);
        assert!(!text.contains("NOT USABLE"), "{text}");
    }
}

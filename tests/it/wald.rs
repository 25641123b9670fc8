//! A standard error from JᵀJ that contradicts the profiled interval is said, not printed
//! silently beside it: ASTM acryl_blue (tests/data/acryl_blue.astm) at 500 nm under
//! Torrance–Sparrow D1, where n's standard error (about 10) beside a 95 % interval about
//! ±1.5 wide made two contradicting claims.

use crate::common::load;
use brdfit::data::ChannelSelect;
use brdfit::fit::{self, FitOptions};
use brdfit::model::{Distribution, ModelKind};

fn opts() -> FitOptions {
    let mut o = FitOptions::new(ModelKind::TorranceSparrow);
    o.dist = Distribution::D1;
    o
}

#[test]
fn a_standard_error_that_contradicts_the_interval_is_said() {
    let ds = load("tests/data/acryl_blue.astm")
        .select(&ChannelSelect::parse("500nm"))
        .unwrap();
    let f = fit::fit(&ds, &opts()).unwrap().remove(0);
    let n = f.get("n").unwrap();
    let k = f.params.iter().position(|p| p.0 == "n").unwrap();
    let se = f.stderr[k];
    let (_, lo, hi) = f.ranges.iter().find(|r| r.0 == "n").unwrap().clone();
    let dof = (f.samples_used - f.n_free) as f64;
    let t = fit::t_quantile(0.95, dof);
    // Which claim holds, by refits with n held (independent of both the profile and JᵀJ): the
    // cost limit of the 95 % interval is S (1 + t²/(m − p)) (Bates & Watts 1988, §6.1.2).
    let limit = f.cost * (1.0 + t * t / dof);
    let held = |v: f64| {
        let mut o = opts();
        o.profile = false;
        o.fix = vec![("n".into(), v)];
        fit::fit(&ds, &o).unwrap()[0].cost
    };
    let wald_hi = n + t * se;
    assert!(
        wald_hi > 2.0 * hi - n,
        "the case no longer contradicts: {n} ± {se}, [{lo}, {hi}]"
    );
    // The data refuse the Wald end, and halfway to it; they allow the profiled ends.
    assert!(held(wald_hi) > limit && held(0.5 * (hi + wald_hi)) > limit);
    assert!(held(lo + 0.01 * (n - lo)) <= limit && held(hi - 0.01 * (hi - n)) <= limit);
    // The warnings say so, and do not call n undetermined on the standard error's word.
    let said = f
        .warnings
        .iter()
        .find(|w| w.starts_with("n's standard error"))
        .unwrap_or_else(|| panic!("{:?}", f.warnings));
    assert!(
        said.contains("contradicts its profiled interval") && said.contains("use the interval")
    );
    assert!(
        !f.warnings
            .iter()
            .any(|w| w.starts_with("n is not determined")),
        "{:?}",
        f.warnings
    );
    // The table flags the standard error and says what the flag means.
    let text = fit::format_fit(&f);
    let row = text
        .lines()
        .find(|l| l.trim_start().starts_with("n "))
        .unwrap();
    assert!(row.trim_end().ends_with('!'), "{text}");
    assert!(
        text.contains("! the standard error contradicts the interval"),
        "{text}"
    );
    // A parameter whose two intervals agree (pd: ±5.1e-3 against about ±5.2e-3) is not flagged.
    let row = text
        .lines()
        .find(|l| l.trim_start().starts_with("pd "))
        .unwrap();
    assert!(!row.trim_end().ends_with('!'), "{text}");
}

//! The README's statements about the bundled data against what the program prints today: the
//! table of `fit data/blinn-mgo.csv` (all but its time), the interval it quotes for
//! `data/blinn-aluminium.csv`, and the verdicts of `choose` it names (`report` prints the
//! same: its scene needs are `choose` on each file). Cheap cases only: the verdicts for
//! blinn-mgo and merl-alumina-oxide are checked by the tests that compute them (choose.rs),
//! cayman's here.

use crate::common::{load, root};
use brdfit::fit::{FitOptions, fit, format_fit, interval_text};
use brdfit::model::ModelKind;

/// The README's text.
fn readme() -> String {
    std::fs::read_to_string(root().join("README.md")).unwrap()
}

/// The README with every run of white space made one space (its sentences span lines).
fn readme_flat() -> String {
    readme().split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The verdict the README states for `choose` on bundled file `name` (e.g. `cayman`) in
/// `case` (`front` or `edge`): the model it names, or `undetermined`, from "`NAME`: front lit
/// `X`, edge lit `Y`".
pub(crate) fn readme_verdict(name: &str, case: &str) -> String {
    verdict_in(&readme_flat(), name, case)
}

/// The verdict `text` states for `name` in `case` (see [`readme_verdict`]).
fn verdict_in(text: &str, name: &str, case: &str) -> String {
    let key = format!("`{name}`: front lit `");
    let at = text
        .find(&key)
        .unwrap_or_else(|| panic!("the README states no verdict for {name}"));
    let rest = &text[at + key.len()..];
    let (front, rest) = rest.split_once('`').unwrap();
    let rest = rest.strip_prefix(", edge lit `").unwrap();
    let edge = rest.split('`').next().unwrap();
    match case {
        "front" => front.to_string(),
        "edge" => edge.to_string(),
        _ => panic!("no case {case}"),
    }
}

/// What `choose` answered for one case, as the README names it.
pub(crate) fn verdict_name(chosen: Option<String>) -> String {
    chosen.unwrap_or_else(|| "undetermined".into())
}

/// The shown time at the end of a fit's cost line (`… evaluations 8  0.009 s`) dropped: it
/// varies from run to run.
fn without_time(line: &str) -> String {
    match line.trim_end().strip_suffix(" s") {
        Some(head) if line.trim_start().starts_with("cost ") => head
            .trim_end()
            .rsplit_once(' ')
            .map_or(head, |(h, _)| h)
            .trim_end()
            .to_string(),
        _ => line.trim_end().to_string(),
    }
}

/// The README's example output of `fit data/blinn-mgo.csv` is what `fit` prints for it (the
/// command's defaults: Torrance–Sparrow D3, log loss, Levenberg–Marquardt), line for line but
/// for the time.
#[test]
fn fit_example_is_what_fit_prints() {
    let text = readme();
    let intro = text
        .find("`fit data/blinn-mgo.csv` on Blinn's")
        .expect("the README shows fit data/blinn-mgo.csv");
    let block = &text[intro..];
    let start = block.find("```text\n").unwrap() + "```text\n".len();
    let end = block[start..].find("```").unwrap();
    let shown: Vec<String> = block[start..start + end]
        .lines()
        .map(without_time)
        .collect();
    let ds = load("data/blinn-mgo.csv");
    let f = &fit(&ds, &FitOptions::new(ModelKind::TorranceSparrow)).unwrap()[0];
    let printed: Vec<String> = format_fit(f).lines().map(without_time).collect();
    assert_eq!(shown, printed);
}

/// The interval the README quotes for n on `data/blinn-aluminium.csv` is the one `fit` prints,
/// and, as it says, it misses the truth 200 (data/README.md).
#[test]
fn aluminium_interval_is_what_fit_prints() {
    let ds = load("data/blinn-aluminium.csv");
    let f = &fit(&ds, &FitOptions::new(ModelKind::TorranceSparrow)).unwrap()[0];
    let (_, lo, hi) = f.ranges.iter().find(|r| r.0 == "n").unwrap().clone();
    let quoted = format!(
        "n's interval {} misses the truth 200",
        interval_text(lo, hi)
    );
    assert!(readme_flat().contains(&quoted), "README lacks: {quoted}");
    assert!(!(lo..=hi).contains(&200.0), "[{lo}, {hi}]");
}

/// `choose data/cayman.astm` (CIE Y, as `report` judges it): the README's verdict per case.
#[test]
fn cayman_choices_are_the_readmes() {
    let r = crate::choose::choose_file("data/cayman.astm");
    for case in ["front", "edge"] {
        let (chosen, _) = crate::choose::chosen(&r, case);
        assert_eq!(
            verdict_name(chosen),
            readme_verdict("cayman", case),
            "cayman {case}"
        );
    }
}

/// Verdicts and times are read as written.
#[test]
fn verdicts_are_read() {
    let text = "As it prints: `a`: front lit `phong`, edge lit `undetermined`; `b`: front lit \
                `lambert`, edge lit `ggx-smith` (each)";
    assert_eq!(verdict_in(text, "a", "front"), "phong");
    assert_eq!(verdict_in(text, "a", "edge"), "undetermined");
    assert_eq!(verdict_in(text, "b", "edge"), "ggx-smith");
    assert_eq!(
        without_time("  cost 2e-3  rmse 6e-4  iterations 6  evaluations 8  0.009 s"),
        "  cost 2e-3  rmse 6e-4  iterations 6  evaluations 8"
    );
}

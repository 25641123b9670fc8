//! What each scene needs: `brdfit choose` on Blinn's Figure 7 cases, its sheets, charts and
//! tables in the report.

use super::doc::{Doc, md_table_to_html};
use super::progress::step_at;
use super::{CHOOSE_RES, DataSet};
use crate::fit::{self, FitResult};
use anyhow::Result;

/// What each scene needs: `brdfit choose` on Blinn's Figure 7 cases at 512², its sheet and
/// chart per case; the model comparison's `fits` are its global fits.
pub(super) fn scene_needs(doc: &mut Doc, set: &DataSet, fits: &[FitResult]) -> Result<Vec<String>> {
    let (name, root, dir) = (&set.name, set.root, &set.name);
    doc.h(3, "What each scene needs", &format!("{name}-choose"));
    let cases = crate::choose::fig7_cases(CHOOSE_RES);
    let watch = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let opts = crate::choose::ChooseOptions {
        watch: Some(watch.clone()),
        ..Default::default()
    };
    // One progress line per step (`choose::progress_steps`), and every 0.25 s the fits'
    // passes over the data so far beside the step last done.
    let steps = crate::choose::progress_steps(&set.ds, &cases, &opts);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let last = std::sync::Mutex::new(String::from("global fits of every model"));
    let share = || done.load(std::sync::atomic::Ordering::Relaxed) as f64 / steps as f64;
    let tick = |k: usize| {
        let last = last.lock().expect("no progress hook panics");
        step_at(set, 4, share(), &fit::with_count(&last, k));
    };
    let chosen = fit::ticking(&watch, &tick, || {
        crate::choose::choose_with(&set.ds, &cases, &opts, fits, &|m| {
            let mut last = last.lock().expect("no progress hook panics");
            *last = m.to_string();
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            step_at(set, 4, share(), m)
        })
    });
    let (r, images) = chosen?;
    let out = root.join(dir).join("choose");
    crate::choose::write(&out, &r, &images)?;
    doc.p(&format!(
        "The measurement itself is rendered as the reference (resampled onto a half/difference \
         table, {:.0} % of its cells filled from the {} fit) on Blinn's Figure 7 sphere at \
         {CHOOSE_RES}², and each model is fitted to the configurations the scene's lit pixels \
         show (`brdfit choose`, threshold {} ≤ {}). The simplest model under the threshold is \
         enough for that scene.",
        100.0 * r.fill_share,
        r.fill_model,
        r.threshold.metric,
        r.threshold.value
    ));
    for c in &r.cases {
        let answer = format!("{} lit: {}.", c.case, c.answer());
        doc.p(&answer);
        doc.p(&format!("Verdict: {}: {}.", c.verdict.name(), c.reason));
        let sheet = format!("{dir}/choose/{}/sheet.png", c.case);
        doc.figure(
            &sheet,
            None,
            &format!(
                "{answer} Top: the reference and each model's render; below: ꟻLIP error maps."
            ),
        );
        let chart = format!("{dir}/choose/{}/chart", c.case);
        doc.figure(
            &format!("{chart}.png"),
            Some(&format!("{chart}.svg")),
            "Image error against fit + render time (times measured in this run; the other \
             numbers are the same on every run); the ringed point is the choice.",
        );
        let md = crate::choose::case_table(c, false);
        doc.md.push_str(&md);
        doc.md.push('\n');
        doc.html.push_str(&md_table_to_html(&md));
    }
    doc.link(
        &format!("{dir}/choose/choose.json"),
        "the choice as JSON (choose.json)",
    );
    Ok(r.cases
        .iter()
        .map(|c| match &c.chosen {
            Some(m) => m.clone(),
            None if c.verdict == crate::choose::Verdict::Undetermined => {
                format!("undetermined (closest {})", c.closest)
            }
            None => format!("none (closest {})", c.closest),
        })
        .collect())
}

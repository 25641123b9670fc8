//! A data set's studies in the report: speed against accuracy and stability from random
//! starts, with their charts, tables and takeaways.

use super::DataSet;
use super::doc::{Doc, md_table_to_html, save_chart};
use super::progress::{step, step_at};
use crate::fit::FitResult;
use crate::model::ModelKind;
use crate::study;
use crate::support::output::write_bytes_atomic;
use anyhow::Result;
use serde_json::{Value, json};

/// Speed against accuracy and stability from random starts.
pub(super) fn studies(
    doc: &mut Doc,
    set: &DataSet,
    ts: &FitResult,
    tm: &mut serde_json::Map<String, Value>,
) -> Result<()> {
    let (ds, name, root, dir, opts) = (&set.ds, &set.name, set.root, &set.name, set.opts);
    let m = ts.model_for(0);
    doc.h(3, "Speed against accuracy", &format!("{name}-speed"));
    let truth = study::parse_truth(ds);
    step(set, 5, "studies: speed against accuracy");
    // The speed study about half of the stage, the stability study the rest.
    let rows = study::speed_accuracy_with_progress(ds, truth.as_ref(), 1, &|i, n, what| {
        step_at(
            set,
            5,
            0.5 * i as f64 / n as f64,
            &format!("studies: speed against accuracy: {what}"),
        )
    });
    let chart = study::speed_chart(
        &format!("{name}: cost against fit time, every method × model"),
        &rows,
    );
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/speed-accuracy"))?;
    doc.figure(&png, Some(&svg), "Fit time (measured in this run) against the cost above the best found, for the solvers on Torrance–Sparrow (D3) and for each model with its best solver, and, where the file carries its truth, against each solver's largest parameter error; ringed points and the step line mark the Pareto front (no point is both faster and better)");
    {
        // Deterministic (no times): which solvers reach the lowest cost found on
        // Torrance–Sparrow (D3), which do not, and the best model.
        let ts_rows: Vec<&study::SpeedRow> = rows
            .iter()
            .filter(|r| r.model == "torrance-sparrow (d3)")
            .collect();
        let best = ts_rows.iter().map(|r| r.cost).fold(f64::INFINITY, f64::min);
        let (reach, miss): (Vec<&study::SpeedRow>, Vec<&study::SpeedRow>) =
            ts_rows.iter().partition(|r| r.cost <= best * (1.0 + 1e-6));
        let names = |v: &[&study::SpeedRow]| {
            v.iter()
                .map(|r| r.method.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let lowest = rows
            .iter()
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
            .map_or(String::new(), |r| r.model.clone());
        doc.p(&format!(
            "Takeaway: the lowest cost of all is {lowest}'s. On Torrance–Sparrow (D3) {} reach \
             the lowest cost found for it{}.",
            names(&reach),
            if miss.is_empty() {
                String::new()
            } else {
                format!(
                    "; {} {} not (see why each stopped in the table)",
                    names(&miss),
                    if miss.len() == 1 { "does" } else { "do" }
                )
            }
        ));
    }
    let (md, csv) = study::speed_tables(&rows, false);
    write_bytes_atomic(&root.join(dir).join("speed-accuracy.csv"), csv.as_bytes())?;
    doc.md.push_str(&md);
    doc.md.push('\n');
    doc.html.push_str(&md_table_to_html(&md));
    tm.insert(
        "speed_accuracy_fit_seconds".into(),
        json!(
            rows.iter()
                .map(|r| json!({"method": r.method, "model": r.model, "seconds": r.seconds}))
                .collect::<Vec<_>>()
        ),
    );
    doc.h(
        3,
        "Stability from random starts",
        &format!("{name}-stability"),
    );
    let reference = truth
        .filter(|m| m.kind == ModelKind::TorranceSparrow)
        .unwrap_or(m);
    // The stability study is the second half of the stage (the speed study's steps end at 0.5).
    step_at(set, 5, 0.5, "studies: stability from random starts");
    let configurations = std::sync::atomic::AtomicUsize::new(0);
    let srows = study::stability_with_progress(&reference, opts.stability_starts, 600, 1, &|| {
        let k = configurations.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        step_at(
            set,
            5,
            0.5 + 0.5 * k as f64 / study::STABILITY_CONFIGURATIONS as f64,
            &format!(
                "studies: stability from random starts: {k} of {} configurations",
                study::STABILITY_CONFIGURATIONS
            ),
        )
    });
    let chart = study::stability_chart(
        &format!(
            "{name}: share of {} random starts reaching the global minimum",
            opts.stability_starts
        ),
        &srows,
    );
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/stability"))?;
    doc.figure(&png, Some(&svg), "Stability as a heatmap: configurations (noise × sampling) against methods, each cell the share of seeded random starts reaching the global minimum, failures classified");
    doc.p(&stability_takeaway(&srows));
    let (md, csv) = study::stability_tables(&srows);
    doc.p(study::STABILITY_CELLS);
    write_bytes_atomic(&root.join(dir).join("stability.csv"), csv.as_bytes())?;
    doc.md.push_str(&md);
    doc.md.push('\n');
    doc.html.push_str(&md_table_to_html(&md));
    Ok(())
}

/// The takeaway under the stability heatmap: per method, in how many configurations every
/// start reached the minimum, with the global initialisation and from the random start alone.
pub(super) fn stability_takeaway(rows: &[study::StabilityRow]) -> String {
    use crate::fit::lsq::Method;
    let configs = rows.len() / (2 * Method::ALL.len());
    let all_reached = |m: Method, g: bool| {
        rows.iter()
            .filter(|r| r.method == m && r.global == g && r.hits == r.starts)
            .count()
    };
    let list = |g: bool| {
        Method::ALL
            .iter()
            .map(|&m| format!("{} {}", m.name(), all_reached(m, g)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "Takeaway: configurations (of {configs}) in which every start reached the minimum, \
         with the global initialisation: {}; from the random start alone: {}.",
        list(true),
        list(false)
    )
}

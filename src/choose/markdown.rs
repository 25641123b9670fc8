//! The answer as Markdown: per case the choice, the verdict and one table row per model.

use super::{CaseResult, ChooseResult};

/// The answer as Markdown: per case, the choice and one row per model.
pub fn markdown(r: &ChooseResult) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Channel: {}; measurement resampled onto a {}×{}×{} half/difference table, {:.1} % of cells \
         filled from the {} fit; the reference's base: {}. Threshold: {} ≤ {}.\n",
        r.channel,
        r.table.0[0],
        r.table.0[1],
        r.table.0[2],
        100.0 * r.fill_share,
        r.fill_model,
        if r.reference_method.is_empty() {
            "samples"
        } else {
            &r.reference_method
        },
        r.threshold.metric,
        r.threshold.value
    );
    for c in &r.cases {
        let answer = c.answer();
        let _ = writeln!(
            s,
            "### {} lit: {answer}\n\nReference: {}; {} lit pixels in {} scene-weighted \
             configurations, {:.0} % of them where the table holds measured samples (the rest \
             show the fill model).\n",
            c.case,
            c.reference,
            c.lit_pixels,
            c.configurations,
            100.0 * c.measured_share
        );
        let _ = writeln!(s, "Verdict: **{}**: {}.\n", c.verdict.name(), c.reason);
        if let Some(e) = &c.reference_error {
            let _ = writeln!(
                s,
                "The reference's own error: ꟻLIP p99 {:.3}, mean {:.4} ({}).\n",
                e.flip_p99, e.flip_mean, e.method
            );
        }
        s.push_str(&case_table(c, true));
        s.push('\n');
    }
    s
}

/// One case's rows as a Markdown table (model, parameters, BIC, image errors, rays, and with
/// `times` the fit and render times); the chosen row is marked ✔. Without times the table is
/// the same bytes on every run.
pub fn case_table(c: &CaseResult, times: bool) -> String {
    use std::fmt::Write as _;
    let mut s = String::from(
        "| model | fit judged | parameters (scene-weighted fit) | parameters (global fit) | \
         BIC (all data) | ꟻLIP mean | ꟻLIP p99 | ꟻLIP p99, scene-weighted fit | ꟻLIP p99, \
         global fit | ΔE_ITP mean | ΔE_ITP p99 | RMSE | rays |",
    );
    s.push_str(if times { " fit s | render s |\n" } else { "\n" });
    s.push_str("|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    s.push_str(if times { "---:|---:|\n" } else { "\n" });
    let params = |p: &[(String, f64)]| {
        p.iter()
            .map(|(k, v)| format!("{k} {}", crate::model::readable(*v)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut reasons = Vec::new();
    for m in &c.models {
        let mark = if c.chosen.as_deref() == Some(&m.model) {
            " ✔"
        } else {
            ""
        };
        let flag = |why: &[String]| if why.is_empty() { "" } else { " (not usable)" };
        let _ = write!(
            s,
            "| {}{mark}{} | {} | {}{} | {}{} | {:.0} | {:.4} | {:.4} | {:.4} | {:.4} | {:.3} | \
             {:.3} | {:.4} | {} |",
            m.model,
            if m.usable { "" } else { " (not usable)" },
            m.used.name(),
            params(&m.params),
            flag(&m.unusable),
            params(&m.global_params),
            flag(&m.global_unusable),
            m.bic,
            m.flip_mean,
            m.flip_p99,
            m.scene_flip_p99,
            m.global_flip_p99,
            m.delta_e_itp_mean,
            m.delta_e_itp_p99,
            m.rmse,
            m.rays
        );
        if times {
            let _ = write!(s, " {:.3} | {:.3} |", m.fit_seconds, m.render_seconds);
        }
        s.push('\n');
        for (fit, why) in [
            ("scene-weighted", &m.unusable),
            ("global", &m.global_unusable),
        ] {
            if !why.is_empty() {
                reasons.push(format!(
                    "- {} ({fit} fit) is not usable: {}\n",
                    m.model,
                    why.join("; ")
                ));
            }
        }
    }
    if !reasons.is_empty() {
        s.push('\n');
        s.extend(reasons);
    }
    s
}

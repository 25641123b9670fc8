//! A data set's figures: lobes against the in-plane data, residuals, albedo and renders of
//! the fitted material, with a takeaway under each; and Blinn's Figures 5–7.

use super::doc::{Doc, save_chart};
use super::progress::step_at;
use super::{DataSet, ReportOptions, is_synthetic};
use crate::data::Dataset;
use crate::fit::FitResult;
use crate::model::Model;
use crate::support::output::write_bytes_atomic;
use crate::{plot, render};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// Blinn 1977, Figures 5–7, with his parameters.
pub(super) fn blinn_figures(doc: &mut Doc, root: &Path, opts: &ReportOptions) -> Result<()> {
    doc.h(2, "Blinn 1977, Figures 5–7", "blinn");
    let (p5, s5) = save_chart(&plot::blinn_figure(30.0, 5), root, "blinn/figure5")?;
    let (p6, s6) = save_chart(&plot::blinn_figure(70.0, 6), root, "blinn/figure6")?;
    doc.p("Phong ((N·H)^c1, c1 = 50) against Torrance–Sparrow (D3 with the same half-angle β, n 1.8, ps .667, pd .333); Phong's ps matches the Torrance–Sparrow highlight at normal incidence. At 30° the two are nearly identical; at 70° the Torrance–Sparrow bump is far larger and points off-specular, toward grazing.");
    doc.figure(&p5, Some(&s5), "Figure 5: incident light at 30°");
    doc.figure(&p6, Some(&s6), "Figure 6: incident light at 70°");
    let imgs = render::fig7_images(
        &Model::blinn_aluminium(),
        &Model::blinn_mgo(),
        opts.render_res,
        render::AntiAlias::Adaptive {
            threshold: 0.02,
            max_level: 3,
            block: 1,
            jitter: false,
        },
    );
    write_bytes_atomic(&root.join("blinn/fig7.png"), &render::contact_sheet(&imgs)?)?;
    doc.p("Figure 7 with Blinn's parameters (aluminium ps .4 pd .6 n 200 c3 .5; MgO ps .667 pd .333 n 1.8 c3 .35), rendered by brdfit's Whitted ray tracer: front lit the models agree; edge lit the ceramic's Torrance–Sparrow highlight is several times brighter than Phong's.");
    doc.figure(
        "blinn/fig7.png",
        None,
        "Figure 7: aluminium and MgO, front and edge lit, Phong and Torrance–Sparrow",
    );

    Ok(())
}

/// Lobes against the in-plane data, residuals and albedo.
pub(super) fn plots(
    doc: &mut Doc,
    set: &DataSet,
    fits: &[FitResult],
    ts_i: usize,
    rec: usize,
) -> Result<()> {
    let (ds, name, root, dir) = (&set.ds, &set.name, set.root, &set.name);
    let ts = &fits[ts_i];
    let synthetic = is_synthetic(ds);
    let thetas = lobe_angles(ds);
    let models = vec![
        (format!("{} fit", fits[ts_i].label()), ts.model_for(0)),
        (format!("{} fit", fits[rec].label()), fits[rec].model_for(0)),
    ];
    let models: Vec<(String, Model)> = if rec == ts_i {
        models[..1].to_vec()
    } else {
        models
    };
    let chart = plot::lobe_chart(
        &format!("{name}: reflection in the plane of incidence"),
        &models,
        Some((ds, 0)),
        &thetas,
        plot::LobeQuantity::Intensity,
        !synthetic,
        plot::InPlane {
            theta_i: 0.5,
            azimuth: if synthetic { 5.0 } else { 1.0 },
        },
    );
    doc.h(3, "Lobes, residuals and albedo", &format!("{name}-plots"));
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/lobes"))?;
    doc.figure(
        &png,
        Some(&svg),
        &format!(
            "Lobes at θi = {:?}° ({} radius; markers: measured samples in the plane of incidence)",
            thetas,
            if synthetic { "linear" } else { "logarithmic" }
        ),
    );
    doc.p(&lobe_takeaway(&chart));
    // A step per chart (a full MERL table's million residuals take seconds to draw).
    let pts = plot::residual_points(ds, 0, &ts.model_for(0), true);
    let charts = plot::residual_charts(&ts.label(), &pts);
    for (i, (file_name, chart)) in charts.iter().enumerate() {
        let part = (1 + i) as f64 / (2 + charts.len()) as f64;
        step_at(set, 2, part, &format!("plots: {file_name}"));
        let (png, svg) = save_chart(chart, root, &format!("{dir}/{file_name}"))?;
        doc.figure(&png, Some(&svg), &chart.title);
        doc.p(&residual_takeaway(chart));
    }
    step_at(
        set,
        2,
        (1 + charts.len()) as f64 / (2 + charts.len()) as f64,
        "plots: albedo",
    );
    let measured = plot::measured_albedo(ds, 0);
    let (chart, apts) = plot::albedo_chart(&ts.label(), &ts.model_for(0), &measured);
    let (png, svg) = save_chart(&chart, root, &format!("{dir}/albedo"))?;
    doc.figure(
        &png,
        Some(&svg),
        "Directional albedo of the Torrance–Sparrow fit",
    );
    if let Some(p) = apts.iter().find(|p| p.1 > 1.0) {
        doc.p(&format!(
            "⚠ The fitted model creates energy: albedo {:.3} at θi = {}°.",
            p.1, p.0
        ));
    } else if let (Some(a), Some(b)) = (apts.first(), apts.last()) {
        doc.p(&format!(
            "Takeaway: the fit reflects {} of the light at normal incidence and {} at θi = {}°, \
             within the energy limit. {}",
            crate::model::significant(a.1, 3),
            crate::model::significant(b.1, 3),
            b.0,
            albedo_agreement(&apts, &measured)
        ));
    }

    Ok(())
}

/// Figure 7 renders of the fitted Torrance–Sparrow material and its equal-β Phong.
pub(super) fn renders(doc: &mut Doc, set: &DataSet, ts: &FitResult) -> Result<()> {
    let (name, root, dir, opts) = (&set.name, set.root, &set.name, set.opts);
    doc.h(
        3,
        "Renders of the fitted material",
        &format!("{name}-renders"),
    );
    let m = ts.model_for(0);
    let phong = crate::model::equal_beta_phong(&m);
    doc.p(&format!(
        "Blinn's Figure 7 sphere with this data set's fit: {m}; and Phong with the same \
         half-angle β: {phong}."
    ));
    let mut names = Vec::new();
    for (lname, l) in [
        ("front", render::Lighting::Front),
        ("edge", render::Lighting::Edge),
    ] {
        for (mname, mm) in [("phong", crate::model::equal_beta_phong(&m)), ("ts", m)] {
            let img = render::fig7_scene(mm, l, opts.render_res).render(&|| {});
            let base = root.join(dir).join(format!("render-{lname}-{mname}"));
            render::save(&img, &base)?;
            names.push(format!("{dir}/render-{lname}-{mname}.png"));
        }
    }
    let _ = writeln!(doc.html, "<div class=\"row\">");
    for (n, cap) in names.iter().zip([
        "front lit, Phong (equal β)",
        "front lit, Torrance–Sparrow",
        "edge lit, Phong (equal β)",
        "edge lit, Torrance–Sparrow",
    ]) {
        let _ = writeln!(
            doc.html,
            "<figure class=\"small\"><img src=\"{n}\" alt=\"{cap}\"><figcaption>{cap} (<a href=\"{}\">EXR</a>)</figcaption></figure>",
            n.replace(".png", ".exr")
        );
        let _ = writeln!(doc.md, "![{cap}]({n})");
    }
    let _ = writeln!(doc.html, "</div>");
    doc.md.push('\n');

    Ok(())
}

/// How the fit's albedo compares with the estimate from the samples, in one sentence.
pub(super) fn albedo_agreement(fit: &[(f64, f64)], measured: &[(f64, f64)]) -> String {
    let worst = measured
        .iter()
        .filter_map(|(t, m)| {
            let f = fit.iter().find(|p| p.0 == *t)?.1;
            Some((*t, (f - m) / m))
        })
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    match worst {
        None => "The samples do not cover and resolve the outgoing hemisphere at any θi, so \
                 the albedo cannot be estimated from them."
            .into(),
        Some((t, d)) => format!(
            "The estimate from the samples ({} incidence angle{}) differs from the fit by at \
             most {} % (θi = {t}°).",
            measured.len(),
            if measured.len() == 1 { "" } else { "s" },
            crate::model::significant(100.0 * d.abs(), 2)
        ),
    }
}

/// One line under the lobe chart: where each panel's first fitted curve peaks relative to
/// the mirror direction, and how many measured samples lie near the plane.
pub(super) fn lobe_takeaway(chart: &plot::LobeChart) -> String {
    let parts: Vec<String> = chart
        .panels
        .iter()
        .map(|p| {
            let peak = p.series.first().and_then(|s| {
                s.points
                    .iter()
                    .filter(|q| q.1.is_finite())
                    .max_by(|a, b| a.1.total_cmp(&b.1))
            });
            let measured = p
                .series
                .iter()
                .filter(|s| s.markers)
                .map(|s| s.points.len())
                .sum::<usize>();
            // Signed θo < 0 is the mirror side; the mirror direction is at −θi.
            match peak {
                Some(q) => format!(
                    "at θi = {}° the fit peaks {}° from the mirror direction{} ({measured} \
                     measured sample{} near the plane)",
                    p.theta_i_deg,
                    crate::model::significant((q.0 + p.theta_i_deg).abs(), 2),
                    if q.0 < -p.theta_i_deg - 0.5 {
                        ", toward grazing"
                    } else {
                        ""
                    },
                    if measured == 1 { "" } else { "s" }
                ),
                None => format!("at θi = {}° nothing to show", p.theta_i_deg),
            }
        })
        .collect();
    format!("Takeaway: {}.", parts.join("; "))
}

/// One line under a residual chart: the largest binned median and where it is.
pub(super) fn residual_takeaway(chart: &plot::XyChart) -> String {
    let median = chart.series.iter().find(|s| s.label == "binned median");
    let worst = median.and_then(|s| {
        s.points
            .iter()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    });
    match worst {
        Some(w) => format!(
            "Takeaway: the binned median residual stays within ±{} (loss units); its largest \
             departure is at {} = {}°.",
            crate::model::significant(w.1.abs(), 2),
            chart.x_label.split(' ').next().unwrap_or("x"),
            crate::model::significant(w.0, 3)
        ),
        None => "Takeaway: too few samples for a binned median.".into(),
    }
}

/// Incidence angles for the lobe plots: the two measured θi closest to 30° and 60° that have
/// in-plane samples, else 30° and 60°.
pub(super) fn lobe_angles(ds: &Dataset) -> Vec<f64> {
    let mut tis: Vec<f64> = ds
        .theta_i
        .iter()
        .map(|t| (t.to_degrees() * 10.0).round() / 10.0)
        .collect();
    tis.sort_by(f64::total_cmp);
    tis.dedup();
    if tis.len() > 30 || tis.is_empty() {
        return vec![30.0, 60.0];
    }
    let pick = |want: f64| {
        tis.iter()
            .cloned()
            .min_by(|a, b| (a - want).abs().total_cmp(&(b - want).abs()))
            .unwrap_or(want)
    };
    let (a, b) = (pick(30.0), pick(60.0));
    if a == b { vec![a] } else { vec![a, b] }
}

//! The choice itself: the global fits, the reference, then per lighting case the reference
//! render, each candidate's fits, renders and errors, and the verdict.

use super::fitting::{exposure, fit_one, refit_on_pixels, scene_samples};
use super::judge::{Judged, Prepared, render_with, used_fit};
use super::reference::Reference;
use super::{
    Case, CaseImages, CaseResult, ChooseOptions, ChooseResult, DEFAULT_THRESHOLD, FLIP_LEVEL,
    FitUsed, Metric, ModelRow, RENDER_COST_ORDER, Threshold, ThresholdJson, Verdict, model_name,
    verdict,
};
use crate::data::Dataset;
use crate::fit::{FitOptions, FitResult};
use crate::model::{Distribution, Model, ModelKind};
use crate::render::Image;
use crate::render::compare;
use crate::render::measured::Tabulated;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// Which rows pass, and the choice: the simplest passing row (fewest parameters, then
/// [`RENDER_COST_ORDER`]); and the closest row (lowest error on the threshold's metric) among
/// the usable rows, or among all where none is usable.
pub fn pick(rows: &[ModelRow], threshold: Threshold) -> (Option<usize>, usize) {
    let rank = |r: &ModelRow| {
        let pos = RENDER_COST_ORDER
            .iter()
            .position(|&(k, d)| model_name(k, d) == r.model)
            .unwrap_or(usize::MAX);
        (r.n_params(), pos)
    };
    let chosen = (0..rows.len())
        .filter(|&i| rows[i].usable && rows[i].error(threshold.metric) <= threshold.value)
        .min_by_key(|&i| rank(&rows[i]));
    // The closest usable row; the closest of all only where none is usable.
    let any_usable = rows.iter().any(|r| r.usable);
    let closest = (0..rows.len())
        .filter(|&i| rows[i].usable || !any_usable)
        .min_by(|&a, &b| {
            rows[a]
                .error(threshold.metric)
                .total_cmp(&rows[b].error(threshold.metric))
        })
        .unwrap_or(0);
    (chosen, closest)
}

/// Run the choice for a single-channel data set over `cases`. Returns the answer and each
/// case's images. `progress` receives one line per step.
pub fn choose(
    ds: &Dataset,
    cases: &[Case],
    opts: &ChooseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<(ChooseResult, Vec<CaseImages>), crate::fit::FitError> {
    choose_with(ds, cases, opts, &[], progress)
}

/// How many progress lines [`choose_with`] gives for `ds` and `cases`: one per candidate's
/// global fit; for the resampling, one as it starts, one for the resampling base's fit when
/// no candidate is Torrance–Sparrow (ABC), one as the table is rebuilt, one per
/// cross-validation fold (`verdict::fold_count`) and one as it ends; then per case its
/// reference, its cross-validation and each candidate.
pub fn progress_steps(ds: &Dataset, cases: &[Case], opts: &ChooseOptions) -> usize {
    let abc = (ModelKind::TorranceSparrow, Distribution::Abc);
    let base_fit = usize::from(!opts.candidates.contains(&abc));
    opts.candidates.len()
        + 3
        + base_fit
        + verdict::fold_count(ds)
        + cases.len() * (2 + opts.candidates.len())
}

/// [`choose`] reusing fits of `ds` made already (the report's model comparison): a candidate
/// with a fit in `fitted` (same model and distribution, the default options, verified with at
/// least `opts.verify` starts, one channel) takes it as its global fit instead of fitting
/// again; the others are fitted. A fit with more starts is the same fit (the first
/// `opts.verify` starts are the same seeded starts) under a stricter certificate.
pub fn choose_with(
    ds: &Dataset,
    cases: &[Case],
    opts: &ChooseOptions,
    fitted: &[FitResult],
    progress: &(dyn Fn(&str) + Sync),
) -> Result<(ChooseResult, Vec<CaseImages>), crate::fit::FitError> {
    // Global fits: the comparison the report already makes, and the fill of empty cells.
    // The candidates in parallel (each fit is deterministic, so the order of work is free).
    let reuse = |kind: ModelKind, dist: Distribution| {
        fitted.iter().find(|f| {
            let default = FitOptions::new(kind);
            (f.model, f.dist) == (kind, dist)
                && (f.loss, f.method) == (default.loss, default.method)
                && f.params.len() == kind.params(dist).len()
                && f.verification
                    .as_ref()
                    .map_or(opts.verify == 0, |v| v.starts >= opts.verify)
        })
    };
    // A progress line as each is done (a full MERL table's take up to 30 s together).
    let global = opts
        .candidates
        .par_iter()
        .map(|&(kind, dist)| {
            let f = match reuse(kind, dist) {
                Some(f) => {
                    progress(&format!("{}: global fit taken as given", kind.label(dist)));
                    f.clone()
                }
                None => {
                    let f = fit_one(ds, kind, dist, opts.verify, opts.watch.as_ref())?;
                    progress(&format!(
                        "{}: global fit in {:.2} s",
                        kind.label(dist),
                        f.seconds
                    ));
                    f
                }
            };
            Ok(f)
        })
        .collect::<Result<Vec<_>, _>>()?;
    progress("resampling the measurement and refitting its cross-validation folds");
    let reference = Reference::new(
        ds,
        &global,
        opts.prior.as_ref(),
        progress,
        opts.watch.as_ref(),
    );
    let r = &reference;
    progress(&format!(
        "resampled {} samples onto a {}×{}×{} table in {:.2} s; {:.1} % of cells filled from {}; \
         {} cross-validation folds refitted and rebuilt in {:.2} s",
        ds.len(),
        r.table.dims.0[0],
        r.table.dims.0[1],
        r.table.dims.0[2],
        r.seconds,
        100.0 * r.table.fill_share(),
        r.fill_name,
        r.folds.len(),
        r.fold_seconds
    ));
    // The cases in parallel too, so one case's last slow candidate does not leave a core idle
    // (each case is deterministic; the results in case order).
    let done = cases
        .par_iter()
        .map(|case| run_case(case, r, &global, opts, progress))
        .collect::<Result<Vec<_>, _>>()?;
    let (mut results, images): (Vec<CaseResult>, Vec<CaseImages>) = done.into_iter().unzip();
    for c in &mut results {
        refuse_unsupported(c, ds.len());
    }
    Ok((
        ChooseResult {
            threshold: ThresholdJson {
                metric: opts.threshold.metric.key().into(),
                value: opts.threshold.value,
            },
            channel: ds.channel_label(0),
            table: r.table.dims,
            fill_share: r.table.fill_share(),
            fill_model: r.fill_name.clone(),
            resample_seconds: r.seconds,
            reference_method: r.method.clone(),
            cases: results,
        },
        images,
    ))
}

/// One candidate of a case: its row, the image judged and its ꟻLIP map.
type Candidate = (ModelRow, Image, Vec<f32>);

/// One lighting case: the reference render, the scene-weighted samples, and each candidate's
/// fit, render and image error.
fn run_case(
    case: &Case,
    reference: &Reference,
    global: &[FitResult],
    opts: &ChooseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<(CaseResult, CaseImages), crate::fit::FitError> {
    let base = case.scene.materials[0].clone();
    let material = |model: Model, table: Option<Arc<Tabulated>>| crate::render::Material {
        model,
        measured: table,
        ..base.clone()
    };
    let table = reference.measured.then(|| reference.table.clone());
    // One geometry pass (primary hits and the light's geometry at every pixel corner) for
    // every render of the case: the reference, the folds and both fits of each candidate.
    // The scene-weighted samples (the candidates' fits) beside that pass and the reference's
    // render: they read the reference's table, not its image.
    let ((corners, (ref_img, reference_seconds)), ((samples, mask, lit), measured_share)) =
        rayon::join(
            || {
                let corners = case.scene.corners();
                let rendered = render_with(&case.scene, &corners, material(reference.fill, table));
                (corners, rendered)
            },
            || {
                let s = scene_samples(&case.scene, 0, &|g| reference.brdf(g));
                let share = reference.measured_share(&s.0);
                (s, share)
            },
        );
    progress(&format!(
        "{}: {} lit pixels in {} configurations, {:.0} % of them in measured cells; \
         reference rendered in {:.2} s",
        case.name,
        lit,
        samples.len(),
        100.0 * measured_share,
        reference_seconds
    ));
    let prepared = Prepared::new(&ref_img, &mask);
    // The reference's own error (each cross-validation fold rendered against it) beside the
    // candidates: both deterministic, so the order of work is free.
    let (cross, done) = rayon::join(
        || {
            let cross = verdict::cross_validate_against(
                &case.scene,
                &corners,
                &prepared,
                &reference.folds,
                &mask,
                &|t| material(reference.fill, Some(t)),
            );
            let (p99, mean) = cross
                .0
                .as_ref()
                .map_or((0.0, 0.0), |e| (e.flip_p99, e.flip_mean));
            progress(&format!(
                "{}: the reference's own error (cross-validation, {} folds): ꟻLIP p99 {p99:.3}, mean {mean:.4}",
                case.name,
                reference.folds.len()
            ));
            cross
        },
        || {
            candidates(
                case, &corners, &samples, &prepared, &mask, global, opts, progress,
            )
        },
    );
    let (reference_error, reference_error_map, worst) = cross;
    let (err_p99, err_mean) = reference_error
        .as_ref()
        .map_or((0.0, 0.0), |e| (e.flip_p99, e.flip_mean));
    let mut rows = Vec::new();
    let mut renders = vec![(reference.name(), ref_img.clone())];
    let mut flip_maps = Vec::new();
    for d in done {
        let (row, image, map) = d?;
        renders.push((row.model.clone(), image));
        rows.push(row);
        flip_maps.push(map);
    }
    let (chosen, closest) = pick(&rows, opts.threshold);
    let err = match opts.threshold.metric {
        Metric::FlipMean => err_mean,
        _ => err_p99,
    };
    let (metric, limit) = match opts.threshold.metric {
        Metric::FlipMean | Metric::FlipP99 => (opts.threshold.metric, opts.threshold.value),
        _ => (DEFAULT_THRESHOLD.metric, DEFAULT_THRESHOLD.value),
    };
    let (verdict, reason) = verdict::verdict(
        chosen.map(|i| rows[i].model.as_str()),
        (
            &rows[closest].model,
            rows[closest].error(opts.threshold.metric),
        ),
        metric.key(),
        limit,
        if reference_error.is_some() { err } else { 0.0 },
        worst,
        reference.spacing,
        1.0 - measured_share,
    );
    let chosen = chosen.filter(|_| verdict == Verdict::Chosen);
    Ok((
        CaseResult {
            case: case.name.clone(),
            reference: reference.name(),
            chosen: chosen.map(|i| rows[i].model.clone()),
            closest: rows[closest].model.clone(),
            configurations: samples.len(),
            lit_pixels: lit,
            measured_share,
            reference_render_seconds: reference_seconds,
            verdict,
            reason,
            reference_error,
            models: rows,
        },
        CaseImages {
            case: case.name.clone(),
            renders,
            flip_maps,
            reference_error_map,
            mask,
        },
    ))
}

/// Each candidate's fit, renders and judgement against the prepared reference, in parallel
/// (every step is deterministic); each progress line as its candidate finishes (so a bar
/// moves), the rows in candidate order.
#[allow(clippy::too_many_arguments)]
fn candidates(
    case: &Case,
    corners: &crate::render::Corners,
    samples: &Dataset,
    prepared: &Prepared,
    mask: &[bool],
    global: &[FitResult],
    opts: &ChooseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Vec<Result<Candidate, crate::fit::FitError>> {
    let base = case.scene.materials[0].clone();
    let material = |model: Model| crate::render::Material {
        model,
        measured: None,
        ..base.clone()
    };
    let metric = opts.threshold.metric;
    opts.candidates
        .par_iter()
        .enumerate()
        .map(|(k, &(kind, dist))| {
            let t = Instant::now();
            // Nothing lit: the global fit stands in (every model renders black there); so it
            // does where the lit configurations are too few for the model's parameters (the
            // tabulated NDF's 35 on a small test object).
            let fitted = if samples.len() <= kind.params(dist).len() {
                global[k].clone()
            } else {
                // The log-loss fit is only the refit's start: unverified (the refit is).
                let log_fit = fit_one(samples, kind, dist, 0, opts.watch.as_ref())?;
                let g = global[k].model_for(0);
                let e = exposure(&case.scene);
                refit_on_pixels(samples, log_fit, &g, e, opts.verify, opts.watch.as_ref())
            };
            let fit_seconds = t.elapsed().as_secs_f64();
            // The two fits rendered and judged side by side.
            let ((render_seconds, scene_fit), global_fit) = rayon::join(
                || {
                    let (img, seconds) =
                        render_with(&case.scene, corners, material(fitted.model_for(0)));
                    let judged = Judged::new(prepared, img, mask, fitted.usable(), metric);
                    (seconds, judged)
                },
                || {
                    let (img, _) =
                        render_with(&case.scene, corners, material(global[k].model_for(0)));
                    Judged::new(prepared, img, mask, global[k].usable(), metric)
                },
            );
            let scene_p99 = scene_fit.flip.p99;
            let global_p99 = global_fit.flip.p99;
            let used = used_fit(&scene_fit, &global_fit, opts.threshold.metric);
            // ΔE_ITP and RMSE of the fit judged alone (the other's are not reported).
            let mut judged = match used {
                FitUsed::SceneWeighted => scene_fit,
                FitUsed::Global => global_fit,
            };
            let (delta_e, rmse) = judged.complete(prepared, mask);
            let name = model_name(kind, dist);
            let line = format!(
                "{}: {name}: ꟻLIP p99 {scene_p99:.3} scene-weighted fit{}, {global_p99:.3} global \
                 fit{}; the {} fit judged",
                case.name,
                if fitted.usable() { "" } else { " (not usable)" },
                if global[k].usable() {
                    ""
                } else {
                    " (not usable)"
                },
                used.name()
            );
            let row = ModelRow {
                model: name.clone(),
                distribution: dist,
                used,
                params: fitted.params.clone(),
                global_params: global[k].params.clone(),
                bic: global[k].bic,
                flip_mean: compare::summarise(&judged.map, &[], FLIP_LEVEL).mean,
                flip_p99: judged.flip.p99,
                flip_above: judged.flip.above,
                delta_e_itp_mean: delta_e.mean,
                delta_e_itp_p99: delta_e.p99,
                rmse,
                scene_flip_p99: scene_p99,
                global_flip_p99: global_p99,
                fit_seconds,
                render_seconds,
                rays: judged.image.total_rays(),
                usable: judged.usable,
                unusable: fitted.unusable.clone(),
                global_unusable: global[k].unusable.clone(),
            };
            progress(&line);
            Ok((row, judged.image, judged.map))
        })
        .collect()
}

/// Fewest samples from which `choose` states a verdict: below this the cross-validation folds
/// (half the samples each, or slices of one sample) are rebuilt mostly from the fitted fill,
/// so they agree with the reference whatever the truth (50 samples of a glossy material gave
/// "lambert is enough" where 20,000 gave phong; 200 gave phong).
pub const MIN_SAMPLES: usize = 200;

/// The words that open the reason of a case with too few samples ([`CaseResult::answer`]).
pub(super) const FEW_SAMPLES: &str = "too few samples for the cross-validation";

/// Turn a case's verdict into `undetermined` where nothing supports one: no lit pixel of the
/// test object (every model renders the same nothing), or fewer than [`MIN_SAMPLES`] samples.
fn refuse_unsupported(c: &mut CaseResult, samples: usize) {
    let why = if c.lit_pixels == 0 {
        "no pixel of the test object is lit at this resolution, so every model renders the same; render larger (--res) or light the object".to_string()
    } else if samples < MIN_SAMPLES {
        format!(
            "{FEW_SAMPLES}: the measurement holds {samples} samples, fewer than the {MIN_SAMPLES} the cross-validation needs to state the reference's own error; measure more samples"
        )
    } else {
        return;
    };
    c.verdict = Verdict::Undetermined;
    c.chosen = None;
    c.reason = format!("the reference is not determined: {why}");
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of `model` with ꟻLIP p99 `p99`, usable or not (the other figures 0).
    fn row(model: &str, p99: f64, usable: bool) -> ModelRow {
        serde_json::from_value(serde_json::json!({
            "model": model, "distribution": "d3", "params": {"pd": 0.5},
            "global_params": {"pd": 0.5}, "bic": 0.0, "flip_mean": 0.0, "flip_p99": p99,
            "flip_above": 0.0, "delta_e_itp_mean": 0.0, "delta_e_itp_p99": 0.0, "rmse": 0.0,
            "global_flip_p99": p99, "fit_seconds": 0.0, "render_seconds": 0.0, "rays": 0,
            "usable": usable
        }))
        .unwrap()
    }

    /// None within the threshold: the closest named is the usable row nearest the reference,
    /// not a nearer one that is not usable (satin: torrance-sparrow-d3 with ps 1.5e7); with
    /// no usable row, the nearest of all.
    #[test]
    fn the_closest_is_usable_where_any_is() {
        let rows = [
            row("lambert", 0.9, true),
            row("torrance-sparrow-d3", 0.2, false),
            row("phong", 0.4, true),
        ];
        let (chosen, closest) = pick(&rows, DEFAULT_THRESHOLD);
        assert_eq!(chosen, None);
        assert_eq!(rows[closest].model, "phong");
        let rows = [row("lambert", 0.9, false), row("phong", 0.4, false)];
        assert_eq!(rows[pick(&rows, DEFAULT_THRESHOLD).1].model, "phong");
    }
}

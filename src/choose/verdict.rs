//! The reference's own error bar, by cross-validation, and the verdict it allows.
//!
//! The reference image is a reconstruction of the samples ([`crate::render::reconstruct`]);
//! where the samples are sparse it may be far from the material. Its error is estimated the
//! way a goniometer misses data: the table is rebuilt without whole slices of the
//! measurement (alternate interior θi slices, the first and last kept; alternate azimuth
//! slices; the last θi slice and the θo beyond 2 θo_max − 90°; alternate samples for
//! scattered data), each rebuilt table is rendered in the case's scene, and its LDR-ꟻLIP
//! against the reference over the object is taken; the largest fold is the stated error.
//! Every fold doubles what the reference bridges (the θi or azimuth spacing, the
//! extrapolation's reach), no more: if the reconstruction's error grows as spacingᵖ, a fold
//! differs from the reference by about (2ᵖ − 1) times the reference's own error, which is at
//! least that error for any order p ≥ 1 (Richardson's estimate taken at p = 1, the safe end).
//! Measured on five MERL networks × two scenes (256²) the stated error was 1.5–3.6 times the
//! true one (README).

use crate::data::Dataset;
use crate::render::measured::Tabulated;
use crate::render::{Image, Material, Scene};
use std::sync::Arc;

/// The reference's own error, as `choose.json` writes it per case.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReferenceError {
    /// 99th percentile of LDR-ꟻLIP over the object, the largest over the folds.
    pub flip_p99: f64,
    /// Mean LDR-ꟻLIP over the whole image, the largest over the folds.
    pub flip_mean: f64,
    /// How it was estimated.
    pub method: String,
}

/// A case's verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// A model is within the threshold, and the reference's own error is below it.
    Chosen,
    /// No model is within the threshold, and the reference is determined.
    None,
    /// The reference's own error exceeds the threshold: no choice can be trusted.
    Undetermined,
}

impl Verdict {
    /// The JSON spelling.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Chosen => "chosen",
            Verdict::None => "none",
            Verdict::Undetermined => "undetermined",
        }
    }
}

/// Which slices a fold leaves out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoldKind {
    /// Alternate interior θi slices (the first and last kept).
    ThetaI,
    /// Alternate azimuth (φo − φi) slices.
    Azimuth,
    /// The outermost θi slice and the last θo (as many degrees as the data stop short of
    /// 90°): extrapolation twice as far as the reference's.
    Extrapolation,
    /// Alternate samples (scattered data).
    Samples,
}

/// A table rebuilt without part of the samples.
pub struct Fold {
    /// What was left out, in words.
    pub name: String,
    /// Which kind of slices.
    pub kind: FoldKind,
    /// The rebuilt table.
    pub table: Arc<Tabulated>,
}

/// Most distinct values an angle may take for the data to count as slices of it.
const MAX_SLICES: usize = 90;

/// The distinct values of `a` (to 0.01°), sorted; `None` when there are more than
/// [`MAX_SLICES`] or fewer than 3.
fn slices(a: impl Iterator<Item = f64>) -> Option<Vec<i64>> {
    let mut v: Vec<i64> = a.map(|x| (x.to_degrees() * 100.0).round() as i64).collect();
    v.sort_unstable();
    v.dedup();
    (3..=MAX_SLICES).contains(&v.len()).then_some(v)
}

/// Azimuth difference φo − φi in [0, 2π).
fn azimuth(ds: &Dataset, k: usize) -> f64 {
    (ds.phi_o[k] - ds.phi_i[k]).rem_euclid(std::f64::consts::TAU)
}

/// Which rows of a dataset a fold keeps.
type Keep<'a> = Box<dyn Fn(usize) -> bool + Sync + 'a>;

/// The subsets a cross-validation rebuilds from, with their names: without alternate
/// interior θi slices, without the last θi slice and θo (extrapolation) and without alternate
/// azimuth slices when the data come in such slices, else without alternate samples.
pub fn fold_sets(ds: &Dataset) -> Vec<(String, FoldKind, Dataset)> {
    let subset = |keep: &Keep| {
        let mut out = ds.clone();
        let idx: Vec<usize> = (0..ds.len()).filter(|&k| keep(k)).collect();
        let pick = |v: &[f64]| idx.iter().map(|&k| v[k]).collect::<Vec<_>>();
        out.theta_i = pick(&ds.theta_i);
        out.phi_i = pick(&ds.phi_i);
        out.theta_o = pick(&ds.theta_o);
        out.phi_o = pick(&ds.phi_o);
        for (c, src) in out.channels.iter_mut().zip(&ds.channels) {
            c.values = pick(&src.values);
        }
        out.weights = ds.weights.as_deref().map(pick);
        out
    };
    fold_plan(ds)
        .into_iter()
        .map(|(name, kind, keep)| {
            let sub = subset(&keep);
            (name, kind, sub)
        })
        .collect()
}

/// How many folds [`fold_sets`] makes of `ds` (without making them).
pub fn fold_count(ds: &Dataset) -> usize {
    fold_plan(ds).len()
}

/// [`fold_sets`]'s folds as names, kinds and the rows each keeps.
fn fold_plan(ds: &Dataset) -> Vec<(String, FoldKind, Keep<'_>)> {
    let key = |x: f64| (x.to_degrees() * 100.0).round() as i64;
    let mut out: Vec<(String, FoldKind, Keep)> = Vec::new();
    if let Some(ti) = slices(ds.theta_i.iter().copied()) {
        // Alternate interior slices: the first and last are kept, so the fold interpolates
        // at twice the spacing where the reference interpolates, and extrapolates no farther
        // (dropping the first slice made the front-lit fold extrapolate from 20° down to the
        // highlight at 7.5°, over-stating the error 3–5×).
        for parity in 0..2 {
            let drop: Vec<i64> = ti[1..ti.len() - 1]
                .iter()
                .copied()
                .skip(parity)
                .step_by(2)
                .collect();
            if drop.is_empty() {
                continue;
            }
            let words = drop
                .iter()
                .map(|d| format!("{}", *d as f64 / 100.0))
                .collect::<Vec<_>>()
                .join(", ");
            out.push((
                format!("without θi = {words}°"),
                FoldKind::ThetaI,
                Box::new(move |k| !drop.contains(&key(ds.theta_i[k]))),
            ));
        }
    }
    if let (Some(ti), Some(top)) = (
        slices(ds.theta_i.iter().copied()),
        ds.theta_o.iter().copied().reduce(f64::max),
    ) {
        // Extrapolation: without the last θi slice and as many degrees of θo as the
        // reference extrapolates beyond the last θo (to 90°; at most 10°), so the rebuilt table
        // extrapolates twice as far as the full one does (10 rather than 5° of θo on a
        // goniometer to 85°; from θi 70° rather than 80°), as the other folds double the
        // spacing.
        let last = ti[ti.len() - 1];
        let cut = top - (std::f64::consts::FRAC_PI_2 - top).clamp(0.0, 10f64.to_radians());
        out.push((
            format!(
                "without θi = {}° and θo > {:.0}° (extrapolation)",
                last as f64 / 100.0,
                cut.to_degrees()
            ),
            FoldKind::Extrapolation,
            Box::new(move |k| key(ds.theta_i[k]) != last && ds.theta_o[k] <= cut + 1e-9),
        ));
    }
    if let Some(ph) = slices((0..ds.len()).map(|k| azimuth(ds, k))) {
        for parity in 0..2 {
            let drop: Vec<i64> = ph.iter().copied().skip(parity).step_by(2).collect();
            out.push((
                format!(
                    "without alternate azimuth slices ({} of {})",
                    drop.len(),
                    ph.len()
                ),
                FoldKind::Azimuth,
                Box::new(move |k| !drop.contains(&key(azimuth(ds, k)))),
            ));
        }
    }
    if out.is_empty() {
        for parity in 0..2 {
            out.push((
                format!("without alternate samples ({})", ["even", "odd"][parity]),
                FoldKind::Samples,
                Box::new(move |k| k % 2 != parity),
            ));
        }
    }
    out
}

/// The cross-validation folds of `ds` (`fold_sets`), in parallel, `progress` called as each
/// ends (their fits counting in `watch`): each subset's own fit of the base model (`kind`,
/// `dist`; the full data's `fill` where that fit fails or is not usable), and the subset
/// rebuilt on it ([`crate::render::reconstruct::reconstruct`]) on a
/// table of `dims`. The base is refitted so that a fold knows nothing of the samples it
/// leaves out: the full data's fit would carry them into the fold's reconstruction, and the
/// fold would differ from the reference less than the reference from the truth.
///
/// With a prior, each fold's table is rebuilt on the fold's own posterior
/// ([`crate::prior::Posterior::condition`] on the subset): the prior is part of the
/// reconstruction the fold re-runs.
pub fn folds(
    ds: &Dataset,
    dims: crate::render::measured::Dims,
    (kind, dist): (crate::model::ModelKind, crate::model::Distribution),
    fill: crate::model::Model,
    prior: Option<&Arc<crate::prior::Prior>>,
    progress: &(dyn Fn(&str) + Sync),
    watch: Option<&crate::fit::Watch>,
) -> Vec<Fold> {
    use rayon::prelude::*;
    fold_sets(ds)
        .into_par_iter()
        .map(|(name, kind_of_fold, sub)| {
            let base = super::fit_one(&sub, kind, dist, 0, watch)
                .ok()
                .filter(|r| r.usable())
                .map_or(fill, |r| r.model_for(0));
            let on = prior
                .and_then(|p| {
                    crate::prior::Posterior::condition(
                        p.clone(),
                        &sub,
                        &crate::prior::PosteriorOptions::default(),
                    )
                })
                .map(crate::render::measured::Base::posterior);
            let table = Arc::new(crate::render::reconstruct::reconstruct_on(
                &sub, dims, base, on,
            ));
            progress(&format!(
                "cross-validation fold refitted and rebuilt ({name})"
            ));
            Fold {
                name,
                kind: kind_of_fold,
                table,
            }
        })
        .collect()
}

/// The spacing of the data's slices of θi and of azimuth, and the largest θi (degrees), when
/// they come in slices.
pub fn spacings(ds: &Dataset) -> (Option<f64>, Option<f64>, Option<f64>) {
    let step = |v: Vec<i64>| {
        v.windows(2)
            .map(|w| (w[1] - w[0]) as f64 / 100.0)
            .fold(0.0f64, f64::max)
    };
    (
        slices(ds.theta_i.iter().copied()).map(step),
        slices((0..ds.len()).map(|k| azimuth(ds, k))).map(step),
        slices(ds.theta_i.iter().copied()).and_then(|v| v.last().map(|&x| x as f64 / 100.0)),
    )
}

/// The reference's own error in `scene`: each fold's table rendered (as `material` makes it)
/// and compared with the (prepared) `reference` image by LDR-ꟻLIP over `mask`; the largest p99 and mean
/// over the folds, the per-pixel largest error, and the kind of the worst fold. `None` with
/// no folds.
pub fn cross_validate(
    scene: &Scene,
    reference: &Image,
    folds: &[Fold],
    mask: &[bool],
    material: &(dyn Fn(Arc<Tabulated>) -> Material + Sync),
) -> (Option<ReferenceError>, Vec<f32>, Option<FoldKind>) {
    let prepared = super::Prepared::new(reference, mask);
    cross_validate_against(scene, &scene.corners(), &prepared, folds, mask, material)
}

/// [`cross_validate`] against a reference prepared once for all its comparisons.
pub(super) fn cross_validate_against(
    scene: &Scene,
    corners: &crate::render::Corners,
    reference: &super::Prepared,
    folds: &[Fold],
    mask: &[bool],
    material: &(dyn Fn(Arc<Tabulated>) -> Material + Sync),
) -> (Option<ReferenceError>, Vec<f32>, Option<FoldKind>) {
    let mut map_max = vec![0f32; reference.image.pixels.len()];
    let (mut p99, mut mean, mut worst) = (0.0f64, 0.0f64, None);
    // The folds rendered and compared in parallel (each deterministic), then taken in order.
    use rayon::prelude::*;
    let judged: Vec<_> = folds
        .par_iter()
        .map(|fold| {
            let (img, _) = super::render_with(scene, corners, material(fold.table.clone()));
            let map = reference.flip(&img);
            let f = crate::render::compare::summarise(&map, mask, super::FLIP_LEVEL);
            (f, map)
        })
        .collect();
    for (fold, (f, map)) in folds.iter().zip(judged) {
        let m = crate::render::compare::summarise(&map, &[], super::FLIP_LEVEL).mean;
        if f.p99 > p99 || worst.is_none() {
            worst = Some(fold.kind);
        }
        p99 = p99.max(f.p99);
        mean = mean.max(m);
        for (a, b) in map_max.iter_mut().zip(&map) {
            *a = a.max(*b);
        }
    }
    let err = (!folds.is_empty()).then(|| ReferenceError {
        flip_p99: p99,
        flip_mean: mean,
        method: method(folds),
    });
    (err, map_max, worst)
}

/// The method's description for `choose.json`.
pub fn method(folds: &[Fold]) -> String {
    format!(
        "cross-validation: the table rebuilt {} ({} folds), each rendered and compared with the \
         reference by LDR-ꟻLIP; the largest fold (each fold doubles the spacing or the \
         extrapolation's reach, so it differs from the reference by at least the reference's \
         own error wherever that error grows at least linearly with the spacing)",
        folds
            .iter()
            .map(|f| f.name.as_str())
            .collect::<Vec<_>>()
            .join("; "),
        folds.len()
    )
}

/// The verdict and its reason. `passes` is the chosen model, if any; `closest` the closest
/// one and its error; `err` the reference's error under the threshold's metric (ꟻLIP p99 for
/// metrics other than ꟻLIP); `worst` the fold with the largest error; `spacing` the data's θi
/// and azimuth slice spacing; `beyond` the share of lit pixels outside measured cells.
#[allow(clippy::too_many_arguments)]
pub fn verdict(
    chosen: Option<&str>,
    closest: (&str, f64),
    metric: &str,
    threshold: f64,
    err: f64,
    worst: Option<FoldKind>,
    spacing: (Option<f64>, Option<f64>, Option<f64>),
    beyond: f64,
) -> (Verdict, String) {
    if err > threshold {
        let why = match worst {
            Some(FoldKind::ThetaI) => format!(
                "it changes by {metric} {err:.3} when alternate interior θi slices are left out: the \
                 {}° steps of θi are too coarse for this scene's highlight; measure at finer θi \
                 steps (at least where the scene's configurations lie)",
                spacing
                    .0
                    .map(|s| format!("{s}"))
                    .unwrap_or_else(|| "?".into())
            ),
            Some(FoldKind::Azimuth) => format!(
                "it changes by {metric} {err:.3} when alternate azimuth slices are left out: the \
                 highlight is narrower than the {}° azimuth spacing near the mirror; measure at \
                 finer azimuth steps near the mirror direction",
                spacing
                    .1
                    .map(|s| format!("{s}"))
                    .unwrap_or_else(|| "?".into())
            ),
            Some(FoldKind::Extrapolation) => format!(
                "it changes by {metric} {err:.3} when the outermost θi slice and the last θo \
                 are left out: the scene needs configurations at the edge of the measured \
                 angles (θi up to {}°), where the measurement has no outer neighbour to \
                 confirm it; measure closer to grazing incidence and view",
                spacing
                    .2
                    .map(|s| format!("{s}"))
                    .unwrap_or_else(|| "?".into())
            ),
            _ => format!(
                "it changes by {metric} {err:.3} when alternate samples are left out: the samples \
                 are too sparse for this scene; measure more densely"
            ),
        };
        let beyond = if beyond > 0.05 {
            format!(
                "; {:.0} % of the lit pixels lie beyond the measured configurations \
                 (extrapolated)",
                100.0 * beyond
            )
        } else {
            String::new()
        };
        return (
            Verdict::Undetermined,
            format!(
                "the reference is not determined: {why}{beyond}; the closest model, {} at {:.3}, \
                 cannot be judged below that; `brdfit plan DATA --scene SCENE --budget 100 -o \
                 plan.csv` names the configurations to measure next",
                closest.0, closest.1
            ),
        );
    }
    match chosen {
        Some(m) => (
            Verdict::Chosen,
            format!(
                "{m} is within {metric} {threshold}, and the reference's own error ({err:.3}) is \
                 below the threshold"
            ),
        ),
        None => (
            Verdict::None,
            format!(
                "no model is within {metric} {threshold} (the closest, {}, is at {:.3}) while the \
                 reference's own error ({err:.3}) is below it: the material needs a model richer \
                 than these",
                closest.0, closest.1
            ),
        ),
    }
}

/// `text` in lines of at most `width` characters, broken at spaces (a word longer than a
/// line stands alone on its line).
pub(super) fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let n = line.chars().count();
        if n > 0 && n + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Dataset {
        let mut ds = Dataset::new(crate::data::Quantity::Brdf, vec![("v".into(), None)]);
        for ti in [10.0f64, 20.0, 30.0, 40.0] {
            for po in [0.0f64, 15.0, 30.0, 345.0] {
                for to in [0.2, 0.5] {
                    ds.push([ti.to_radians(), 0.0, to, po.to_radians()], &[ti]);
                }
            }
        }
        ds
    }

    /// Goniometer-like data give two θi folds that leave out alternate interior slices (the
    /// first and last kept), an extrapolation fold and two azimuth folds, counted by hand.
    #[test]
    fn folds_leave_out_alternate_slices() {
        let f = fold_sets(&grid());
        assert_eq!(f.len(), 5);
        assert_eq!(f[0].1, FoldKind::ThetaI);
        // Without θi = 20°: the 24 rows of 10°, 30° and 40° remain; without 30°, likewise.
        assert_eq!(f[0].2.len(), 24);
        assert!(
            f[0].2.channels[0]
                .values
                .iter()
                .all(|&v| v == 10.0 || v == 30.0 || v == 40.0)
        );
        assert_eq!(f[1].2.len(), 24);
        assert!(f[1].2.channels[0].values.iter().all(|&v| v != 30.0));
        // Without θi = 40° and θo > 28.6° − 10° (the reference reaches 61.4° beyond its
        // data, the cut at most 10°): the rows of θo 0.2 rad, 3 × 4.
        assert_eq!(f[2].1, FoldKind::Extrapolation);
        assert_eq!(f[2].2.len(), 12);
        assert_eq!(f[3].1, FoldKind::Azimuth);
        assert_eq!(f[3].2.len() + f[4].2.len(), 32);
        assert_eq!(spacings(&grid()), (Some(10.0), Some(315.0), Some(40.0)));
    }

    /// A reason wraps at spaces into lines no longer than the width (counted by hand); a
    /// longer word stands alone.
    #[test]
    fn reason_wraps() {
        assert_eq!(
            wrap("the reference is not determined", 12),
            ["the", "reference is", "not", "determined"]
        );
        assert_eq!(wrap("a verylongword b", 4), ["a", "verylongword", "b"]);
        assert!(wrap("", 10).is_empty());
    }

    /// The three verdicts and their conditions.
    #[test]
    fn verdicts() {
        let v = |chosen, err| {
            verdict(
                chosen,
                ("phong", 0.03),
                "flip_p99",
                0.05,
                err,
                Some(FoldKind::Azimuth),
                (Some(10.0), Some(15.0), Some(80.0)),
                0.0,
            )
        };
        assert_eq!(v(Some("phong"), 0.01).0, Verdict::Chosen);
        assert_eq!(v(None, 0.01).0, Verdict::None);
        let (u, why) = v(Some("phong"), 0.2);
        assert_eq!(u, Verdict::Undetermined);
        assert!(why.contains("15° azimuth spacing"), "{why}");
    }

    /// Every lit pixel inside the measured cells (none beyond), the extrapolation fold the
    /// worst: the reason speaks of the edge of the measured angles, never of configurations
    /// beyond them (which the table's 100 % measured share would contradict).
    #[test]
    fn an_edge_fold_is_not_called_beyond_the_data() {
        let (u, why) = verdict(
            None,
            ("phong", 0.03),
            "flip_p99",
            0.05,
            0.2,
            Some(FoldKind::Extrapolation),
            (Some(10.0), Some(15.0), Some(80.0)),
            0.0,
        );
        assert_eq!(u, Verdict::Undetermined);
        assert!(!why.contains("beyond"), "{why}");
        assert!(why.contains("edge of the measured angles"), "{why}");
    }
}

//! What the reference images are rendered with: the measurement resampled onto a
//! half/difference table (with its cross-validation folds), or the best global fit.

use super::fitting::fit_one;
use super::{MAX_FILL_SHARE, model_name, verdict};
use crate::data::Dataset;
use crate::fit::{FitResult, Watch};
use crate::model::{Distribution, Model, ModelKind};
use crate::prior::{Posterior, PosteriorOptions, Prior};
use crate::render::measured::{Base, Dims, Tabulated};
use std::sync::Arc;
use std::time::Instant;

/// What the reference images are rendered with: the resampled measurement, or (when most of
/// its table would be the fill) the best global fit.
pub(super) struct Reference {
    pub(super) table: Arc<Tabulated>,
    /// The table rebuilt without parts of the data (cross-validation).
    pub(super) folds: Vec<verdict::Fold>,
    /// The data's θi and azimuth slice spacing and largest θi (degrees).
    pub(super) spacing: (Option<f64>, Option<f64>, Option<f64>),
    pub(super) fill: Model,
    pub(super) fill_name: String,
    /// True when the table is the reference.
    pub(super) measured: bool,
    /// Resampling time (s).
    pub(super) seconds: f64,
    /// Time to refit and rebuild the cross-validation folds (s).
    pub(super) fold_seconds: f64,
    /// What the table's ratios multiply: `samples` (the best fit) or the prior's posterior.
    pub(super) method: String,
}

impl Reference {
    /// Resample `ds` on the lowest-BIC usable model among the global fits and a
    /// Torrance–Sparrow fit with Löw et al.'s ABC distribution (the better the base model,
    /// the flatter the ratio the table interpolates).
    /// `progress` is called as the base's own fit ends (when it is not among `global`), as
    /// the table is rebuilt and as each cross-validation fold is (see
    /// [`progress_steps`](super::progress_steps)). Every fit counts its passes over the data
    /// in `watch`.
    pub(super) fn new(
        ds: &Dataset,
        global: &[FitResult],
        prior: Option<&Arc<Prior>>,
        progress: &(dyn Fn(&str) + Sync),
        watch: Option<&Watch>,
    ) -> Reference {
        let abc = (ModelKind::TorranceSparrow, Distribution::Abc);
        let extra = if global.iter().any(|g| (g.model, g.dist) == abc) {
            None
        } else {
            let f = fit_one(ds, abc.0, abc.1, 0, watch).ok();
            progress(&format!(
                "{}: fitted as a base of the resampling",
                abc.0.label(abc.1)
            ));
            f
        };
        let bases: Vec<&FitResult> = global.iter().chain(extra.as_ref()).collect();
        let best = (0..bases.len())
            .filter(|&i| bases[i].usable())
            .min_by(|&a, &b| bases[a].bic.total_cmp(&bases[b].bic))
            .unwrap_or(0);
        let base = bases[best];
        let fill = base.model_for(0);
        let dims = Dims::for_samples(ds.len());
        let post =
            prior.and_then(|p| Posterior::condition(p.clone(), ds, &PosteriorOptions::default()));
        let method = match &post {
            Some(p) => format!(
                "prior: the samples' ratios to the posterior of {} materials' {} principal \
                 components (cross-validated residual {:.3} in ln f·cos)",
                p.prior.materials.len(),
                p.components(),
                p.cv_rms
            ),
            None => "samples: the samples' ratios to the best fit".into(),
        };
        let on = post.map(Base::posterior);
        // The table beside its cross-validation folds (each deterministic).
        let ((table, seconds), (folds, fold_seconds)) = rayon::join(
            || {
                let t = Instant::now();
                let table = Arc::new(crate::render::reconstruct::reconstruct_on(
                    ds, dims, fill, on,
                ));
                progress("resampled table rebuilt from every sample");
                (table, t.elapsed().as_secs_f64())
            },
            || {
                let t = Instant::now();
                let base = (base.model, base.dist);
                let folds = verdict::folds(ds, dims, base, fill, prior, progress, watch);
                (folds, t.elapsed().as_secs_f64())
            },
        );
        let measured = table.fill_share() <= MAX_FILL_SHARE;
        Reference {
            table,
            folds,
            spacing: verdict::spacings(ds),
            fill,
            fill_name: model_name(base.model, base.dist),
            measured,
            seconds,
            fold_seconds,
            method,
        }
    }

    /// The name `choose.json` gives the reference.
    pub(super) fn name(&self) -> String {
        if self.measured {
            "measured".into()
        } else {
            self.fill_name.clone()
        }
    }

    /// f_r of the reference.
    pub(super) fn brdf(&self, g: &crate::model::Geometry) -> f64 {
        if self.measured {
            self.table.brdf(g)
        } else {
            self.fill.brdf(g)
        }
    }

    /// Pixel-weighted share of `samples` in measured table cells.
    pub(super) fn measured_share(&self, samples: &Dataset) -> f64 {
        if !self.measured {
            return 0.0;
        }
        let w = samples.weights.as_deref().unwrap_or(&[]);
        let (mut inside, mut all) = (0.0, 0.0);
        for k in 0..samples.len().min(w.len()) {
            let g = crate::model::Geometry::from_angles(
                samples.theta_i[k],
                samples.phi_i[k],
                samples.theta_o[k],
                samples.phi_o[k],
            );
            all += w[k];
            if self.table.is_measured(&g) {
                inside += w[k];
            }
        }
        inside / all.max(1.0)
    }
}

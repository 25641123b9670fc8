//! The model a scene needs: render the measurement itself, fit each model where the scene
//! looks, and choose the simplest whose image a viewer cannot tell from the measurement's.
//!
//! For each lighting case of a scene:
//! 1. the measurement is resampled onto a half/difference table
//!    ([`Tabulated`](crate::render::measured::Tabulated)) and rendered
//!    as the test object's material: the reference image;
//! 2. the light/eye configurations of the object's lit pixels are collected
//!    ([`Scene::lit_configurations`]), binned, and the measurement is looked up there, with the
//!    pixel counts as weights: the scene-weighted samples;
//! 3. every candidate model is fitted to those samples with the usual fitter (its loss,
//!    verification and physical checks), rendered, and compared with the reference by
//!    LDR-ꟻLIP, ΔE_ITP and RMSE ([`crate::render::compare`]) over the object's pixels; its fit
//!    to all the data is rendered and compared too, and the row judges the one of the two that
//!    renders closer among the usable ones ([`FitUsed`]);
//! 4. the chosen model is the simplest (fewest parameters, then the cheapest to render, in
//!    [`RENDER_COST_ORDER`]) whose error stays within the threshold.
//!
//! Blinn's Figure 7 is the case this answers: front lit, Phong is enough for magnesium oxide;
//! edge lit, it is not (Blinn 1977, §"Comparison of the models").

mod chart;
mod colour;
mod files;
mod fitting;
mod judge;
mod markdown;
mod reference;
mod run;
mod sheet;
mod verdict;

use crate::fit::Watch;
use crate::model::{Distribution, Model, ModelKind};
use crate::render::measured::Dims;
use crate::render::{Image, Scene};
use crate::render::{Lighting, fig7_scene};
use glam::DVec3;

pub use colour::{colour_reference, rgb_channels};
pub use files::write;
pub use fitting::{MAX_FINE_CONFIGURATIONS, PIXEL_STALL, exposure, refit_on_pixels, scene_samples};
pub use markdown::{case_table, markdown};
pub use run::{choose, choose_with, pick, progress_steps};
pub use sheet::flip_scale;
pub use verdict::{Fold, FoldKind, ReferenceError, Verdict, cross_validate, folds};
// For the cross-validation (`verdict`), which renders and judges folds as the candidates are.
use fitting::fit_one;
use judge::{Prepared, render_with};

/// An error key of [`ModelRow`] that a threshold can test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    /// Mean LDR-ꟻLIP over the whole image.
    FlipMean,
    /// 99th percentile of LDR-ꟻLIP over the object's pixels.
    FlipP99,
    /// Mean ΔE_ITP over the object's pixels.
    DeltaEItpMean,
    /// 99th percentile of ΔE_ITP over the object's pixels.
    DeltaEItpP99,
    /// RMSE of linear radiance over the object's pixels.
    Rmse,
}

impl Metric {
    /// Every metric, in the order of the JSON keys.
    pub const ALL: [Metric; 5] = [
        Metric::FlipMean,
        Metric::FlipP99,
        Metric::DeltaEItpMean,
        Metric::DeltaEItpP99,
        Metric::Rmse,
    ];

    /// The JSON key.
    pub fn key(self) -> &'static str {
        match self {
            Metric::FlipMean => "flip_mean",
            Metric::FlipP99 => "flip_p99",
            Metric::DeltaEItpMean => "delta_e_itp_mean",
            Metric::DeltaEItpP99 => "delta_e_itp_p99",
            Metric::Rmse => "rmse",
        }
    }

    /// The metric named by a JSON key.
    pub fn from_key(key: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.key() == key)
    }
}

/// The largest error a chosen model may have.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Threshold {
    /// Which error.
    pub metric: Metric,
    /// Its largest admitted value.
    pub value: f64,
}

/// The default threshold: the 99th percentile of LDR-ꟻLIP over the object at most 0.05.
///
/// Calibration (README, "Choosing a model for a scene"): on the front-lit Figure 7 sphere at
/// 512², scaling the whole image's radiance by 1.02, about the Weber fraction of luminance
/// discrimination, gives a ꟻLIP p99 of 0.049 and a ΔE_ITP p99 of 1.3 (one just-noticeable
/// difference is about 1); by 1.05 it gives 0.082 and 3.3. So 0.05 admits a model whose worst
/// percent of the object differs no more than a barely visible 2 % change of exposure.
pub const DEFAULT_THRESHOLD: Threshold = Threshold {
    metric: Metric::FlipP99,
    value: 0.05,
};

/// The level [`Summary::above`](crate::render::compare::Summary::above) counts ꟻLIP errors
/// above (also shown in the error maps' bar).
pub const FLIP_LEVEL: f64 = 0.05;

/// Models of equal parameter count ordered by the time a render with them takes (measured by
/// `benches/choose.rs`, front-lit Figure 7 at 512² with MERL alumina-oxide fits: lambert 11.6
/// ms; phong 15.4, blinn-phong 16.8; torrance-sparrow d3 14.7, ggx-smith 16.5, d1 18.2, d2
/// 18.4; the measured table 20.2): the tie-break of the choice. A fixed order keeps the choice the same
/// on every run, while measured times vary. Torrance–Sparrow with ABC (five parameters) and
/// ggx-smith-2 (six) come last: no other model has as many parameters, so they tie with none;
/// after them the tabulated-NDF model (35 parameters, and per shading point two 33-term dot
/// products where GGX has a closed form).
pub const RENDER_COST_ORDER: [(ModelKind, Distribution); 10] = [
    (ModelKind::Lambert, Distribution::D3),
    (ModelKind::Phong, Distribution::D3),
    (ModelKind::BlinnPhong, Distribution::D3),
    (ModelKind::TorranceSparrow, Distribution::D3),
    (ModelKind::GgxSmith, Distribution::D3),
    (ModelKind::TorranceSparrow, Distribution::D1),
    (ModelKind::TorranceSparrow, Distribution::D2),
    (ModelKind::TorranceSparrow, Distribution::Abc),
    (ModelKind::GgxSmith2, Distribution::D3),
    (ModelKind::TabulatedNdf, Distribution::D3),
];

/// Fill shares above this make the resampled measurement mostly a model: the reference is
/// then the best global fit, and the case's `reference` says so.
pub const MAX_FILL_SHARE: f64 = 0.5;

/// The name of a candidate as `--model` spells it, with `-d1`/`-d2`/`-d3` for the models
/// that take a facet distribution (`torrance-sparrow-d3`).
pub fn model_name(kind: ModelKind, dist: Distribution) -> String {
    if kind.has_distribution() {
        format!("{}-{}", kind.name(), dist.name())
    } else {
        kind.name().to_string()
    }
}

/// A named lighting case: a scene whose material 0 is the test object.
#[derive(Clone, Debug)]
pub struct Case {
    /// Name (`front`, `edge`, or the scene file's stem).
    pub name: String,
    /// The scene.
    pub scene: Scene,
}

/// Refuse a scene whose test object (`materials[0]`) has no lit pixel: every model would
/// render it black and score the same. The error says whether the camera sees none of it or
/// no light reaches what it sees, and the fix.
pub fn check_test_object(scene: &Scene) -> Result<(), String> {
    let Some(test) = scene.materials.first() else {
        return Err(
            "the scene has no material\n  fix: give it a [materials.NAME] for the test object"
                .into(),
        );
    };
    let (lit, mask) = scene.lit_configurations(0);
    if !lit.is_empty() {
        return Ok(());
    }
    let seen = mask.iter().filter(|&&m| m).count();
    Err(if seen == 0 {
        format!(
            "the test object (material {}) has no lit pixel: the camera sees no object of that material, so every model would score the same\n  fix: aim the camera at it, or name the test object with test_object = \"NAME\"",
            test.name
        )
    } else if in_shadow(scene) {
        format!(
            "the test object (material {}) has no lit pixel: the camera sees {seen} pixels of it, and a light shines on that side, but other objects cast their shadow over all of it, so every model would score the same\n  fix: move the light, or the object between it and the test object, so the light reaches the side the camera sees",
            test.name
        )
    } else {
        format!(
            "the test object (material {}) has no lit pixel: the camera sees {seen} pixels of it, but no light reaches them from above the surface, so every model would score the same\n  fix: move a light so it shines on the side the camera sees (a light inside a closed object reaches nothing)",
            test.name
        )
    })
}

/// The case of a scene file: `scene` read from `path` (named in errors), its camera's image
/// within the size limits (`allow_large` lifts them) and its test object lit
/// ([`check_test_object`]); the case is named by the file's stem.
pub fn scene_case(path: &std::path::Path, scene: Scene, allow_large: bool) -> Result<Case, String> {
    crate::render::check_image_size(scene.camera.width, scene.camera.height, allow_large)
        .map_err(|e| format!("{}: camera: {e}", path.display()))?;
    check_test_object(&scene).map_err(|e| format!("{}: {e}", path.display()))?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    Ok(Case { name, scene })
}

/// True when the test object, alone in `scene` (the other objects removed), has lit pixels:
/// what keeps the light from it is the others' shadow.
fn in_shadow(scene: &Scene) -> bool {
    let mut alone = scene.clone();
    alone.objects.retain(|o| o.material == 0);
    !alone.lit_configurations(0).0.is_empty()
}

/// The two lighting cases of Blinn's Figure 7 at `res`², lit by the light alone (no ambient
/// term, so the images show only the BRDF under the light).
pub fn fig7_cases(res: u32) -> Vec<Case> {
    [("front", Lighting::Front), ("edge", Lighting::Edge)]
        .into_iter()
        .map(|(name, lighting)| {
            let mut scene = fig7_scene(Model::blinn_mgo(), lighting, res);
            scene.ambient = DVec3::ZERO;
            Case {
                name: name.into(),
                scene,
            }
        })
        .collect()
}

/// Options of [`choose`].
#[derive(Clone, Debug)]
pub struct ChooseOptions {
    /// Candidate models, in the order rows are reported.
    pub candidates: Vec<(ModelKind, Distribution)>,
    /// The error a chosen model may have.
    pub threshold: Threshold,
    /// Random-start verification of every fit (see
    /// [`FitOptions::verify`](crate::fit::FitOptions::verify)).
    pub verify: usize,
    /// Counts every fit's passes over the data as they start
    /// ([`FitOptions::watch`](crate::fit::FitOptions::watch)), for a progress display to read
    /// while the fits run.
    pub watch: Option<Watch>,
    /// What real materials are like: the reference multiplies the samples' ratios onto the
    /// posterior under this prior instead of onto the best fit ([`crate::prior`]).
    pub prior: Option<std::sync::Arc<crate::prior::Prior>>,
}

impl Default for ChooseOptions {
    fn default() -> Self {
        ChooseOptions {
            // The tabulated NDF (the order's last) only when asked: its 35-parameter pixel
            // refits took 65 of the main job's 195 s on Blinn's MgO.
            candidates: RENDER_COST_ORDER[..RENDER_COST_ORDER.len() - 1].to_vec(),
            threshold: DEFAULT_THRESHOLD,
            verify: 4,
            watch: None,
            prior: None,
        }
    }
}

/// Which of a candidate's two fits a row judges: the one fitted to the scene-weighted samples
/// or the one fitted to all the data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FitUsed {
    /// The fit to the scene-weighted samples.
    SceneWeighted,
    /// The fit to all the data.
    Global,
}

impl FitUsed {
    /// The JSON and table spelling: `scene-weighted` or `global`.
    pub fn name(self) -> &'static str {
        match self {
            FitUsed::SceneWeighted => "scene-weighted",
            FitUsed::Global => "global",
        }
    }
}

/// One candidate in one case. Each model is fitted twice, to the scene-weighted samples and
/// to all the data; both are rendered and the row judges the one that renders closer to the
/// reference among the usable ones (`used`; the scene-weighted fit on a tie).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ModelRow {
    /// Model name as `--model` spells it (`torrance-sparrow-d3`).
    pub model: String,
    /// Facet distribution (`d3` for models without one).
    pub distribution: Distribution,
    /// Which fit the row's errors, image and choice are of.
    #[serde(default = "scene_weighted")]
    pub used: FitUsed,
    /// Parameters of the scene-weighted fit.
    #[serde(with = "ordered_map")]
    pub params: Vec<(String, f64)>,
    /// Parameters of the fit to all the data.
    #[serde(with = "ordered_map")]
    pub global_params: Vec<(String, f64)>,
    /// BIC of the fit to all the data.
    pub bic: f64,
    /// The errors below are those of the fit `used`. Mean LDR-ꟻLIP over the whole image.
    pub flip_mean: f64,
    /// 99th percentile of LDR-ꟻLIP over the object.
    pub flip_p99: f64,
    /// Share of the object's pixels with ꟻLIP above [`FLIP_LEVEL`].
    pub flip_above: f64,
    /// Mean ΔE_ITP over the object.
    pub delta_e_itp_mean: f64,
    /// 99th percentile of ΔE_ITP over the object.
    pub delta_e_itp_p99: f64,
    /// RMSE of linear radiance over the object.
    pub rmse: f64,
    /// ꟻLIP p99 over the object of the scene-weighted fit's rendering.
    #[serde(default)]
    pub scene_flip_p99: f64,
    /// ꟻLIP p99 over the object of the global fit's rendering.
    pub global_flip_p99: f64,
    /// Wall time of the scene-weighted fit (s).
    pub fit_seconds: f64,
    /// Wall time of the render (s).
    pub render_seconds: f64,
    /// Rays traced for the render.
    pub rays: u64,
    /// Whether the fit `used` is usable (verification, first-order check, physical values).
    pub usable: bool,
    /// Why the scene-weighted fit is not usable (empty when it is).
    #[serde(default)]
    pub unusable: Vec<String>,
    /// Why the global fit is not usable (empty when it is).
    #[serde(default)]
    pub global_unusable: Vec<String>,
}

fn scene_weighted() -> FitUsed {
    FitUsed::SceneWeighted
}

impl ModelRow {
    /// The value of an error key.
    pub fn error(&self, m: Metric) -> f64 {
        match m {
            Metric::FlipMean => self.flip_mean,
            Metric::FlipP99 => self.flip_p99,
            Metric::DeltaEItpMean => self.delta_e_itp_mean,
            Metric::DeltaEItpP99 => self.delta_e_itp_p99,
            Metric::Rmse => self.rmse,
        }
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.params.len()
    }
}

/// One lighting case's answer.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct CaseResult {
    /// Case name.
    pub case: String,
    /// `measured`, or the model rendered as the reference when the measurement could not be.
    pub reference: String,
    /// The simplest model within the threshold; `None` when none is.
    pub chosen: Option<String>,
    /// The model with the lowest error under the threshold's metric.
    pub closest: String,
    /// Scene-weighted samples: distinct (θi, θo, Δφ) bins of the lit pixels.
    pub configurations: usize,
    /// Lit object pixels × lights they see.
    pub lit_pixels: usize,
    /// Share of those (pixel-weighted) whose configuration falls in a measured table cell;
    /// the rest show the fill model.
    pub measured_share: f64,
    /// Wall time of the reference render (s).
    pub reference_render_seconds: f64,
    /// `chosen`, `none` or `undetermined` (the reference's own error exceeds the threshold;
    /// `chosen` is then null).
    #[serde(default = "verdict_chosen")]
    pub verdict: Verdict,
    /// Why, in words a person can act on.
    #[serde(default)]
    pub reason: String,
    /// The reference's own error, by cross-validation (`choose::verdict`).
    #[serde(default)]
    pub reference_error: Option<ReferenceError>,
    /// One row per candidate.
    pub models: Vec<ModelRow>,
}

fn verdict_chosen() -> Verdict {
    Verdict::Chosen
}

impl CaseResult {
    /// The answer in words: "phong is enough", or "no model is within the threshold; the
    /// closest is torrance-sparrow-d3".
    pub fn answer(&self) -> String {
        if self.verdict == Verdict::Undetermined && self.lit_pixels == 0 {
            return format!(
                "undetermined: no pixel of the test object is lit (closest {})",
                self.closest
            );
        }
        if self.verdict == Verdict::Undetermined && self.reason.contains(run::FEW_SAMPLES) {
            return format!(
                "undetermined: {} (closest {})",
                run::FEW_SAMPLES,
                self.closest
            );
        }
        if self.verdict == Verdict::Undetermined {
            return format!(
                "undetermined: the reference's own error, ꟻLIP p99 {:.3}, exceeds the threshold \
                 (closest {})",
                self.reference_error
                    .as_ref()
                    .map_or(f64::NAN, |e| e.flip_p99),
                self.closest
            );
        }
        match &self.chosen {
            Some(m) => format!("{m} is enough"),
            None => format!(
                "no model is within the threshold; the closest is {}",
                self.closest
            ),
        }
    }
}

/// The whole answer, as written to `choose.json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ChooseResult {
    /// The threshold applied.
    pub threshold: ThresholdJson,
    /// Channel judged.
    pub channel: String,
    /// Table size of the resampled measurement.
    pub table: Dims,
    /// Share of table cells with no sample near, filled from the best global fit.
    pub fill_share: f64,
    /// The global fit that filled them.
    pub fill_model: String,
    /// Wall time of the resampling (s).
    pub resample_seconds: f64,
    /// What the resampled measurement's ratios multiply: `samples: …` (the best fit) or
    /// `prior: …` (the posterior under a prior of measured materials).
    #[serde(default)]
    pub reference_method: String,
    /// One entry per lighting case.
    pub cases: Vec<CaseResult>,
}

/// The threshold as `choose.json` writes it: `{"metric": "flip_p99", "value": 0.05}`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ThresholdJson {
    /// Error key.
    pub metric: String,
    /// Largest admitted value.
    pub value: f64,
}

/// Images of one case, for the files and the contact sheet.
pub struct CaseImages {
    /// Case name.
    pub case: String,
    /// (name, image): the reference first, then each candidate.
    pub renders: Vec<(String, Image)>,
    /// Per-candidate LDR-ꟻLIP maps (same order as `renders[1..]`).
    pub flip_maps: Vec<Vec<f32>>,
    /// The reference's own error per pixel (the largest LDR-ꟻLIP over the cross-validation
    /// folds).
    pub reference_error_map: Vec<f32>,
    /// Object mask.
    pub mask: Vec<bool>,
}

mod ordered_map {
    use serde::ser::SerializeMap;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &[(String, f64)], s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(v.len()))?;
        for (k, x) in v {
            m.serialize_entry(k, x)?;
        }
        m.end()
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<(String, f64)>, D::Error> {
        let m = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        Ok(m.into_iter()
            .map(|(k, v)| (k, v.as_f64().unwrap_or(f64::NAN)))
            .collect())
    }
}

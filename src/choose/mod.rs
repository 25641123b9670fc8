//! The model a scene needs: render the measurement itself, fit each model where the scene
//! looks, and choose the simplest whose image a viewer cannot tell from the measurement's.
//!
//! For each lighting case of a scene:
//! 1. the measurement is resampled onto a half/difference table ([`Tabulated`]) and rendered
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

use crate::data::Dataset;
use crate::fit::{FitOptions, FitResult, Watch, fit};
use crate::model::{Distribution, Model, ModelKind};
use crate::render::compare::{self, Summary};
use crate::render::measured::{Dims, Tabulated};
use crate::render::scene::{Lighting, fig7_scene};
use crate::render::{Image, Scene};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

mod verdict;
pub use verdict::{Fold, FoldKind, ReferenceError, Verdict, cross_validate, folds};

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

/// The level [`Summary::above`] counts ꟻLIP errors above (also shown in the error maps' bar).
pub const FLIP_LEVEL: f64 = 0.05;

/// Models of equal parameter count ordered by the time a render with them takes (measured by
/// `benches/choose.rs`, front-lit Figure 7 at 512² with MERL alumina-oxide fits: lambert 11.6
/// ms; phong 15.4, blinn-phong 16.8; torrance-sparrow d3 14.7, ggx-smith 16.5, d1 18.2, d2
/// 18.4; the measured table 20.2): the tie-break of the choice. A fixed order keeps the choice the same
/// on every run, while measured times vary. Torrance–Sparrow with ABC (five parameters) and
/// ggx-smith-2 (six) come last: no other model has as many parameters, so they tie with none.
pub const RENDER_COST_ORDER: [(ModelKind, Distribution); 9] = [
    (ModelKind::Lambert, Distribution::D3),
    (ModelKind::Phong, Distribution::D3),
    (ModelKind::BlinnPhong, Distribution::D3),
    (ModelKind::TorranceSparrow, Distribution::D3),
    (ModelKind::GgxSmith, Distribution::D3),
    (ModelKind::TorranceSparrow, Distribution::D1),
    (ModelKind::TorranceSparrow, Distribution::D2),
    (ModelKind::TorranceSparrow, Distribution::Abc),
    (ModelKind::GgxSmith2, Distribution::D3),
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
    } else {
        format!(
            "the test object (material {}) has no lit pixel: the camera sees {seen} pixels of it, but no light reaches them from above the surface, so every model would score the same\n  fix: move a light so it shines on the side the camera sees (a light inside a closed object reaches nothing)",
            test.name
        )
    })
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
    /// Random-start verification of every fit (see [`FitOptions::verify`]).
    pub verify: usize,
    /// Counts every fit's passes over the data as they start ([`FitOptions::watch`]), for a
    /// progress display to read while the fits run.
    pub watch: Option<Watch>,
}

impl Default for ChooseOptions {
    fn default() -> Self {
        ChooseOptions {
            candidates: RENDER_COST_ORDER.to_vec(),
            threshold: DEFAULT_THRESHOLD,
            verify: 4,
            watch: None,
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

/// Bin width of scene-weighted configurations (radians): 1°.
const BIN: f64 = std::f64::consts::PI / 180.0;

/// More 1° bins than this are merged into 2° bins (Blinn's sphere front lit at 512²: 19,161
/// bins of 1°, 5,497 of 2°; every ꟻLIP p99 of `choose.md` the same to 4 digits, a quarter of
/// the fitting time).
pub const MAX_FINE_CONFIGURATIONS: usize = 8_000;

/// The configurations `configs` binned to `width` (radians) in (θi, θo, Δφ): per bin the sum
/// of its configurations and their count, in a fixed order.
fn bin_configurations(configs: &[[f64; 3]], width: f64) -> Vec<([f64; 3], f64)> {
    let mut bins: std::collections::BTreeMap<[i64; 3], ([f64; 3], f64)> = Default::default();
    for c in configs {
        let key = c.map(|a| (a / width).floor() as i64);
        let e = bins.entry(key).or_insert(([0.0; 3], 0.0));
        for k in 0..3 {
            e.0[k] += c[k];
        }
        e.1 += 1.0;
    }
    bins.into_values().collect()
}

/// The scene-weighted sample set: the configurations of `scene`'s lit pixels of `material`,
/// binned to 1° in (θi, θo, Δφ) (2° where there would be more than
/// [`MAX_FINE_CONFIGURATIONS`] bins) with the bins' pixel counts as weights, each bin at the
/// mean of its configurations, valued by `brdf` (f_r there). Bins are in a fixed order.
pub fn scene_samples(
    scene: &Scene,
    material: usize,
    brdf: &dyn Fn(&crate::model::Geometry) -> f64,
) -> (Dataset, Vec<bool>, usize) {
    let (configs, mask) = scene.lit_configurations(material);
    let mut bins = bin_configurations(&configs, BIN);
    if bins.len() > MAX_FINE_CONFIGURATIONS {
        bins = bin_configurations(&configs, 2.0 * BIN);
    }
    let mut ds = Dataset::new(crate::data::Quantity::Brdf, vec![("scene".into(), None)]);
    let mut weights = Vec::with_capacity(bins.len());
    for (sum, count) in &bins {
        let a = sum.map(|s| s / count);
        let g = crate::model::Geometry::from_angles(a[0], 0.0, a[1], a[2]);
        let y = brdf(&g);
        if !(y > 0.0) || !y.is_finite() {
            continue;
        }
        ds.push([a[0], 0.0, a[1], a[2]], &[y]);
        weights.push(*count);
    }
    ds.weights = Some(weights);
    ds.meta.source = "scene-weighted samples".into();
    (ds, mask, configs.len())
}

/// Fit one candidate with the usual fitter; the fitted model and the result.
fn fit_one(
    ds: &Dataset,
    kind: ModelKind,
    dist: Distribution,
    verify: usize,
    watch: Option<&Watch>,
) -> Result<FitResult, crate::fit::FitError> {
    let mut o = FitOptions::new(kind);
    o.dist = dist;
    o.verify = verify;
    o.profile = false;
    o.watch = watch.cloned();
    Ok(fit(ds, &o)?.remove(0))
}

/// The scene's exposure as a factor on f_r cosθi: the irradiance its lights give (green) at
/// the point the camera looks at, facing each light; a pixel of the test object shows about
/// this × f_r cosθi (plus the ambient term, which this leaves out).
pub fn exposure(scene: &Scene) -> f64 {
    scene
        .lights
        .iter()
        .map(|l| l.toward(scene.camera.target).2.y)
        .sum::<f64>()
}

/// The pixel-loss refits stop when their cost fell by less than 10⁻⁶ relative over the last
/// 25 steps ([`crate::fit::Limits::stall`]). Torrance–Sparrow on Blinn's MgO front lit slides
/// toward n → 1, ps → ∞ (F ≈ 0 holding the lobe down, a fit not usable anyway) with each step
/// lowering the cost by about 10⁻⁸ and ran to the 500-iteration limit in every refinement and
/// verification start; a converging refit falls faster until its last few steps (GGX–Smith
/// there: 5·10⁻⁶ or more per 25 steps until 1e-9 of its end).
pub const PIXEL_STALL: (usize, f64) = (25, 1e-6);

/// Refit `start` (the log-loss fit of the scene-weighted samples `ds`) on what the pixel
/// shows ([`crate::fit::Loss::Pixel`]): the samples scaled to the scene's `exposure` and the
/// display value of each, clipped as the PNG clips, compared; local refinements from the
/// log-loss fit and from `global` (the model's fit to all the data; both scaled alike), the
/// lower pixel cost kept and its f_r scaled back, then verified with `verify` random starts
/// unless it already fails the physical checks. Each configuration counts by its pixel
/// count (the samples' weights), and a local fit never ends above its start, so the result's
/// pixel cost is never above the global fit's; a refinement stops where its cost stalls
/// ([`PIXEL_STALL`]). The physical checks are made again on the result. The log-loss fit
/// stands where both refinements fail. Every fit counts its passes over the data in `watch`.
pub fn refit_on_pixels(
    ds: &Dataset,
    start: FitResult,
    global: &Model,
    exposure: f64,
    verify: usize,
    watch: Option<&Watch>,
) -> FitResult {
    use crate::model::Role;
    // The log-loss fit is made unverified (only a start here): where it stands, it is
    // verified now.
    let fallback = |start: FitResult| {
        if verify > 0 && start.verification.is_none() {
            fit_one(ds, start.model, start.dist, verify, watch).unwrap_or(start)
        } else {
            start
        }
    };
    if !(exposure > 0.0 && exposure.is_finite()) {
        return fallback(start);
    }
    let specs = start.model.params(start.dist);
    let start_kind = (start.model, start.dist);
    let linear = |name: &str| {
        specs
            .iter()
            .any(|s| s.name == name && matches!(s.role, Role::Specular | Role::Diffuse))
    };
    let mut scaled = ds.clone();
    for c in &mut scaled.channels {
        c.values.iter_mut().for_each(|v| *v *= exposure);
    }
    let run = |start: Vec<(String, f64)>, verify: usize| {
        let mut o = FitOptions::new(start_kind.0);
        o.dist = start_kind.1;
        o.loss = crate::fit::Loss::Pixel;
        o.limits.stall = PIXEL_STALL;
        o.local_only = true;
        o.profile = false;
        o.verify = verify;
        o.watch = watch.cloned();
        o.start = start;
        fit(&scaled, &o).ok().map(|mut f| f.remove(0))
    };
    let scaled_start = |m: &Model| {
        m.param_names()
            .iter()
            .zip(m.params())
            .map(|(n, v)| (n.to_string(), if linear(n) { v * exposure } else { *v }))
            .collect::<Vec<_>>()
    };
    // Both refinements unverified; the better one is then verified once (from its own
    // solution, so the local method only confirms it).
    let best = [
        run(scaled_start(&start.model_for(0)), 0),
        run(scaled_start(global), 0),
    ]
    .into_iter()
    .flatten()
    .min_by(|a, b| a.cost.total_cmp(&b.cost));
    let Some(best) = best else {
        return fallback(start);
    };
    // The fit in the data's units with the physical checks made again (and whether any fails).
    let unscaled = |mut r: FitResult| {
        let scaled_checks = crate::fit::physical::problems(&r);
        r.unusable.retain(|u| !scaled_checks.contains(u));
        for (n, v) in &mut r.params {
            if linear(n) {
                *v /= exposure;
            }
        }
        let checks = crate::fit::physical::problems(&r);
        let unphysical = !checks.is_empty();
        r.unusable.extend(checks);
        (r, unphysical)
    };
    let (unverified, unphysical) = unscaled(best.clone());
    // A refinement that fails the physical checks stays not usable whatever random starts
    // find, so it is not verified (the verification of Torrance–Sparrow's slide toward n → 1
    // on Blinn's MgO front lit was three quarters of its refit's time).
    if verify == 0 || unphysical {
        return unverified;
    }
    unscaled(run(best.params.clone(), verify).unwrap_or(best)).0
}

/// `scene` rendered with `material` as its test object, reading the case's geometry pass
/// `corners` ([`Scene::corners`]); the image and its wall time (s).
fn render_with(
    scene: &Scene,
    corners: &crate::render::Corners,
    material: crate::render::Material,
) -> (Image, f64) {
    let mut s = scene.clone();
    s.materials[0] = material;
    let t = Instant::now();
    let img = s.render_with_corners(Some(corners), &|| {});
    (img, t.elapsed().as_secs_f64())
}

/// A reference image with what every comparison against it needs computed once: its
/// LDR-ꟻLIP side (8-bit sRGB, filtered colours and features) and its ITP over the mask.
struct Prepared<'a> {
    image: &'a Image,
    flip: compare::FlipReference,
    itp: Vec<[f64; 3]>,
}

impl<'a> Prepared<'a> {
    fn new(image: &'a Image, mask: &[bool]) -> Prepared<'a> {
        // The two sides in parallel (each deterministic).
        let (flip, itp) = rayon::join(
            || {
                compare::FlipReference::new(
                    &crate::render::to_srgb8(image),
                    image.width,
                    image.height,
                    compare::PIXELS_PER_DEGREE,
                )
            },
            || compare::itp_masked(&image.pixels, mask),
        );
        Prepared { image, flip, itp }
    }

    /// Per-pixel LDR-ꟻLIP of `test` against the reference (on the 8-bit sRGB images).
    fn flip(&self, test: &Image) -> Vec<f32> {
        self.flip.against(&crate::render::to_srgb8(test))
    }
}

/// ΔE_ITP's summary and the RMSE of `test` against a prepared reference over `mask`.
fn other_errors(reference: &Prepared, test: &Image, mask: &[bool]) -> (Summary, f64) {
    let de =
        compare::delta_e_itp_against(&reference.image.pixels, &reference.itp, &test.pixels, mask);
    (
        compare::summarise(&de, mask, 1.0),
        compare::rmse(&reference.image.pixels, &test.pixels, mask),
    )
}

/// One fit's render and its errors against the reference: ꟻLIP's summary and map, and
/// (ΔE_ITP's summary, RMSE) once computed ([`Judged::complete`]; at once when the threshold's
/// metric reads them).
struct Judged {
    image: Image,
    flip: Summary,
    map: Vec<f32>,
    others: Option<(Summary, f64)>,
    usable: bool,
}

impl Judged {
    fn new(
        reference: &Prepared,
        image: Image,
        mask: &[bool],
        usable: bool,
        metric: Metric,
    ) -> Judged {
        let map = reference.flip(&image);
        let flip = compare::summarise(&map, mask, FLIP_LEVEL);
        let others = (!matches!(metric, Metric::FlipMean | Metric::FlipP99))
            .then(|| other_errors(reference, &image, mask));
        Judged {
            image,
            flip,
            map,
            others,
            usable,
        }
    }

    /// ΔE_ITP's summary and RMSE, computed now if not yet (only the fit a row judges needs
    /// them).
    fn complete(&mut self, reference: &Prepared, mask: &[bool]) -> (Summary, f64) {
        let image = &self.image;
        *self
            .others
            .get_or_insert_with(|| other_errors(reference, image, mask))
    }

    /// The error under `metric` (ΔE_ITP and RMSE as NaN before [`Judged::complete`]; `new`
    /// computes them when `metric` reads them).
    fn error(&self, metric: Metric) -> f64 {
        let (delta_e, rmse) = self.others.map_or((None, f64::NAN), |(d, r)| (Some(d), r));
        match metric {
            Metric::FlipMean => compare::summarise(&self.map, &[], FLIP_LEVEL).mean,
            Metric::FlipP99 => self.flip.p99,
            Metric::DeltaEItpMean => delta_e.map_or(f64::NAN, |d| d.mean),
            Metric::DeltaEItpP99 => delta_e.map_or(f64::NAN, |d| d.p99),
            Metric::Rmse => rmse,
        }
    }
}

/// Which of a model's two fits a row judges: a usable one before one that is not, then the
/// lower error under `metric`; the scene-weighted fit on a tie.
fn used_fit(scene: &Judged, global: &Judged, metric: Metric) -> FitUsed {
    let better = match (scene.usable, global.usable) {
        (true, false) => false,
        (false, true) => true,
        _ => global.error(metric) < scene.error(metric),
    };
    if better {
        FitUsed::Global
    } else {
        FitUsed::SceneWeighted
    }
}

/// Which rows pass, and the choice: the simplest passing row (fewest parameters, then
/// [`RENDER_COST_ORDER`]); and the closest row (lowest error on the threshold's metric).
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
    let closest = (0..rows.len())
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
    let reference = Reference::new(ds, &global, progress, opts.watch.as_ref());
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
    let (results, images): (Vec<CaseResult>, Vec<CaseImages>) = done.into_iter().unzip();
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
            cases: results,
        },
        images,
    ))
}

/// What the reference images are rendered with: the resampled measurement, or (when most of
/// its table would be the fill) the best global fit.
struct Reference {
    table: Arc<Tabulated>,
    /// The table rebuilt without parts of the data (cross-validation).
    folds: Vec<verdict::Fold>,
    /// The data's θi and azimuth slice spacing and largest θi (degrees).
    spacing: (Option<f64>, Option<f64>, Option<f64>),
    fill: Model,
    fill_name: String,
    /// True when the table is the reference.
    measured: bool,
    /// Resampling time (s).
    seconds: f64,
    /// Time to refit and rebuild the cross-validation folds (s).
    fold_seconds: f64,
}

impl Reference {
    /// Resample `ds` on the lowest-BIC usable model among the global fits and a
    /// Torrance–Sparrow fit with Löw et al.'s ABC distribution (the better the base model,
    /// the flatter the ratio the table interpolates).
    /// `progress` is called as the base's own fit ends (when it is not among `global`), as
    /// the table is rebuilt and as each cross-validation fold is (see [`progress_steps`]).
    /// Every fit counts its passes over the data in `watch`.
    fn new(
        ds: &Dataset,
        global: &[FitResult],
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
        // The table beside its cross-validation folds (each deterministic).
        let ((table, seconds), (folds, fold_seconds)) = rayon::join(
            || {
                let t = Instant::now();
                let table = Arc::new(crate::render::reconstruct::reconstruct(ds, dims, fill));
                progress("resampled table rebuilt from every sample");
                (table, t.elapsed().as_secs_f64())
            },
            || {
                let t = Instant::now();
                let base = (base.model, base.dist);
                let folds = verdict::folds(ds, dims, base, fill, progress, watch);
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
        }
    }

    /// The name `choose.json` gives the reference.
    fn name(&self) -> String {
        if self.measured {
            "measured".into()
        } else {
            self.fill_name.clone()
        }
    }

    /// f_r of the reference.
    fn brdf(&self, g: &crate::model::Geometry) -> f64 {
        if self.measured {
            self.table.brdf(g)
        } else {
            self.fill.brdf(g)
        }
    }

    /// Pixel-weighted share of `samples` in measured table cells.
    fn measured_share(&self, samples: &Dataset) -> f64 {
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
            // Nothing lit: the global fit stands in (every model renders black there).
            let fitted = if samples.is_empty() {
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

/// Write each case's renders (`DIR/<case>/measured.{exr,png}` and `DIR/<case>/<model>.{exr,png}`,
/// one exposure), its contact sheet (`sheet.png`) and chart (`chart.{svg,png}`), then
/// `DIR/choose.json` and `DIR/choose.md`; returns the paths written, in order.
pub fn write(
    dir: &std::path::Path,
    result: &ChooseResult,
    images: &[CaseImages],
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use crate::output::write_bytes_atomic;
    // The cases' directories in order (the list of directories created stays in case
    // order), then each case's files in parallel; the paths in case order.
    for case in &result.cases {
        crate::output::create_dir(&dir.join(&case.case))?;
    }
    let per_case = result
        .cases
        .par_iter()
        .zip(images.par_iter())
        .map(|(case, imgs)| write_case(&dir.join(&case.case), case, imgs, &result.threshold))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut wrote: Vec<std::path::PathBuf> = per_case.into_iter().flatten().collect();
    let json = dir.join("choose.json");
    let mut text = serde_json::to_string_pretty(result)?;
    text.push('\n');
    write_bytes_atomic(&json, text.as_bytes())?;
    wrote.push(json);
    let md = dir.join("choose.md");
    write_bytes_atomic(&md, markdown(result).as_bytes())?;
    wrote.push(md);
    Ok(wrote)
}

/// One case's files in `sub` (renders, the reference's error map when undetermined, sheet,
/// chart); the paths written, in order.
fn write_case(
    sub: &std::path::Path,
    case: &CaseResult,
    imgs: &CaseImages,
    threshold: &ThresholdJson,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use crate::output::write_bytes_atomic;
    // The renders' PNG and EXR encodings in parallel, beside the error map, the sheet and
    // the chart (each file is written whole, so the order of work is free); the paths in
    // render order, then the others.
    let (saved, others) = rayon::join(
        || {
            imgs.renders
                .par_iter()
                .enumerate()
                .map(|(k, (name, img))| {
                    crate::render::save(
                        img,
                        &sub.join(if k == 0 { "measured" } else { name.as_str() }),
                    )
                })
                .collect::<anyhow::Result<Vec<_>>>()
        },
        || -> anyhow::Result<Vec<std::path::PathBuf>> {
            let mut wrote = Vec::new();
            if case.verdict == Verdict::Undetermined {
                let path = sub.join("reference-error.png");
                write_bytes_atomic(&path, &reference_error_png(imgs, threshold)?)?;
                wrote.push(path);
            }
            let sheet = sub.join("sheet.png");
            write_bytes_atomic(&sheet, &contact_sheet(case, imgs, threshold)?)?;
            wrote.push(sheet);
            let (svg, png) = crate::plot::save(
                &TradeoffChart {
                    case: case.clone(),
                    threshold: threshold.clone(),
                },
                &sub.join("chart"),
            )?;
            wrote.push(svg);
            wrote.push(png);
            Ok(wrote)
        },
    );
    let mut wrote: Vec<std::path::PathBuf> = saved?.into_iter().flatten().collect();
    wrote.extend(others?);
    Ok(wrote)
}

/// The reference's own error per pixel as an sRGB PNG: magma from 0 to twice the threshold
/// (ꟻLIP), the object's pixels only (others black).
fn reference_error_png(imgs: &CaseImages, th: &ThresholdJson) -> anyhow::Result<Vec<u8>> {
    let lut = nv_flip::magma_lut().to_vec();
    let top = if th.metric.starts_with("flip") {
        2.0 * th.value
    } else {
        0.1
    } as f32;
    let img = &imgs.renders[0].1;
    let rgb: Vec<u8> = imgs
        .reference_error_map
        .iter()
        .zip(&imgs.mask)
        .flat_map(|(&e, &m)| if m { magma(&lut, e, top) } else { [0, 0, 0] })
        .collect();
    crate::plot::encode_png(img.width, img.height, &rgb)
}

/// The answer as Markdown: per case, the choice and one row per model.
pub fn markdown(r: &ChooseResult) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Channel: {}; measurement resampled onto a {}×{}×{} half/difference table, {:.1} % of cells \
         filled from the {} fit. Threshold: {} ≤ {}.\n",
        r.channel,
        r.table.0[0],
        r.table.0[1],
        r.table.0[2],
        100.0 * r.fill_share,
        r.fill_model,
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

/// Magma colour of an error in [0, `max`] (NVIDIA ꟻLIP's map stretched to `max`; errors
/// above it take the brightest colour).
fn magma(lut: &[u8], e: f32, max: f32) -> [u8; 3] {
    let i = (((e / max).clamp(0.0, 1.0) * 255.0).round() as usize).min(255);
    [lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]]
}

/// The top of the contact sheet's ꟻLIP colour scale: the median of the models' ꟻLIP 99th
/// percentiles `p99` (the upper one of an even count), rounded up to two significant digits,
/// within [0.01, 1]. So the maps use the colours where the models' errors lie (on a fixed
/// 0–1 scale errors of 0.03 were black), and one far-off model (Lambert at 0.6) does not
/// darken the others; the worse half of the models saturate at the brightest colour. The
/// bar shows the value.
pub fn flip_scale(p99: &[f64]) -> f64 {
    let mut v: Vec<f64> = p99.iter().copied().filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let worst = v.get(v.len() / 2).copied().unwrap_or(0.0);
    if worst <= 0.01 {
        return 0.01;
    }
    if worst >= 1.0 {
        return 1.0;
    }
    let step = 10f64.powf(worst.log10().floor() - 1.0);
    // The 1e-9 keeps a value already on the grid (0.034) from rounding up a step.
    ((worst / step - 1e-9).ceil() * step).min(1.0)
}

/// The contact sheet of a case, 4 columns wide so its text stays legible where the report
/// shows it: each cell is a render over its ꟻLIP map (magma, 0 to [`flip_scale`]), labelled
/// with the model and its 99th percentiles; the reference's cell holds the colour bar with
/// its scale instead of a map. A small visible region (an edge-lit crescent) is shown zoomed
/// with a smooth filter ([`crate::render::zoom_crop`]), and the title says so.
fn contact_sheet(
    case: &CaseResult,
    imgs: &CaseImages,
    th: &ThresholdJson,
) -> anyhow::Result<Vec<u8>> {
    use plotters::prelude::*;
    let (tile, gap, label_h) = (256u32, 14u32, 40u32);
    let cols = 4u32;
    let w = gap + cols * (tile + gap);
    let srgb: Vec<Vec<u8>> = imgs
        .renders
        .par_iter()
        .map(|(_, i)| crate::render::to_srgb8(i))
        .collect();
    let (iw, ih) = (imgs.renders[0].1.width, imgs.renders[0].1.height);
    let (cx, cy, side) = crate::render::visible_crop(&srgb, iw, ih, 8);
    // The title (20 px, about 11 px a character) and the verdict's reason (13 px, about 7 px
    // a character) wrapped to the sheet's width, 24 and 17 px a line; the tiles start below.
    let zoom = if side < iw.min(ih) {
        format!(", images zoomed ×{:.1}", iw.min(ih) as f64 / side as f64)
    } else {
        String::new()
    };
    let title = verdict::wrap(
        &format!(
            "{} lit: {} ({} ≤ {}{zoom})",
            case.case,
            case.answer(),
            th.metric,
            th.value
        ),
        (w - 2 * gap) as usize / 11,
    );
    let reason = verdict::wrap(&case.reason, (w - 2 * gap) as usize / 7);
    let reason_y = 38 + 24 * (title.len().max(1) as u32 - 1);
    let top = reason_y + 8 + 17 * reason.len().max(1) as u32;
    let n = imgs.renders.len() as u32;
    let rows = n.div_ceil(cols);
    let cell_h = label_h + 2 * tile + 8;
    let h = top + rows * (cell_h + gap);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let lut = nv_flip::magma_lut().to_vec();
    let put = |buf: &mut Vec<u8>, x: u32, y: u32, c: [u8; 3]| {
        let o = ((y * w + x) * 3) as usize;
        buf[o..o + 3].copy_from_slice(&c);
    };
    let origin = |k: u32| {
        (
            gap + (k % cols) * (tile + gap),
            top + (k / cols) * (cell_h + gap),
        )
    };
    let p99: Vec<f64> = case.models.iter().map(|m| m.flip_p99).collect();
    let scale = flip_scale(&p99);
    // The colour bar spans x = 8 … tile − 9 of the reference's lower tile.
    let (bar0, bar1) = (8u32, tile - 9);
    // Each cell's zoomed render and map in parallel (each deterministic), then laid out.
    let tiles: Vec<(Vec<u8>, Option<Vec<u8>>)> = (0..n as usize)
        .into_par_iter()
        .map(|k| {
            let render = crate::render::zoom_crop(&srgb[k], iw, (cx, cy, side), tile);
            let map = (k > 0).then(|| {
                let coloured: Vec<u8> = imgs.flip_maps[k - 1]
                    .iter()
                    .flat_map(|&e| magma(&lut, e, scale as f32))
                    .collect();
                crate::render::zoom_crop(&coloured, iw, (cx, cy, side), tile)
            });
            (render, map)
        })
        .collect();
    for (k, (render, map)) in (0..n).zip(tiles) {
        let (x0, y0) = origin(k);
        for y in 0..tile {
            for x in 0..tile {
                let i = 3 * (y * tile + x) as usize;
                put(
                    &mut buf,
                    x0 + x,
                    y0 + label_h + y,
                    [render[i], render[i + 1], render[i + 2]],
                );
                let below = y0 + label_h + tile + 8 + y;
                if let Some(m) = &map {
                    put(&mut buf, x0 + x, below, [m[i], m[i + 1], m[i + 2]]);
                } else if (tile / 2..tile / 2 + 20).contains(&y) && (bar0..=bar1).contains(&x) {
                    let e = (x - bar0) as f32 / (bar1 - bar0) as f32 * scale as f32;
                    put(&mut buf, x0 + x, below, magma(&lut, e, scale as f32));
                }
            }
        }
    }
    {
        crate::plot::register_font_once();
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let e = |r: Result<(), DrawingAreaErrorKind<_>>| {
            r.map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"))
        };
        let text = |s: String, x: u32, y: u32, size: f64| {
            root.draw(&Text::new(
                s,
                (x as i32, y as i32),
                ("sans-serif", size).into_font(),
            ))
        };
        for (i, line) in title.iter().enumerate() {
            e(text(line.clone(), gap, 12 + 24 * i as u32, 20.0))?;
        }
        for (i, line) in reason.iter().enumerate() {
            e(text(line.clone(), gap, reason_y + 17 * i as u32, 13.0))?;
        }
        for k in 0..n {
            let (x0, y0) = origin(k);
            if k == 0 {
                e(text(
                    format!("reference ({})", case.reference),
                    x0,
                    y0 + 2,
                    16.0,
                ))?;
                let bar_y = y0 + label_h + tile + 8 + tile / 2;
                e(text(
                    "ꟻLIP error, 0 to the models' median p99".into(),
                    x0 + 8,
                    bar_y - 42,
                    14.0,
                ))?;
                e(text(
                    format!(
                        "(brightest: {} or more)",
                        crate::model::significant(scale, 2)
                    ),
                    x0 + 8,
                    bar_y - 24,
                    14.0,
                ))?;
                let at = |v: f64| x0 + bar0 + ((v / scale) * (bar1 - bar0) as f64).round() as u32;
                let half = crate::model::significant(scale / 2.0, 2);
                let top = crate::model::significant(scale, 2);
                e(text("0".into(), at(0.0), bar_y + 26, 14.0))?;
                e(text(
                    half.clone(),
                    at(scale / 2.0) - 4 * half.len() as u32,
                    bar_y + 26,
                    14.0,
                ))?;
                e(text(
                    top.clone(),
                    at(scale) - 8 * top.len() as u32,
                    bar_y + 26,
                    14.0,
                ))?;
                // The threshold's ꟻLIP level, where the scale reaches it.
                if th.metric.starts_with("flip") && th.value > 0.0 && th.value < scale {
                    let x = at(th.value);
                    e(root.draw(&PathElement::new(
                        vec![(x as i32, bar_y as i32 - 4), (x as i32, bar_y as i32 + 24)],
                        RGBColor(0, 160, 255).stroke_width(2),
                    )))?;
                    e(text(
                        format!("threshold {}", th.value),
                        x.saturating_sub(30).max(x0),
                        bar_y + 44,
                        13.0,
                    ))?;
                }
                continue;
            }
            let m = &case.models[k as usize - 1];
            let mark = if case.chosen.as_deref() == Some(&m.model) {
                " ✔ chosen"
            } else {
                ""
            };
            let global = if m.used == FitUsed::Global {
                " (global fit)"
            } else {
                ""
            };
            e(text(format!("{}{global}{mark}", m.model), x0, y0 + 2, 16.0))?;
            e(text(
                format!(
                    "ꟻLIP p99 {:.3}   ΔE_ITP p99 {:.2}",
                    m.flip_p99, m.delta_e_itp_p99
                ),
                x0,
                y0 + 21,
                14.0,
            ))?;
        }
        root.present()
            .map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"))?;
    }
    crate::plot::encode_png(w, h, &buf)
}

/// Image error against fit + render time, one labelled point per model, the chosen one
/// ringed, the threshold as a line: speed against accuracy in the image.
struct TradeoffChart {
    case: CaseResult,
    threshold: ThresholdJson,
}

impl crate::plot::Chart for TradeoffChart {
    fn size(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    ) -> anyhow::Result<()> {
        use plotters::prelude::*;
        let metric = Metric::from_key(&self.threshold.metric).unwrap_or(Metric::FlipP99);
        root.fill(&WHITE).map_err(crate::plot::err)?;
        let pts: Vec<(f64, f64, &ModelRow)> = self
            .case
            .models
            .iter()
            .map(|m| {
                (
                    (m.fit_seconds + m.render_seconds).max(1e-4),
                    m.error(metric),
                    m,
                )
            })
            .collect();
        let (mut x0, mut x1) = (f64::INFINITY, 0.0f64);
        let mut y1 = self.threshold.value;
        for &(x, y, _) in &pts {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y1 = y1.max(y);
        }
        let lx1 = x1 * 2.2;
        // At least a decade, so the log axis has labelled ticks.
        let lx0 = (x0 / 1.4).min(lx1 / 12.0);
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "{} lit: image error against fit + render time (verdict: {})",
                    self.case.case,
                    self.case.verdict.name()
                ),
                ("sans-serif", 18),
            )
            .margin(14)
            .x_label_area_size(46)
            .y_label_area_size(64)
            // Room below 0, so a point with no error is not on the axis and its label fits
            // on its own line.
            .build_cartesian_2d((lx0..lx1).log_scale(), -0.06 * y1..y1 * 1.12)
            .map_err(crate::plot::err)?;
        chart
            .configure_mesh()
            .x_desc("fit + render time (s, log scale)")
            .y_desc(metric.key())
            // Enough ticks that 1-2-5 values inside the decade are labelled, not only 0.1.
            .x_labels(30)
            .x_label_formatter(&|v| crate::plot::log_tick(*v))
            .y_label_formatter(&|v| {
                if *v < -1e-12 {
                    String::new()
                } else {
                    crate::plot::tick(*v)
                }
            })
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(crate::plot::err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(lx0, self.threshold.value), (lx1, self.threshold.value)],
                RGBColor(200, 0, 0).stroke_width(1),
            )))
            .map_err(crate::plot::err)?;
        let th_at = (lx0 * 1.05, self.threshold.value + 0.02 * y1);
        chart
            .draw_series(std::iter::once(Text::new(
                format!("threshold {}", self.threshold.value),
                th_at,
                ("sans-serif", 13).into_font().color(&RGBColor(200, 0, 0)),
            )))
            .map_err(crate::plot::err)?;
        // Points first, then direct labels placed greedily so none overlaps another, nor the
        // threshold line and its label.
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let (tx, ty) = chart.backend_coord(&th_at);
        let (_, line_y) = chart.backend_coord(&(lx0, self.threshold.value));
        let mut placed: Vec<(i32, i32, i32, i32)> = vec![
            (tx, ty, tx + 110, ty + 16),
            (xr.start, line_y - 1, xr.end, line_y + 1),
        ];
        let colour_of = |y: f64| {
            if y <= self.threshold.value {
                RGBColor(0, 120, 60)
            } else {
                RGBColor(60, 60, 60)
            }
        };
        // Every point (and the chosen one's ring) is drawn and kept free of labels first.
        for &(x, y, m) in &pts {
            let chosen = self.case.chosen.as_deref() == Some(&m.model);
            chart
                .draw_series(std::iter::once(Circle::new(
                    (x, y),
                    4,
                    colour_of(y).filled(),
                )))
                .map_err(crate::plot::err)?;
            let r = if chosen {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (x, y),
                        9,
                        RGBColor(200, 0, 0).stroke_width(2),
                    )))
                    .map_err(crate::plot::err)?;
                10
            } else {
                5
            };
            let (px, py) = chart.backend_coord(&(x, y));
            placed.push((px - r, py - r, px + r, py + r));
        }
        // Then the labels, lowest error first (the chosen model's and its neighbours' nearest
        // their points); a label moved off its point's line is joined to it by a leader line.
        let mut order: Vec<usize> = (0..pts.len()).collect();
        order.sort_by(|&a, &b| pts[a].1.total_cmp(&pts[b].1));
        for k in order {
            let (x, y, m) = pts[k];
            let chosen = self.case.chosen.as_deref() == Some(&m.model);
            let colour = colour_of(y);
            let label = format!("{}{}", m.model, if chosen { " (chosen)" } else { "" });
            let (px, py) = chart.backend_coord(&(x, y));
            let h = 16;
            let w = 7 * label.chars().count() as i32;
            let (left, top) = crate::plot::place_label(
                &mut placed,
                (px + 2, py),
                (w, h),
                (xr.start, yr.start, xr.end, yr.end),
            );
            if crate::plot::needs_leader(py, top, h) {
                let end = if left > px { left } else { left + w };
                root.draw(&PathElement::new(
                    vec![(px, py), (end, top + h / 2)],
                    colour.mix(0.6).stroke_width(1),
                ))
                .map_err(crate::plot::err)?;
            }
            root.draw(&Text::new(
                label,
                (left, top),
                ("sans-serif", 13).into_font().color(&colour),
            ))
            .map_err(crate::plot::err)?;
        }
        Ok(())
    }
}

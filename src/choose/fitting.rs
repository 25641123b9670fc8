//! The scene-weighted samples of a case and the candidates' fits to them: the usual fit with
//! the log loss, then the refit on what the pixel shows.

use crate::data::Dataset;
use crate::fit::{FitOptions, FitResult, Watch, fit};
use crate::model::{Distribution, Model, ModelKind};
use crate::render::Scene;

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
pub(super) fn fit_one(
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
        // The samples are scaled by the exposure: an albedo bound of 1 would hold the wrong
        // material; the physical checks are made in the data's units below instead.
        o.conserve = false;
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

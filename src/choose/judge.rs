//! A fit rendered in the case's scene and judged against the reference image: LDR-ꟻLIP,
//! ΔE_ITP and RMSE over the object, and which of a model's two fits a row judges.

use super::{FLIP_LEVEL, FitUsed, Metric};
use crate::render::compare::{self, Summary};
use crate::render::{Image, Scene};
use std::time::Instant;

/// `scene` rendered with `material` as its test object, reading the case's geometry pass
/// `corners` ([`Scene::corners`]); the image and its wall time (s).
pub(super) fn render_with(
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
pub(super) struct Prepared<'a> {
    pub(super) image: &'a Image,
    flip: compare::FlipReference,
    itp: Vec<[f64; 3]>,
}

impl<'a> Prepared<'a> {
    pub(super) fn new(image: &'a Image, mask: &[bool]) -> Prepared<'a> {
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
    pub(super) fn flip(&self, test: &Image) -> Vec<f32> {
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
pub(super) struct Judged {
    pub(super) image: Image,
    pub(super) flip: Summary,
    pub(super) map: Vec<f32>,
    others: Option<(Summary, f64)>,
    pub(super) usable: bool,
}

impl Judged {
    pub(super) fn new(
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
    pub(super) fn complete(&mut self, reference: &Prepared, mask: &[bool]) -> (Summary, f64) {
        let image = &self.image;
        *self
            .others
            .get_or_insert_with(|| other_errors(reference, image, mask))
    }

    /// The error under `metric` (ΔE_ITP and RMSE as NaN before [`Judged::complete`]; `new`
    /// computes them when `metric` reads them).
    pub(super) fn error(&self, metric: Metric) -> f64 {
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
pub(super) fn used_fit(scene: &Judged, global: &Judged, metric: Metric) -> FitUsed {
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

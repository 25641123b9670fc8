//! RGB data in colour: each channel's measurement resampled onto its own half/difference
//! table and rendered as the test object's material, the three renders joined into one colour
//! image (channel c of the image from channel c's render). `choose` judges one channel; this
//! is the reference as a viewer sees the material.

use super::Case;
use super::fitting::fit_one;
use crate::data::{ChannelSelect, Dataset};
use crate::model::{Distribution, ModelKind};
use crate::render::Image;
use crate::render::measured::Dims;
use std::sync::Arc;

/// The base model each channel's table is resampled on (its ratios to this model's fit of
/// that channel are interpolated): Torrance–Sparrow with Löw et al.'s ABC distribution, the
/// base `choose` fits beside its candidates.
const BASE: (ModelKind, Distribution) = (ModelKind::TorranceSparrow, Distribution::Abc);

/// The names of RGB data's channels in image order, when `ds` has exactly channels r, g and b
/// (in any order; case ignored): their indices in `ds`.
pub fn rgb_channels(ds: &Dataset) -> Option<[usize; 3]> {
    let find =
        |n: &str| (0..ds.channels.len()).find(|&c| ds.channels[c].name.eq_ignore_ascii_case(n));
    (ds.channels.len() == 3).then_some(())?;
    Some([find("r")?, find("g")?, find("b")?])
}

/// The reference image of `case` in colour for RGB data `ds`: each of r, g, b resampled on
/// its own table (filled by its own fit of the base model) and rendered with the case's test
/// object; `None` when `ds` is not RGB or a channel cannot be fitted.
pub fn colour_reference(ds: &Dataset, case: &Case) -> Option<Image> {
    let idx = rgb_channels(ds)?;
    let corners = case.scene.corners();
    let mut out: Option<Image> = None;
    for (c, &k) in idx.iter().enumerate() {
        let one = ds.select(&ChannelSelect::Index(k)).ok()?;
        let fill = fit_one(&one, BASE.0, BASE.1, 0, None).ok()?.model_for(0);
        let table = crate::render::reconstruct::reconstruct_on(
            &one,
            Dims::for_samples(one.len()),
            fill,
            None,
        );
        let material = crate::render::Material {
            model: fill,
            measured: Some(Arc::new(table)),
            ..case.scene.materials[0].clone()
        };
        let (img, _) = super::judge::render_with(&case.scene, &corners, material);
        match &mut out {
            None => {
                let mut first = img;
                for p in &mut first.pixels {
                    *p = [p[0], 0.0, 0.0];
                }
                out = Some(first);
            }
            Some(o) => {
                for (p, q) in o.pixels.iter_mut().zip(&img.pixels) {
                    p[c] = q[c];
                }
            }
        }
    }
    out
}

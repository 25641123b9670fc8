//! Scene files (TOML) and the OBJ reader, read into a [`crate::render::Scene`]; a material may
//! name a fit file (`fit = "…"`), read through [`crate::fit::read_fit_file`]. The built-in Figure 7 scenes
//! are the renderer's ([`crate::render::fig7_scene`]), re-exported here.
//!
//! ```toml
//! max_depth = 4            # ray-tree depth (1 = primary rays only)
//! min_weight = 0.001       # rays weighing less are not traced
//! ambient = [0.02, 0.02, 0.02]   # uniform ambient radiance (a number is grey)
//! background = 0.0
//! [camera]
//! eye = [0, 2.2, 8]
//! target = [0, 0.8, 0]
//! up = [0, 1, 0]
//! fov = 35                  # horizontal, degrees
//! width = 512
//! height = 512
//! [antialias]
//! mode = "adaptive"         # adaptive | uniform | stratified | none
//! threshold = 0.02          # adaptive: difference of √(linear value) that subdivides
//! max_level = 3             # adaptive: at most 2^3 × 2^3 squares per pixel
//! block = 1                 # adaptive: first squares of 1, 2 or 4 pixels (>1: interpolate)
//! jitter = false            # adaptive: trace each corner at a fixed random point near it
//! samples = 4               # uniform / stratified: 4 × 4 per pixel (stratified: jittered)
//! [[lights]]
//! kind = "point"            # point (1/r² falloff) | directional
//! position = [1, 4, 9]      # point; directional lights give `direction` (toward the light)
//! color = [1, 1, 1]
//! intensity = 120           # radiant intensity (point) or irradiance (directional)
//! [materials.mgo]
//! model = "torrance-sparrow"   # or fit = "mgo.json" (relative to this file)
//! distribution = "d3"
//! params = { n = 1.8, c3 = 0.35, ps = 0.667, pd = 0.333 }
//! color = [1, 1, 1]         # diffuse colour; the highlight is white
//! ks = 0.0                  # Whitted mirror weight
//! kt = 0.0                  # Whitted transmission weight
//! ior = 1.5                 # index for the refracted ray
//! checker = { size = 1.0, color0 = [0.2, 0.2, 0.2], color1 = [0.8, 0.8, 0.8] }
//! roughness = { cmin = 0.2, frequency = 4.0 }   # Blinn's Figure 8 (torrance-sparrow d3)
//! [[objects]]
//! kind = "sphere"           # sphere | plane | mesh
//! center = [1.2, 1, 0]
//! radius = 1
//! material = "mgo"
//! ```
//! Planes take `point`, `normal` and an optional half-size `size`; meshes take `path` (an OBJ
//! file relative to the scene file).
//!
//! Reading (`parse`) checks every value (`values`) and names the line of any error
//! (`lines`); the file's own types are in `spec`, materials in `material`, meshes in `obj`,
//! and the built-in Figure 7 scenes in `preset`.

mod lines;
mod material;
mod obj;
mod parse;
mod spec;
mod values;

pub use crate::render::{Lighting, fig7_scene};
pub use obj::read_obj;
pub use parse::{MAX_LIGHTS, MAX_OBJECTS, parse_scene, parse_scene_noted, plane_axes};

use crate::render::Scene;
use anyhow::{Result, anyhow};
use lines::AtLine;
use std::path::Path;

/// Largest |coordinate| of a position (eye, target, centre, point, light position).
pub const MAX_COORD: f64 = 1e6;
/// Largest sphere radius and plane half-size.
pub const MAX_SIZE: f64 = 1e6;
/// Largest ambient or background radiance, and largest light colour component.
pub const MAX_RADIANCE: f64 = 1e6;
/// Largest light intensity, and largest product of a light's colour and intensity.
pub const MAX_INTENSITY: f64 = 1e12;
/// Most triangles of an OBJ mesh (with its BVH, about 200 bytes each).
pub const MAX_TRIANGLES: usize = 4_000_000;
/// Largest roughness-texture frequency and checker square size.
pub const MAX_FREQUENCY: f64 = 1e6;
/// Largest directional albedo (at any θi, by the quadrature `fit` uses to mark fits not
/// usable) of a material given by `model` and `params`. Blinn's lobes may exceed 1 at grazing
/// incidence, so 1 is not the limit; a million is no material (ps = 1e300 would overflow
/// the image).
pub const MAX_ALBEDO: f64 = 1e6;

/// Read a scene file.
pub fn load_scene(path: &Path) -> Result<Scene> {
    load_scene_noted(path).map(|(s, _)| s)
}

/// [`load_scene`] with the notes of [`parse_scene_noted`] (what was chosen for the user);
/// its warnings come as `warning: FILE:LINE: …`, ready to show.
pub fn load_scene_noted(path: &Path) -> Result<(Scene, Vec<String>)> {
    let text =
        crate::support::input::read_to_string_limited(path, crate::support::input::Input::Scene)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut notes = Vec::new();
    let s = parse_scene_noted(&text, dir, &mut notes).map_err(|e| {
        match e.downcast_ref::<AtLine>() {
            Some(at) => anyhow!("{}:{}: {}", path.display(), at.line, at.msg),
            None => e.context(path.display().to_string()),
        }
    })?;
    let notes = notes
        .into_iter()
        .map(|n| match n.strip_prefix("warning: line ") {
            Some(rest) => format!("warning: {}:{rest}", path.display()),
            None => n,
        })
        .collect();
    Ok((s, notes))
}

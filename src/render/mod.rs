//! A Whitted-style ray tracer (Whitted 1980) shading with the fitted reflection models.
//!
//! - Primary rays, one shadow ray per light whose direction faces the surface, recursive mirror
//!   (ks) and refraction (kt, Snell's law, total internal reflection) rays, Whitted's eq. (2):
//!   `I = I_a + Σ_j local_j + ks S + kt T`. Recursion stops at `max_depth` or when a ray's
//!   weight falls below `min_weight`; no ray is traced that the scene cannot use (no
//!   refraction ray without kt > 0, no mirror ray without ks > 0, no shadow ray toward a light
//!   behind the surface).
//! - Local model: Blinn's intensity for a unit light, `i = pd N·L + ps D G F/(N·E)` (or any
//!   [`crate::model::Model`]), turned into radiance `L = (i/π)·E_light`, i.e. f_r cosθ E, so a
//!   Lambertian surface of albedo pd under irradiance E has radiance pd E/π. The diffuse term is
//!   coloured by the material (and texture), the highlight is white, as Blinn prescribes.
//!   Ambient: a uniform ambient radiance A adds pd·A·colour.
//! - Anti-aliasing as Whitted describes: samples at pixel corners; a pixel is subdivided (up to
//!   `max_level`) only where its corner values differ beyond `threshold`, a different object is
//!   hit, or a ray passes within the minimum radius (one sample footprint at that distance) of
//!   an object smaller than that without hitting it (a small object may fall between corners). Uniform n×n supersampling and
//!   single centre samples are there for comparison.
//! - Bounding spheres for every object and a BVH for triangle meshes; rayon over rows; linear
//!   f32 OpenEXR and 8-bit sRGB PNG output; deterministic.
//!
//! The renderer's parts: [`Scene`] and the checks of its inputs here; rays (`ray`), shapes and
//! lights (`geometry`), the meshes' BVH (`bvh`), materials (`material`), the camera (`camera`),
//! Whitted's ray tree (`trace`), anti-aliasing and the render loops (`sampling`), sRGB
//! (`srgb`), image files (`save`), resampling (`resample`) and Figure 7's contact sheet
//! (`sheet`), Figure 7's scenes (`preset`); scene files in [`crate::scene`], measured
//! materials in [`measured`] and [`reconstruct`], image differences in [`compare`] and
//! [`flip`].

mod bvh;
mod camera;
pub mod compare;
pub mod flip;
mod geometry;
mod gonio;
mod material;
pub mod measured;
mod preset;
mod ray;
pub mod reconstruct;
mod resample;
mod sampling;
mod save;
mod sheet;
mod srgb;
mod trace;

pub use bvh::Mesh;
pub use camera::{Camera, CameraFrame};
pub use geometry::{Light, Object, Shape, reflect, refract};
pub use material::{Checker, Material, RoughnessTexture};
pub use preset::{Lighting, fig7_scene};
pub use ray::Ray;
pub use resample::resize_catmull_rom;
pub use sampling::{AntiAlias, Corners};
pub use save::{MAX_PIXELS, MAX_SIDE, check_finite, check_image_size, rmse, save};
pub use sheet::{contact_sheet, fig7_images, fig7_images_with_progress, visible_crop, zoom_crop};
pub use srgb::{SRGB_BUCKET_BITS, srgb, srgb_steps, to_srgb8};
pub use trace::LightAt;

use glam::DVec3;
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

/// A scene ready to render.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Camera.
    pub camera: Camera,
    /// Objects.
    pub objects: Vec<Object>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Uniform ambient radiance (colour).
    pub ambient: DVec3,
    /// Background radiance.
    pub background: DVec3,
    /// Maximum ray-tree depth (1 = primary rays only).
    pub max_depth: u32,
    /// Rays whose weight falls below this are not traced.
    pub min_weight: f64,
    /// Anti-aliasing.
    pub antialias: AntiAlias,
}

/// Ray counts of one thread's work (plain cells: counting from several threads into shared
/// atomics would make every ray contend for one cache line); [`Counters::add_to`] merges them.
#[derive(Debug, Default)]
pub struct Counters {
    /// Primary rays.
    pub primary: Cell<u64>,
    /// Shadow rays.
    pub shadow: Cell<u64>,
    /// Mirror rays.
    pub reflected: Cell<u64>,
    /// Refracted rays.
    pub refracted: Cell<u64>,
    /// The secondary-ray budget of the ray being shaded ([`RAY_TREE_BUDGET`] at a primary hit,
    /// split among its mirror and refracted rays in proportion to their weights).
    pub budget: Cell<f64>,
}

/// Most secondary (mirror and refracted) rays one primary ray's tree may hold: 1,024. Each
/// ray's budget, less the ray itself, is split between its mirror and refracted rays in
/// proportion to ks and kt, and a ray whose share is below one is not traced, so any scene
/// ends (20 parallel planes with ks = kt = 0.99 and `max_depth = 64` would otherwise take
/// 2^64 rays a pixel). A tree of the usual depths (a glass sphere, `max_depth` up to 10) is
/// not cut. This bounds the tree by count where Whitted's adaptive depth (`min_weight`,
/// Whitted 1980 §2) bounds it by weight.
pub const RAY_TREE_BUDGET: f64 = 1024.0;

impl Counters {
    fn bump(c: &Cell<u64>) {
        c.set(c.get() + 1);
    }

    /// Add these counts to render-wide totals.
    pub fn add_to(&self, total: &[AtomicU64; 4]) {
        for (t, c) in total.iter().zip([
            &self.primary,
            &self.shadow,
            &self.reflected,
            &self.refracted,
        ]) {
            t.fetch_add(c.get(), Ordering::Relaxed);
        }
    }
}

/// A rendered image: linear RGB, row-major, and the ray counts.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Linear RGB radiance per pixel.
    pub pixels: Vec<[f32; 3]>,
    /// Primary, shadow, reflected and refracted rays.
    pub rays: [u64; 4],
}

impl Image {
    /// Total rays traced.
    pub fn total_rays(&self) -> u64 {
        self.rays.iter().sum()
    }

    /// Primary rays per pixel.
    pub fn primary_per_pixel(&self) -> f64 {
        self.rays[0] as f64 / (self.width as f64 * self.height as f64).max(1.0)
    }

    /// Pixel (x, y).
    pub fn at(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[(y * self.width + x) as usize]
    }
}

impl Scene {
    /// Check what the renderer relies on: every number finite, radiances, colours and
    /// intensities ≥ 0, ks, kt and `min_weight` in [0, 1], a positive index, checker size and
    /// resolution, a camera that can look. A scene file is checked in more detail where it is
    /// read ([`crate::scene::parse_scene`]); this guards scenes built in code.
    pub fn check_inputs(&self) -> Result<(), String> {
        let fin = |v: DVec3| v.is_finite();
        let nonneg = |v: DVec3| v.is_finite() && v.min_element() >= 0.0;
        let c = &self.camera;
        if !(fin(c.eye) && fin(c.target) && fin(c.up) && c.fov_deg > 0.0 && c.fov_deg < 180.0)
            || c.width == 0
            || c.height == 0
        {
            return Err("the camera has a value that is not finite or out of range".into());
        }
        if !(nonneg(self.ambient) && nonneg(self.background)) {
            return Err("ambient and background must be finite and ≥ 0".into());
        }
        if !(self.min_weight >= 0.0 && self.min_weight <= 1.0) {
            return Err(format!("min_weight {} is not in [0, 1]", self.min_weight));
        }
        if let AntiAlias::Adaptive { threshold, .. } = self.antialias
            && !(threshold.is_finite() && threshold >= 0.0)
        {
            return Err(format!(
                "antialias threshold {threshold} is not a finite number ≥ 0"
            ));
        }
        for (k, l) in self.lights.iter().enumerate() {
            let ok = match l {
                Light::Point {
                    position,
                    intensity,
                } => fin(*position) && nonneg(*intensity),
                Light::Directional {
                    direction,
                    irradiance,
                } => fin(*direction) && direction.length() > 0.0 && nonneg(*irradiance),
            };
            if !ok {
                return Err(format!(
                    "light {} has a value that is not finite or < 0",
                    k + 1
                ));
            }
        }
        for m in &self.materials {
            let ok = nonneg(m.color)
                && m.model.params().iter().all(|p| p.is_finite())
                && (0.0..=1.0).contains(&m.ks)
                && (0.0..=1.0).contains(&m.kt)
                && m.ior.is_finite()
                && m.ior > 0.0
                && m.checker.is_none_or(|ch| {
                    ch.size.is_finite() && ch.size > 0.0 && nonneg(ch.color0) && nonneg(ch.color1)
                })
                && m.roughness
                    .is_none_or(|r| r.cmin.is_finite() && r.cmin > 0.0 && r.frequency.is_finite());
            if !ok {
                return Err(format!(
                    "material {} has a value that is not finite or out of range",
                    m.name
                ));
            }
        }
        Ok(())
    }
}

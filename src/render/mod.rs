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

pub mod compare;
pub mod flip;
pub mod measured;
pub mod reconstruct;
pub mod scene;

use crate::model::{Distribution, Geometry, Model, ModelKind};
use glam::DVec3;
use rayon::prelude::*;
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

/// A ray with unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin.
    pub o: DVec3,
    /// Unit direction.
    pub d: DVec3,
}

/// A triangle mesh with a bounding-volume hierarchy.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// Triangles (vertex positions).
    pub tris: Vec<[DVec3; 3]>,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

#[derive(Clone, Debug)]
struct Node {
    min: DVec3,
    max: DVec3,
    /// Leaf: first index into `order` and count; inner: left child index (right = left + 1), count 0.
    start: u32,
    count: u32,
}

impl Mesh {
    /// Build the BVH (median split on the longest axis, leaves of ≤ 4 triangles). Degenerate
    /// triangles (zero area) are dropped, and so are repeats of a triangle (the same vertices
    /// in the same winding): no split separates coincident triangles, so a mesh of many copies
    /// would make every ray visit them all.
    pub fn new(tris: Vec<[DVec3; 3]>) -> Mesh {
        let mut seen = std::collections::HashSet::new();
        let tris: Vec<[DVec3; 3]> = tris
            .into_iter()
            .filter(|t| (t[1] - t[0]).cross(t[2] - t[0]).length_squared() > 1e-24)
            .filter(|t| seen.insert(winding_key(t)))
            .collect();
        let mut m = Mesh {
            order: (0..tris.len() as u32).collect(),
            tris,
            nodes: Vec::new(),
        };
        if !m.tris.is_empty() {
            m.nodes.push(Node {
                min: DVec3::ZERO,
                max: DVec3::ZERO,
                start: 0,
                count: 0,
            });
            m.build(0, 0, m.tris.len());
        }
        m
    }

    /// Number of triangles kept (after dropping degenerate and repeated ones).
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when no triangle was kept.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    fn bounds(&self, a: usize, b: usize) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for &i in &self.order[a..b] {
            for v in self.tris[i as usize] {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo, hi)
    }

    fn build(&mut self, node: usize, a: usize, b: usize) {
        let (lo, hi) = self.bounds(a, b);
        self.nodes[node].min = lo;
        self.nodes[node].max = hi;
        if b - a <= 4 {
            self.nodes[node].start = a as u32;
            self.nodes[node].count = (b - a) as u32;
            return;
        }
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let tris = &self.tris;
        let centroid = |i: u32| {
            let t = tris[i as usize];
            (t[0] + t[1] + t[2])[axis]
        };
        let mid = (a + b) / 2;
        self.order[a..b]
            .select_nth_unstable_by(mid - a, |x, y| centroid(*x).total_cmp(&centroid(*y)));
        let left = self.nodes.len();
        for _ in 0..2 {
            self.nodes.push(Node {
                min: DVec3::ZERO,
                max: DVec3::ZERO,
                start: 0,
                count: 0,
            });
        }
        self.nodes[node].start = left as u32;
        self.nodes[node].count = 0;
        self.build(left, a, mid);
        self.build(left + 1, mid, b);
    }

    fn hit_box(r: &Ray, inv: DVec3, lo: DVec3, hi: DVec3, tmax: f64) -> bool {
        let t0 = (lo - r.o) * inv;
        let t1 = (hi - r.o) * inv;
        let tmin = t0.min(t1).max_element().max(0.0);
        let tmx = t0.max(t1).min_element().min(tmax);
        tmin <= tmx
    }

    /// Nearest hit: (t, geometric normal).
    pub fn intersect(&self, r: &Ray, tmax: f64) -> Option<(f64, DVec3)> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = r.d.recip();
        let mut best: Option<(f64, DVec3)> = None;
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            let limit = best.map_or(tmax, |b| b.0);
            if !Self::hit_box(r, inv, node.min, node.max, limit) {
                continue;
            }
            if node.count == 0 {
                stack.push(node.start as usize);
                stack.push(node.start as usize + 1);
                continue;
            }
            for &i in &self.order[node.start as usize..(node.start + node.count) as usize] {
                let t = self.tris[i as usize];
                // Möller–Trumbore.
                let e1 = t[1] - t[0];
                let e2 = t[2] - t[0];
                let p = r.d.cross(e2);
                let det = e1.dot(p);
                if det.abs() < 1e-14 {
                    continue;
                }
                let inv_det = 1.0 / det;
                let s = r.o - t[0];
                let u = s.dot(p) * inv_det;
                if !(0.0..=1.0).contains(&u) {
                    continue;
                }
                let q = s.cross(e1);
                let v = r.d.dot(q) * inv_det;
                if v < 0.0 || u + v > 1.0 {
                    continue;
                }
                let tt = e2.dot(q) * inv_det;
                if tt > 1e-9 && tt < best.map_or(tmax, |b| b.0) {
                    best = Some((tt, e1.cross(e2).normalize()));
                }
            }
        }
        best
    }
}

/// A triangle's vertices as bits, rotated so the smallest comes first: equal for the same
/// triangle in the same winding, whichever vertex it starts at.
fn winding_key(t: &[DVec3; 3]) -> [u64; 9] {
    let bits = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let b = [bits(t[0]), bits(t[1]), bits(t[2])];
    let first = (0..3).min_by_key(|&i| b[i]).unwrap_or(0);
    let mut key = [0; 9];
    for k in 0..3 {
        key[3 * k..3 * k + 3].copy_from_slice(&b[(first + k) % 3]);
    }
    key
}

/// Geometry of an object.
#[derive(Clone, Debug)]
pub enum Shape {
    /// Sphere: centre, radius.
    Sphere {
        /// Centre.
        center: DVec3,
        /// Radius.
        radius: f64,
    },
    /// Plane through `point` with unit `normal`, optionally limited to a square of half-size
    /// `half` around `point` (texture coordinates along `u`, `v`).
    Plane {
        /// A point on the plane.
        point: DVec3,
        /// Unit normal.
        normal: DVec3,
        /// Half-size of the square, or unbounded.
        half: Option<f64>,
        /// First in-plane axis (texture u).
        u: DVec3,
        /// Second in-plane axis (texture v).
        v: DVec3,
    },
    /// Triangle mesh.
    Mesh(Mesh),
}

/// An object: shape, material index and its bounding sphere.
#[derive(Clone, Debug)]
pub struct Object {
    /// Shape.
    pub shape: Shape,
    /// Index into the scene's materials.
    pub material: usize,
    /// Bounding sphere (centre, radius); ∞ radius for unbounded planes.
    pub bound: (DVec3, f64),
}

impl Object {
    /// Object with its bounding sphere computed.
    pub fn new(shape: Shape, material: usize) -> Object {
        let bound = match &shape {
            Shape::Sphere { center, radius } => (*center, *radius),
            Shape::Plane { point, half, .. } => (
                *point,
                half.map_or(f64::INFINITY, |h| h * std::f64::consts::SQRT_2),
            ),
            Shape::Mesh(m) => {
                let (lo, hi) = if m.tris.is_empty() {
                    (DVec3::ZERO, DVec3::ZERO)
                } else {
                    m.bounds(0, m.tris.len())
                };
                let c = 0.5 * (lo + hi);
                (c, (hi - c).length())
            }
        };
        Object {
            shape,
            material,
            bound,
        }
    }

    /// Texture coordinates (u, v) at hit point `p` with outward normal `n`: longitude and
    /// colatitude over [0, 1] on a sphere, distances along the plane's axes on a plane.
    pub fn uv(&self, p: DVec3, n: DVec3) -> (f64, f64) {
        match &self.shape {
            Shape::Sphere { .. } => (
                0.5 + n.z.atan2(n.x) / std::f64::consts::TAU,
                n.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI,
            ),
            Shape::Plane { point, u, v, .. } => {
                let q = p - *point;
                (q.dot(*u), q.dot(*v))
            }
            Shape::Mesh(_) => (0.0, 0.0),
        }
    }

    /// True if `r` hits the object before `tmax` (a shadow ray's test: no normal needed).
    #[inline]
    pub fn blocks(&self, r: &Ray, tmax: f64) -> bool {
        match &self.shape {
            Shape::Sphere { center, radius } => sphere_hit(r, *center, *radius, tmax).is_some(),
            _ => self.intersect(r, tmax).is_some(),
        }
    }

    /// Nearest hit along `r` before `tmax`: (t, outward normal).
    #[inline]
    pub fn intersect(&self, r: &Ray, tmax: f64) -> Option<(f64, DVec3)> {
        // Bounding-sphere test first (Whitted's bounding volumes); a sphere is its own bound.
        let (c, rad) = self.bound;
        if rad.is_finite() && !matches!(self.shape, Shape::Sphere { .. }) {
            let oc = r.o - c;
            let b = oc.dot(r.d);
            let disc = b * b - (oc.length_squared() - rad * rad);
            if disc < 0.0 || -b + disc.max(0.0).sqrt() < 0.0 {
                return None;
            }
        }
        match &self.shape {
            Shape::Sphere { center, radius } => sphere_hit(r, *center, *radius, tmax)
                .map(|t| (t, (r.o + t * r.d - *center) / *radius)),
            Shape::Plane {
                point,
                normal,
                half,
                u,
                v,
            } => {
                let den = normal.dot(r.d);
                if den.abs() < 1e-14 {
                    return None;
                }
                let t = (*point - r.o).dot(*normal) / den;
                if t <= 1e-9 || t >= tmax {
                    return None;
                }
                let q = r.o + t * r.d - *point;
                let (a, b) = (q.dot(*u), q.dot(*v));
                if let Some(h) = half
                    && (a.abs() > *h || b.abs() > *h)
                {
                    return None;
                }
                Some((t, *normal))
            }
            Shape::Mesh(m) => m.intersect(r, tmax),
        }
    }
}

/// Nearest t in (ε, `tmax`) where unit-direction ray `r` meets the sphere, if any.
#[inline]
fn sphere_hit(r: &Ray, center: DVec3, radius: f64, tmax: f64) -> Option<f64> {
    let oc = r.o - center;
    let b = oc.dot(r.d);
    let disc = b * b - (oc.length_squared() - radius * radius);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let eps = 1e-9 * radius.max(1.0);
    let t = if -b - s > eps { -b - s } else { -b + s };
    (t > eps && t < tmax).then_some(t)
}

/// A light source.
#[derive(Clone, Debug)]
pub enum Light {
    /// Point light with 1/r² falloff: position, colour × intensity (radiant intensity).
    Point {
        /// Position.
        position: DVec3,
        /// Colour × intensity.
        intensity: DVec3,
    },
    /// Directional light: unit direction *toward* the light, colour × irradiance.
    Directional {
        /// Unit direction toward the light.
        direction: DVec3,
        /// Colour × irradiance.
        irradiance: DVec3,
    },
}

impl Light {
    /// Unit direction from `p` toward the light, its distance, and the irradiance it gives
    /// a surface facing it at `p`.
    #[inline]
    pub fn toward(&self, p: DVec3) -> (DVec3, f64, DVec3) {
        match self {
            Light::Point {
                position,
                intensity,
            } => {
                let v = *position - p;
                let d2 = v.length_squared();
                (v / d2.sqrt(), d2.sqrt(), *intensity / d2.max(1e-300))
            }
            Light::Directional {
                direction,
                irradiance,
            } => (*direction, f64::INFINITY, *irradiance),
        }
    }
}

/// A checker texture on the diffuse colour: squares of side `size` in texture units.
#[derive(Clone, Copy, Debug)]
pub struct Checker {
    /// Square size.
    pub size: f64,
    /// Colour of even squares.
    pub color0: DVec3,
    /// Colour of odd squares.
    pub color1: DVec3,
}

impl Checker {
    /// Indices (i, j) of the square holding texture coordinates (u, v).
    pub fn cell(&self, (u, v): (f64, f64)) -> (i64, i64) {
        (
            (u / self.size).floor() as i64,
            (v / self.size).floor() as i64,
        )
    }

    /// Colour at texture coordinates (u, v).
    pub fn at(&self, uv: (f64, f64)) -> DVec3 {
        let (i, j) = self.cell(uv);
        let k = i + j;
        if k.rem_euclid(2) == 0 {
            self.color0
        } else {
            self.color1
        }
    }
}

/// Blinn's texture-modulated roughness (Figure 8): t(u, v) = ½ + ½ sin(2π u f) sin(2π v f),
/// C3 = Cmin + (1 − Cmin) t, D3 normalised by Cmin ([`crate::model::d3_textured`]).
#[derive(Clone, Copy, Debug)]
pub struct RoughnessTexture {
    /// Minimum c3 over the surface.
    pub cmin: f64,
    /// Spatial frequency of the pattern (cycles per texture unit).
    pub frequency: f64,
}

/// A material: a reflection model plus Whitted's mirror and transmission coefficients.
#[derive(Clone, Debug)]
pub struct Material {
    /// Name.
    pub name: String,
    /// The local reflection model (f_r, with its pd).
    pub model: Model,
    /// Diffuse colour (multiplies the pd term).
    pub color: DVec3,
    /// Specular colour (multiplies the ps term; white but for a colour fit, whose channels'
    /// ps it holds).
    pub specular: DVec3,
    /// Optional checker on the diffuse colour.
    pub checker: Option<Checker>,
    /// Whitted's ks: weight of the mirror ray.
    pub ks: f64,
    /// Whitted's kt: weight of the refracted ray.
    pub kt: f64,
    /// Index of refraction for the refracted ray.
    pub ior: f64,
    /// Optional roughness texture (torrance-sparrow D3 only).
    pub roughness: Option<RoughnessTexture>,
    /// Optional measured BRDF: when set, the surface reflects by this table (times `color`)
    /// instead of `model`, which then gives only the ambient term's pd.
    pub measured: Option<std::sync::Arc<measured::Tabulated>>,
}

impl Material {
    fn pd(&self) -> f64 {
        self.model.pd()
    }

    /// Blinn's specular intensity for a unit light (the model with pd = 0).
    fn specular(&self, g: &Geometry, uv: (f64, f64)) -> f64 {
        if let (Some(rt), ModelKind::TorranceSparrow, Distribution::D3) =
            (self.roughness, self.model.kind, self.model.dist)
        {
            if !g.visible() {
                return 0.0;
            }
            let t = 0.5
                + 0.5
                    * (std::f64::consts::TAU * uv.0 * rt.frequency).sin()
                    * (std::f64::consts::TAU * uv.1 * rt.frequency).sin();
            let d = crate::model::d3_textured(g.nh, rt.cmin, t);
            let n = self.model.role(crate::model::Role::Index).unwrap_or(1.5);
            let ps = self.model.role(crate::model::Role::Specular).unwrap_or(0.0);
            return ps * d * crate::model::fresnel(n, g.eh) * g.g_ne;
        }
        let pd = self.pd();
        (self.model.intensity(g) - pd * g.nl.max(0.0)).max(0.0)
    }
}

/// Camera: look-at with a horizontal field of view.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye position.
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Up vector.
    pub up: DVec3,
    /// Horizontal field of view, degrees.
    pub fov_deg: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// The primary ray through continuous image position (x, y) ∈ [0, W] × [0, H].
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        self.frame().ray(x, y)
    }

    /// The camera's basis and image-plane scale, computed once for many rays.
    pub fn frame(&self) -> CameraFrame {
        let f = (self.target - self.eye).normalize();
        let r = f.cross(self.up).normalize();
        let tx = (0.5 * self.fov_deg.to_radians()).tan();
        CameraFrame {
            eye: self.eye,
            // One pixel step along x and y, and the image corner, in world directions.
            dx: r * (2.0 * tx / self.width as f64),
            dy: r.cross(f) * (-2.0 * tx / self.width as f64),
            corner: f - r * tx + r.cross(f) * (tx * self.height as f64 / self.width as f64),
        }
    }
}

/// A camera's precomputed basis ([`Camera::frame`]).
#[derive(Clone, Copy, Debug)]
pub struct CameraFrame {
    eye: DVec3,
    dx: DVec3,
    dy: DVec3,
    corner: DVec3,
}

impl CameraFrame {
    /// The primary ray through continuous image position (x, y) ∈ [0, W] × [0, H].
    #[inline]
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        Ray {
            o: self.eye,
            d: (self.corner + x * self.dx + y * self.dy).normalize(),
        }
    }
}

/// Anti-aliasing mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AntiAlias {
    /// One ray through each pixel centre.
    None,
    /// n × n regular samples per pixel, averaged (box filter).
    Uniform(u32),
    /// n × n strata per pixel with one sample at a fixed random point in each (jittered
    /// stratified sampling, Cook 1986, "Stochastic sampling in computer graphics"), averaged:
    /// the regular grid's error on edges nearly aligned with it becomes noise that falls faster.
    Stratified(u32),
    /// Whitted's adaptive corner sampling: subdivide where corners differ by more than
    /// `threshold` (in display units, √ of the linear value), have different ray trees or
    /// pass near a small object, up to `max_level`.
    Adaptive {
        /// Display-value difference that triggers subdivision.
        threshold: f64,
        /// Maximum subdivision depth (a pixel becomes at most 2^level × 2^level squares).
        max_level: u32,
        /// Side in pixels of the first squares (1, 2 or 4). 1 is Whitted's scheme, corners on
        /// every pixel. Larger blocks trace corners on a coarser lattice and subdivide the same
        /// way down to pixels and below; a block whose four corners agree is filled from them by
        /// bilinear interpolation (each pixel gets the patch's mean over its area, the value at
        /// its centre), so smooth regions cost fewer than one ray per pixel.
        block: u32,
        /// Trace each lattice point at a fixed random point of the finest square (side
        /// 2^-max_level pixel) centred on it instead of at the point itself (Cook 1986): at the
        /// finest level the corner average becomes a stratified estimate, and a grid-aligned edge
        /// no longer errs the same way in every square.
        jitter: bool,
    },
}

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
/// atomics made every ray contend for one cache line); [`Counters::add_to`] merges them.
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
}

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

/// Mirror direction of `d` about `n`.
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit `d` at unit normal `n` (facing against `d`) with relative index
/// `eta` = n1/n2 (Snell's law); `None` on total internal reflection.
pub fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// One traced sample: radiance and what the anti-aliasing test compares.
#[derive(Clone, Copy, Debug, Default)]
struct Sample {
    color: DVec3,
    /// Display-like value (gamma 2: √ of the linear value) for the subdivision test. Not
    /// clamped at 1: differences among over-range values (a highlight, its reflection) are
    /// real in the linear EXR and in any error measured on it.
    display: DVec3,
    /// What the ray tree hit (objects, checker squares, shadowing lights), hashed.
    key: u64,
    near_miss: bool,
}

impl Scene {
    /// Check what the renderer relies on: every number finite, radiances, colours and
    /// intensities ≥ 0, ks, kt and `min_weight` in [0, 1], a positive index, checker size and
    /// resolution, a camera that can look. A scene file is checked in more detail where it is
    /// read ([`scene::parse_scene`]); this guards scenes built in code.
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

    /// Nearest hit: (object index, t, outward normal, uv).
    pub fn intersect(&self, r: &Ray, tmax: f64) -> Option<(usize, f64, DVec3)> {
        let mut best: Option<(usize, f64, DVec3)> = None;
        for (i, o) in self.objects.iter().enumerate() {
            let limit = best.map_or(tmax, |b| b.1);
            if let Some((t, n)) = o.intersect(r, limit) {
                best = Some((i, t, n));
            }
        }
        best
    }

    fn occluded(&self, r: &Ray, tmax: f64) -> bool {
        self.objects.iter().any(|o| o.blocks(r, tmax))
    }

    /// Radiance along `r` (Whitted's eq. 2), recursing up to `max_depth`.
    pub fn trace(&self, r: &Ray, depth: u32, weight: f64, c: &Counters) -> DVec3 {
        self.trace_key(r, depth, weight, c, &mut 0)
    }

    /// [`Scene::trace`], folding what the ray tree hit into `key`.
    fn trace_key(&self, r: &Ray, depth: u32, weight: f64, c: &Counters, key: &mut u64) -> DVec3 {
        match self.intersect(r, f64::INFINITY) {
            Some(hit) => self.shade(r, hit, depth, weight, c, key, None),
            None => {
                *key = mix(*key, MISSED);
                self.background
            }
        }
    }

    /// The surface a ray meets at its hit (t, outward normal): the point, whether the ray
    /// comes from inside, the normal facing the ray, the direction to the eye, and the offset
    /// that starts secondary rays off the surface.
    #[inline]
    fn surface(r: &Ray, t: f64, n_out: DVec3) -> (DVec3, bool, DVec3, DVec3, f64) {
        let p = r.o + t * r.d;
        let inside = n_out.dot(r.d) > 0.0;
        let n = if inside { -n_out } else { n_out };
        let e = -r.d;
        let scale = p.abs().max_element().max(1.0);
        (p, inside, n, e, 1e-7 * scale)
    }

    /// What `light` contributes at surface point `p` (normal `n`, eye direction `e`, offset
    /// `eps`) before any material: behind the surface (no shadow ray), shadowed, or lit with
    /// the geometry the models read.
    #[inline]
    fn light_at(&self, light: &Light, p: DVec3, n: DVec3, e: DVec3, eps: f64) -> LightAt {
        let (ldir, dist, irr) = light.toward(p);
        if n.dot(ldir) <= 0.0 || n.dot(e) <= 0.0 {
            return LightAt::Behind;
        }
        if self.occluded(
            &Ray {
                o: p + eps * n,
                d: ldir,
            },
            dist - 2.0 * eps,
        ) {
            return LightAt::Shadowed;
        }
        LightAt::Lit {
            g: Geometry::from_vectors(n.to_array(), ldir.to_array(), e.to_array()),
            n_dot_l: n.dot(ldir),
            irr,
        }
    }

    /// Radiance along `r` given its nearest hit (object, t, outward normal); `lit`, when
    /// given, holds each light's [`Scene::light_at`] there, computed beforehand ([`Corners`]).
    #[allow(clippy::too_many_arguments)]
    fn shade(
        &self,
        r: &Ray,
        (oi, t, n_out): (usize, f64, DVec3),
        depth: u32,
        weight: f64,
        c: &Counters,
        key: &mut u64,
        lit: Option<&[LightAt]>,
    ) -> DVec3 {
        let obj = &self.objects[oi];
        *key = mix(*key, oi as u64);
        let m = &self.materials[obj.material];
        let (p, inside, n, e, eps) = Self::surface(r, t, n_out);
        // Texture coordinates only where a texture reads them.
        let uv = if m.checker.is_some() || m.roughness.is_some() {
            obj.uv(p, n_out)
        } else {
            (0.0, 0.0)
        };
        let albedo = m.checker.map_or(m.color, |ch| {
            let (i, j) = ch.cell(uv);
            *key = mix(mix(*key, i as u64), j as u64);
            ch.at(uv) * m.color
        });
        let pd = m.pd();
        let mut out = self.ambient * albedo * pd;
        for (li, light) in self.lights.iter().enumerate() {
            let at = match lit {
                Some(lit) => lit[li],
                None => self.light_at(light, p, n, e, eps),
            };
            let (g, n_dot_l, irr) = match at {
                LightAt::Behind => continue,
                LightAt::Shadowed => {
                    Counters::bump(&c.shadow);
                    *key = mix(*key, SHADOWED | li as u64);
                    continue;
                }
                LightAt::Lit { g, n_dot_l, irr } => {
                    Counters::bump(&c.shadow);
                    (g, n_dot_l, irr)
                }
            };
            // A Lambert surface needs only N·L; the other models the whole geometry.
            if let Some(t) = &m.measured {
                out += albedo * (t.brdf(&g) * g.nl) * irr;
                continue;
            }
            let (i_d, i_s) = if m.model.kind == ModelKind::Lambert {
                (pd * n_dot_l, 0.0)
            } else {
                (pd * g.nl, m.specular(&g, uv))
            };
            out += (albedo * i_d + m.specular * i_s) * irr * std::f64::consts::FRAC_1_PI;
        }
        if depth + 1 < self.max_depth {
            if m.ks > 0.0 && weight * m.ks >= self.min_weight {
                Counters::bump(&c.reflected);
                let d = reflect(r.d, n);
                out += m.ks
                    * self.trace_key(&Ray { o: p + eps * n, d }, depth + 1, weight * m.ks, c, key);
            }
            if m.kt > 0.0 && weight * m.kt >= self.min_weight {
                let eta = if inside { m.ior } else { 1.0 / m.ior };
                match refract(r.d, n, eta) {
                    Some(d) => {
                        Counters::bump(&c.refracted);
                        out += m.kt
                            * self.trace_key(
                                &Ray { o: p - eps * n, d },
                                depth + 1,
                                weight * m.kt,
                                c,
                                key,
                            );
                    }
                    None => {
                        // Total internal reflection: the transmitted share is reflected.
                        Counters::bump(&c.reflected);
                        let d = reflect(r.d, n);
                        out += m.kt
                            * self.trace_key(
                                &Ray { o: p + eps * n, d },
                                depth + 1,
                                weight * m.kt,
                                c,
                                key,
                            );
                    }
                }
            }
        }
        out
    }

    /// The local light/eye configurations this scene shows of `material`: for each pixel
    /// whose centre ray first hits an object of that material, and each light that reaches
    /// the point unshadowed with light and eye above the surface, (θi, θo, φo − φi) in radians
    /// (φo − φi ∈ [0, π]; 180° is the mirror direction). Also returns the object mask: the
    /// pixels whose centre ray hits the material, lit or not. Primary rays only: a mirror or
    /// refracted view of the object is not counted.
    pub fn lit_configurations(&self, material: usize) -> (Vec<[f64; 3]>, Vec<bool>) {
        let (w, h) = (self.camera.width, self.camera.height);
        let cam = self.camera.frame();
        // Rows in parallel, joined in row order: the same list as row by row.
        let rows: Vec<(Vec<[f64; 3]>, Vec<bool>)> = (0..h)
            .into_par_iter()
            .map(|y| self.lit_row(&cam, material, y))
            .collect();
        let mut configs = Vec::new();
        let mut mask = Vec::with_capacity((w as usize) * (h as usize));
        for (c, m) in rows {
            configs.extend(c);
            mask.extend(m);
        }
        (configs, mask)
    }

    /// Row `y` of [`Scene::lit_configurations`]: its configurations and its mask.
    fn lit_row(&self, cam: &CameraFrame, material: usize, y: u32) -> (Vec<[f64; 3]>, Vec<bool>) {
        let w = self.camera.width;
        let mut configs = Vec::new();
        let mut mask = vec![false; w as usize];
        {
            for x in 0..w {
                let r = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
                let Some((oi, t, n_out)) = self.intersect(&r, f64::INFINITY) else {
                    continue;
                };
                if self.objects[oi].material != material {
                    continue;
                }
                mask[x as usize] = true;
                let p = r.o + t * r.d;
                let n = if n_out.dot(r.d) > 0.0 { -n_out } else { n_out };
                let e = -r.d;
                let eps = 1e-7 * p.abs().max_element().max(1.0);
                for light in &self.lights {
                    let (l, dist, _) = light.toward(p);
                    let (nl, ne) = (n.dot(l), n.dot(e));
                    if nl <= 0.0 || ne <= 0.0 {
                        continue;
                    }
                    if self.occluded(
                        &Ray {
                            o: p + eps * n,
                            d: l,
                        },
                        dist - 2.0 * eps,
                    ) {
                        continue;
                    }
                    let (lt, et) = (l - nl * n, e - ne * n);
                    let den = lt.length() * et.length();
                    let dphi = if den > 1e-12 {
                        (lt.dot(et) / den).clamp(-1.0, 1.0).acos()
                    } else {
                        0.0
                    };
                    configs.push([nl.min(1.0).acos(), ne.min(1.0).acos(), dphi]);
                }
            }
        }
        (configs, mask)
    }

    /// Radiance of the primary ray through (x, y): the uniform and no-anti-aliasing modes
    /// need nothing else.
    fn radiance(&self, cam: &CameraFrame, x: f64, y: f64, c: &Counters) -> DVec3 {
        Counters::bump(&c.primary);
        self.trace(&cam.ray(x, y), 0, 1.0, c)
    }

    /// A corner sample of the adaptive mode at lattice point (x, y) of a square of side
    /// `side` pixels: radiance plus what the subdivision test reads.
    fn sample(
        &self,
        cam: &CameraFrame,
        (x, y): (f64, f64),
        side: f64,
        sub: &Subdivision,
        c: &Counters,
    ) -> Sample {
        Counters::bump(&c.primary);
        let footprint = sub.footprint * side;
        let (x, y) = if sub.jitter_cells > 0.0 {
            // Lattice coordinates (≥ 0) are multiples of 2^-max_level: x·k is an exact integer
            // (the cast truncates; no libm call for `round` on baseline x86-64).
            let k = sub.jitter_cells;
            let (i, j) = ((x * k + 0.5) as u64, (y * k + 0.5) as u64);
            let (u, v) = jitter(i, j);
            let inv = 1.0 / k;
            ((i as f64 + u - 0.5) * inv, (j as f64 + v - 0.5) * inv)
        } else {
            (x, y)
        };
        let r = cam.ray(x, y);
        // At an integer corner the hit and the lights' geometry are in the table when one
        // is given (the positions are exact: no jitter).
        let cached = sub
            .corners
            .filter(|_| sub.jitter_cells == 0.0)
            .and_then(|k| k.index(x, y));
        let hit = match (cached, sub.corners) {
            (Some(i), Some(k)) => k.hits[i],
            _ => self.intersect(&r, f64::INFINITY),
        };
        let lit = match (cached, sub.corners) {
            (Some(i), Some(k)) => Some(&k.lights[i * k.per_point..(i + 1) * k.per_point]),
            _ => None,
        };
        // Whitted's small-object test: an object whose bounding sphere is smaller than the
        // sample footprint gets a minimum radius r_min = footprint·distance; a ray passing
        // within r_min of its centre without hitting it flags the square for subdivision.
        let near_miss = self.objects.iter().enumerate().any(|(i, o)| {
            let (ctr, rad) = o.bound;
            if !rad.is_finite() || hit.is_some_and(|h| h.0 == i) {
                return false;
            }
            let v = ctr - r.o;
            let t = v.dot(r.d);
            let r_min = footprint * t;
            t > 0.0 && rad < r_min && (v - t * r.d).length() < r_min
        });
        // The primary hit is already known: shade it without intersecting again.
        let mut key = 0;
        let color = match hit {
            Some(h) => self.shade(&r, h, 0, 1.0, c, &mut key, lit),
            None => {
                key = mix(key, MISSED);
                self.background
            }
        };
        Sample {
            color,
            display: color.max(DVec3::ZERO).map(f64::sqrt),
            key,
            near_miss,
        }
    }

    /// The geometry pass [`Scene::render_with_corners`] reads ([`Corners`]), rows in
    /// parallel.
    pub fn corners(&self) -> Corners {
        let (w, h) = (
            self.camera.width as usize + 1,
            self.camera.height as usize + 1,
        );
        let cam = self.camera.frame();
        let per_point = self.lights.len();
        let rows: Vec<(Vec<Option<Hit>>, Vec<LightAt>)> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut hits = Vec::with_capacity(w);
                let mut lights = Vec::with_capacity(w * per_point);
                for x in 0..w {
                    let r = cam.ray(x as f64, y as f64);
                    let hit = self.intersect(&r, f64::INFINITY);
                    hits.push(hit);
                    match hit {
                        Some((_, t, n_out)) => {
                            let (p, _, n, e, eps) = Self::surface(&r, t, n_out);
                            lights
                                .extend(self.lights.iter().map(|l| self.light_at(l, p, n, e, eps)));
                        }
                        None => lights.extend((0..per_point).map(|_| LightAt::Behind)),
                    }
                }
                (hits, lights)
            })
            .collect();
        let mut hits = Vec::with_capacity(w * h);
        let mut lights = Vec::with_capacity(w * h * per_point);
        for (a, b) in rows {
            hits.extend(a);
            lights.extend(b);
        }
        Corners {
            camera: self.camera,
            per_point,
            hits,
            lights,
        }
    }

    /// Render the image (rayon over rows); `progress` is called once per finished row.
    pub fn render(&self, progress: &(dyn Fn() + Sync)) -> Image {
        self.render_with_corners(None, progress)
    }

    /// [`Scene::render`] taking the primary hits and the lights' geometry at the pixel
    /// corners from `corners` (made by [`Scene::corners`] from a scene that differs from this
    /// one at most in its materials' reflection models and tables): the same image, the same
    /// ray counts, without intersecting or building the geometry again at those corners. Only
    /// the adaptive mode (whose samples are at the corners) reads it.
    pub fn render_with_corners(
        &self,
        corners: Option<&Corners>,
        progress: &(dyn Fn() + Sync),
    ) -> Image {
        let (w, h) = (self.camera.width, self.camera.height);
        let total: [AtomicU64; 4] = Default::default();
        let footprint = (0.5 * self.camera.fov_deg.to_radians()).tan() * 2.0 / w.max(1) as f64;
        let cam = &self.camera.frame();
        // Every pass writes rows in place into a preallocated buffer (no per-row vectors to
        // join), one rayon task per row, ray counts kept per row.
        let mut pixels = vec![[0.0f32; 3]; (w as usize) * (h as usize)];
        match self.antialias {
            AntiAlias::None | AntiAlias::Uniform(_) | AntiAlias::Stratified(_) => {
                let (n, jittered) = match self.antialias {
                    AntiAlias::Uniform(n) => (n.max(1), false),
                    AntiAlias::Stratified(n) => (n.max(1), true),
                    _ => (1, false),
                };
                let rows = pixels.par_chunks_mut(w.max(1) as usize).enumerate();
                rows.for_each(|(y, row)| {
                    let c = Counters::default();
                    for (x, px) in row.iter_mut().enumerate() {
                        let mut sum = DVec3::ZERO;
                        for j in 0..n {
                            for i in 0..n {
                                let (ju, jv) = if jittered {
                                    let n = n as u64;
                                    jitter(x as u64 * n + i as u64, y as u64 * n + j as u64)
                                } else {
                                    (0.5, 0.5)
                                };
                                let sx = x as f64 + (i as f64 + ju) / n as f64;
                                let sy = y as f64 + (j as f64 + jv) / n as f64;
                                sum += self.radiance(cam, sx, sy, &c);
                            }
                        }
                        let v = sum / (n * n) as f64;
                        *px = [v.x as f32, v.y as f32, v.z as f32];
                    }
                    c.add_to(&total);
                    progress();
                });
            }
            AntiAlias::Adaptive {
                threshold,
                max_level,
                block,
                jitter,
            } => {
                let sub = &Subdivision {
                    threshold,
                    max_level,
                    footprint,
                    jitter_cells: if jitter {
                        2f64.powi(max_level.min(60) as i32)
                    } else {
                        0.0
                    },
                    corners: corners.filter(|k| k.fits(self)),
                };
                // Blocks of B × B pixels with corners on a lattice of spacing B (B = 1: Whitted's
                // pixel corners), in bands of rows swept with two rows of corner samples shared
                // by neighbouring blocks; a band recomputes the corner row above it.
                const BAND: usize = 32;
                let (wu, hu, b) = (w.max(1) as usize, h.max(1) as usize, block as usize);
                let nb = wu.div_ceil(b);
                let corner_row = |y: usize, c: &Counters| -> Vec<Sample> {
                    (0..=nb)
                        .map(|k| self.sample(cam, ((k * b) as f64, y as f64), b as f64, sub, c))
                        .collect()
                };
                pixels
                    .par_chunks_mut(wu * BAND)
                    .enumerate()
                    .for_each(|(band_index, band)| {
                        let c = Counters::default();
                        let y0 = band_index * BAND;
                        let rows = band.len() / wu;
                        let mut top = corner_row(y0, &c);
                        for by in (0..rows).step_by(b) {
                            let bottom = corner_row(y0 + by + b, &c);
                            for k in 0..nb {
                                let q = [top[k], top[k + 1], bottom[k], bottom[k + 1]];
                                let area = BlockArea {
                                    out: &mut *band,
                                    y0,
                                    width: wu,
                                    height: hu.min(y0 + rows),
                                };
                                self.block(cam, (k * b, y0 + by, b), q, sub, area, &c);
                            }
                            top = bottom;
                            for _ in 0..b.min(rows - by) {
                                progress();
                            }
                        }
                        c.add_to(&total);
                    });
            }
        }
        Image {
            width: w,
            height: h,
            pixels,
            rays: total.map(|t| t.into_inner()),
        }
    }

    /// Whitted's recursive subdivision of the square at (x, y) of side `s` with corner samples
    /// q = [top-left, top-right, bottom-left, bottom-right].
    fn adaptive(
        &self,
        cam: &CameraFrame,
        (x, y, s): (f64, f64, f64),
        q: [Sample; 4],
        level: u32,
        sub: &Subdivision,
        c: &Counters,
    ) -> DVec3 {
        if !corners_differ(&q, sub.threshold) || level >= sub.max_level {
            return (q[0].color + q[1].color + q[2].color + q[3].color) * 0.25;
        }
        let h = 0.5 * s;
        let m = |dx: f64, dy: f64| self.sample(cam, (x + dx, y + dy), s, sub, c);
        let (top, left, mid, right, bottom) = (m(h, 0.0), m(0.0, h), m(h, h), m(s, h), m(h, s));
        let quarter = |xx, yy, qq| self.adaptive(cam, (xx, yy, h), qq, level + 1, sub, c);
        0.25 * (quarter(x, y, [q[0], top, left, mid])
            + quarter(x + h, y, [top, q[1], mid, right])
            + quarter(x, y + h, [left, mid, q[2], bottom])
            + quarter(x + h, y + h, [mid, right, bottom, q[3]]))
    }

    /// A block of `s` × `s` pixels at pixel (x, y) with corner samples q (as in
    /// [`Scene::adaptive`]): filled by bilinear interpolation where the corners agree, else
    /// split in four (five new samples) down to single pixels, which [`Scene::adaptive`] takes
    /// over. Pixels outside the image are skipped.
    fn block(
        &self,
        cam: &CameraFrame,
        (x, y, s): (usize, usize, usize),
        q: [Sample; 4],
        sub: &Subdivision,
        area: BlockArea,
        c: &Counters,
    ) {
        let BlockArea {
            out,
            y0,
            width,
            height,
        } = area;
        if s == 1 {
            if x < width && y < height {
                let v = self.adaptive(cam, (x as f64, y as f64, 1.0), q, 0, sub, c);
                out[(y - y0) * width + x] = [v.x as f32, v.y as f32, v.z as f32];
            }
            return;
        }
        if !corners_differ(&q, sub.threshold) {
            let sf = s as f64;
            for j in y..(y + s).min(height) {
                let v = (j - y) as f64 / sf + 0.5 / sf;
                for i in x..(x + s).min(width) {
                    let u = (i - x) as f64 / sf + 0.5 / sf;
                    let col = (1.0 - v) * ((1.0 - u) * q[0].color + u * q[1].color)
                        + v * ((1.0 - u) * q[2].color + u * q[3].color);
                    out[(j - y0) * width + i] = [col.x as f32, col.y as f32, col.z as f32];
                }
            }
            return;
        }
        let h = s / 2;
        let m = |dx: usize, dy: usize| {
            self.sample(cam, ((x + dx) as f64, (y + dy) as f64), h as f64, sub, c)
        };
        let (top, left, mid, right, bottom) = (m(h, 0), m(0, h), m(h, h), m(s, h), m(h, s));
        for (dx, dy, qq) in [
            (0, 0, [q[0], top, left, mid]),
            (h, 0, [top, q[1], mid, right]),
            (0, h, [left, mid, q[2], bottom]),
            (h, h, [mid, right, bottom, q[3]]),
        ] {
            let area = BlockArea {
                out: &mut *out,
                y0,
                width,
                height,
            };
            self.block(cam, (x + dx, y + dy, h), qq, sub, area, c);
        }
    }
}

/// Ray-tree key tags: a ray that left the scene, a light blocked (ORed with its index).
const MISSED: u64 = u64::MAX;
const SHADOWED: u64 = 1 << 63;

/// The adaptive mode's settings as its recursion reads them.
#[derive(Clone, Copy, Debug)]
struct Subdivision<'a> {
    threshold: f64,
    max_level: u32,
    /// Angle subtended by one pixel (tan); the small-object test scales it by the sample spacing.
    footprint: f64,
    /// Finest-lattice points per pixel (2^max_level) when samples are jittered, else 0.
    jitter_cells: f64,
    /// The corners' hits and lights, when computed beforehand.
    corners: Option<&'a Corners>,
}

/// A ray's nearest hit: object index, t, outward normal.
type Hit = (usize, f64, DVec3);

/// What a light contributes at a surface point before any material (`Scene::light_at`).
#[derive(Clone, Copy, Debug)]
pub enum LightAt {
    /// Light or eye below the surface: no shadow ray.
    Behind,
    /// The shadow ray is blocked.
    Shadowed,
    /// Lit: the geometry (N, L, E), N·L as the Lambert term reads it, and the irradiance.
    Lit {
        /// The geometry the models read.
        g: Geometry,
        /// N·L (the vector dot product).
        n_dot_l: f64,
        /// Irradiance on a surface facing the light.
        irr: DVec3,
    },
}

/// One geometry pass of a scene, shared by renders that differ only in materials (the
/// candidates of `brdfit choose`): at every integer pixel corner (x, y) ∈ [0, W] × [0, H]
/// the primary ray's nearest hit and, where it hits, each light's [`LightAt`]. Every value
/// is computed by the code a render runs, so a render reading it gives the same image.
#[derive(Clone, Debug)]
pub struct Corners {
    /// The camera it was made with (a render with another camera ignores it).
    camera: Camera,
    /// Number of lights it was made with.
    per_point: usize,
    /// Nearest hit per corner, x fastest ((W + 1) × (H + 1)).
    hits: Vec<Option<Hit>>,
    /// Each light's contribution per corner (`per_point` per corner; `Behind` where the
    /// ray misses).
    lights: Vec<LightAt>,
}

impl Corners {
    /// The index of corner (x, y), when it is an integer corner of the table.
    #[inline]
    fn index(&self, x: f64, y: f64) -> Option<usize> {
        let (w, h) = (
            self.camera.width as usize + 1,
            self.camera.height as usize + 1,
        );
        let (i, j) = (x as usize, y as usize);
        (x >= 0.0 && y >= 0.0 && i as f64 == x && j as f64 == y && i < w && j < h)
            .then_some(j * w + i)
    }

    /// True when made for `scene`'s camera and number of lights.
    fn fits(&self, scene: &Scene) -> bool {
        let (a, b) = (&self.camera, &scene.camera);
        self.per_point == scene.lights.len()
            && (a.eye, a.target, a.up, a.fov_deg, a.width, a.height)
                == (b.eye, b.target, b.up, b.fov_deg, b.width, b.height)
    }
}

/// Whitted's subdivision test on the corner samples of a square: display values differing by
/// more than `threshold`, different ray trees (objects, checker squares or shadowing lights
/// anywhere in them), or a near miss of a small object. Without the ray-tree test a pixel
/// whose corners land on two squares of one colour, or see the same brightness in a mirror,
/// is averaged over a wedge of the other colour it never sampled.
fn corners_differ(q: &[Sample; 4], threshold: f64) -> bool {
    let d0 = q[0].display;
    q.iter().any(|a| {
        (a.display - d0).abs().max_element() > threshold || a.key != q[0].key || a.near_miss
    })
}

/// The pixels a block may write: a band of whole rows starting at row `y0`, `width` wide, and
/// the first row past the image (or the band).
struct BlockArea<'a> {
    out: &'a mut [[f32; 3]],
    y0: usize,
    width: usize,
    height: usize,
}

/// sRGB transfer function of a linear value in [0, 1].
pub fn srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0 + 0.5) as u8
}

/// 8-bit sRGB bytes of a linear image: [`srgb`] of each channel, looked up instead of
/// computed with a power: the code at the start of the value's bucket (its `f32` bit pattern
/// shifted right by [`SRGB_BUCKET_BITS`]) raised past the steps ([`srgb_steps`]) the value
/// reaches within the bucket. The same bytes as [`srgb`] wherever [`srgb`] never decreases.
pub fn to_srgb8(img: &Image) -> Vec<u8> {
    let (steps, start) = (srgb_steps(), srgb_bucket_codes());
    let code = |v: f32| -> u8 {
        if !(v > 0.0) {
            return 0;
        }
        if v >= 1.0 {
            return 255;
        }
        let mut c = start[(v.to_bits() >> SRGB_BUCKET_BITS) as usize];
        while c < 255 && v >= steps[c as usize] {
            c += 1;
        }
        c
    };
    img.pixels
        .iter()
        .flat_map(|p| [code(p[0]), code(p[1]), code(p[2])])
        .collect()
}

/// Bit patterns of [0, 1) per bucket of [`to_srgb8`]'s table, as a shift (2¹⁴ patterns: the
/// buckets are narrower than the gaps between steps, at most 10⁻³ wide near 1 where codes
/// are 9·10⁻³ apart, so a lookup passes at most one step).
pub const SRGB_BUCKET_BITS: u32 = 14;

/// [`srgb`] of the first value of each bucket of [`to_srgb8`]'s table.
fn srgb_bucket_codes() -> &'static [u8] {
    static CODES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    CODES.get_or_init(|| {
        (0..=1.0f32.to_bits() >> SRGB_BUCKET_BITS)
            .map(|b| srgb(f32::from_bits(b << SRGB_BUCKET_BITS)))
            .collect()
    })
}

/// Where [`srgb`] steps: entry k − 1 is the least `f32` whose code is k (k = 1…255), found by
/// bisection on the bit patterns of [0, 1] (ordered as the numbers are).
pub fn srgb_steps() -> &'static [f32; 255] {
    static STEPS: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    STEPS.get_or_init(|| {
        let mut steps = [0.0f32; 255];
        for (k, step) in (1..=255u8).zip(steps.iter_mut()) {
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if srgb(f32::from_bits(mid)) >= k {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *step = f32::from_bits(hi);
        }
        steps
    })
}

/// Largest image side rendered without an explicit permission (`--allow-large-image`).
pub const MAX_SIDE: u32 = 8192;
/// Largest pixel count rendered without an explicit permission: 16 M pixels.
pub const MAX_PIXELS: u64 = 1 << 24;

/// An error for an image beyond [`MAX_SIDE`] on a side or [`MAX_PIXELS`] in all, unless
/// `allow_large` (rendering keeps about 35 bytes a pixel, so 16 M pixels take about 0.6 GB).
pub fn check_image_size(width: u32, height: u32, allow_large: bool) -> Result<(), String> {
    let pixels = width as u64 * height as u64;
    if !allow_large && (width > MAX_SIDE || height > MAX_SIDE || pixels > MAX_PIXELS) {
        return Err(format!(
            "the image would be {width}×{height} ({:.1} M pixels), above the limit of {MAX_SIDE} on a side and {} M pixels (about 35 bytes of memory a pixel)\n  fix: render smaller, or allow it with --allow-large-image",
            pixels as f64 / 1e6,
            MAX_PIXELS >> 20
        ));
    }
    Ok(())
}

/// An error unless every pixel of `img` is finite: how many are not, and the first (x, y).
pub fn check_finite(img: &Image) -> anyhow::Result<()> {
    let bad = img
        .pixels
        .iter()
        .filter(|p| p.iter().any(|v| !v.is_finite()))
        .count();
    if let Some(k) = img
        .pixels
        .iter()
        .position(|p| p.iter().any(|v| !v.is_finite()))
    {
        let w = img.width.max(1) as usize;
        anyhow::bail!(
            "the rendered image has {bad} pixels that are not finite numbers (the first at x = {}, y = {}: {:?}); nothing was written\n  fix: lower the values that overflow: light intensity, colours or the material's parameters",
            k % w,
            k / w,
            img.pixels[k]
        );
    }
    Ok(())
}

/// Write `base.png` (sRGB 8-bit) and `base.exr` (linear f32), atomically; returns both paths.
/// An image holding a NaN or infinite pixel is refused (an error, no file): the message gives
/// how many and the first.
pub fn save(img: &Image, base: &std::path::Path) -> anyhow::Result<[std::path::PathBuf; 2]> {
    check_finite(img)
        .map_err(|e| anyhow::anyhow!("{}: {e}", base.with_extension("exr").display()))?;
    let png = crate::plot::encode_png(img.width, img.height, &to_srgb8(img))?;
    crate::output::write_bytes_atomic(&base.with_extension("png"), &png)?;
    // The encoder's buffer at the uncompressed size (a growing one copies itself as it
    // doubles), and the pixels as one flat copy.
    let mut exr = std::io::Cursor::new(Vec::with_capacity(12 * img.pixels.len() + 4096));
    let data: Vec<f32> = img.pixels.as_flattened().to_vec();
    let buf = image::Rgb32FImage::from_raw(img.width, img.height, data)
        .ok_or_else(|| anyhow::anyhow!("image size mismatch"))?;
    image::DynamicImage::ImageRgb32F(buf)
        .write_to(&mut exr, image::ImageFormat::OpenExr)
        .map_err(|e| anyhow::anyhow!("EXR encoding failed: {e}"))?;
    crate::output::write_bytes_atomic(&base.with_extension("exr"), exr.get_ref())?;
    Ok([base.with_extension("png"), base.with_extension("exr")])
}

/// Root-mean-square difference of two linear images (all channels).
pub fn rmse(a: &Image, b: &Image) -> f64 {
    let n = a.pixels.len().min(b.pixels.len()).max(1);
    let s: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (0..3).map(|k| ((p[k] - q[k]) as f64).powi(2)).sum::<f64>())
        .sum();
    (s / (3 * n) as f64).sqrt()
}

/// The eight images of Blinn's Figure 7: `{aluminium,mgo}-{front,edge}-{phong,ts}`, with the
/// Torrance–Sparrow models given and Phong with equal β ([`crate::model::equal_beta_phong`]).
pub fn fig7_images(
    aluminium: &Model,
    mgo: &Model,
    res: u32,
    aa: AntiAlias,
) -> Vec<(String, Image)> {
    fig7_images_with_progress(aluminium, mgo, res, aa, &|| {})
}

/// [`fig7_images`], calling `progress` once per finished image row (8 × `res` calls in all).
pub fn fig7_images_with_progress(
    aluminium: &Model,
    mgo: &Model,
    res: u32,
    aa: AntiAlias,
    progress: &(dyn Fn() + Sync),
) -> Vec<(String, Image)> {
    let mut out = Vec::new();
    for (mat, ts) in [("aluminium", aluminium), ("mgo", mgo)] {
        for (lname, lighting) in [
            ("front", scene::Lighting::Front),
            ("edge", scene::Lighting::Edge),
        ] {
            for (mname, m) in [("phong", crate::model::equal_beta_phong(ts)), ("ts", *ts)] {
                let mut s = scene::fig7_scene(m, lighting, res);
                s.antialias = aa;
                out.push((format!("{mat}-{lname}-{mname}"), s.render(progress)));
            }
        }
    }
    out
}

/// The square crop (x0, y0, side) of the images that holds every pixel brighter than `level`
/// (sRGB, in any image) with a margin: the whole image unless the visible part is small, so a thin
/// edge-lit crescent is shown large.
pub fn visible_crop(srgb: &[Vec<u8>], w: u32, h: u32, level: u8) -> (u32, u32, u32) {
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = 3 * (y * w + x) as usize;
            if srgb.iter().any(|s| s[i..i + 3].iter().any(|&v| v > level)) {
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
    }
    if x1 < x0 {
        return (0, 0, w.min(h));
    }
    let side = ((x1 - x0).max(y1 - y0) + 1 + w / 16)
        .max(w / 8)
        .min(w.min(h));
    if side * 10 > w.min(h) * 7 {
        return (0, 0, w.min(h));
    }
    let cx = (x0 + x1) / 2;
    let cy = (y0 + y1) / 2;
    let left = cx.saturating_sub(side / 2).min(w - side);
    let top = cy.saturating_sub(side / 2).min(h - side);
    (left, top, side)
}

/// The square `side`×`side` crop at (`cx`, `cy`) of an 8-bit RGB image `w` pixels wide,
/// resampled to `tile`×`tile` with a smooth filter (Catmull–Rom bicubic, as the `image`
/// crate's `imageops::resize`, whose support widens when it shrinks: [`resize_catmull_rom`]):
/// a zoomed crescent shows smooth edges, not blocks of pixels. The crop is clamped to the
/// image.
pub fn zoom_crop(rgb: &[u8], w: u32, (cx, cy, side): (u32, u32, u32), tile: u32) -> Vec<u8> {
    let h = (rgb.len() / 3) as u32 / w.max(1);
    let (cx, cy) = (cx.min(w.saturating_sub(1)), cy.min(h.saturating_sub(1)));
    let side = side.min(w - cx).min(h - cy).max(1) as usize;
    let (w, cx, cy) = (w as usize, cx as usize, cy as usize);
    let mut crop = Vec::with_capacity(3 * side * side);
    for y in cy..cy + side {
        crop.extend_from_slice(&rgb[3 * (y * w + cx)..3 * (y * w + cx + side)]);
    }
    resize_catmull_rom(&crop, (side, side), (tile as usize, tile as usize))
}

/// The Catmull–Rom kernel (Keys 1981; the Mitchell–Netravali cubic with B = 0, C = ½), in
/// `f32` as the `image` crate writes it.
fn catmull_rom(x: f32) -> f32 {
    let a = x.abs();
    let k = if a < 1.0 {
        9.0 * a.powi(3) + -15.0 * a.powi(2) + 6.0
    } else if a < 2.0 {
        -3.0 * a.powi(3) + 15.0 * a.powi(2) + -24.0 * a + 12.0
    } else {
        0.0
    };
    k / 6.0
}

/// The taps of one output coordinate of a resampling from `from` to `to` samples: the first
/// input index and the normalised weights (the support widened by the ratio when shrinking).
fn resample_taps(from: usize, to: usize) -> Vec<(usize, Vec<f32>)> {
    let ratio = from as f32 / to as f32;
    let sratio = if ratio < 1.0 { 1.0 } else { ratio };
    let support = 2.0 * sratio;
    (0..to)
        .map(|o| {
            let centre = (o as f32 + 0.5) * ratio;
            let left = ((centre - support).floor() as i64).clamp(0, from as i64 - 1);
            let right = ((centre + support).ceil() as i64).clamp(left + 1, from as i64);
            let centre = centre - 0.5;
            let mut ws: Vec<f32> = (left..right)
                .map(|i| catmull_rom((i as f32 - centre) / sratio))
                .collect();
            let sum = ws.iter().fold(0.0f32, |s, &w| s + w);
            ws.iter_mut().for_each(|w| *w /= sum);
            (left as usize, ws)
        })
        .collect()
}

/// An 8-bit RGB image of `(sw, sh)` pixels resampled to `(tw, th)` with the Catmull–Rom
/// filter: the bytes of the `image` crate's `imageops::resize(…, FilterType::CatmullRom)`
/// (columns first into `f32`, then rows, each sum in the same order, rounded half away from
/// zero), with both passes running along rows (that crate's second pass walks down columns).
pub fn resize_catmull_rom(
    src: &[u8],
    (sw, sh): (usize, usize),
    (tw, th): (usize, usize),
) -> Vec<u8> {
    if (sw, sh) == (tw, th) {
        return src.to_vec();
    }
    if sw == 0 || sh == 0 {
        return vec![0; 3 * tw * th];
    }
    // Columns: output row o is the weighted sum of input rows left.., a row at a time.
    let mut mid = vec![0.0f32; 3 * sw * th];
    for ((left, ws), out) in resample_taps(sh, th)
        .iter()
        .zip(mid.chunks_exact_mut(3 * sw))
    {
        for (k, &wt) in ws.iter().enumerate() {
            let row = &src[3 * sw * (left + k)..3 * sw * (left + k + 1)];
            for (t, &v) in out.iter_mut().zip(row) {
                *t += v as f32 * wt;
            }
        }
    }
    // Rows: each output pixel of a row from its taps along that row.
    let taps = resample_taps(sw, tw);
    let mut out = vec![0u8; 3 * tw * th];
    for (row, dst) in mid.chunks_exact(3 * sw).zip(out.chunks_exact_mut(3 * tw)) {
        for ((left, ws), px) in taps.iter().zip(dst.chunks_exact_mut(3)) {
            let mut t = [0.0f32; 3];
            for (k, &wt) in ws.iter().enumerate() {
                let p = &row[3 * (left + k)..3 * (left + k) + 3];
                for c in 0..3 {
                    t[c] += p[c] * wt;
                }
            }
            for c in 0..3 {
                px[c] = t[c].clamp(0.0, 255.0).round() as u8;
            }
        }
    }
    out
}

/// A labelled contact sheet (PNG bytes) of Figure 7 images laid out as Blinn's figure: rows
/// aluminium and MgO, columns front/edge × Phong/Torrance–Sparrow.
pub fn contact_sheet(images: &[(String, Image)]) -> anyhow::Result<Vec<u8>> {
    use plotters::prelude::*;
    let tile = 256u32;
    let (cols, rows) = (4u32, 2u32);
    let (top, left, gap) = (60u32, 110u32, 8u32);
    let (w, h) = (left + cols * (tile + gap), top + rows * (tile + gap + 24));
    let mut buf = vec![0u8; (w * h * 3) as usize];
    for px in buf.chunks_mut(3) {
        px.copy_from_slice(&[255, 255, 255]);
    }
    // The edge-lit images (columns 3 and 4) of each row share one crop around the lit
    // crescent, so its thin highlight is large enough to compare.
    let crop = |r: usize| {
        let edge: Vec<Vec<u8>> = images
            .iter()
            .skip(4 * r + 2)
            .take(2)
            .map(|(_, i)| to_srgb8(i))
            .collect();
        match images.get(4 * r + 2) {
            Some((_, i)) if edge.len() == 2 => {
                // The highlight: pixels above half the brightest (the ambient-lit rest of
                // the sphere stays below).
                let top = edge.iter().flatten().copied().max().unwrap_or(0);
                visible_crop(&edge, i.width, i.height, top / 2)
            }
            Some((_, i)) => (0, 0, i.width.min(i.height)),
            None => (0, 0, 1),
        }
    };
    let crops = [crop(0), crop(1)];
    for (k, (_, img)) in images.iter().enumerate().take(8) {
        let (r, c) = (k as u32 / 4, k as u32 % 4);
        let (x0, y0) = (left + c * (tile + gap), top + r * (tile + gap + 24));
        let (cx, cy, side) = if c >= 2 {
            crops[r as usize]
        } else {
            (0, 0, img.width.min(img.height))
        };
        // Smooth resampling of the (cropped) image onto the tile.
        let zoomed = zoom_crop(&to_srgb8(img), img.width, (cx, cy, side), tile);
        for y in 0..tile {
            let o = (((y0 + y) * w + x0) * 3) as usize;
            let i = (3 * y * tile) as usize;
            buf[o..o + 3 * tile as usize].copy_from_slice(&zoomed[i..i + 3 * tile as usize]);
        }
    }
    {
        crate::plot::register_font_once();
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let font = ("sans-serif", 16).into_font();
        let t = |s: &str, x: u32, y: u32, size: f64| {
            root.draw(&Text::new(
                s.to_string(),
                (x as i32, y as i32),
                ("sans-serif", size).into_font(),
            ))
        };
        let e = |r: Result<(), _>| r.map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"));
        e(root.draw(&Text::new(
            "Blinn 1977, Figure 7: Phong against Torrance–Sparrow (equal β)".to_string(),
            (10, 8),
            font,
        )))?;
        for (c, label) in [
            "front lit, Phong",
            "front lit, Torrance–Sparrow",
            "edge lit, Phong",
            "edge lit, Torrance–Sparrow",
        ]
        .iter()
        .enumerate()
        {
            e(t(label, left + c as u32 * (tile + gap) + 4, 36, 14.0))?;
        }
        for (r, label) in ["aluminium", "MgO"].iter().enumerate() {
            e(t(
                label,
                8,
                top + r as u32 * (tile + gap + 24) + tile / 2,
                16.0,
            ))?;
        }
        for (k, (name, img)) in images.iter().enumerate().take(8) {
            let (r, c) = (k as u32 / 4, k as u32 % 4);
            let side = if c >= 2 {
                crops[r as usize].2
            } else {
                img.width
            };
            let name = if side < img.width.min(img.height) {
                format!("{name}, zoomed ×{:.1}", img.width as f64 / side as f64)
            } else {
                name.clone()
            };
            e(t(
                &name,
                left + c * (tile + gap) + 4,
                top + r * (tile + gap + 24) + tile + 4,
                12.0,
            ))?;
        }
        root.present()
            .map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"))?;
    }
    crate::plot::encode_png(w, h, &buf)
}

/// Folds `v` into the hash `h` with the splitmix64 finaliser (Steele, Lea & Flood 2014): the
/// keys of ray trees and the fixed random offsets of jittered samples.
fn mix(h: u64, v: u64) -> u64 {
    let mut z = (h.rotate_left(23) ^ v).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A fixed point of [0, 1)² for the sample at integer lattice position (i, j): the same
/// position gives the same offset in every run, so jittered images are deterministic.
fn jitter(i: u64, j: u64) -> (f64, f64) {
    // One finaliser over both coordinates (each below 2^32 in any image we render): it sits
    // on every sample's critical path.
    let z = mix(0, i ^ (j << 32));
    let unit = 1.0 / (1u64 << 24) as f64;
    (
        (z >> 40) as f64 * unit,
        ((z >> 16) & 0xFF_FFFF) as f64 * unit,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-major resampler gives the `image` crate's `resize` bytes (the peer it replaced)
    /// for shrinking, enlarging, mixed, equal and tiny sizes, on pseudo-random images with
    /// hard edges (0 and 255 runs, where the kernel's negative lobes clamp).
    #[test]
    fn catmull_rom_resize_equals_the_image_crates() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut byte = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            match state % 8 {
                0 => 0,
                1 => 255,
                _ => (state >> 32) as u8,
            }
        };
        for (src, dst) in [
            ((512, 512), (256, 256)),
            ((37, 37), (256, 256)),
            ((300, 200), (256, 97)),
            ((256, 256), (256, 256)),
            ((1, 1), (4, 4)),
            ((5, 9), (3, 2)),
            ((64, 3), (7, 11)),
        ] {
            let px: Vec<u8> = (0..3 * src.0 * src.1).map(|_| byte()).collect();
            let img = image::RgbImage::from_raw(src.0 as u32, src.1 as u32, px.clone()).unwrap();
            let peer = image::imageops::resize(
                &img,
                dst.0 as u32,
                dst.1 as u32,
                image::imageops::FilterType::CatmullRom,
            )
            .into_raw();
            let ours = resize_catmull_rom(&px, src, dst);
            let differ = ours.iter().zip(&peer).filter(|(a, b)| a != b).count();
            assert_eq!((ours.len(), differ), (peer.len(), 0), "{src:?} → {dst:?}");
        }
    }

    /// The table's codes are [`srgb`]'s own at every step (the value there and the bit
    /// patterns 300 either side), at a stride through every `f32` of [0, 1], at each bucket's
    /// first and last value, and beyond.
    #[test]
    fn srgb_codes_from_the_steps_equal_the_transfer_function() {
        let mut values = vec![f32::NAN, f32::NEG_INFINITY, -1.0, -0.0, 0.0, 1.0, 2.0];
        values.push(f32::INFINITY);
        for &t in srgb_steps() {
            let b = t.to_bits();
            values.extend((b - 300..=b + 300).map(f32::from_bits));
        }
        values.extend((0..=1.0f32.to_bits()).step_by(997).map(f32::from_bits));
        for b in 0..=1.0f32.to_bits() >> SRGB_BUCKET_BITS {
            let first = b << SRGB_BUCKET_BITS;
            values.push(f32::from_bits(first));
            values.push(f32::from_bits(first + (1 << SRGB_BUCKET_BITS) - 1));
        }
        let img = Image {
            width: values.len() as u32,
            height: 1,
            pixels: values.iter().map(|&v| [v, v, v]).collect(),
            rays: [0; 4],
        };
        let codes = to_srgb8(&img);
        for (k, &v) in values.iter().enumerate() {
            assert_eq!(codes[3 * k], srgb(v), "at {v:e} ({:#x})", v.to_bits());
        }
        // Hand-worked: code 1 from half a code of 12.92 v, code 255 from 254.5/255 of
        // 1.055 v^(1/2.4) − 0.055.
        let s = srgb_steps();
        assert!((s[0] - 0.5 / 255.0 / 12.92).abs() < 1e-8, "{}", s[0]);
        let top = ((254.5 / 255.0 + 0.055) / 1.055f64).powf(2.4) as f32;
        assert!((s[254] - top).abs() < 1e-6, "{} against {top}", s[254]);
    }
}

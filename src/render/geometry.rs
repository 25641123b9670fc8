//! Shapes and lights: what a ray meets (spheres, planes, meshes inside bounding
//! spheres), where a light is seen from a point, and the mirror and refracted directions.

use super::Mesh;
use super::ray::Ray;
use glam::DVec3;

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

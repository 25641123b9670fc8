//! Whitted's ray tree: the nearest hit, shadow rays, local shading by the material's model,
//! and the recursive mirror and refracted rays (Whitted 1980, eq. 2); also the light/eye
//! configurations a scene shows of a material.

use super::geometry::{reflect, refract};
use super::{CameraFrame, Counters, Light, Ray, Scene};
use crate::model::{Geometry, ModelKind};
use glam::DVec3;
use rayon::prelude::*;

impl Scene {
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
    pub(super) fn trace_key(
        &self,
        r: &Ray,
        depth: u32,
        weight: f64,
        c: &Counters,
        key: &mut u64,
    ) -> DVec3 {
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
    pub(super) fn surface(r: &Ray, t: f64, n_out: DVec3) -> (DVec3, bool, DVec3, DVec3, f64) {
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
    pub(super) fn light_at(
        &self,
        light: &Light,
        p: DVec3,
        n: DVec3,
        e: DVec3,
        eps: f64,
    ) -> LightAt {
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
    /// given, holds each light's [`Scene::light_at`] there, computed beforehand ([`Corners`](super::Corners)).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn shade(
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
            // This ray's share of the tree's budget, less itself, split by weight.
            let budget = if depth == 0 {
                super::RAY_TREE_BUDGET
            } else {
                c.budget.get()
            };
            let share = |k: f64| (budget - 1.0) * k / (m.ks + m.kt);
            if m.ks > 0.0 && weight * m.ks >= self.min_weight && share(m.ks) >= 1.0 {
                Counters::bump(&c.reflected);
                c.budget.set(share(m.ks));
                let d = reflect(r.d, n);
                out += m.ks
                    * self.trace_key(&Ray { o: p + eps * n, d }, depth + 1, weight * m.ks, c, key);
            }
            c.budget.set(share(m.kt));
            if m.kt > 0.0 && weight * m.kt >= self.min_weight && share(m.kt) >= 1.0 {
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
    pub(super) fn radiance(&self, cam: &CameraFrame, x: f64, y: f64, c: &Counters) -> DVec3 {
        Counters::bump(&c.primary);
        self.trace(&cam.ray(x, y), 0, 1.0, c)
    }
}

/// Ray-tree key tags: a ray that left the scene, a light blocked (ORed with its index).
pub(super) const MISSED: u64 = u64::MAX;
const SHADOWED: u64 = 1 << 63;

/// A ray's nearest hit: object index, t, outward normal.
pub(super) type Hit = (usize, f64, DVec3);

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

/// Folds `v` into the hash `h` with the splitmix64 finaliser (Steele, Lea & Flood 2014): the
/// keys of ray trees and the fixed random offsets of jittered samples.
pub(super) fn mix(h: u64, v: u64) -> u64 {
    let mut z = (h.rotate_left(23) ^ v).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

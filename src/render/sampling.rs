//! Image sampling: the primary rays of each anti-aliasing mode, Whitted's adaptive corner
//! subdivision with its shared corner pass ([`Corners`]), and the render loops over rows.

use super::trace::{Hit, MISSED, mix};
use super::{Camera, CameraFrame, Counters, Image, LightAt, Scene};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::AtomicU64;

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

//! Triangle meshes and their bounding-volume hierarchy: building it and intersecting a ray
//! with it.

use super::ray::Ray;
use glam::DVec3;

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

    pub(super) fn bounds(&self, a: usize, b: usize) -> (DVec3, DVec3) {
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

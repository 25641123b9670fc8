//! A goniometer's grid of log ratios: the lookup `reconstruct` uses when
//! the samples fill a regular grid in the instrument's own coordinates (θi slices, θo and the
//! azimuth Δφ at uniform steps), interpolated at the samples themselves, where there is no
//! θh → 0 degeneracy. The table (`measured::Tabulated`) holds it and
//! calls it at each lookup.

use crate::model::Geometry;

/// Steps of θo over which the trend beyond the last θo is taken (linear continuation of the
/// log ratio: it lowered white-paint's front-lit ꟻLIP p99 from 0.052 to 0.045 against holding
/// the last value, README).
const TREND: usize = 5;

/// Floor of an estimate's reach in that blend (radians, 0.01°).
const REACH_FLOOR: f64 = 0.01 * std::f64::consts::PI / 180.0;

/// A goniometer's measurement as a regular grid of log ratios to the base model: θi slices,
/// θo at a uniform step, the azimuth Δφ = φo − φi at a uniform step over the whole circle
/// (a missing azimuth taken from its mirror image −Δφ by isotropy).
#[derive(Debug)]
pub struct GonioGrid {
    /// θi of the slices (radians), ascending.
    slices: Vec<f64>,
    /// (sin, cos) of each slice's θi, for the rotation of [`GonioGrid::estimate`].
    slice_sin_cos: Vec<(f64, f64)>,
    /// First θo, its step (radians) and count.
    to: (f64, f64, usize),
    /// First Δφ, its step (radians) and count (the whole circle).
    ph: (f64, f64, usize),
    /// Log ratios, Δφ fastest, then θo, then slice.
    v: Vec<f64>,
}

/// Catmull–Rom weights at fraction `t` for the points −1, 0, 1, 2.
#[inline]
fn cr(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t + 2.0 * t2 - t3),
        0.5 * (2.0 - 5.0 * t2 + 3.0 * t3),
        0.5 * (t + 4.0 * t2 - 3.0 * t3),
        0.5 * (t3 - t2),
    ]
}

/// The distinct keys, sorted.
fn distinct(keys: impl Iterator<Item = i64>) -> Vec<i64> {
    let mut v: Vec<i64> = keys.collect();
    v.sort_unstable();
    v.dedup();
    v
}

impl GonioGrid {
    /// The grid of `keys` (θi, θo, Δφ in hundredths of a degree, Δφ in [0, 36000)) with the
    /// log ratios `val`; `None` unless the samples fill a regular grid.
    pub(super) fn new(keys: &[[i64; 3]], val: &[f64]) -> Option<GonioGrid> {
        let ti = distinct(keys.iter().map(|k| k[0]));
        let to = distinct(keys.iter().map(|k| k[1]));
        let ph = distinct(keys.iter().map(|k| k[2]));
        if !(2..=90).contains(&ti.len()) || to.len() < 4 || ph.len() < 2 {
            return None;
        }
        let tstep = to[1] - to[0];
        if tstep <= 0 || to.windows(2).any(|w| w[1] - w[0] != tstep) {
            return None;
        }
        let pstep = ph.windows(2).map(|w| w[1] - w[0]).min()?;
        if pstep <= 0 || 36000 % pstep != 0 || ph.iter().any(|p| (p - ph[0]) % pstep != 0) {
            return None;
        }
        let (nti, nto, nph) = (ti.len(), to.len(), (36000 / pstep) as usize);
        if nph < 4 {
            return None;
        }
        let cells = nti * nto * nph;
        let mut direct = vec![(0.0, 0u32); cells];
        let mut mirror = vec![(0.0, 0u32); cells];
        for (k, v) in keys.iter().zip(val) {
            let i = ti.binary_search(&k[0]).ok()?;
            let j = ((k[1] - to[0]) / tstep) as usize;
            let base = (i * nto + j) * nph;
            let l = ((k[2] - ph[0]) / pstep) as usize;
            direct[base + l].0 += v;
            direct[base + l].1 += 1;
            let m = (36000 - k[2]) % 36000 - ph[0];
            if m.rem_euclid(pstep) == 0 {
                let l = (m.rem_euclid(36000) / pstep) as usize % nph;
                mirror[base + l].0 += v;
                mirror[base + l].1 += 1;
            }
        }
        let mut out = Vec::with_capacity(cells);
        for (d, m) in direct.iter().zip(&mirror) {
            let (s, n) = if d.1 > 0 { *d } else { *m };
            if n == 0 {
                return None;
            }
            out.push(s / n as f64);
        }
        let rad = |x: i64| (x as f64 / 100.0).to_radians();
        let slices: Vec<f64> = ti.iter().map(|&x| rad(x)).collect();
        Some(GonioGrid {
            slice_sin_cos: slices.iter().map(|s| s.sin_cos()).collect(),
            slices,
            to: (rad(to[0]), rad(tstep), nto),
            ph: (rad(ph[0]), rad(pstep), nph),
            v: out,
        })
    }

    /// The log ratio within slice `k` at view (θo, Δφ), bicubic (Catmull–Rom in θo, periodic
    /// in Δφ); below the first θo the first θo's value, beyond the last the trend of the last
    /// [`TREND`] steps continued linearly.
    #[inline]
    fn in_slice(&self, k: usize, to: f64, ph: f64) -> f64 {
        let (t0, ts, nt) = self.to;
        let x = (to - t0) / ts;
        let last = (nt - 1) as f64;
        if x > last && nt > TREND {
            // Beyond the last θo: the trend of the last TREND steps continues linearly.
            let a = self.at_index(k, last, ph);
            let b = self.at_index(k, last - TREND as f64, ph);
            return a + (a - b) / TREND as f64 * (x - last);
        }
        self.at_index(k, x, ph)
    }

    /// The log ratio within slice `k` at fractional θo index `x` (clamped to the measured
    /// range) and azimuth `ph`, bicubic.
    #[inline]
    fn at_index(&self, k: usize, x: f64, ph: f64) -> f64 {
        let (_, _, nt) = self.to;
        let x = x.clamp(0.0, (nt - 1) as f64);
        let i = (x as usize).min(nt - 2);
        let wt = cr(x - i as f64);
        let (p0, ps, np) = self.ph;
        // The azimuth index modulo np: within one period of [0, np) (every view from
        // `estimate`, ph in [−π, π], when the grid's first azimuth p0 is below π), the value
        // itself or one addition, as `rem_euclid` gives it there; `rem_euclid` (a library
        // fmod) only beyond.
        let (y, npf) = ((ph - p0) / ps, np as f64);
        let y = if (0.0..npf).contains(&y) {
            y
        } else if y > -npf && y < 0.0 {
            y + npf
        } else {
            y.rem_euclid(npf)
        };
        let j = (y as usize).min(np - 1);
        let wp = cr(y - j as f64);
        // The four azimuth columns j − 1 … j + 2, wrapped once (not a division per tap).
        let wrap = |c: usize| if c >= np { c - np } else { c };
        let cols = [wrap(j + np - 1), j, wrap(j + 1), wrap(j + 2)];
        let mut s = 0.0;
        for (a, wa) in wt.iter().enumerate() {
            let row = (i + a).saturating_sub(1).min(nt - 1);
            let v = &self.v[(k * nt + row) * np..][..np];
            let mut r = 0.0;
            for (wb, &c) in wp.iter().zip(&cols) {
                r += wb * v[c];
            }
            s += wa * r;
        }
        s
    }

    /// The log ratio at light θi `a`, view θo, azimuth cos/sin of Δφ, from the θi slices:
    /// between the two neighbouring slices (or the nearest beyond them), each evaluated where
    /// the view keeps its offset from that slice's mirror direction (`along_lobe`).
    /// `(sa, ca)` and `(sb, cb)` are the sines and cosines of `a` and θo: each slice's
    /// rotation is the angle difference θi_k − θi from the slices' precomputed sines and
    /// cosines.
    fn estimate(
        &self,
        a: f64,
        (sa, ca): (f64, f64),
        (sb, cb): (f64, f64),
        cp: f64,
        sp: f64,
    ) -> f64 {
        let e = [sb * cp, sb * sp, cb];
        let at = |k: usize| {
            // The view rotated about the y axis by θi − θi_k as the light is rotated by
            // θi_k − θi: its offset from the mirror direction is kept. sin and cos of
            // θi_k − θi by the difference formulas.
            let (sk, ck) = self.slice_sin_cos[k];
            let (st, ct) = (sk * ca - ck * sa, ck * ca + sk * sa);
            let x = e[0] * ct - e[2] * st;
            let z = e[2] * ct + e[0] * st;
            // The rotated view's polar angle from its z (a rotation keeps the view a unit
            // vector): one acos instead of a hypot and an atan2, within 1e-13 rad but for
            // views within 0.1° of the normal, where the rounding of z gives at most 1.5e-8.
            self.in_slice(k, z.clamp(-1.0, 1.0).acos(), e[1].atan2(x))
        };
        let n = self.slices.len();
        if a <= self.slices[0] {
            return at(0);
        }
        let s = &self.slices;
        if a >= s[n - 1] {
            // Beyond the last slice: the trend of the last two continues linearly (along the
            // lobe).
            let (p, q) = (at(n - 1), at(n - 2));
            return p + (p - q) * (a - s[n - 1]) / (s[n - 1] - s[n - 2]);
        }
        let k = s.partition_point(|&x| x <= a) - 1;
        let h = s[k + 1] - s[k];
        let t = (a - s[k]) / h;
        if n < 3 {
            return (1.0 - t) * at(k) + t * at(k + 1);
        }
        // Cubic Hermite with the tangents of the neighbouring slices (Catmull–Rom where the
        // slices are evenly spaced; at an end the missing neighbour repeats the end slice at
        // one step beyond it).
        let (v0, v1) = (at(k), at(k + 1));
        let m0 = if k > 0 {
            (v1 - at(k - 1)) / (s[k + 1] - s[k - 1])
        } else {
            (v1 - v0) / (2.0 * h)
        };
        let m1 = if k + 2 < n {
            (at(k + 2) - v0) / (s[k + 2] - s[k])
        } else {
            (v1 - v0) / (2.0 * h)
        };
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * v0
            + (t3 - 2.0 * t2 + t) * h * m0
            + (3.0 * t2 - 2.0 * t3) * v1
            + (t3 - t2) * h * m1
    }

    /// How far an estimate with light θi `a` and view θo `b` reaches beyond the measured
    /// configurations (radians): the distance of `a` to the nearest slice (or to the slices'
    /// range) plus how far `b` lies beyond the measured θo.
    fn reach(&self, a: f64, b: f64) -> f64 {
        let n = self.slices.len();
        let da = if a <= self.slices[0] {
            self.slices[0] - a
        } else if a >= self.slices[n - 1] {
            a - self.slices[n - 1]
        } else {
            let k = self.slices.partition_point(|&s| s <= a) - 1;
            (a - self.slices[k]).min(self.slices[k + 1] - a)
        };
        let (t0, ts, nt) = self.to;
        da + (b - (t0 + ts * (nt - 1) as f64)).max(0.0) + (t0 - b).max(0.0)
    }

    /// The log ratio at a configuration: the direct estimate (θi interpolated between slices)
    /// and the reciprocal one (θo and θi exchanged), blended by how far each reaches beyond
    /// the measured configurations.
    pub fn log_ratio(&self, g: &Geometry) -> f64 {
        let (ca, cb) = (g.nl.clamp(-1.0, 1.0), g.ne.clamp(-1.0, 1.0));
        let (a, b) = (ca.acos(), cb.acos());
        // sin θ = √(1 − cos² θ) for θ in [0, π], and cos θ the cosine itself: no sine or
        // cosine of the angles just taken.
        let (sa, sb) = (
            (1.0 - ca * ca).max(0.0).sqrt(),
            (1.0 - cb * cb).max(0.0).sqrt(),
        );
        let le = 2.0 * g.nl * g.ne - g.re;
        let den = sa * sb;
        let cp = if den > 1e-12 {
            ((le - g.nl * g.ne) / den).clamp(-1.0, 1.0)
        } else {
            -1.0
        };
        let sp = (1.0 - cp * cp).max(0.0).sqrt();
        let direct = self.estimate(a, (sa, ca), (sb, cb), cp, sp);
        let recip = self.estimate(b, (sb, cb), (sa, ca), cp, sp);
        // The blend's weights, reach^−2, as a reciprocal square, not a power.
        let inverse_square = |x: f64| 1.0 / (x * x);
        let wa = inverse_square(self.reach(a, b) + REACH_FLOOR);
        let wb = inverse_square(self.reach(b, a) + REACH_FLOOR);
        (wa * direct + wb * recip) / (wa + wb)
    }
}

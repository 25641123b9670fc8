//! The BRDF fitting problem: per-sample geometry computed once, parameters transformed so
//! their bounds hold by construction, residuals of the `log` or `linear` loss.

use super::lsq::{Normal, Problem, Robust};
#[path = "kernels.rs"]
mod kernels;
use crate::lanes::{self, LANES};
use crate::model::{Distribution, Geometry, MAX_PARAMS, Model, ModelKind, ParamSpec, Scale};

/// Rows per channel above which a fit refines its candidates on a subsample of this many rows
/// per channel before polishing on every row.
pub const SUBSAMPLE_ROWS: usize = 2_000;

/// Which residual the fit minimises (½ Σ r²).
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Loss {
    /// r = ln(1 + cosθi f_model) − ln(1 + cosθi f_data) (default; balances peak and tail).
    #[default]
    Log,
    /// r = f_model − f_data.
    Linear,
    /// What a pixel shows: r = φ(cosθi f_model) − φ(cosθi f_data), φ = [`pixel`], the sRGB
    /// encoding of the radiance of a unit irradiance clipped (smoothly) at 1 as a PNG clips it.
    /// For scene-weighted fits whose data are scaled to the scene's exposure (`choose`); not on
    /// the command line. The global initialisation does not take it: give a start and
    /// `local_only`.
    #[value(skip)]
    Pixel,
}

/// Width of the smooth clip of [`pixel`] (in linear radiance).
pub const PIXEL_CLIP_WIDTH: f64 = 0.02;

/// The display value of linear radiance `x` and its derivative: the sRGB transfer function
/// (IEC 61966-2-1: 12.92 x up to 0.0031308, else 1.055 x^(1/2.4) − 0.055) of x clipped at 1
/// by the smooth minimum c(x) = −δ ln(e^(−x/δ) + e^(−1/δ)), δ = [`PIXEL_CLIP_WIDTH`] (c → x
/// below 1 − 3δ, → 1 above 1 + 3δ, c' = 1/(1 + e^((x − 1)/δ)) > 0, so the gradient exists where
/// a PNG saturates).
#[inline]
pub fn pixel(x: f64) -> (f64, f64) {
    let d = PIXEL_CLIP_WIDTH;
    // c = 1 − δ ln(1 + e^((1 − x)/δ)) written to stay finite for any x.
    let t = (1.0 - x) / d;
    let (c, dc) = if t > 0.0 {
        (x - d * (-t).exp().ln_1p(), 1.0 / (1.0 + (-t).exp()))
    } else {
        (1.0 - d * t.exp().ln_1p(), t.exp() / (1.0 + t.exp()))
    };
    if c <= 0.003_130_8 {
        (12.92 * c, 12.92 * dc)
    } else {
        let p = c.powf(1.0 / 2.4);
        (1.055 * p - 0.055, 1.055 / 2.4 * p / c * dc)
    }
}

impl Loss {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Loss::Log => "log",
            Loss::Linear => "linear",
            Loss::Pixel => "pixel",
        }
    }

    /// Parse `log` or `linear`.
    pub fn parse(s: &str) -> Option<Self> {
        <Self as clap::ValueEnum>::from_str(s, true).ok()
    }

    /// The data-side term: ln(1 + cosθi f) or f.
    #[inline]
    pub fn target(self, f: f64, cos_i: f64) -> f64 {
        match self {
            Loss::Log => (cos_i * f).ln_1p(),
            Loss::Linear => f,
            Loss::Pixel => pixel(cos_i * f).0,
        }
    }

    /// The residual's model term at f and its derivative with respect to f.
    #[inline]
    pub fn term(self, f: f64, cos_i: f64) -> (f64, f64) {
        match self {
            Loss::Log => {
                let fm = cos_i * f;
                (fm.ln_1p(), cos_i / (1.0 + fm))
            }
            Loss::Linear => (f, 1.0),
            Loss::Pixel => {
                let (v, d) = pixel(cos_i * f);
                (v, d * cos_i)
            }
        }
    }
}

/// How a free solver variable u maps to a model parameter θ, and the box u lives in.
///
/// Made from a parameter's [`ParamSpec`]: linear parameters (ps, pd) are solver variables
/// themselves, boxed by their bounds (a bound-constrained solver lets them reach and leave 0);
/// shape parameters are fitted on a log scale, θ = offset + e^u, whose derivative never vanishes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The mapping.
    pub scale: Scale,
    /// Lower bound of θ.
    pub lo: f64,
    /// Upper bound of θ.
    pub hi: f64,
}

impl Transform {
    /// θ = u without bounds (for statistics in natural parameters).
    pub const IDENTITY: Transform = Transform {
        scale: Scale::Linear,
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// The transform of a declared parameter.
    pub fn of(spec: &ParamSpec) -> Self {
        Transform {
            scale: spec.scale,
            lo: spec.lo,
            hi: spec.hi,
        }
    }

    /// θ(u) and dθ/du. On a log scale θ is capped at the upper bound: u at its bound gives
    /// offset + e^ln(hi − offset), which rounding can put an ulp above hi (n = 1e7 + 1e-8), a
    /// value the fit file reader rightly refuses.
    #[inline]
    pub fn apply(self, u: f64) -> (f64, f64) {
        match self.scale {
            Scale::Linear => (u, 1.0),
            Scale::Log { offset } => {
                let e = u.exp();
                ((offset + e).min(self.hi), e)
            }
        }
    }

    /// u(θ), the inverse, with θ first brought inside the bounds.
    pub fn invert(self, v: f64) -> f64 {
        let (lo, hi) = self.bounds();
        let u = match self.scale {
            Scale::Linear => v,
            Scale::Log { offset } => (v - offset).max(1e-300).ln(),
        };
        u.clamp(lo, hi)
    }

    /// The box on u.
    pub fn bounds(self) -> (f64, f64) {
        match self.scale {
            Scale::Linear => (self.lo, self.hi),
            Scale::Log { offset } => ((self.lo - offset).ln(), (self.hi - offset).ln()),
        }
    }

    /// A step u may always take in one Levenberg–Marquardt iteration: 1 on a log scale (a
    /// factor e), 0 on a linear one (purely relative).
    pub fn step_scale(self) -> f64 {
        match self.scale {
            Scale::Linear => 0.0,
            Scale::Log { .. } => 1.0,
        }
    }
}

/// The indices of the `k` largest values of `v` in `range` (ties to the lower index), in no
/// particular order. The k-th largest of the block maxima is a lower bound of the k-th largest
/// value, so only rows of blocks whose maximum reaches it are candidates; among them one
/// selection (linear time) finds the k-th largest value, and the rows above it, then the rows
/// equal to it in index order, are taken. The blocks (16–1,024 rows) are short enough that
/// there are about 4k of them: with fewer blocks than k the bound is void and every row would
/// be a candidate (the 62,500-row subsample of a million rows, k = 6,250, copied and selected
/// all million values). Values are compared as [`total_key`]s, the order of `f64::total_cmp`
/// (NaN and −0 included), so a block's maximum bounds every value in it.
fn largest(v: &[f64], range: std::ops::Range<usize>, k: usize) -> Vec<usize> {
    if k == 0 || range.is_empty() {
        return Vec::new();
    }
    let block = (range.len() / (4 * k)).clamp(16, 1024);
    let maxima = block_maxima(&v[range.clone()], block);
    let floor = if maxima.len() > k {
        let mut m = maxima.clone();
        *m.select_nth_unstable_by(k - 1, |a, b| b.cmp(a)).1
    } else {
        i64::MIN
    };
    let mut cand: Vec<usize> = Vec::new();
    for (b, &max) in maxima.iter().enumerate() {
        if max < floor {
            continue;
        }
        let lo = range.start + b * block;
        cand.extend((lo..(lo + block).min(range.end)).filter(|&i| total_key(v[i]) >= floor));
    }
    if cand.len() <= k {
        return cand;
    }
    let keys: Vec<i64> = cand.iter().map(|&i| total_key(v[i])).collect();
    let t = *keys
        .clone()
        .select_nth_unstable_by(k - 1, |a, b| b.cmp(a))
        .1;
    // Every value above t, then the values equal to t by lower index (`cand` is in order).
    let mut out: Vec<usize> = cand
        .iter()
        .zip(&keys)
        .filter_map(|(&i, &key)| (key > t).then_some(i))
        .collect();
    let equal = cand.iter().zip(&keys).filter(|(_, key)| **key == t);
    out.extend(equal.map(|(&i, _)| i).take(k - out.len()));
    out
}

/// `x` as an integer in the order of `f64::total_cmp` (the standard library's own mapping:
/// negative values have their magnitude bits flipped).
#[inline]
fn total_key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ (((b >> 63) as u64) >> 1) as i64
}

/// The largest [`total_key`] of each `block` values of `v`; vectorised (a 64-bit integer
/// maximum), compiled for AVX-512 and AVX2 as well and picked at run time.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn block_maxima(v: &[f64], block: usize) -> Vec<i64> {
    v.chunks(block)
        .map(|c| c.iter().map(|&x| total_key(x)).max().unwrap_or(i64::MIN))
        .collect()
}

/// Where a model parameter of one channel comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Slot {
    /// Free solver variable `k`.
    Free(usize),
    /// Held at a value.
    Fixed(f64),
}

/// One residual's data: the parameter-independent geometry and the data term.
#[derive(Clone, Copy, Debug)]
pub struct Row {
    /// Dot products of the sample's directions.
    pub g: Geometry,
    /// cosθi.
    pub cos_i: f64,
    /// ln(1 + cosθi f_data) or f_data.
    pub target: f64,
    /// √weight.
    pub sw: f64,
}

/// Where one chunk of [`Rows::par_fill`] puts the rows it keeps: its part of each column's
/// reserved (not yet written) memory, in the order nl, ne, nh, eh, re, g_ne, target, √weight
/// (an absent column: an empty part, skipped). Every push writes the row to every present
/// column, so the first `len` entries of each are set.
pub struct RowWriter<'a> {
    cols: [&'a mut [std::mem::MaybeUninit<f64>]; 8],
    len: usize,
}

impl RowWriter<'_> {
    /// Push [`LANES`] rows: row l's value of column j is `block[j][l]`. Panics (before
    /// counting them) if the part has no room for them.
    #[inline(always)]
    pub fn push_block(&mut self, block: &[[f64; LANES]; 8]) {
        let at = self.len;
        for (c, x) in self
            .cols
            .iter_mut()
            .zip(block)
            .filter(|(c, _)| !c.is_empty())
        {
            for (d, &v) in c[at..at + LANES].iter_mut().zip(x) {
                d.write(v);
            }
        }
        self.len += LANES;
    }

    /// Push row `l` of `block` (see [`RowWriter::push_block`]).
    #[inline(always)]
    pub fn push_lane(&mut self, block: &[[f64; LANES]; 8], l: usize) {
        let at = self.len;
        for (c, x) in self
            .cols
            .iter_mut()
            .zip(block)
            .filter(|(c, _)| !c.is_empty())
        {
            c[at].write(x[l]);
        }
        self.len += 1;
    }
}

/// Rows stored column by column (structure of arrays), so a kernel streams only the columns
/// its model reads and can work on several rows at once.
#[derive(Clone, Debug, Default)]
pub struct Rows {
    /// N·L (= cosθi).
    pub nl: Vec<f64>,
    /// N·E.
    pub ne: Vec<f64>,
    /// N·H.
    pub nh: Vec<f64>,
    /// E·H.
    pub eh: Vec<f64>,
    /// R·E.
    pub re: Vec<f64>,
    /// G/(N·E).
    pub g_ne: Vec<f64>,
    /// ln(1 + cosθi f_data) or f_data.
    pub target: Vec<f64>,
    /// √weight; empty when the rows are unweighted (every weight 1).
    pub sw: Vec<f64>,
    weighted: bool,
    /// Columns derived from the geometry alone, computed on first use and kept with the rows.
    derived: Derived,
}

/// Parameter-free columns a kernel reads, each computed once on first use ([`Rows::theta_h`],
/// [`Rows::ln_nh`], [`Rows::ggx`]); adding rows drops them.
#[derive(Clone, Debug, Default)]
struct Derived {
    /// θh = acos N·H (Torrance–Sparrow D2's kernel).
    theta_h: std::sync::OnceLock<Vec<f64>>,
    /// ln N·H (Torrance–Sparrow D1's kernel).
    ln_nh: std::sync::OnceLock<Vec<f64>>,
    /// GGX–Smith's terms.
    ggx: std::sync::OnceLock<GgxTerms>,
}

/// What GGX–Smith's lobe (Walter et al. 2007, eqs. 33 and 34 with Smith's G1) needs of a row
/// beside its roughness, one column each: tan² θi and tan² θo (G1's arguments), tan² θh and
/// 1/(4π N·E (N·H)⁴) (D's), and E·H (Fresnel's). Where N·H ≤ 0 or E·H ≤ 0 (no specular
/// reflection) tan² θh is 0, E·H is 1 and the factor 0, so the lobe is 0 with every term
/// finite.
#[derive(Clone, Debug, Default)]
pub struct GgxTerms {
    /// tan² θi = (1 − (N·L)²)/(N·L)².
    pub tan2_i: Vec<f64>,
    /// tan² θo.
    pub tan2_o: Vec<f64>,
    /// tan² θh, or 0.
    pub tan2_h: Vec<f64>,
    /// 1/(4π N·E (N·H)⁴), or 0.
    pub factor: Vec<f64>,
    /// E·H, or 1.
    pub eh: Vec<f64>,
}

/// tan² of the angle whose cosine is `c`: (1 − c²)/c², 0 at c ≥ 1.
#[inline(always)]
pub(super) fn tan2(c: f64) -> f64 {
    let c2 = c * c;
    (1.0 - c2).max(0.0) / c2
}

impl Rows {
    /// Empty columns with room for `n` rows.
    pub fn with_capacity(n: usize, weighted: bool) -> Self {
        let v = || Vec::with_capacity(n);
        Rows {
            nl: v(),
            ne: v(),
            nh: v(),
            eh: v(),
            re: v(),
            g_ne: v(),
            target: v(),
            sw: if weighted { v() } else { Vec::new() },
            weighted,
            derived: Derived::default(),
        }
    }

    /// θh = acos N·H of every row (N·H clamped to [0, 1]), computed once.
    pub fn theta_h(&self) -> &Vec<f64> {
        self.derived
            .theta_h
            .get_or_init(|| self.nh.iter().map(|x| x.clamp(0.0, 1.0).acos()).collect())
    }

    /// ln N·H of every row, N·H clamped to [0, 1] and taken as 1 where it is 0 (Torrance–Sparrow
    /// D1's kernel masks those rows), computed once in lanes as that kernel did per evaluation
    /// ([`lanes::ln`]: the same bits).
    pub fn ln_nh(&self) -> &Vec<f64> {
        self.derived.ln_nh.get_or_init(|| {
            let mut out = Vec::with_capacity(self.len().next_multiple_of(LANES));
            for chunk in self.nh.chunks(LANES) {
                let xs: [f64; LANES] = std::array::from_fn(|l| {
                    let x = chunk.get(l).map_or(1.0, |v| v.clamp(0.0, 1.0));
                    if x > 0.0 { x } else { 1.0 }
                });
                out.extend(lanes::ln(&xs));
            }
            out.truncate(self.len());
            out
        })
    }

    /// GGX–Smith's parameter-free terms of every row ([`GgxTerms`]), computed once (in
    /// parallel over many rows).
    pub fn ggx(&self) -> &GgxTerms {
        use rayon::prelude::*;
        self.derived.ggx.get_or_init(|| {
            let n = self.len();
            let row = |i: usize| {
                let (nh, eh) = (self.nh[i], self.eh[i]);
                let ok = nh > 0.0 && eh > 0.0;
                let nh2 = nh * nh;
                [
                    tan2(self.nl[i]),
                    tan2(self.ne[i]),
                    if ok { tan2(nh) } else { 0.0 },
                    if ok {
                        0.25 / (std::f64::consts::PI * self.ne[i] * nh2 * nh2)
                    } else {
                        0.0
                    },
                    if ok { eh } else { 1.0 },
                ]
            };
            let terms: Vec<[f64; 5]> = if n > 1 << 16 {
                (0..n)
                    .into_par_iter()
                    .with_min_len(1 << 14)
                    .map(row)
                    .collect()
            } else {
                (0..n).map(row).collect()
            };
            let col = |k: usize| terms.iter().map(|t| t[k]).collect();
            GgxTerms {
                tan2_i: col(0),
                tan2_o: col(1),
                tan2_h: col(2),
                factor: col(3),
                eh: col(4),
            }
        })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.nl.len()
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.nl.is_empty()
    }

    /// True when the rows carry a weight column.
    pub fn weighted(&self) -> bool {
        self.weighted
    }

    /// Append a row (its weight is kept only if the columns are weighted).
    pub fn push(&mut self, r: &Row) {
        self.derived = Derived::default();
        self.nl.push(r.g.nl);
        self.ne.push(r.g.ne);
        self.nh.push(r.g.nh);
        self.eh.push(r.g.eh);
        self.re.push(r.g.re);
        self.g_ne.push(r.g.g_ne);
        self.target.push(r.target);
        if self.weighted {
            self.sw.push(r.sw);
        }
    }

    /// Row `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Row {
        let g = Geometry {
            nl: self.nl[i],
            ne: self.ne[i],
            nh: self.nh[i],
            eh: self.eh[i],
            re: self.re[i],
            g_ne: self.g_ne[i],
        };
        Row {
            g,
            cos_i: g.nl,
            target: self.target[i],
            sw: self.sw.get(i).copied().unwrap_or(1.0),
        }
    }

    /// Rows from `n` inputs, filled in parallel over chunks: `fill(range, out)` pushes the
    /// rows it keeps from inputs `range` to `out` (a [`RowWriter`]); the kept rows are joined
    /// in input order. The chunks are equal, at most 16,384 inputs and at least two beyond
    /// 4,096 inputs (a 10,000-sample set or a MERL table's 16,512 rows in two halves, not one
    /// chunk or chunks of 16,384 and 128); every row is the same however they are cut. The
    /// columns are reserved once at full size, written without being zeroed first (for a
    /// million rows 56 MB, about 2.8 ms of a 14 ms pass on the 2-core VM) and compacted in
    /// place; unweighted rows get no √weight column.
    pub fn par_fill<F>(n: usize, weighted: bool, fill: F) -> Rows
    where
        F: Fn(std::ops::Range<usize>, &mut RowWriter) + Sync,
    {
        use rayon::prelude::*;
        use std::mem::MaybeUninit;
        const CHUNK: usize = 16_384;
        let chunk = if n <= 4_096 {
            n.max(1)
        } else {
            n.div_ceil(n.div_ceil(CHUNK).max(2))
        };
        let width = |j: usize| if j == 7 && !weighted { 0 } else { n };
        let mut cols: [Vec<f64>; 8] = std::array::from_fn(|j| Vec::with_capacity(width(j)));
        // Each chunk's part of every column's reserved memory (an absent column: empty parts).
        let mut parts: Vec<(std::ops::Range<usize>, RowWriter)> = Vec::new();
        let mut rest: [&mut [MaybeUninit<f64>]; 8] =
            std::array::from_fn(|_| &mut [] as &mut [MaybeUninit<f64>]);
        for (j, (r, c)) in rest.iter_mut().zip(cols.iter_mut()).enumerate() {
            *r = &mut c.spare_capacity_mut()[..width(j)];
        }
        let mut start = 0;
        while start < n {
            let len = chunk.min(n - start);
            let part: [&mut [MaybeUninit<f64>]; 8] = std::array::from_fn(|j| {
                let c = std::mem::take(&mut rest[j]);
                let (a, b) = c.split_at_mut(len.min(c.len()));
                rest[j] = b;
                a
            });
            parts.push((start..start + len, RowWriter { cols: part, len: 0 }));
            start += len;
        }
        let run = |(range, mut out): (std::ops::Range<usize>, RowWriter)| {
            fill(range, &mut out);
            out.len
        };
        let counts: Vec<usize> = if parts.len() <= 1 {
            parts.into_iter().map(run).collect()
        } else {
            parts.into_par_iter().map(run).collect()
        };
        // Chunk k's rows sit at the front of its part, from k·chunk; moved down, in order.
        let mut kept = 0;
        for (k, &count) in counts.iter().enumerate() {
            let from = k * chunk;
            if from != kept {
                for col in cols.iter_mut().filter(|c| c.capacity() > 0) {
                    col.spare_capacity_mut()
                        .copy_within(from..from + count, kept);
                }
            }
            kept += count;
        }
        for (j, col) in cols.iter_mut().enumerate() {
            if width(j) > 0 {
                // SAFETY: the first `kept` entries of every present column are written. A
                // [`RowWriter`] writes each row it counts to every present column of its part,
                // so chunk k's part holds `counts[k]` written rows at its front (from k·chunk);
                // the moves above put them, in order, at [Σ earlier counts, + counts[k]), and
                // those ranges cover [0, kept). `kept` ≤ n ≤ the capacity.
                unsafe { col.set_len(kept) };
            }
        }
        let [nl, ne, nh, eh, re, g_ne, target, mut sw] = cols;
        if !weighted {
            sw = Vec::new();
        }
        Rows {
            nl,
            ne,
            nh,
            eh,
            re,
            g_ne,
            target,
            sw,
            weighted,
            derived: Derived::default(),
        }
    }

    /// Append every row of `other`.
    pub fn extend(&mut self, other: &Rows) {
        self.derived = Derived::default();
        if other.weighted && !self.weighted {
            self.sw = vec![1.0; self.len()];
            self.weighted = true;
        }
        self.nl.extend_from_slice(&other.nl);
        self.ne.extend_from_slice(&other.ne);
        self.nh.extend_from_slice(&other.nh);
        self.eh.extend_from_slice(&other.eh);
        self.re.extend_from_slice(&other.re);
        self.g_ne.extend_from_slice(&other.g_ne);
        self.target.extend_from_slice(&other.target);
        if other.weighted {
            self.sw.extend_from_slice(&other.sw);
        } else if self.weighted {
            self.sw.resize(self.len(), 1.0);
        }
    }
}

impl From<Vec<Row>> for Rows {
    /// Columns of `rows`; weighted if any weight differs from 1.
    fn from(rows: Vec<Row>) -> Self {
        let weighted = rows.iter().any(|r| r.sw != 1.0);
        let mut out = Rows::with_capacity(rows.len(), weighted);
        for r in &rows {
            out.push(r);
        }
        out
    }
}

/// The BRDF least-squares problem over one or more channels (rows contiguous per channel).
#[derive(Clone, Debug)]
pub struct BrdfProblem {
    /// Model template (kind, distribution, fast power); its parameter values are ignored.
    pub template: Model,
    /// Rows, channel after channel (shared, so problems derived from this one are cheap).
    pub rows: std::sync::Arc<Rows>,
    /// Start row of each channel (plus the total at the end).
    pub starts: Vec<usize>,
    /// Per channel, where each model parameter comes from.
    pub layout: Vec<[Slot; MAX_PARAMS]>,
    /// Per free variable, its transform.
    pub transforms: Vec<Transform>,
    /// The loss.
    pub loss: Loss,
    /// Counts every pass over the data as it starts (each evaluation of the cost, with or
    /// without its normal equations; problems derived from this one count here too), for a
    /// progress display to read while a long fit goes on ([`super::FitOptions::watch`]).
    pub watch: Option<super::Watch>,
}

/// Per-evaluation data: each channel's model and the chain factors dθ/du.
pub struct Prepared {
    chans: Vec<(Model, [(usize, f64); MAX_PARAMS])>,
}

impl BrdfProblem {
    /// Number of model parameters.
    pub fn n_model_params(&self) -> usize {
        self.template.specs().len()
    }

    /// Each channel's model parameters for solver variables `x`.
    pub fn models(&self, x: &[f64]) -> Vec<Model> {
        self.layout
            .iter()
            .map(|slots| {
                let mut p = [0.0; MAX_PARAMS];
                for j in 0..self.n_model_params() {
                    p[j] = match slots[j] {
                        Slot::Free(k) => self.transforms[k].apply(x[k]).0,
                        Slot::Fixed(v) => v,
                    };
                }
                self.template.with_params(&p)
            })
            .collect()
    }

    /// The same problem in natural parameters θ (identity transforms), for statistics.
    pub fn natural(&self) -> BrdfProblem {
        BrdfProblem {
            transforms: vec![Transform::IDENTITY; self.transforms.len()],
            ..self.clone()
        }
    }

    /// A problem on at most `max_rows_per_channel` rows of each channel (deterministic): the
    /// tenth of them with the largest data terms (a sharp highlight's few peak samples, which a
    /// stride would skip and which decide between basins), and every `stride`-th of the other
    /// rows, weighted by the stride so the cost estimates the full cost.
    pub fn subsample(&self, max_rows_per_channel: usize) -> BrdfProblem {
        let mut pick: Vec<(usize, f64)> = Vec::new();
        let mut starts = vec![0];
        for c in 0..self.layout.len() {
            let (lo, hi) = (self.starts[c], self.starts[c + 1]);
            if hi - lo <= max_rows_per_channel {
                pick.extend((lo..hi).map(|i| (i, 1.0)));
            } else {
                let top = max_rows_per_channel / 10;
                let mut order = largest(&self.rows.target, lo..hi, top);
                order.sort_unstable();
                let rest = hi - lo - order.len();
                let stride = (hi - lo).div_ceil(max_rows_per_channel - top).max(1);
                // Every stride-th row and the largest, merged in index order in one walk (both
                // increasing); a strided row among the largest is taken once, with weight 1.
                // The strided rows' weight, known once they are counted, is set after.
                let first = pick.len();
                pick.reserve(max_rows_per_channel + 1);
                let mut top_rows = order.iter().copied().peekable();
                let mut strided = 0;
                for i in (lo..hi).step_by(stride) {
                    while let Some(o) = top_rows.next_if(|&o| o < i) {
                        pick.push((o, 1.0));
                    }
                    if top_rows.next_if_eq(&i).is_some() {
                        pick.push((i, 1.0));
                    } else {
                        pick.push((i, f64::NAN));
                        strided += 1;
                    }
                }
                pick.extend(top_rows.map(|o| (o, 1.0)));
                let w = rest as f64 / strided as f64;
                for p in pick[first..].iter_mut().filter(|p| p.1.is_nan()) {
                    p.1 = w;
                }
            }
            starts.push(pick.len());
        }
        let r = &self.rows;
        // A large subsample (a full MERL table's 64th, 22,781 of 1,458,000 rows) gathers each
        // column on every thread: seven strided sweeps through 11 MB columns, memory-bound.
        let large = pick.len() >= 16_384;
        let take = |v: &Vec<f64>| -> Vec<f64> {
            use rayon::prelude::*;
            if large {
                pick.par_iter()
                    .with_min_len(8_192)
                    .map(|&(i, _)| v[i])
                    .collect()
            } else {
                pick.iter().map(|&(i, _)| v[i]).collect()
            }
        };
        let [nl, ne, nh, eh, re, g_ne, target] =
            [&r.nl, &r.ne, &r.nh, &r.eh, &r.re, &r.g_ne, &r.target].map(take);
        let weighted = r.weighted || pick.iter().any(|&(_, w)| w != 1.0);
        let sw = if weighted {
            pick.iter()
                .map(|&(i, w)| r.sw.get(i).copied().unwrap_or(1.0) * w.sqrt())
                .collect()
        } else {
            Vec::new()
        };
        let rows = Rows {
            nl,
            ne,
            nh,
            eh,
            re,
            g_ne,
            target,
            sw,
            weighted,
            derived: Derived::default(),
        };
        BrdfProblem {
            rows: std::sync::Arc::new(rows),
            starts,
            ..self.clone()
        }
    }

    #[inline]
    fn channel_of(&self, i: usize) -> usize {
        if self.starts.len() == 2 {
            0
        } else {
            self.starts.partition_point(|&s| s <= i) - 1
        }
    }
}

impl Problem for BrdfProblem {
    type Prepared = Prepared;

    fn dim(&self) -> usize {
        self.transforms.len()
    }

    fn n_residuals(&self) -> usize {
        self.rows.len()
    }

    fn prepare(&self, x: &[f64]) -> Option<Prepared> {
        if let Some(w) = &self.watch {
            w.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        if x.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let np = self.n_model_params();
        let mut chans = Vec::with_capacity(self.layout.len());
        for slots in &self.layout {
            let mut p = [0.0; MAX_PARAMS];
            let mut map = [(usize::MAX, 0.0); MAX_PARAMS];
            for j in 0..np {
                match slots[j] {
                    Slot::Free(k) => {
                        let (v, d) = self.transforms[k].apply(x[k]);
                        if !v.is_finite() {
                            return None;
                        }
                        p[j] = v;
                        map[j] = (k, d);
                    }
                    Slot::Fixed(v) => p[j] = v,
                }
            }
            chans.push((self.template.with_params(&p), map));
        }
        Some(Prepared { chans })
    }

    #[inline]
    fn residual_grad(&self, prep: &Prepared, i: usize, row: &mut [f64]) -> f64 {
        let rw = &self.rows.get(i);
        let (model, map) = &prep.chans[self.channel_of(i)];
        let mut grad = [0.0; MAX_PARAMS];
        let f = model.brdf_grad(&rw.g, &mut grad);
        let (r, drdf) = match self.loss {
            Loss::Log => {
                let fm = rw.cos_i * f;
                (fm.ln_1p() - rw.target, rw.cos_i / (1.0 + fm))
            }
            Loss::Linear => (f - rw.target, 1.0),
            Loss::Pixel => {
                let (v, d) = self.loss.term(f, rw.cos_i);
                (v - rw.target, d)
            }
        };
        row.iter_mut().for_each(|v| *v = 0.0);
        let s = rw.sw * drdf;
        for j in 0..self.n_model_params() {
            let (k, d) = map[j];
            if k != usize::MAX {
                row[k] += s * grad[j] * d;
            }
        }
        rw.sw * r
    }

    #[inline]
    fn residual(&self, prep: &Prepared, i: usize) -> f64 {
        let rw = &self.rows.get(i);
        let f = prep.chans[self.channel_of(i)].0.brdf(&rw.g);
        let r = match self.loss {
            Loss::Log => (rw.cos_i * f).ln_1p() - rw.target,
            Loss::Linear => f - rw.target,
            Loss::Pixel => pixel(rw.cos_i * f).0 - rw.target,
        };
        rw.sw * r
    }

    fn bounds(&self) -> Vec<(f64, f64)> {
        self.transforms.iter().map(|t| t.bounds()).collect()
    }

    /// The parameter behind variable `k` and its natural value, e.g. `pd = -1.587 (pd ≥ 0)`.
    fn describe(&self, k: usize, u: f64) -> String {
        let specs = self.template.specs();
        let named = self
            .layout
            .iter()
            .find_map(|slots| (0..specs.len()).find(|&j| slots[j] == Slot::Free(k)));
        match named {
            Some(j) => format!(
                "{} = {} ({})",
                specs[j].name,
                crate::model::readable(self.transforms[k].apply(u).0),
                specs[j].bounds_text()
            ),
            None => format!("variable {k} = {u:.4e}"),
        }
    }

    /// Logit and log variables may move by 1 per step (a factor e in the odds or the value),
    /// whatever their size; near u = 0 (c3 = ½, say) a relative bound alone would crawl.
    fn step_scale(&self) -> Vec<f64> {
        self.transforms.iter().map(|t| t.step_scale()).collect()
    }

    fn accumulate(
        &self,
        prep: &Prepared,
        range: std::ops::Range<usize>,
        robust: Robust,
        acc: &mut Normal,
    ) {
        let n = self.dim();
        let np = self.n_model_params();
        // Channel by channel: accumulate in model-parameter space (at most 4×4), then map
        // once into the free variables with the chain factors.
        for c in 0..self.layout.len() {
            let lo = range.start.max(self.starts[c]);
            let hi = range.end.min(self.starts[c + 1]);
            if lo >= hi {
                continue;
            }
            let (model, map) = &prep.chans[c];
            let mut g = [[0.0f64; MAX_PARAMS]; MAX_PARAMS];
            let mut gr = [0.0f64; MAX_PARAMS];
            // Torrance–Sparrow with D3 and the log loss (the default fit) has a lane kernel.
            acc.cost += if ts_d3_log_applies(self.loss, model, robust) {
                let (mut g4, mut gr4) = ([[0.0f64; 4]; 4], [0.0f64; 4]);
                let cost = ts_d3_log(&self.rows, lo..hi, p4(model), &mut g4, &mut gr4);
                for a in 0..4 {
                    gr[a] = gr4[a];
                    g[a][..4].copy_from_slice(&g4[a]);
                }
                cost
            } else if let Some(lane) = kernels::Lane::of(model, self.loss) {
                kernels::rows_normal(
                    (lane, self.loss, robust),
                    &self.rows,
                    lo..hi,
                    model,
                    &mut g,
                    &mut gr,
                )
            } else {
                kernel_rows_any(
                    &self.rows,
                    lo..hi,
                    self.loss,
                    model,
                    robust,
                    &mut g,
                    &mut gr,
                )
            };
            for j in 0..np {
                let (kj, cj) = map[j];
                if kj == usize::MAX {
                    continue;
                }
                acc.jtr[kj] += cj * gr[j];
                for l in j..np {
                    let (kl, cl) = map[l];
                    if kl == usize::MAX {
                        continue;
                    }
                    let (a, b) = (kj.min(kl), kj.max(kl));
                    acc.jtj[a * n + b] += cj * cl * g[j][l];
                }
            }
        }
    }

    fn cost_range(&self, prep: &Prepared, range: std::ops::Range<usize>, robust: Robust) -> f64 {
        let mut s = 0.0;
        for c in 0..self.layout.len() {
            let lo = range.start.max(self.starts[c]);
            let hi = range.end.min(self.starts[c + 1]);
            if lo >= hi {
                continue;
            }
            let model = &prep.chans[c].0;
            if ts_d3_log_applies(self.loss, model, robust) {
                s += ts_d3_log_cost(&self.rows, lo..hi, p4(model));
                continue;
            }
            if let Some(lane) = kernels::Lane::of(model, self.loss) {
                s += kernels::rows_cost(lane, self.loss, robust, &self.rows, lo..hi, model);
                continue;
            }
            for i in lo..hi {
                let rw = self.rows.get(i);
                let f = model.brdf(&rw.g);
                let r = match self.loss {
                    Loss::Log => (rw.cos_i * f).ln_1p() - rw.target,
                    Loss::Linear => f - rw.target,
                    Loss::Pixel => pixel(rw.cos_i * f).0 - rw.target,
                };
                s += robust.rho(rw.sw * r);
            }
        }
        s
    }
}

/// The GGX lobe D G1(L) G1(E)/(4 N·L N·E) of roughness `alpha` (GGX–Smith's f_r per unit
/// ps·F; Walter et al. 2007, eqs. 33 and 34) at rows `range`, 0 where N·H ≤ 0 or E·H ≤ 0.
pub fn ggx_lobe_values(alpha: f64, rows: &Rows, range: std::ops::Range<usize>) -> Vec<f64> {
    kernels::ggx_lobe_values(alpha, rows, range)
}

/// ABC's shape term (1 + b (1 − N·H))^(−c) at each N·H of `nh` for every c of `cs`, one row
/// per c appended to `out` (the form of ABC's lane kernel).
pub fn abc_shape_rows(b: f64, cs: &[f64], nh: &[f64], out: &mut Vec<f64>) {
    kernels::abc_shape_rows(b, cs, nh, out)
}

/// f_r of `model` at rows `range` (the lane form of `TsD3` for Torrance–Sparrow with D3).
pub fn brdf_values(model: &Model, rows: &Rows, range: std::ops::Range<usize>) -> Vec<f64> {
    if model.kind == ModelKind::TorranceSparrow && model.dist == Distribution::D3 {
        ts_d3_values(p4(model), rows, range)
    } else {
        range.map(|i| model.brdf(&rows.get(i).g)).collect()
    }
}

#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn ts_d3_values(p: [f64; 4], rows: &Rows, range: std::ops::Range<usize>) -> Vec<f64> {
    let k = TsD3::new(p);
    let pd_pi = p[3] * std::f64::consts::FRAC_1_PI;
    range
        .map(|i| pd_pi + k.ps * k.eval(rows.nh[i], rows.eh[i], rows.g_ne[i]).0 / rows.nl[i])
        .collect()
}

/// True where the lane kernel [`ts_d3_log`] computes what [`kernel_rows`] would.
fn ts_d3_log_applies(loss: Loss, model: &Model, robust: Robust) -> bool {
    loss == Loss::Log
        && robust == Robust::None
        && model.kind == ModelKind::TorranceSparrow
        && model.dist == Distribution::D3
}

/// The first four parameters of a model (Torrance–Sparrow D3's n, c3, ps, pd) for its lane kernel.
fn p4(model: &Model) -> [f64; 4] {
    [model.p[0], model.p[1], model.p[2], model.p[3]]
}

/// [`kernel_rows`] for the model's number of parameters (a constant inside, so its loops unroll).
fn kernel_rows_any(
    rows: &Rows,
    range: std::ops::Range<usize>,
    loss: Loss,
    model: &Model,
    robust: Robust,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    match model.specs().len() {
        1 => kernel_rows::<1>(rows, range, loss, model, robust, g, gr),
        2 => kernel_rows::<2>(rows, range, loss, model, robust, g, gr),
        3 => kernel_rows::<3>(rows, range, loss, model, robust, g, gr),
        4 => kernel_rows::<4>(rows, range, loss, model, robust, g, gr),
        5 => kernel_rows::<5>(rows, range, loss, model, robust, g, gr),
        6 => kernel_rows::<6>(rows, range, loss, model, robust, g, gr),
        7 => kernel_rows::<7>(rows, range, loss, model, robust, g, gr),
        _ => kernel_rows::<MAX_PARAMS>(rows, range, loss, model, robust, g, gr),
    }
}

/// The hot loop, row by row through [`Model::brdf_grad`] (every model, loss and robust weight):
/// residuals of one channel's rows `range` with the gradient of the model's `N` parameters,
/// accumulated into the model-space normal equations `g` (upper triangle) and `gr`; returns
/// Σ ρ(r). Free of allocation.
fn kernel_rows<const N: usize>(
    rows: &Rows,
    range: std::ops::Range<usize>,
    loss: Loss,
    model: &Model,
    robust: Robust,
    g: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    gr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let mut cost = 0.0;
    let mut grad = [0.0; MAX_PARAMS];
    for i in range {
        let rw = rows.get(i);
        let f = model.brdf_grad(&rw.g, &mut grad);
        let (r, drdf) = match loss {
            Loss::Log => {
                let fm = rw.cos_i * f;
                (fm.ln_1p() - rw.target, rw.cos_i / (1.0 + fm))
            }
            Loss::Linear => (f - rw.target, 1.0),
            Loss::Pixel => {
                let (v, d) = loss.term(f, rw.cos_i);
                (v - rw.target, d)
            }
        };
        let r = rw.sw * r;
        let s = rw.sw * drdf;
        let j: [f64; N] = std::array::from_fn(|a| s * grad[a]);
        let (rho, w) = match robust {
            Robust::None => (0.5 * r * r, 1.0),
            _ => (robust.rho(r), robust.weight(r)),
        };
        cost += rho;
        for a in 0..N {
            let wa = w * j[a];
            gr[a] += wa * r;
            for b in a..N {
                g[a][b] += wa * j[b];
            }
        }
    }
    cost
}

/// Torrance–Sparrow with D3 and the log loss, [`LANES`] rows at a time: the same formulas
/// as [`Model::brdf_grad`] (Blinn 1977: D3, exact Fresnel with its n-derivative, G/(N·E))
/// written without branches so the compiler turns each lane loop into vector instructions,
/// with [`lanes::ln_1p`] for the logarithm. Each lane keeps its own sums, added in lane order at
/// the end, so the result does not depend on the instruction set; it is compiled for AVX-512
/// and AVX2 as well and picked at run time (the `multiversion` crate).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn ts_d3_log(
    rows: &Rows,
    range: std::ops::Range<usize>,
    p: [f64; 4],
    g: &mut [[f64; 4]; 4],
    gr: &mut [f64; 4],
) -> f64 {
    ts_d3_log_body::<true>(rows, range, p, g, gr)
}

/// Σ ½r² of [`ts_d3_log`] alone (no Jacobian), for cost-only evaluations.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn ts_d3_log_cost(rows: &Rows, range: std::ops::Range<usize>, p: [f64; 4]) -> f64 {
    ts_d3_log_body::<false>(rows, range, p, &mut [[0.0; 4]; 4], &mut [0.0; 4])
}

#[inline(always)]
fn ts_d3_log_body<const JAC: bool>(
    rows: &Rows,
    range: std::ops::Range<usize>,
    p: [f64; 4],
    g: &mut [[f64; 4]; 4],
    gr: &mut [f64; 4],
) -> f64 {
    let k = TsD3::new(p);
    let pd_pi = p[3] * std::f64::consts::FRAC_1_PI;
    let cols = [&rows.nl, &rows.nh, &rows.eh, &rows.g_ne, &rows.target];
    let acc = kernels::drive(rows, range, cols, &TsD3Block::<JAC>(k, pd_pi));
    let lane_sum = |k: usize| acc[k].iter().sum::<f64>();
    let mut t = kernels::TRI;
    for a in 0..4 {
        gr[a] += lane_sum(1 + a);
        for b in a..4 {
            g[a][b] += lane_sum(t);
            t += 1;
        }
    }
    lane_sum(0)
}

/// [`ts_d3_block`] with its parameters (D3 at fixed n, c3, ps; pd/π).
struct TsD3Block<const JAC: bool>(TsD3, f64);

impl<const JAC: bool> kernels::Block for TsD3Block<JAC> {
    #[inline(always)]
    fn run(&self, c: &[[f64; LANES]; 5], sw: &[f64; LANES], acc: &mut kernels::Acc) {
        ts_d3_block::<JAC>(&self.0, self.1, c, sw, acc)
    }
}

/// One block of [`LANES`] rows of [`ts_d3_log`]: columns nl, nh, eh, g_ne, target; √weight.
#[inline(always)]
fn ts_d3_block<const JAC: bool>(
    k: &TsD3,
    pd_pi: f64,
    c: &[[f64; LANES]; 5],
    sw: &[f64; LANES],
    acc: &mut kernels::Acc,
) {
    let [nl, nh, eh, gn, tg] = c;
    let mut y = [0.0f64; LANES];
    let mut dy = [[0.0f64; LANES]; 3];
    for l in 0..LANES {
        // y = cosθi f_r = cosθi pd/π + ps a, a = D F G/(π N·E) (no division by cosθi).
        let (a, da) = k.eval(nh[l], eh[l], gn[l]);
        y[l] = nl[l] * pd_pi + k.ps * a;
        dy[0][l] = k.ps * da[0];
        dy[1][l] = k.ps * da[1];
        dy[2][l] = a;
    }
    let (ly, iu) = lanes::ln_1p(&y);
    for l in 0..LANES {
        // r = ln(1 + y) − target, dr/dθ = (dy/dθ)/(1 + y).
        let r = sw[l] * (ly[l] - tg[l]);
        if JAC {
            let s = sw[l] * iu[l];
            let j = [
                s * dy[0][l],
                s * dy[1][l],
                s * dy[2][l],
                s * nl[l] * std::f64::consts::FRAC_1_PI,
            ];
            kernels::accumulate_lane(acc, l, r, j);
        } else {
            acc[0][l] += 0.5 * r * r;
        }
    }
}

/// Blinn's Torrance–Sparrow model with D3 at fixed parameters, for the lane kernels.
#[derive(Clone, Copy)]
struct TsD3 {
    n: f64,
    n2m1: f64,
    c: f64,
    s: f64,
    ps: f64,
}

impl TsD3 {
    fn new(p: [f64; 4]) -> Self {
        let (n, c) = (p[0], p[1]);
        TsD3 {
            n,
            n2m1: n * n - 1.0,
            c,
            s: c * c,
            ps: p[2],
        }
    }

    /// D3 and dD3/dc3 at cos θh = `nh`, without branches (0 where [`Distribution::eval_dc`]
    /// returns early).
    #[inline(always)]
    fn d(&self, nh: f64) -> (f64, f64) {
        // D3 = (c²/den)², den = x(c²−1) + 1, x = (N·H)²; dD/dc = 4c³(1 − x)/den³.
        let x = nh * nh;
        let den = x * (self.s - 1.0) + 1.0;
        let ok_d = den > 0.0;
        let id = 1.0 / if ok_d { den } else { 1.0 };
        let q = self.s * id;
        let d = if ok_d { q * q } else { 0.0 };
        let dd = if ok_d {
            4.0 * self.c * self.s * (1.0 - x) * id * id * id
        } else {
            0.0
        };
        (d, dd)
    }

    /// a = D3 F G/(π N·E), the specular term per unit ps times cosθi (so f_r = pd/π + ps a/N·L),
    /// and its derivatives with respect to n and c3. The formulas of [`crate::model::fresnel_dn`]
    /// and D3 in [`Distribution::eval_dc`], without branches (where those return early, the
    /// selects below give the same) and with the divisions shared.
    #[inline(always)]
    fn eval(&self, nh: f64, eh: f64, g_ne: f64) -> (f64, [f64; 2]) {
        let (d, dd) = self.d(nh);
        let (f, df) = kernels::fresnel(self.n, self.n2m1, eh);
        let w = g_ne * std::f64::consts::FRAC_1_PI;
        (d * f * w, [d * df * w, dd * f * w])
    }
}

#[cfg(test)]
mod tests {
    /// Rows filled in parallel chunks, some kept a block at a time and some row by row, come
    /// out in input order with every column right (written without zeroing first): inputs
    /// dropped singly and in runs that straddle chunk and block edges, with and without
    /// weights, in one chunk, two and three. Both ways of pushing must be exercised.
    #[test]
    fn par_fill_keeps_rows_in_input_order() {
        use super::{LANES, Rows};
        use std::sync::Mutex;
        // 40,003 inputs are cut at 13,335 and 26,670; 20,000 at 10,000.
        let dropped = |i: usize| {
            i % 29 == 3
                || (9_950..10_050).contains(&i)
                || (13_300..13_400).contains(&i)
                || (20_000..20_100).contains(&i)
        };
        for (n, weighted) in [
            (0, false),
            (5, true),
            (4_096, false),
            (20_000, true),
            (40_003, true),
            (40_003, false),
        ] {
            // Per chunk: its first input, and how many blocks and single lanes it pushed.
            let pushes = Mutex::new(Vec::new());
            let rows = Rows::par_fill(n, weighted, |range, out| {
                let (mut blocks, mut lanes) = (0, 0);
                let mut k = range.start;
                while k < range.end {
                    let m = (range.end - k).min(LANES);
                    let block: [[f64; LANES]; 8] =
                        std::array::from_fn(|j| std::array::from_fn(|l| (10 * (k + l) + j) as f64));
                    if m == LANES && (k..k + m).all(|i| !dropped(i)) {
                        out.push_block(&block);
                        blocks += 1;
                    } else {
                        for l in (0..m).filter(|&l| !dropped(k + l)) {
                            out.push_lane(&block, l);
                            lanes += 1;
                        }
                    }
                    k += m;
                }
                pushes.lock().unwrap().push((range.start, blocks, lanes));
            });
            let mut pushes = pushes.into_inner().unwrap();
            pushes.sort_unstable();
            let chunks = match n {
                0..=4_096 => 1,
                20_000 => 2,
                _ => 3,
            };
            if n > 0 {
                assert_eq!(pushes.len(), chunks, "n = {n}: {pushes:?}");
            }
            if n >= 4_096 {
                for &(start, blocks, lanes) in &pushes {
                    assert!(
                        blocks > 0 && lanes > 0,
                        "n = {n}, chunk at {start}: {pushes:?}"
                    );
                }
            }
            let kept: Vec<usize> = (0..n).filter(|&i| !dropped(i)).collect();
            let col =
                |j: usize| -> Vec<f64> { kept.iter().map(|&i| (10 * i + j) as f64).collect() };
            // The first wrong row, not two columns of 40,000 numbers.
            let first_difference = |a: &[f64], b: &[f64]| {
                (a.len() != b.len())
                    .then_some(a.len().min(b.len()))
                    .or_else(|| a.iter().zip(b).position(|(x, y)| x != y))
            };
            assert_eq!(rows.len(), kept.len(), "n = {n}");
            let got = [
                &rows.nl,
                &rows.ne,
                &rows.nh,
                &rows.eh,
                &rows.re,
                &rows.g_ne,
                &rows.target,
            ];
            for (j, c) in got.into_iter().enumerate() {
                assert_eq!(first_difference(c, &col(j)), None, "n = {n}, column {j}");
            }
            let sw = if weighted { col(7) } else { Vec::new() };
            assert_eq!(first_difference(&rows.sw, &sw), None, "n = {n}, weights");
        }
    }

    /// The `k` largest values of a range equal the first `k` of the range sorted by value
    /// (largest first, ties to the lower index), with many ties and with more blocks than `k`
    /// (the block maxima's bound in use; blocks of 16 to 1,024 rows) or fewer.
    #[test]
    fn largest_matches_a_full_sort() {
        for (n, k, levels) in [
            (10_000, 200, 37),
            (10_000, 50, 1_000_000),
            (200_000, 5_000, 1_000_000),
            (200_000, 5_000, 40),
            (300_000, 100, 5_000),
            (5, 9, 3),
            (2_100, 2_100, 7),
        ] {
            // A deterministic scramble of `levels` values: many exact ties when levels is small.
            let v: Vec<f64> = (0..n)
                .map(|i: usize| ((i.wrapping_mul(2_654_435_761) >> 7) % levels) as f64 * 0.25 - 3.0)
                .collect();
            for range in [0..n, n / 3..n - n / 5] {
                let mut want: Vec<usize> = range.clone().collect();
                want.sort_by(|&a, &b| v[b].total_cmp(&v[a]).then(a.cmp(&b)));
                want.truncate(k);
                want.sort_unstable();
                let mut got = super::largest(&v, range.clone(), k);
                got.sort_unstable();
                assert_eq!(got, want, "n {n} k {k} range {range:?}");
            }
        }
        assert!(super::largest(&[1.0, 2.0], 0..2, 0).is_empty());
    }

    /// The same in the order of `f64::total_cmp` with NaN (either sign) and both zeros among
    /// the values: a block whose other values are all below the bound still yields its NaN
    /// (largest of all) and its +0 (above −0), as a full sort does.
    #[test]
    fn largest_orders_nan_and_signed_zeros_as_total_cmp() {
        let n = 20_000;
        let v: Vec<f64> = (0..n)
            .map(|i: usize| match i.wrapping_mul(2_654_435_761) % 997 {
                0 => f64::NAN,
                1 => -f64::NAN,
                2..=40 => 0.0,
                41..=80 => -0.0,
                r => -(r as f64),
            })
            .collect();
        for k in [5, 30, 60, 150, 400] {
            let mut want: Vec<usize> = (0..n).collect();
            want.sort_by(|&a, &b| v[b].total_cmp(&v[a]).then(a.cmp(&b)));
            want.truncate(k);
            want.sort_unstable();
            let mut got = super::largest(&v, 0..n, k);
            got.sort_unstable();
            assert_eq!(got, want, "k {k}");
        }
    }

    /// The pixel value against the sRGB standard's own numbers (IEC 61966-2-1: 0.5 linear is
    /// 0.735357 encoded, 0.0031308 is 0.0404500, 0.2 is 0.484529), saturation at 1 (a PNG's
    /// 255) for radiance well above 1, and the derivative against central differences,
    /// positive everywhere, across the clip.
    #[test]
    fn pixel_is_srgb_smoothly_clipped() {
        use super::pixel;
        for (x, want) in [(0.5, 0.735_357), (0.003_130_8, 0.040_45), (0.2, 0.484_529)] {
            assert!((pixel(x).0 - want).abs() < 2e-6, "{x}: {}", pixel(x).0);
        }
        assert!((pixel(3.0).0 - 1.0).abs() < 1e-12);
        assert!((pixel(1e300).0 - 1.0).abs() < 1e-12 && pixel(1e300).1 >= 0.0);
        assert!(pixel(0.0).0.abs() < 1e-12);
        for k in 1..400 {
            let x = k as f64 * 0.005;
            let h = 1e-6;
            let fd = (pixel(x + h).0 - pixel(x - h).0) / (2.0 * h);
            let d = pixel(x).1;
            assert!(d > 0.0, "{x}");
            if (x - 0.003_130_8).abs() > 1e-5 {
                assert!((fd - d).abs() < 1e-5 * (1.0 + d), "{x}: {d} vs {fd}");
            }
        }
    }

    use super::*;
    use rand::{Rng, SeedableRng};

    /// The lane kernel of Torrance–Sparrow D3 with the log loss gives the same cost and normal
    /// equations as the row-by-row path through `Model::brdf_grad` (an independent code path:
    /// library `ln_1p`, the model's own Fresnel and D3), weighted or not, for any row count.
    #[test]
    fn lane_kernel_matches_row_kernel() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for (case, weighted) in [(0, false), (1, true), (2, false), (3, true)] {
            let m = [1, 7, 8, 1003][case];
            let mut rows = Rows::with_capacity(m, weighted);
            for _ in 0..m {
                let a: [f64; 4] = [
                    rng.random_range(0.0..1.5),
                    rng.random_range(0.0..6.3),
                    rng.random_range(0.0..1.5),
                    rng.random_range(0.0..6.3),
                ];
                let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
                let f: f64 = rng.random_range(0.0..3.0);
                rows.push(&Row {
                    g,
                    cos_i: g.nl,
                    target: (g.nl * f).ln_1p(),
                    sw: if weighted {
                        rng.random_range(0.1..2.0)
                    } else {
                        1.0
                    },
                });
            }
            for _ in 0..20 {
                let p = [
                    rng.random_range(1.01..300.0),
                    rng.random_range(0.01..1.0),
                    rng.random_range(0.0..2.0),
                    rng.random_range(0.0..2.0),
                ];
                let model = Model::new(ModelKind::TorranceSparrow, Distribution::D3, &p).unwrap();
                let (mut g1, mut r1) = ([[0.0; 4]; 4], [0.0; 4]);
                let (mut g2, mut r2) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
                let c1 = ts_d3_log(&rows, 0..m, p, &mut g1, &mut r1);
                assert_eq!(c1, ts_d3_log_cost(&rows, 0..m, p));
                let c2 = kernel_rows_any(
                    &rows,
                    0..m,
                    Loss::Log,
                    &model,
                    Robust::None,
                    &mut g2,
                    &mut r2,
                );
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-11 * (a.abs() + b.abs()) + 1e-300;
                assert!(close(c1, c2), "cost {c1} vs {c2} ({p:?})");
                for a in 0..4 {
                    assert!(close(r1[a], r2[a]), "Jᵀr[{a}] {} vs {}", r1[a], r2[a]);
                    for b in a..4 {
                        assert!(
                            close(g1[a][b], g2[a][b]),
                            "JᵀJ[{a}][{b}] {} vs {}",
                            g1[a][b],
                            g2[a][b]
                        );
                    }
                }
            }
        }
    }
}

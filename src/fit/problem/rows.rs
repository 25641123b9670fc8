//! The rows of a fit: each sample's parameter-independent geometry and data term, stored by
//! column, filled in parallel, with GGX's terms derived on first use.

use crate::model::Geometry;
use crate::support::lanes::{self, LANES};

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
    pub(super) weighted: bool,
    /// Columns derived from the geometry alone, computed on first use and kept with the rows.
    pub(super) derived: Derived,
}

/// Parameter-free columns a kernel reads, each computed once on first use ([`Rows::theta_h`],
/// [`Rows::ln_nh`], [`Rows::ggx`]); adding rows drops them.
#[derive(Clone, Debug, Default)]
pub(super) struct Derived {
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
}

//! The BRDF fitting problem itself: the rows of every channel, which parameter is free or
//! held on each, and the residuals and normal equations the solvers ask of it.

use super::kernels;
use super::loss::{Loss, pixel};
use super::passes::{kernel_rows_any, p4, ts_d3_log, ts_d3_log_applies, ts_d3_log_cost};
use super::rows::{Derived, Rows};
use super::select::largest;
use super::transform::Transform;
use crate::fit::lsq::{Normal, Problem, Robust};
use crate::fit::progress::Watch;
use crate::model::{MAX_PARAMS, Model};

/// Rows per channel above which a fit refines its candidates on a subsample of this many rows
/// per channel before polishing on every row.
pub const SUBSAMPLE_ROWS: usize = 2_000;

/// Where a model parameter of one channel comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Slot {
    /// Free solver variable `k`.
    Free(usize),
    /// Held at a value.
    Fixed(f64),
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
    /// progress display to read while a long fit goes on ([`crate::fit::FitOptions::watch`]).
    pub watch: Option<Watch>,
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

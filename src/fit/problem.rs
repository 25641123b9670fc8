//! The BRDF fitting problem: per-sample geometry computed once, parameters transformed so
//! their bounds hold by construction, residuals of the `log` or `linear` loss.

use super::lsq::{Normal, Problem, Robust};
use crate::model::{Distribution, Geometry, Model, ModelKind, f0_from_n};

/// Which residual the fit minimises (½ Σ r²).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Loss {
    /// r = ln(1 + cosθi f_model) − ln(1 + cosθi f_data) (default; balances peak and tail).
    #[default]
    Log,
    /// r = f_model − f_data.
    Linear,
}

impl Loss {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Loss::Log => "log",
            Loss::Linear => "linear",
        }
    }

    /// Parse `log` or `linear`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "log" => Some(Loss::Log),
            "linear" => Some(Loss::Linear),
            _ => None,
        }
    }

    /// The data-side term: ln(1 + cosθi f) or f.
    #[inline]
    pub fn target(self, f: f64, cos_i: f64) -> f64 {
        match self {
            Loss::Log => (cos_i * f).ln_1p(),
            Loss::Linear => f,
        }
    }
}

/// How a free solver variable u maps to a model parameter θ (bounds by construction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Transform {
    /// θ = u (for statistics in natural parameters).
    Identity,
    /// n = (1 + √F0)/(1 − √F0) with F0 = 1/(1 + e^−u) ∈ (0, 1): n > 1.
    IndexViaF0,
    /// θ = 1/(1 + e^−u) ∈ (0, 1) (for c3).
    Logistic,
    /// θ = e^u > 0 (for c1, c2).
    Exp,
    /// θ = u², u ≥ 0 (for ps, pd: θ ≥ 0, reaching 0).
    Square,
}

fn logistic(u: f64) -> f64 {
    1.0 / (1.0 + (-u).exp())
}

impl Transform {
    /// The transform used for a parameter name.
    pub fn for_param(name: &str) -> Self {
        match name {
            "n" => Transform::IndexViaF0,
            "c3" => Transform::Logistic,
            "c1" | "c2" => Transform::Exp,
            _ => Transform::Square,
        }
    }

    /// θ(u) and dθ/du.
    #[inline]
    pub fn apply(self, u: f64) -> (f64, f64) {
        match self {
            Transform::Identity => (u, 1.0),
            Transform::IndexViaF0 => {
                let f0 = logistic(u);
                let s = f0.sqrt();
                ((1.0 + s) / (1.0 - s), s * (1.0 + s) / (1.0 - s))
            }
            Transform::Logistic => {
                let t = logistic(u);
                (t, t * (1.0 - t))
            }
            Transform::Exp => {
                let e = u.exp();
                (e, e)
            }
            Transform::Square => (u * u, 2.0 * u),
        }
    }

    /// u(θ), the inverse, with θ first brought inside the open domain.
    pub fn invert(self, v: f64) -> f64 {
        let (lo, hi) = self.bounds();
        let u = match self {
            Transform::Identity => v,
            Transform::IndexViaF0 => {
                let f0 = f0_from_n(v.max(1.0 + 1e-9)).clamp(1e-12, 1.0 - 1e-12);
                (f0 / (1.0 - f0)).ln()
            }
            Transform::Logistic => {
                let t = v.clamp(1e-9, 1.0 - 1e-9);
                (t / (1.0 - t)).ln()
            }
            Transform::Exp => v.max(1e-300).ln(),
            Transform::Square => v.max(0.0).sqrt().max(1e-4),
        };
        u.clamp(lo, hi)
    }

    /// Box on u that keeps θ finite and the gradient alive.
    pub fn bounds(self) -> (f64, f64) {
        match self {
            Transform::Identity => (f64::NEG_INFINITY, f64::INFINITY),
            // F0 ∈ [2e-9, 1 − 1.1e-7]: n ∈ [1.0001, 3.6e7].
            Transform::IndexViaF0 => (-20.0, 16.0),
            // c3 ∈ [6e-6, 0.999994].
            Transform::Logistic => (-12.0, 12.0),
            // c ∈ [1e-3, 1e6].
            Transform::Exp => (-6.9, 13.8),
            Transform::Square => (0.0, 1e4),
        }
    }
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

/// The BRDF least-squares problem over one or more channels (rows contiguous per channel).
#[derive(Clone, Debug)]
pub struct BrdfProblem {
    /// Model template (kind, distribution, fast power); its parameter values are ignored.
    pub template: Model,
    /// Rows, channel after channel (shared, so problems derived from this one are cheap).
    pub rows: std::sync::Arc<Vec<Row>>,
    /// Start row of each channel (plus the total at the end).
    pub starts: Vec<usize>,
    /// Per channel, where each model parameter comes from.
    pub layout: Vec<[Slot; 4]>,
    /// Per free variable, its transform.
    pub transforms: Vec<Transform>,
    /// The loss.
    pub loss: Loss,
}

/// Per-evaluation data: each channel's model and the chain factors dθ/du.
pub struct Prepared {
    chans: Vec<(Model, [(usize, f64); 4])>,
}

impl BrdfProblem {
    /// Number of model parameters.
    pub fn n_model_params(&self) -> usize {
        self.template.param_names().len()
    }

    /// Each channel's model parameters for solver variables `x`.
    pub fn models(&self, x: &[f64]) -> Vec<Model> {
        self.layout
            .iter()
            .map(|slots| {
                let mut p = [0.0; 4];
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
            transforms: vec![Transform::Identity; self.transforms.len()],
            ..self.clone()
        }
    }

    /// A problem on every `stride`-th row of each channel (deterministic subsample).
    pub fn subsample(&self, max_rows_per_channel: usize) -> BrdfProblem {
        let mut rows = Vec::new();
        let mut starts = vec![0];
        for c in 0..self.layout.len() {
            let r = &self.rows[self.starts[c]..self.starts[c + 1]];
            let stride = r.len().div_ceil(max_rows_per_channel).max(1);
            rows.extend(r.iter().step_by(stride).copied());
            starts.push(rows.len());
        }
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
        if x.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let np = self.n_model_params();
        let mut chans = Vec::with_capacity(self.layout.len());
        for slots in &self.layout {
            let mut p = [0.0; 4];
            let mut map = [(usize::MAX, 0.0); 4];
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
        let rw = &self.rows[i];
        let (model, map) = &prep.chans[self.channel_of(i)];
        let mut grad = [0.0; 4];
        let f = model.brdf_grad(&rw.g, &mut grad);
        let (r, drdf) = match self.loss {
            Loss::Log => {
                let fm = rw.cos_i * f;
                (fm.ln_1p() - rw.target, rw.cos_i / (1.0 + fm))
            }
            Loss::Linear => (f - rw.target, 1.0),
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
        let rw = &self.rows[i];
        let f = prep.chans[self.channel_of(i)].0.brdf(&rw.g);
        let r = match self.loss {
            Loss::Log => (rw.cos_i * f).ln_1p() - rw.target,
            Loss::Linear => f - rw.target,
        };
        rw.sw * r
    }

    fn bounds(&self) -> Vec<(f64, f64)> {
        self.transforms.iter().map(|t| t.bounds()).collect()
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
            let mut g = [[0.0f64; 4]; 4];
            let mut gr = [0.0f64; 4];
            acc.cost += match self.loss {
                Loss::Log => kernel::<true>(&self.rows[lo..hi], model, robust, &mut g, &mut gr),
                Loss::Linear => kernel::<false>(&self.rows[lo..hi], model, robust, &mut g, &mut gr),
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
            for rw in &self.rows[lo..hi] {
                let f = model.brdf(&rw.g);
                let r = match self.loss {
                    Loss::Log => (rw.cos_i * f).ln_1p() - rw.target,
                    Loss::Linear => f - rw.target,
                };
                s += robust.rho(rw.sw * r);
            }
        }
        s
    }
}

/// The hot loop: residuals of one channel's rows with the model's parameter gradient,
/// accumulated into the model-space normal equations `g` (upper triangle) and `gr`; returns
/// Σ ρ(r). Free of allocation; the loss is a compile-time constant.
#[inline(never)]
fn kernel<const LOG: bool>(
    rows: &[Row],
    model: &Model,
    robust: Robust,
    g: &mut [[f64; 4]; 4],
    gr: &mut [f64; 4],
) -> f64 {
    let mut cost = 0.0;
    let mut grad = [0.0; 4];
    for rw in rows {
        let f = model.brdf_grad(&rw.g, &mut grad);
        let (r, drdf) = if LOG {
            let fm = rw.cos_i * f;
            (fm.ln_1p() - rw.target, rw.cos_i / (1.0 + fm))
        } else {
            (f - rw.target, 1.0)
        };
        let r = rw.sw * r;
        let s = rw.sw * drdf;
        let j = [s * grad[0], s * grad[1], s * grad[2], s * grad[3]];
        let (rho, w) = match robust {
            Robust::None => (0.5 * r * r, 1.0),
            _ => (robust.rho(r), robust.weight(r)),
        };
        cost += rho;
        for a in 0..4 {
            let wa = w * j[a];
            gr[a] += wa * r;
            for b in a..4 {
                g[a][b] += wa * j[b];
            }
        }
    }
    cost
}

/// Grid of candidate values for a nonlinear parameter in the global initialisation.
pub fn init_grid(name: &str, dist: Distribution) -> Vec<f64> {
    let _ = dist;
    match name {
        "n" => [
            1e-3, 4e-3, 0.01, 0.02, 0.035, 0.05, 0.08, 0.12, 0.2, 0.35, 0.55, 0.75, 0.9, 0.97,
            0.995,
        ]
        .iter()
        .map(|&f0| crate::model::n_from_f0(f0))
        .collect(),
        "c3" => vec![
            0.01, 0.03, 0.06, 0.1, 0.15, 0.22, 0.3, 0.4, 0.55, 0.75, 0.95,
        ],
        // Blinn's c(β) for half-angles 1°…60°, so the grids of D1 and D2 match D3's.
        "c1" | "c2" => {
            let d = if name == "c1" {
                Distribution::D1
            } else {
                Distribution::D2
            };
            [
                0.5, 1.0, 2.0, 3.0, 4.5, 6.0, 8.0, 11.0, 15.0, 20.0, 27.0, 35.0, 45.0, 60.0, 75.0,
            ]
            .iter()
            .map(|deg: &f64| d.param_from_beta(deg.to_radians()))
            .collect()
        }
        _ => vec![],
    }
}

/// The model kinds whose specular coefficient is `ps` and diffuse coefficient `pd`.
pub fn linear_index(kind: ModelKind, name: &str) -> Option<usize> {
    kind.param_names(Distribution::D3)
        .iter()
        .position(|n| *n == name)
}

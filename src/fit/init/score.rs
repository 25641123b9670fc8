//! The score of one grid point: each channel's linear coefficients solved at the point's
//! nonlinear values, and the declared loss (or its linearisation) at them. A [`Scorer`]
//! holds everything a grid's points share (the subsample, the linearised data, the sums
//! computed once for the whole grid).

use super::grid::{GridPoints, Points, grid_points};
use super::linear::{
    Basis, gram_sums, linear_coefficients, linear_cost_log, linear_cost_log_many, linear_pass,
    linear_pass_many, linearised_cost, linearised_data, refine_linear, weights,
};
use super::nnls::linear_solve;
use super::tables::{LobeTables, TsFactors, TwoLobeGram, basis_free_sums, basis_sums};
use crate::fit::options::FitOptions;
use crate::fit::problem::{self, BrdfProblem, Loss, Slot};
use crate::model::{Distribution, MAX_PARAMS, ModelKind, ParamSpec, Role};
use std::ops::Range;

/// What every point of one grid shares.
pub(super) struct Scorer<'a> {
    /// The problem whose model template gives the lobes' bases.
    full: &'a BrdfProblem,
    /// The subsample the grid is scored on.
    pub(super) p: BrdfProblem,
    pub(super) opts: &'a FitOptions,
    /// The model's parameters.
    model_specs: &'static [ParamSpec],
    /// The linear coefficients' model indices: each lobe's ps, then pd (as pd/π, its basis
    /// being 1).
    pub(super) ips: Vec<usize>,
    pub(super) ipd: usize,
    /// How many linear coefficients (the lobes' and pd).
    k: usize,
    /// How many free variables.
    nfree: usize,
    /// The gridded variables with their values.
    pub(super) nonlinear: Vec<(usize, Vec<f64>)>,
    /// The grid's sizes.
    pub(super) dims: Vec<usize>,
    /// The grid's points.
    pub(super) points: Points,
    /// Per row, the weight that linearises the loss, and that weight times the data.
    wdata: Vec<f64>,
    wf: Vec<f64>,
    /// Per channel, the sums that do not depend on the grid point.
    free_sums: Vec<[f64; 3]>,
    /// One lobe on one channel, every shape parameter and n free: every point's basis as two
    /// factors and its sums, at once.
    separable: Option<(TsFactors, Vec<[f64; 3]>)>,
    /// GGX–Smith (one lobe or two): the lobes and Fresnel factors at the grid's α and n.
    lobe_tables: Option<LobeTables>,
    /// Two GGX lobes on one channel with α1, α2 and n free: every point's Gram sums.
    pub(super) two_lobes: Option<TwoLobeGram>,
    ones: Vec<f64>,
    zeros: Vec<f64>,
    /// The grid is searched by the linearised cost (only refined points carry the declared
    /// loss).
    pub(super) linearised: bool,
}

/// One channel at one grid point.
struct Channel {
    /// The channel.
    c: usize,
    /// Its rows in the subsample.
    rows: Range<usize>,
    /// The model's parameters at the point, the linear coefficients 0.
    vals: [f64; MAX_PARAMS],
    /// The linear coefficients' values where held (pd as pd/π), and which are free.
    held: Vec<f64>,
    free: Vec<bool>,
}

impl<'a> Scorer<'a> {
    /// The grid of `specs`' nonlinear free variables scored on `rows_per_channel` rows per
    /// channel of `full`, with the sums that serve every point computed once.
    pub(super) fn new(
        full: &'a BrdfProblem,
        specs: &[&ParamSpec],
        opts: &'a FitOptions,
        rows_per_channel: usize,
    ) -> Self {
        let p = full.subsample(rows_per_channel);

        let nfree = p.transforms.len();
        let kind = opts.kind;
        let model_specs = kind.params(opts.dist);
        // The linear coefficients: each lobe's ps, then pd (as pd/π, its basis being 1).
        let ips: Vec<usize> = (0..model_specs.len())
            .filter(|&i| model_specs[i].role == Role::Specular)
            .collect();
        let ipd = kind
            .index_of(opts.dist, Role::Diffuse)
            .expect("every model has pd");
        let k = ips.len() + 1;
        let (nonlinear, dims, points): GridPoints = grid_points(specs, nfree);
        let (fdata, wdata) = linearised_data(&p, opts.loss);
        let wf: Vec<f64> = wdata.iter().zip(&fdata).map(|(w, f)| w * f).collect();
        // Per channel, the sums that do not depend on the grid point.
        let free_sums: Vec<[f64; 3]> = (0..p.layout.len())
            .map(|c| {
                let rows = p.starts[c]..p.starts[c + 1];
                basis_free_sums(&wdata[rows.clone()], &fdata[rows])
            })
            .collect();
        // Torrance–Sparrow on one channel with n and every shape parameter free: every
        // point's sums at once.
        let shapes = model_specs.iter().filter(|s| s.role == Role::Shape).count();
        let separable = (kind == ModelKind::TorranceSparrow
            && p.layout.len() == 1
            && ips.len() == 1
            && nonlinear.len() == 1 + shapes
            && specs[nonlinear[0].0].role == Role::Index
            && nonlinear[1..]
                .iter()
                .all(|(k, _)| specs[*k].role == Role::Shape))
        .then(|| {
            // The shape grid points, row-major as in `points` (n is the slowest axis).
            let per_n = points.len() / nonlinear[0].1.len();
            let cs: Vec<Vec<f64>> = (0..per_n).map(|i| points.get(i)[1..].to_vec()).collect();
            let f = TsFactors::new(&p.rows, opts.dist, &nonlinear[0].1, &cs);
            let table = f.grid_sums(&wdata, &wf);
            (f, table)
        });
        // GGX–Smith (one lobe or two): the lobes and Fresnel factors at the grid's α and n,
        // once.
        let ggx = matches!(kind, ModelKind::GgxSmith | ModelKind::GgxSmith2);
        let lobe_tables = ggx.then(|| {
            let grid = |role: Role| -> Vec<f64> {
                nonlinear
                    .iter()
                    .filter(|(k, _)| specs[*k].role == role)
                    .flat_map(|(_, g)| g.iter().copied())
                    .collect()
            };
            LobeTables::new(&p.rows, &grid(Role::Shape), &grid(Role::Index))
        });
        // One GGX lobe on one channel with α and n free: every point's sums at once (α is the
        // slower axis, as declared).
        let separable = separable.or_else(|| {
            let t = lobe_tables.as_ref()?;
            (kind == ModelKind::GgxSmith
                && p.layout.len() == 1
                && nonlinear.len() == 2
                && specs[nonlinear[0].0].role == Role::Shape
                && specs[nonlinear[1].0].role == Role::Index)
                .then(|| {
                    let f = TsFactors::ggx(t, &nonlinear[0].1, &nonlinear[1].1)?;
                    let table = f.grid_sums(&wdata, &wf);
                    Some((f, table))
                })
                .flatten()
        });
        // Two GGX lobes on one channel with α1, α2 and n free: every point's Gram sums at
        // once.
        let two_lobes = lobe_tables.as_ref().and_then(|t| {
            let roles: Vec<Role> = nonlinear.iter().map(|(k, _)| specs[*k].role).collect();
            (kind == ModelKind::GgxSmith2
                && p.layout.len() == 1
                && roles == [Role::Shape, Role::Shape, Role::Index]
                && nonlinear[0].1 == nonlinear[1].1)
                .then(|| TwoLobeGram::new(t, &nonlinear[0].1, &nonlinear[2].1, &wdata, &wf))
                .flatten()
        });
        let (ones, zeros) = (vec![1.0; p.rows.len()], vec![0.0; p.rows.len()]);
        // One lobe on one channel with one shape parameter and n free (Torrance–Sparrow D1–D3,
        // GGX–Smith): the grid is searched (coarse to fine) by the linearised cost (see
        // [`Scorer::one_lobe`]). Not ABC, whose two shape parameters leave flat valleys where
        // the two searches end at different points (acryl_blue, 540–570 nm: up to 5e-6 of the
        // cost higher).
        let linearised = separable.is_some()
            && !(kind == ModelKind::TorranceSparrow && opts.dist == Distribution::Abc);
        Scorer {
            full,
            p,
            opts,
            model_specs,
            ips,
            ipd,
            k,
            nfree,
            nonlinear,
            dims,
            points,
            wdata,
            wf,
            free_sums,
            separable,
            lobe_tables,
            two_lobes,
            ones,
            zeros,
            linearised,
        }
    }

    /// The score of grid point `index` (+∞ where not finite) and its solver variables, the
    /// linear coefficients solved per channel and refined by `steps` Gauss–Newton steps on
    /// the declared loss (0: the linear solve's, scored on the linearised cost where the grid
    /// is searched by it).
    pub(super) fn score_point(&self, index: usize, steps: usize) -> (f64, Vec<f64>) {
        let (p, ips, ipd, k) = (&self.p, &self.ips, self.ipd, self.k);
        let pt = self.points.get(index);
        // Natural values of all free variables at this grid point (linear ones solved).
        let mut theta = vec![f64::NAN; self.nfree];
        let mut score = 0.0;
        for ((k, _), v) in self.nonlinear.iter().zip(pt) {
            theta[*k] = *v;
        }
        for c in 0..p.layout.len() {
            let slots = p.layout[c];
            let rows = p.starts[c]..p.starts[c + 1];
            let mut vals = [0.0; MAX_PARAMS];
            for j in 0..self.model_specs.len() {
                vals[j] = match slots[j] {
                    Slot::Fixed(v) => v,
                    Slot::Free(k) => theta[k],
                };
            }
            let (held, free) = linear_coefficients(&slots, ips, ipd);
            for &i in ips.iter().chain([&ipd]) {
                vals[i] = 0.0;
            }
            let at = Channel {
                c,
                rows,
                vals,
                held,
                free,
            };
            let (cost, x) = if ips.len() <= 1 {
                self.one_lobe(&at, index, steps)
            } else {
                self.several_lobes(&at, index, steps)
            };
            score += cost;
            for (j, &i) in ips.iter().chain([&ipd]).enumerate() {
                if let Slot::Free(v) = slots[i] {
                    theta[v] = if j == k - 1 {
                        x[j] * std::f64::consts::PI
                    } else {
                        x[j]
                    };
                }
            }
        }
        let x: Vec<f64> = (0..self.nfree)
            .map(|k| p.transforms[k].invert(theta[k]))
            .collect();
        let score = if score.is_finite() {
            score
        } else {
            f64::INFINITY
        };
        (score, x)
    }

    /// The specular basis of lobe `i` on `rows`: the model at `vals` with that ps = 1 and
    /// every other linear parameter 0.
    fn lobe(&self, vals: &[f64; MAX_PARAMS], i: usize, rows: Range<usize>) -> Vec<f64> {
        let mut v = *vals;
        v[i] = 1.0;
        problem::brdf_values(&self.full.template.with_params(&v), &self.p.rows, rows)
    }

    /// One lobe (or none): the cost and the coefficients (ps, pd/π; pd/π alone without a
    /// lobe) of one channel at grid point `index`, through the lane kernels.
    fn one_lobe(&self, at: &Channel, index: usize, steps: usize) -> (f64, Vec<f64>) {
        let (p, opts, ips) = (&self.p, self.opts, &self.ips);
        let (c, rows, held, free) = (at.c, &at.rows, &at.held, &at.free);
        let (wdata, wf, ones, zeros) = (&self.wdata, &self.wf, &self.ones, &self.zeros);
        let n = rows.len();
        let owned: Vec<f64>;
        let basis = match (&self.separable, ips.first()) {
            (Some((f, _)), _) => f.basis(index),
            (None, Some(&i)) => {
                owned = self.lobe(&at.vals, i, rows.clone());
                Basis {
                    a: &owned,
                    b: &ones[..n],
                }
            }
            (None, None) => Basis {
                a: &zeros[..n],
                b: &ones[..n],
            },
        };
        let [ss, s1, sf] = match &self.separable {
            Some((_, table)) => table[index],
            // Here the basis is its first factor (the second is ones).
            None => basis_sums(basis.a, &wdata[rows.clone()], &wf[rows.clone()]),
        };
        let [w1, f1, ff] = self.free_sums[c];
        let (start, free2) = if ips.is_empty() {
            ([0.0, held[0]], [false, free[0]])
        } else {
            ([held[0], held[1]], [free[0], free[1]])
        };
        let x0 = linear_solve(&[ss, s1, s1, w1], &[sf, f1], &start, &free2);
        let pass = |x: &[f64]| {
            let (cost, jtj, jtr) =
                linear_pass(&p.rows, rows.clone(), basis, (x[0], x[1]), opts.loss);
            (cost, vec![jtj[0], jtj[1], jtj[1], jtj[2]], jtr.to_vec())
        };
        let cost = |x: &[f64]| match opts.loss {
            Loss::Log => {
                let r = rows.clone();
                linear_cost_log(
                    &p.rows.nl[r.clone()],
                    &p.rows.target[r.clone()],
                    weights(&p.rows, r),
                    basis,
                    (x[0], x[1]),
                )
            }
            Loss::Linear | Loss::Pixel => pass(x).0,
        };
        let (cost, x) = if steps == 0 && self.linearised {
            // The search's score: the linearised cost ½ Σ w (s·x − f)² at the linear solve's
            // (ps, pd), from the grid's sums with no pass over the rows; only the points then
            // refined are scored on the declared loss (the linear loss: the same cost). The
            // weights linearise the declared loss at the data, so its basins lie low in the
            // linearised cost (as for two lobes, [`super::two_lobe::two_lobe_prescreen`]).
            let q = linearised_cost([ss, s1, w1], [sf, f1], ff, [x0[0], x0[1]]);
            (q, x0)
        } else {
            refine_linear(&x0, &free2, opts.loss, steps, pass, cost)
        };
        let x = if ips.is_empty() { vec![x[1]] } else { x };
        (cost, x)
    }

    /// Several lobes: the cost and the coefficients (each lobe's ps, then pd/π) of one
    /// channel at grid point `index`, a basis each and a row loop. GGX–Smith's two lobes come
    /// from the tables (lobe i's α is the parameter before its ps), others from the model.
    fn several_lobes(&self, at: &Channel, index: usize, steps: usize) -> (f64, Vec<f64>) {
        let (p, opts, ips, k, dims) = (&self.p, self.opts, &self.ips, self.k, &self.dims);
        let (vals, rows, held, free) = (&at.vals, &at.rows, &at.held, &at.free);
        let (wdata, wf, ones) = (&self.wdata, &self.wf, &self.ones);
        let n = rows.len();
        let kind = opts.kind;
        let tabled = |i: usize| {
            let t = self.lobe_tables.as_ref()?;
            let n_index = kind.index_of(opts.dist, Role::Index)?;
            t.basis(vals[i - 1], vals[n_index], rows.clone())
        };
        let owned: Vec<Option<Vec<f64>>> = ips
            .iter()
            .map(|&i| {
                tabled(i)
                    .is_none()
                    .then(|| self.lobe(vals, i, rows.clone()))
            })
            .collect();
        let mut bases: Vec<Basis> = ips
            .iter()
            .zip(&owned)
            .map(|(&i, s)| match s {
                Some(s) => Basis {
                    a: s,
                    b: &ones[..n],
                },
                None => tabled(i).expect("a tabulated lobe"),
            })
            .collect();
        bases.push(Basis {
            a: &ones[..n],
            b: &ones[..n],
        });
        let (g, h) = match &self.two_lobes {
            Some(t) => {
                let (d1, d2) = (dims[1] * dims[2], dims[2]);
                t.gram(index / d1, (index / d2) % dims[1], index % d2)
            }
            None => gram_sums(&bases, &wdata[rows.clone()], &wf[rows.clone()]),
        };
        let x0 = linear_solve(&g, &h, held, free);
        let pass = |x: &[f64]| linear_pass_many(&p.rows, rows.clone(), &bases, x, opts.loss);
        let cost = |x: &[f64]| match opts.loss {
            Loss::Log => {
                let r = rows.clone();
                linear_cost_log_many(
                    &p.rows.nl[r.clone()],
                    &p.rows.target[r.clone()],
                    weights(&p.rows, r),
                    &bases[..k - 1],
                    &x[..k - 1],
                    x[k - 1],
                )
            }
            Loss::Linear | Loss::Pixel => pass(x).0,
        };
        refine_linear(&x0, free, opts.loss, steps, pass, cost)
    }
}

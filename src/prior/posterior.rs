//! A measurement conditioned on the prior: the posterior of the component coefficients given
//! the samples (Nielsen et al. 2015, §5: regularised least squares in the mapped space with
//! the components' variances as the prior, a Gaussian posterior), the number of components
//! and the noise level chosen by cross-validation on the samples.

use super::{Prior, map, unmap};
use crate::data::Dataset;
use crate::model::Geometry;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// The candidates cross-validation chooses among.
#[derive(Clone, Debug)]
pub struct PosteriorOptions {
    /// Numbers of components tried (each at most the prior's).
    pub components: Vec<usize>,
    /// Noise variances tried, in mapped units (ln² of a ratio).
    pub noise: Vec<f64>,
    /// Cross-validation folds (samples grouped by θi and azimuth slice, so a fold leaves out
    /// whole curves).
    pub folds: usize,
}

impl Default for PosteriorOptions {
    fn default() -> Self {
        PosteriorOptions {
            components: vec![2, 4, 8, 16, 32, 48, 64, 96, 128, 160, 200],
            noise: vec![1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0],
            folds: 5,
        }
    }
}

/// The posterior of a measurement under a prior.
#[derive(Clone, Debug)]
pub struct Posterior {
    /// The prior.
    pub prior: Arc<Prior>,
    /// Posterior mean of the coefficients of the first `coef.len()` components.
    pub coef: Vec<f64>,
    /// Posterior covariance of the coefficients (row-major, `coef.len()`²).
    pub cov: Vec<f64>,
    /// The noise variance chosen (mapped units).
    pub noise: f64,
    /// Cross-validated root-mean-square residual of the chosen candidate (mapped units: a
    /// relative error of f_r cos θi cos θo + ε).
    pub cv_rms: f64,
    /// Root-mean-square residual of the posterior mean at the samples (mapped units).
    pub fit_rms: f64,
    /// Samples used.
    pub samples: usize,
    /// The posterior mean's mapped value at each cell.
    table: Vec<f32>,
}

/// One sample as a row: its cells and weights, and its mapped value minus the median's.
struct Row {
    corners: [(usize, f64); 8],
    r: f64,
    fold: usize,
}

fn rows(prior: &Prior, ds: &Dataset, folds: usize) -> Vec<Row> {
    let values = ds.channels.first().map(|c| &c.values[..]).unwrap_or(&[]);
    let key = |x: f64| (x.to_degrees() * 100.0).round() as i64;
    let mut out = Vec::with_capacity(ds.len());
    for k in 0..ds.len().min(values.len()) {
        let g = Geometry::from_angles(ds.theta_i[k], ds.phi_i[k], ds.theta_o[k], ds.phi_o[k]);
        let y = values[k] * ds.quantity.to_brdf_factor(g.nl);
        if !g.visible() || !y.is_finite() || y < 0.0 {
            continue;
        }
        let corners = prior.corners(&g);
        let m: f64 = corners
            .iter()
            .map(|&(c, w)| w * prior.median[c] as f64)
            .sum();
        let slice = (
            key(ds.theta_i[k]),
            key((ds.phi_o[k] - ds.phi_i[k]).rem_euclid(std::f64::consts::TAU)),
        );
        let h = ((slice.0 * 1_000_003 + slice.1) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        out.push(Row {
            corners,
            r: map(y, &g) - m,
            fold: ((h >> 33) % folds.max(1) as u64) as usize,
        });
    }
    out
}

/// AᵀA and Aᵀr over the rows `take` selects.
fn normal(
    a: &[Vec<f64>],
    rows: &[Row],
    k: usize,
    take: impl Fn(&Row) -> bool,
) -> (DMatrix<f64>, DVector<f64>) {
    let mut ata = DMatrix::zeros(k, k);
    let mut atr = DVector::zeros(k);
    for (row, x) in rows.iter().zip(a) {
        if !take(row) {
            continue;
        }
        for i in 0..k {
            atr[i] += x[i] * row.r;
            for j in 0..=i {
                ata[(i, j)] += x[i] * x[j];
            }
        }
    }
    for i in 0..k {
        for j in 0..i {
            ata[(j, i)] = ata[(i, j)];
        }
    }
    (ata, atr)
}

/// Solve (AᵀA + σ² Λ⁻¹) c = Aᵀr for the first `k` components; also the inverse.
fn solve(
    prior: &Prior,
    ata: &DMatrix<f64>,
    atr: &DVector<f64>,
    k: usize,
    noise: f64,
) -> Option<(DVector<f64>, DMatrix<f64>)> {
    let mut m = ata.view((0, 0), (k, k)).into_owned();
    for i in 0..k {
        m[(i, i)] += noise / prior.variance[i];
    }
    let chol = m.cholesky()?;
    let c = chol.solve(&atr.rows(0, k).into_owned());
    Some((c, chol.inverse()))
}

impl Posterior {
    /// Condition `prior` on the first channel of `ds` (f_r after the data's quantity is
    /// converted). `None` when no sample is usable.
    pub fn condition(prior: Arc<Prior>, ds: &Dataset, opts: &PosteriorOptions) -> Option<Self> {
        let folds = opts.folds.max(2);
        let rows = rows(&prior, ds, folds);
        if rows.is_empty() {
            return None;
        }
        let kmax = opts
            .components
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .min(prior.components());
        let a: Vec<Vec<f64>> = rows
            .iter()
            .map(|r| {
                let mut x = vec![0.0; kmax];
                prior.components_at(&r.corners, &mut x);
                x
            })
            .collect();
        // Cross-validation: each fold's normal equations are the whole's minus its own.
        let (ata, atr) = normal(&a, &rows, kmax, |_| true);
        let mut sse = vec![vec![0.0; opts.noise.len()]; opts.components.len()];
        let mut count = 0usize;
        for f in 0..folds {
            let (fa, fr) = normal(&a, &rows, kmax, |r| r.fold == f);
            let (ta, tr) = (&ata - &fa, &atr - &fr);
            let held: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].fold == f).collect();
            count += held.len();
            for (ik, &k) in opts.components.iter().enumerate() {
                let k = k.min(kmax);
                for (is, &s) in opts.noise.iter().enumerate() {
                    let Some((c, _)) = solve(&prior, &ta, &tr, k, s) else {
                        sse[ik][is] = f64::INFINITY;
                        continue;
                    };
                    for &i in &held {
                        let p: f64 = (0..k).map(|j| a[i][j] * c[j]).sum();
                        sse[ik][is] += (rows[i].r - p).powi(2);
                    }
                }
            }
        }
        let mut best = (0, 0, f64::INFINITY);
        for (ik, v) in sse.iter().enumerate() {
            for (is, &e) in v.iter().enumerate() {
                if e < best.2 {
                    best = (ik, is, e);
                }
            }
        }
        let k = opts.components.get(best.0).copied().unwrap_or(0).min(kmax);
        let noise = opts.noise.get(best.1).copied().unwrap_or(1.0);
        let (c, inv) = solve(&prior, &ata, &atr, k, noise)?;
        let fit_sse: f64 = rows
            .iter()
            .zip(&a)
            .map(|(r, x)| (r.r - (0..k).map(|j| x[j] * c[j]).sum::<f64>()).powi(2))
            .sum();
        let coef: Vec<f64> = c.iter().copied().collect();
        let table = table(&prior, &coef);
        Some(Posterior {
            cov: (inv * noise).iter().copied().collect(),
            coef,
            noise,
            cv_rms: (best.2 / count.max(1) as f64).sqrt(),
            fit_rms: (fit_sse / rows.len() as f64).sqrt(),
            samples: rows.len(),
            table,
            prior,
        })
    }

    /// Number of components used.
    pub fn components(&self) -> usize {
        self.coef.len()
    }

    /// The posterior mean's mapped value at a configuration.
    pub fn mapped(&self, g: &Geometry) -> f64 {
        self.prior
            .corners(g)
            .iter()
            .map(|&(c, w)| w * self.table[c] as f64)
            .sum()
    }

    /// f_r of the posterior mean at a configuration (0 below the horizon).
    pub fn brdf(&self, g: &Geometry) -> f64 {
        if !g.visible() {
            return 0.0;
        }
        unmap(self.mapped(g), g)
    }

    /// The same posterior with coefficients `coef` (a draw, or the mean moved): its table
    /// rebuilt.
    pub fn with_coef(&self, coef: Vec<f64>) -> Posterior {
        let table = table(&self.prior, &coef);
        Posterior {
            coef,
            table,
            ..self.clone()
        }
    }

    /// A draw of the coefficients from the posterior (seeded): mean + L z, L the Cholesky
    /// factor of the covariance, z standard normal.
    pub fn draw(&self, seed: u64) -> Posterior {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let k = self.components();
        let cov = DMatrix::from_row_slice(k, k, &self.cov);
        let Some(l) = cov.cholesky().map(|c| c.l()) else {
            return self.clone();
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let z = DVector::from_iterator(k, (0..k).map(|_| StandardNormal.sample(&mut rng)));
        let d = l * z;
        self.with_coef(self.coef.iter().zip(d.iter()).map(|(a, b)| a + b).collect())
    }
}

/// median + Σ c_k B_k at every cell.
fn table(prior: &Prior, coef: &[f64]) -> Vec<f32> {
    use rayon::prelude::*;
    let n = prior.cells();
    (0..n)
        .into_par_iter()
        .map(|cell| {
            let mut x = prior.median[cell] as f64;
            for (k, c) in coef.iter().enumerate() {
                x += c * prior.basis[k * n + cell] as f64;
            }
            x as f32
        })
        .collect()
}

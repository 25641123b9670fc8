//! Building a prior from Neural-BRDF networks: each network tabulated and mapped, the
//! per-cell median removed, principal components by the eigenvectors of the tables' Gram
//! matrix (the tables are few and long: 3 × 100 tables of about 10⁵ cells).

use super::{EPSILON, Prior, cell_angles};
use crate::data::nbrdf::Nbrdf;
use crate::model::Geometry;
use rayon::prelude::*;

/// What a prior is built from and at what size.
#[derive(Clone, Debug)]
pub struct BuildOptions {
    /// Table size: cells in θh (square-root scale), θd and folded φd.
    pub dims: [usize; 3],
    /// Materials left out: a weights-file name (`merl/steel`) or its last part (`steel`).
    pub exclude: Vec<String>,
    /// Only networks whose name starts with this (`merl/`); all when empty.
    pub prefix: String,
    /// Largest number of components kept.
    pub max_components: usize,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            dims: [90, 45, 45],
            exclude: Vec::new(),
            prefix: "merl/".into(),
            max_components: 200,
        }
    }
}

impl BuildOptions {
    /// True when the network `name` is used.
    pub fn uses(&self, name: &str) -> bool {
        name.starts_with(&self.prefix)
            && !self
                .exclude
                .iter()
                .any(|e| e == name || name.rsplit('/').next() == Some(e.as_str()))
    }
}

/// The mapped table of one network (symmetrised: reciprocal and isotropic), one per channel.
fn tabulate(net: &Nbrdf, dims: [usize; 3]) -> [Vec<f32>; 3] {
    let [nh, nd, np] = dims;
    let rows: Vec<[f32; 3]> = (0..nh * nd)
        .into_par_iter()
        .flat_map_iter(|r| {
            let (ih, id) = (r / nd, r % nd);
            (0..np).map(move |ip| {
                let a = cell_angles(dims, ih, id, ip);
                let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
                let w = (g.nl * g.ne).max(0.0);
                let f = if g.visible() {
                    net.eval_symmetric(a)
                } else {
                    [0.0; 3]
                };
                f.map(|f| (f.max(0.0) * w + EPSILON).ln() as f32)
            })
        })
        .collect();
    [0, 1, 2].map(|c| rows.iter().map(|v| v[c]).collect())
}

/// Build a prior from the networks `nets` that `opts` uses (each colour channel a training
/// table). `progress(done, total)` is called as each network is tabulated. `None` with fewer
/// than two networks.
pub fn build(
    nets: &[Nbrdf],
    opts: &BuildOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Option<Prior> {
    let used: Vec<&Nbrdf> = nets.iter().filter(|n| opts.uses(&n.name)).collect();
    if used.len() < 2 {
        return None;
    }
    let mut tables: Vec<Vec<f32>> = Vec::with_capacity(3 * used.len());
    for (k, net) in used.iter().enumerate() {
        tables.extend(tabulate(net, opts.dims));
        progress(k + 1, used.len());
    }
    let cells: usize = opts.dims.iter().product();
    let median: Vec<f32> = (0..cells)
        .into_par_iter()
        .map(|c| {
            let mut v: Vec<f32> = tables.iter().map(|t| t[c]).collect();
            v.sort_by(f32::total_cmp);
            let m = v.len() / 2;
            if v.len() % 2 == 1 {
                v[m]
            } else {
                0.5 * (v[m - 1] + v[m])
            }
        })
        .collect();
    for t in &mut tables {
        for (x, m) in t.iter_mut().zip(&median) {
            *x -= m;
        }
    }
    let n = tables.len();
    // The Gram matrix of the centred tables, each entry summed in fixed chunks (deterministic).
    let pairs: Vec<(usize, usize)> = (0..n).flat_map(|i| (i..n).map(move |j| (i, j))).collect();
    let dots: Vec<f64> = pairs
        .par_iter()
        .map(|&(i, j)| {
            tables[i]
                .chunks(4096)
                .zip(tables[j].chunks(4096))
                .map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x * y) as f64).sum::<f64>())
                .sum()
        })
        .collect();
    let mut gram = nalgebra::DMatrix::<f64>::zeros(n, n);
    for (&(i, j), &d) in pairs.iter().zip(&dots) {
        gram[(i, j)] = d;
        gram[(j, i)] = d;
    }
    let eig = gram.symmetric_eigen();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let keep: Vec<usize> = order
        .into_iter()
        .filter(|&k| eig.eigenvalues[k] > 1e-8 * eig.eigenvalues.max())
        .take(opts.max_components)
        .collect();
    // Component k = Σ_i v_ik table_i / √λ_k (unit length); the coefficient variance λ_k / n.
    let basis_k: Vec<Vec<f32>> = keep
        .par_iter()
        .map(|&k| {
            let lambda = eig.eigenvalues[k];
            let v = eig.eigenvectors.column(k);
            // A deterministic sign: the largest entry of v positive.
            let big = (0..n)
                .max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()))
                .unwrap_or(0);
            let s = v[big].signum() / lambda.sqrt();
            let mut b = vec![0f64; cells];
            for (i, t) in tables.iter().enumerate() {
                let w = s * v[i];
                for (x, y) in b.iter_mut().zip(t) {
                    *x += w * *y as f64;
                }
            }
            // Unit length again: for the smallest components the sum above loses digits.
            let norm = b.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
            b.into_iter().map(|x| (x / norm) as f32).collect()
        })
        .collect();
    Some(Prior {
        dims: opts.dims,
        median,
        basis: basis_k.concat(),
        variance: keep
            .iter()
            .map(|&k| eig.eigenvalues[k] / n as f64)
            .collect(),
        materials: used.iter().map(|n| n.name.clone()).collect(),
        residual_variance: {
            let all: f64 = eig.eigenvalues.iter().map(|l| l.max(0.0)).sum();
            let kept: f64 = keep.iter().map(|&k| eig.eigenvalues[k]).sum();
            ((all - kept) / (n * cells) as f64).max(1e-12)
        },
    })
}

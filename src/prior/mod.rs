//! What real materials are like: principal components of measured BRDFs, and a sparse
//! measurement reconstructed on them.
//!
//! Following Nielsen, Jensen & Ramamoorthi 2015 ("On optimal, minimal BRDF sampling for
//! reflectance acquisition", ACM TOG 34(6), §4), each training material's f_r is tabulated
//! on Rusinkiewicz's (1998) half/difference angles and mapped to
//! x = ln(f_r · cos θi · cos θo + ε) (their eq. 2, with the cosines of the cell's centre), which
//! makes the database near-linear; the per-cell median of the training tables is subtracted
//! and the principal components of what remains, with each one's variance, are the prior.
//! Every colour channel of every material is one training table, so one prior serves a
//! single channel of any data.
//!
//! A measurement is reconstructed as the posterior mean of the component coefficients given
//! its samples (regularised least squares with the components' variances as the prior, §5 of
//! the paper), the number of components and the noise level chosen by cross-validation on the
//! samples themselves ([`Posterior::condition`]).
//!
//! The table: θh on MERL's square-root scale (u = √(θh/90°)), θd linear over [0°, 90°], φd
//! folded onto [0°, 90°] by reciprocity and isotropy ([`coordinates`]); lookups interpolate
//! trilinearly between cell centres.

mod build;
mod file;
mod posterior;

pub use build::{BuildOptions, build};
pub use file::{bundled, bundled_weights, load, save};
pub use posterior::{Posterior, PosteriorOptions};

use crate::model::Geometry;
use std::f64::consts::FRAC_PI_2;

/// The floor ε of the mapping x = ln(f_r cos θi cos θo + ε) (f_r in 1/sr), Nielsen et al.'s
/// value of 10⁻³.
pub const EPSILON: f64 = 1e-3;

/// Principal components of a set of measured materials on a half/difference table.
#[derive(Clone, Debug, PartialEq)]
pub struct Prior {
    /// Cells in θh (square-root scale), θd and folded φd.
    pub dims: [usize; 3],
    /// Per cell, the median of the training tables' mapped values (ln ε where a cell's
    /// centre has light or eye below the horizon).
    pub median: Vec<f32>,
    /// The components, each of unit length over the cells, one after the other.
    pub basis: Vec<f32>,
    /// The variance of the training tables' coefficients on each component, largest first.
    pub variance: Vec<f64>,
    /// The training materials (the weights file's names), in the order used.
    pub materials: Vec<String>,
    /// The training tables' variance per cell outside the kept components (mapped units).
    pub residual_variance: f64,
}

impl Prior {
    /// Number of cells of the table.
    pub fn cells(&self) -> usize {
        self.dims.iter().product()
    }

    /// Number of components.
    pub fn components(&self) -> usize {
        self.variance.len()
    }

    /// Component `k` over the cells.
    pub fn component(&self, k: usize) -> &[f32] {
        let n = self.cells();
        &self.basis[k * n..(k + 1) * n]
    }

    /// −ln of the prior's density of a mapped table `x` (one value per cell), up to a
    /// constant: ½ (Σ c_k²/λ_k + |x − median − Σ c_k B_k|² / ρ), c_k the table's coefficients
    /// on the components and ρ the training tables' residual variance per cell (a Gaussian in
    /// the components, isotropic outside them; Nielsen et al. 2015, §5).
    pub fn neg_log_density(&self, x: &[f64]) -> f64 {
        let n = self.cells();
        let d: Vec<f64> = (0..n).map(|i| x[i] - self.median[i] as f64).collect();
        let mut r = d.clone();
        let mut m = 0.0;
        for k in 0..self.components() {
            let b = self.component(k);
            let c: f64 = (0..n).map(|i| b[i] as f64 * d[i]).sum();
            m += c * c / self.variance[k];
            for i in 0..n {
                r[i] -= c * b[i] as f64;
            }
        }
        let rr: f64 = r.iter().map(|v| v * v).sum();
        0.5 * (m + rr / self.residual_variance.max(1e-12))
    }

    /// The cell at index (ih, id, ip).
    #[inline]
    pub fn cell(&self, ih: usize, id: usize, ip: usize) -> usize {
        let [_, nd, np] = self.dims;
        (ih * nd + id) * np + ip
    }

    /// The first `out.len()` components interpolated over `corners` (from [`Prior::corners`]),
    /// as the reconstruction reads its table.
    pub fn components_at(&self, corners: &[(usize, f64); 8], out: &mut [f64]) {
        let n = self.cells();
        for (k, o) in out.iter_mut().enumerate() {
            *o = corners
                .iter()
                .map(|&(c, w)| w * self.basis[k * n + c] as f64)
                .sum();
        }
    }

    /// The eight cells around a configuration and their trilinear weights.
    pub fn corners(&self, g: &Geometry) -> [(usize, f64); 8] {
        let c = coordinates(g);
        let [nh, nd, np] = self.dims;
        let axis = |u: f64, m: usize| {
            let x = (u * m as f64 - 0.5).clamp(0.0, (m - 1) as f64);
            let i = (x as usize).min(m.saturating_sub(2));
            (i, (i + 1).min(m - 1), x - i as f64)
        };
        let (h0, h1, fh) = axis(c[0], nh);
        let (d0, d1, fd) = axis(c[1], nd);
        let (p0, p1, fp) = axis(c[2], np);
        let mut out = [(0usize, 0.0); 8];
        let mut k = 0;
        for (h, wh) in [(h0, 1.0 - fh), (h1, fh)] {
            for (d, wd) in [(d0, 1.0 - fd), (d1, fd)] {
                for (p, wp) in [(p0, 1.0 - fp), (p1, fp)] {
                    out[k] = (self.cell(h, d, p), wh * wd * wp);
                    k += 1;
                }
            }
        }
        out
    }
}

/// f_r from a mapped value at a configuration: (eˣ − ε)/(cos θi cos θo), at least 0.
#[inline]
pub fn unmap(x: f64, g: &Geometry) -> f64 {
    let w = g.nl * g.ne;
    if w <= 0.0 {
        return 0.0;
    }
    ((x.exp() - EPSILON) / w).max(0.0)
}

/// The mapped value ln(f_r cos θi cos θo + ε) of f_r at a configuration.
#[inline]
pub fn map(f: f64, g: &Geometry) -> f64 {
    (f.max(0.0) * (g.nl * g.ne).max(0.0) + EPSILON).ln()
}

/// Continuous table coordinates in [0, 1]³ of one light/eye configuration: √(θh/90°),
/// θd/90°, folded φd/90°. From the cosines alone: cos θh = N·H, cos θd = L·H, and
/// N·L = cos θh cos θd − sin θh sin θd cos φd gives |cos φd|.
#[inline]
pub fn coordinates(g: &Geometry) -> [f64; 3] {
    let th = g.nh.clamp(-1.0, 1.0).acos();
    let td = g.eh.clamp(-1.0, 1.0).acos();
    let (sh, sd) = (th.sin(), td.sin());
    let den = sh * sd;
    let cos_pd = if den > 1e-12 {
        ((g.nh * g.eh - g.nl) / den).abs().min(1.0)
    } else {
        1.0
    };
    [
        (th / FRAC_PI_2).sqrt().min(1.0),
        (td / FRAC_PI_2).min(1.0),
        cos_pd.acos() / FRAC_PI_2,
    ]
}

/// The configuration at the centre of cell (ih, id, ip) of a table of size `dims`.
pub fn cell_geometry(dims: [usize; 3], ih: usize, id: usize, ip: usize) -> Geometry {
    let a = cell_angles(dims, ih, id, ip);
    Geometry::from_angles(a[0], a[1], a[2], a[3])
}

/// The angles (θi, φi, θo, φo) at the centre of cell (ih, id, ip).
pub fn cell_angles(dims: [usize; 3], ih: usize, id: usize, ip: usize) -> [f64; 4] {
    let u = (ih as f64 + 0.5) / dims[0] as f64;
    let th = u * u * FRAC_PI_2;
    let td = (id as f64 + 0.5) / dims[1] as f64 * FRAC_PI_2;
    let pd = (ip as f64 + 0.5) / dims[2] as f64 * FRAC_PI_2;
    crate::data::merl::half_diff_to_std(th, 0.0, td, pd)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::nbrdf::{Nbrdf, load_all};
    use std::sync::Arc;

    fn nets() -> Vec<Nbrdf> {
        load_all(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/nbrdf/weights-merl8.json"),
        )
        .unwrap()
    }

    fn small(exclude: &[&str]) -> Prior {
        let opts = BuildOptions {
            dims: [16, 8, 8],
            exclude: exclude.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        };
        build(&nets(), &opts, &|_, _| {}).unwrap()
    }

    /// The components are orthonormal over the cells (to 10⁻³: the smallest components'
    /// eigenvectors carry the eigensolver's error of about ε λ_max / gap) and their variances
    /// descend.
    #[test]
    fn components_are_orthonormal() {
        let p = small(&[]);
        assert_eq!(p.materials.len(), 8);
        for i in 0..p.components() {
            for j in 0..=i {
                let d: f64 = p
                    .component(i)
                    .iter()
                    .zip(p.component(j))
                    .map(|(a, b)| *a as f64 * *b as f64)
                    .sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-3, "{i}·{j} = {d}");
            }
        }
        assert!(p.variance.windows(2).all(|w| w[0] >= w[1]));
    }

    /// A material inside the prior is its median plus its projection on the components: every
    /// training table lies in their span (each of the 24 tables, 3 channels × 8 networks, is
    /// reproduced within 10⁻³ in ln(f cos θi cos θo + ε) at every cell).
    #[test]
    fn a_material_inside_the_prior_is_reproduced() {
        let p = small(&[]);
        let net = &nets()[2];
        let [nh, nd, np] = p.dims;
        let n = p.cells();
        for ch in 0..3 {
            let mut x = vec![0f64; n];
            for ih in 0..nh {
                for id in 0..nd {
                    for ip in 0..np {
                        let a = cell_angles(p.dims, ih, id, ip);
                        let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
                        let f = if g.visible() {
                            net.eval_symmetric(a)[ch]
                        } else {
                            0.0
                        };
                        x[p.cell(ih, id, ip)] = map(f, &g) - p.median[p.cell(ih, id, ip)] as f64;
                    }
                }
            }
            let c: Vec<f64> = (0..p.components())
                .map(|k| (0..n).map(|i| p.component(k)[i] as f64 * x[i]).sum())
                .collect();
            let worst = (0..n)
                .map(|i| {
                    let y: f64 = (0..c.len()).map(|k| c[k] * p.component(k)[i] as f64).sum();
                    (y - x[i]).abs()
                })
                .fold(0.0, f64::max);
            assert!(worst < 1e-3, "channel {ch}: {worst}");
        }
    }

    /// Samples of a BRDF that is the prior's median plus known coefficients on its first
    /// components are reconstructed with those coefficients, and the posterior mean returns
    /// the samples' values.
    #[test]
    fn posterior_recovers_known_coefficients() {
        let p = Arc::new(small(&[]));
        let truth: Vec<f64> = (0..4)
            .map(|k| [1.5, -0.8, 0.4, 0.2][k] * p.variance[k].sqrt())
            .collect();
        let post0 = Posterior::condition(
            p.clone(),
            &crate::data::Dataset::new(crate::data::Quantity::Brdf, vec![("v".into(), None)]),
            &PosteriorOptions::default(),
        );
        assert!(post0.is_none(), "no samples, no posterior");
        // The truth as a posterior with given coefficients (its table is the same sum).
        let mut ds =
            crate::data::Dataset::new(crate::data::Quantity::Brdf, vec![("v".into(), None)]);
        let mut probe = None;
        for ti in (5..=75).step_by(10) {
            for to in (0..=80).step_by(4) {
                for po in (0..360).step_by(20) {
                    let a = [ti, 0, to, po].map(|d| (d as f64).to_radians());
                    let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
                    let x: f64 = p
                        .corners(&g)
                        .iter()
                        .map(|&(c, w)| {
                            w * (p.median[c] as f64
                                + (0..4)
                                    .map(|k| truth[k] * p.component(k)[c] as f64)
                                    .sum::<f64>())
                        })
                        .sum();
                    ds.push(a, &[unmap(x, &g)]);
                    probe.get_or_insert((g, unmap(x, &g)));
                }
            }
        }
        let post = Posterior::condition(p.clone(), &ds, &PosteriorOptions::default()).unwrap();
        for k in 0..4 {
            let err = (post.coef[k] - truth[k]).abs() / p.variance[k].sqrt();
            assert!(
                err < 0.05,
                "coefficient {k}: {} against {}",
                post.coef[k],
                truth[k]
            );
        }
        let (g, y) = probe.unwrap();
        assert!((post.brdf(&g) - y).abs() < 0.02 * y + 1e-6);
    }

    /// A prior survives its file, and a damaged file is refused with the fix.
    #[test]
    fn file_round_trip_and_damage() {
        let p = small(&["steel"]);
        assert!(!p.materials.iter().any(|m| m.ends_with("steel")));
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("p.prior");
        save(&p, &f).unwrap();
        assert_eq!(load(&f).unwrap(), p);
        let bytes = std::fs::read(&f).unwrap();
        std::fs::write(&f, &bytes[..bytes.len() - 3]).unwrap();
        let e = load(&f).unwrap_err().to_string();
        assert!(
            e.contains("bytes of values") && e.contains("brdfit prior build"),
            "{e}"
        );
        std::fs::write(&f, b"hello").unwrap();
        assert!(
            load(&f)
                .unwrap_err()
                .to_string()
                .contains("not a brdfit prior")
        );
    }
}

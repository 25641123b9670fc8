//! Synthetic samples from a model or a Neural-BRDF network: sampling grids and seeded
//! multiplicative noise.

use crate::data::nbrdf::Nbrdf;
use crate::data::{Dataset, Quantity};
use crate::model::{Geometry, Model};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution as _, StandardNormal};
use std::f64::consts::PI;

/// Where to place samples.
#[derive(Clone, Debug, PartialEq)]
pub enum Grid {
    /// `n` seeded random configurations, light and eye uniform in solid angle over the
    /// hemisphere up to θ = 88°, φi = 0.
    Hemisphere(usize),
    /// The plane of incidence for each listed θi (degrees): θo = 0…89° in 1° steps on both
    /// sides (φo = 0° and 180°), θo = 0 once.
    Plane(Vec<f64>),
    /// A goniometer's grid, that of the Neural-BRDF tables (github.com/asztr/Neural-BRDF) and
    /// of RGL's material database: θi = 10…80° in 10° steps, φi = 0, θo = 0…85° in 1° steps,
    /// φo = 0…345° in 15° steps (16,512 configurations, θi slowest, φo fastest).
    Goniometer,
    /// The cell centres of a MERL 90 × 90 × 180 table (Matusik et al. 2003; see
    /// [`crate::data::merl`]) whose light and eye are both above the horizon, in cell order.
    Merl,
    /// Configurations listed by a file (θi, φi, θo, φo in radians), in its order: a plan of
    /// `brdfit plan`, or any brdfit CSV's angle columns.
    Listed(Vec<[f64; 4]>),
}

/// Most samples `hemisphere:N` draws: 1,000,000 (about 0.1 GB of memory and an 80 MB CSV,
/// more than the 64 MB a data file may have without `--max-input-mb`).
pub const MAX_HEMISPHERE: usize = 1_000_000;

impl Grid {
    /// Parse `hemisphere:N`, `plane:θ1,θ2,…` (degrees), `goniometer` or `merl`.
    pub fn parse(s: &str) -> Result<Grid, String> {
        let fix = "use hemisphere:N (N samples), plane:30,70 (θi in degrees), goniometer or merl";
        match s.trim() {
            "goniometer" => return Ok(Grid::Goniometer),
            "merl" => return Ok(Grid::Merl),
            _ => {}
        }
        let (kind, arg) = s
            .split_once(':')
            .ok_or_else(|| format!("bad grid '{s}': {fix}"))?;
        match kind {
            "hemisphere" => arg
                .trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| n > 0 && n <= MAX_HEMISPHERE)
                .map(Grid::Hemisphere)
                .ok_or_else(|| {
                    format!(
                        "bad sample count '{arg}' (1 to {MAX_HEMISPHERE}: a CSV of about 80 MB; for more, write several files with different seeds): {fix}"
                    )
                }),
            "plane" => {
                let t: Result<Vec<f64>, _> =
                    arg.split(',').map(|x| x.trim().parse::<f64>()).collect();
                match t {
                    Ok(v) if !v.is_empty() && v.iter().all(|x| (0.0..90.0).contains(x)) => {
                        Ok(Grid::Plane(v))
                    }
                    _ => Err(format!(
                        "bad incidence list '{arg}' (each θi in [0, 90)): {fix}"
                    )),
                }
            }
            _ => Err(format!("unknown grid '{kind}': {fix}")),
        }
    }

    /// The sample directions (θi, φi, θo, φo) in radians, deterministic for a seed.
    pub fn directions(&self, seed: u64) -> Vec<[f64; 4]> {
        match self {
            Grid::Hemisphere(n) => {
                let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
                let cmin = 88f64.to_radians().cos();
                (0..*n)
                    .map(|_| {
                        let ci: f64 = rng.random_range(cmin..=1.0);
                        let co: f64 = rng.random_range(cmin..=1.0);
                        let po: f64 = rng.random_range(0.0..2.0 * PI);
                        [ci.acos(), 0.0, co.acos(), po]
                    })
                    .collect()
            }
            Grid::Plane(tis) => {
                let mut out = Vec::new();
                for &ti in tis {
                    for deg in 0..90 {
                        let t = (deg as f64).to_radians();
                        if deg > 0 {
                            out.push([ti.to_radians(), 0.0, t, 0.0]);
                        }
                        out.push([ti.to_radians(), 0.0, t, PI]);
                    }
                }
                out
            }
            Grid::Goniometer => {
                let mut out = Vec::with_capacity(8 * 86 * 24);
                for ti in (10..=80).step_by(10) {
                    for to in 0..=85 {
                        for po in (0..360).step_by(15) {
                            out.push([ti, 0, to, po].map(|d| (d as f64).to_radians()));
                        }
                    }
                }
                out
            }
            Grid::Merl => (0..crate::data::merl::CELLS)
                .map(crate::data::merl::cell_center)
                .filter(|a| a[0] < 0.5 * PI && a[2] < 0.5 * PI)
                .collect(),
            Grid::Listed(v) => v.clone(),
        }
    }
}

/// Evaluate a Neural-BRDF network on `dirs`: f_r in channels r, g, b; with `symmetric` the
/// network made reciprocal and mirror-symmetric ([`Nbrdf::eval_symmetric`]), the truth for an
/// isotropic model or table.
pub fn simulate_nbrdf(net: &Nbrdf, dirs: &[[f64; 4]], symmetric: bool) -> Dataset {
    let mut ds = Dataset::new(
        Quantity::Brdf,
        vec![("r".into(), None), ("g".into(), None), ("b".into(), None)],
    );
    for a in dirs {
        let f = if symmetric {
            net.eval_symmetric(*a)
        } else {
            net.eval(*a)
        };
        ds.push(*a, &f);
    }
    ds.meta.material = Some(net.name.clone());
    ds
}

/// Evaluate `model` on `dirs` and apply multiplicative Gaussian noise v·(1 + σ ε), ε ~ N(0, 1),
/// from a ChaCha8 stream seeded with `seed`. The result holds f_r in one channel.
pub fn simulate(model: &Model, dirs: &[[f64; 4]], noise: f64, seed: u64) -> Dataset {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut ds = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
    for a in dirs {
        let f = model.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
        let eps: f64 = StandardNormal.sample(&mut rng);
        ds.push(*a, &[f * (1.0 + noise * eps)]);
    }
    ds
}

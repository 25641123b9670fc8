//! The stability study: the share of seeded random starts that reach the global minimum, with
//! and without the global initialisation, across noise levels and sampling patterns; its
//! tables.

use super::speed::{ONCE_STARTS, runs_once};
use crate::fit::lsq::Method;
use crate::fit::{self, FitOptions};
use crate::model::Model;
use crate::simulate::{Grid, simulate};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::fmt::Write;

/// A sampling pattern of the stability study.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Pattern {
    /// Light and eye over the whole hemisphere.
    Hemisphere,
    /// The plane of incidence only, θi = 10…80°.
    Plane,
    /// θi, θo ≤ 45° only.
    Near,
    /// θi, θo ≥ 70° only (grazing).
    Grazing,
}

impl Pattern {
    /// All patterns.
    pub const ALL: [Pattern; 4] = [
        Pattern::Hemisphere,
        Pattern::Plane,
        Pattern::Near,
        Pattern::Grazing,
    ];

    /// Name.
    pub fn name(self) -> &'static str {
        match self {
            Pattern::Hemisphere => "hemisphere",
            Pattern::Plane => "plane of incidence",
            Pattern::Near => "θ ≤ 45°",
            Pattern::Grazing => "grazing θ ≥ 70°",
        }
    }

    /// About `n` sample directions of the pattern (seeded).
    pub fn directions(self, n: usize, seed: u64) -> Vec<[f64; 4]> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut draw = |lo: f64, hi: f64| -> Vec<[f64; 4]> {
            (0..n)
                .map(|_| {
                    let ci: f64 = rng.random_range(hi.to_radians().cos()..=lo.to_radians().cos());
                    let co: f64 = rng.random_range(hi.to_radians().cos()..=lo.to_radians().cos());
                    [
                        ci.acos(),
                        0.0,
                        co.acos(),
                        rng.random_range(0.0..std::f64::consts::TAU),
                    ]
                })
                .collect()
        };
        match self {
            Pattern::Hemisphere => draw(0.0, 88.0),
            Pattern::Near => draw(0.0, 45.0),
            Pattern::Grazing => draw(70.0, 88.0),
            Pattern::Plane => {
                Grid::Plane((1..=8).map(|k| 10.0 * k as f64).collect()).directions(seed)
            }
        }
    }
}

/// One cell of the stability table.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StabilityRow {
    /// Relative noise σ.
    pub noise: f64,
    /// Sampling pattern.
    pub pattern: Pattern,
    /// Method.
    pub method: Method,
    /// Global initialisation on.
    pub global: bool,
    /// Starts that reached the global minimum.
    pub hits: usize,
    /// Starts run.
    pub starts: usize,
    /// Starts that ended in an error or a non-finite cost.
    pub failures: usize,
    /// Starts that converged (a tolerance test stopped them) at a higher cost: a wrong basin.
    pub wrong_basin: usize,
    /// Starts stopped by an iteration, evaluation or damping limit at a higher cost.
    pub stalled: usize,
    /// Starts that ended on a bound of the admissible box at a higher cost.
    pub at_bound: usize,
}

/// One column of a configuration: method, global initialisation, and each start's final
/// cost with how it ended.
type Run = (Method, bool, Vec<(f64, Outcome)>);

/// How one start of the stability study ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    Reached,
    WrongBasin,
    Stalled,
    AtBound,
    NonFinite,
}

/// Run the stability study around `reference`: for each noise level and pattern, about
/// `samples` synthetic samples, then `starts` seeded random starts per method with and without the global
/// initialisation. The global minimum of a configuration is the lowest cost any run found;
/// a run reaches it when its cost is within 1e-6 relative (Nelder–Mead's own tolerance) or,
/// for noise-free data whose minimum is 0, within 1e-12 per sample.
pub fn stability(reference: &Model, starts: usize, samples: usize, seed: u64) -> Vec<StabilityRow> {
    stability_with_progress(reference, starts, samples, seed, &|| {})
}

/// The noise levels of the stability study.
const STABILITY_NOISES: [f64; 4] = [0.0, 0.01, 0.05, 0.20];

/// The configurations of the stability study: each noise level × each sampling pattern.
pub const STABILITY_CONFIGURATIONS: usize = STABILITY_NOISES.len() * Pattern::ALL.len();

/// [`stability`], calling `progress` after each of the [`STABILITY_CONFIGURATIONS`]
/// configurations.
///
/// A fit with the global initialisation refines the grid's candidates and the start and keeps
/// the lowest cost (the grid's on a tie: its candidates come first). The candidates do not
/// depend on the start, so on at most [`fit::problem::SUBSAMPLE_ROWS`] samples (no subsample
/// in between) the grid's best is fitted once per configuration and method, and each start's
/// global end is the better of it and that start's local end: the same table for a fifth of
/// the fits (with 16 starts).
pub fn stability_with_progress(
    reference: &Model,
    starts: usize,
    samples: usize,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Vec<StabilityRow> {
    stability_runs(reference, starts, samples, seed, progress, true)
}

/// [`stability_with_progress`]; `share` false fits every global start on its own (to check
/// that sharing the grid's fit changes nothing).
fn stability_runs(
    reference: &Model,
    starts: usize,
    samples: usize,
    seed: u64,
    progress: &(dyn Fn() + Sync),
    share: bool,
) -> Vec<StabilityRow> {
    let noises = STABILITY_NOISES;
    let configs: Vec<(f64, Pattern)> = noises
        .iter()
        .flat_map(|&n| Pattern::ALL.iter().map(move |&p| (n, p)))
        .collect();
    configs
        .par_iter()
        .enumerate()
        .flat_map(|(ci, &(noise, pattern))| {
            let dirs = pattern.directions(samples.max(10), seed + ci as u64);
            let ds = simulate(reference, &dirs, noise, seed + 100 + ci as u64);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 1000 + ci as u64);
            // Random starts from the model's declared ranges (any model, not only
            // Torrance–Sparrow).
            let specs = reference.specs();
            let start_points: Vec<Vec<(String, f64)>> = (0..starts)
                .map(|_| {
                    specs
                        .iter()
                        .map(|s| (s.name.to_string(), s.random_value(&mut rng)))
                        .collect()
                })
                .collect();
            let mut runs: Vec<Run> = Vec::new();
            for method in Method::ALL {
                let starts = if runs_once(method) {
                    starts.min(ONCE_STARTS)
                } else {
                    starts
                };
                let fit_one = |global: bool, start: Option<&Vec<(String, f64)>>| {
                    let mut o = FitOptions::new(reference.kind);
                    o.dist = reference.dist;
                    o.method = method;
                    o.local_only = !global;
                    o.start = start.cloned().unwrap_or_default();
                    o.profile = false;
                    // The solvers are compared on the least-squares problem, as scipy solves it: the
                    // energy constraint's second solve is no solver's work.
                    o.conserve = false;
                    match fit::fit(&ds, &o) {
                        Ok(f) if f[0].cost.is_finite() => {
                            let f = &f[0];
                            let how = if !f.at_bound.is_empty()
                                || f.termination.contains("left the bounds")
                            {
                                Outcome::AtBound
                            } else if f.termination.contains("limit") {
                                Outcome::Stalled
                            } else {
                                Outcome::WrongBasin
                            };
                            (f.cost, how)
                        }
                        _ => (f64::INFINITY, Outcome::NonFinite),
                    }
                };
                let local: Vec<(f64, Outcome)> = start_points[..starts]
                    .iter()
                    .map(|s| fit_one(false, Some(s)))
                    .collect();
                let global: Vec<(f64, Outcome)> =
                    if share && ds.len() <= fit::problem::SUBSAMPLE_ROWS {
                        let grid = fit_one(true, None);
                        local
                            .iter()
                            .map(|l| if l.0 < grid.0 { *l } else { grid })
                            .collect()
                    } else {
                        start_points[..starts]
                            .iter()
                            .map(|s| fit_one(true, Some(s)))
                            .collect()
                    };
                runs.push((method, true, global));
                runs.push((method, false, local));
            }
            let best = runs
                .iter()
                .flat_map(|r| r.2.iter().map(|e| e.0))
                .fold(f64::INFINITY, f64::min);
            progress();
            // Within 1e-6 relative, or (noise-free data, cost ≈ 0) within an absolute 1e-12
            // per sample of the best.
            let tol = 1e-6 * best.abs() + 1e-12 * ds.len() as f64;
            runs.into_iter()
                .map(|(method, global, ends)| {
                    let outcome = |e: &(f64, Outcome)| {
                        if e.1 != Outcome::NonFinite && e.0 - best <= tol {
                            Outcome::Reached
                        } else {
                            e.1
                        }
                    };
                    let count = |o: Outcome| ends.iter().filter(|e| outcome(e) == o).count();
                    StabilityRow {
                        noise,
                        pattern,
                        method,
                        global,
                        hits: count(Outcome::Reached),
                        starts: ends.len(),
                        failures: count(Outcome::NonFinite),
                        wrong_basin: count(Outcome::WrongBasin),
                        stalled: count(Outcome::Stalled),
                        at_bound: count(Outcome::AtBound),
                    }
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The configurations of the study's rows, in their first-seen order.
pub(super) fn configurations(rows: &[StabilityRow]) -> Vec<(f64, Pattern)> {
    let mut configs: Vec<(f64, Pattern)> = Vec::new();
    for r in rows {
        if !configs.contains(&(r.noise, r.pattern)) {
            configs.push((r.noise, r.pattern));
        }
    }
    configs
}

/// The row of one configuration, method and initialisation, if the study ran it.
pub(super) fn stability_row(
    rows: &[StabilityRow],
    (noise, pattern): (f64, Pattern),
    method: Method,
    global: bool,
) -> Option<&StabilityRow> {
    rows.iter().find(|r| {
        r.noise == noise && r.pattern == pattern && r.method == method && r.global == global
    })
}

/// What a cell of the Markdown stability table holds.
pub const STABILITY_CELLS: &str = "Each cell: starts reaching the global minimum with the global initialisation · from the random start alone. argmin's particle swarm, which spends its evaluation budget before it converges, runs one start per configuration.";

/// Markdown and CSV tables of the stability study: one Markdown row per configuration, one
/// column per method, each cell the hits with the global initialisation · from the random
/// start alone; one CSV row per configuration, method and initialisation.
pub fn stability_tables(rows: &[StabilityRow]) -> (String, String) {
    let mut md = String::from("| # | noise | sampling |");
    for m in Method::ALL {
        let _ = write!(md, " {} |", m.name());
    }
    md.push_str("\n|---:|---:|---|");
    md.push_str(&"---:|".repeat(Method::ALL.len()));
    md.push('\n');
    let mut csv = String::from(
        "config,noise,pattern,method,global_init,hits,starts,failures,wrong_basin,stalled,at_bound\n",
    );
    let configs = configurations(rows);
    for r in rows {
        let k = configs
            .iter()
            .position(|c| *c == (r.noise, r.pattern))
            .unwrap_or(0)
            + 1;
        let _ = writeln!(
            csv,
            "{k},{},{},{},{},{},{},{},{},{},{}",
            r.noise,
            r.pattern.name(),
            r.method.name(),
            r.global,
            r.hits,
            r.starts,
            r.failures,
            r.wrong_basin,
            r.stalled,
            r.at_bound
        );
    }
    for (k, &config) in configs.iter().enumerate() {
        let cell = |g: bool, m: Method| {
            stability_row(rows, config, m, g)
                .map_or("–".into(), |r| format!("{}/{}", r.hits, r.starts))
        };
        let _ = write!(
            md,
            "| {} | {:.0} % | {} |",
            k + 1,
            config.0 * 100.0,
            config.1.name()
        );
        for m in Method::ALL {
            let _ = write!(md, " {} · {} |", cell(true, m), cell(false, m));
        }
        md.push('\n');
    }
    (md, csv)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stability table with the grid's fit shared across starts equals the table with
    /// every global start fitted on its own (each a whole `fit` with the start and the grid),
    /// and the starts were not all alike (some global starts end better than their local run).
    #[test]
    fn sharing_the_grid_across_starts_changes_no_cell() {
        let reference = Model::blinn_mgo();
        let shared = stability_runs(&reference, 3, 300, 5, &|| {}, true);
        let own = stability_runs(&reference, 3, 300, 5, &|| {}, false);
        assert_eq!(shared, own);
        let hits = |g: bool| -> usize {
            shared
                .iter()
                .filter(|r| r.global == g)
                .map(|r| r.hits)
                .sum()
        };
        assert!(
            hits(true) > hits(false),
            "{} vs {}",
            hits(true),
            hits(false)
        );
    }
}

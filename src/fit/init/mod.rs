//! Stage 2 of a fit: the global initialisation by variable projection over a grid of the
//! nonlinear parameters, with the linear parameters solved at each grid point.

#[cfg(test)]
mod fixtures;
mod grid;
mod linear;
mod nnls;
mod score;
mod tables;
mod two_lobe;

use super::options::FitOptions;
use super::problem::{BrdfProblem, Slot};
use crate::model::{ModelKind, ParamSpec, Role};
use grid::{COARSE_ABOVE, grid_minima, search_grid};
use score::Scorer;
use two_lobe::two_lobe_prescreen;

/// Gauss–Newton steps on the linear coefficients at the grid points that are refined.
pub(super) const LINEAR_STEPS: usize = 3;

/// Grid points whose (ps, pd) are refined in the declared loss: the best this many by the
/// first score, and as many of the grid's local minima.
pub(super) const REFINED_POINTS: usize = 8;

/// Rows per channel the global initialisation scores its grid on.
pub(super) const INIT_ROWS: usize = 500;

/// How many candidates of distinct basins the global initialisation hands to the local method.
pub(super) const CANDIDATES: usize = 4;

/// A grid minimum whose score is more than this many times the best minimum's is not handed
/// to the local method: its basin ends far above the best. Measured on the 14 bundled and
/// test files and the scipy benchmark's 10,000 synthetic samples, 9 models each (2,484
/// searches, 3,265 candidates after the first): no candidate scored above 15.2 times the
/// best ended within [`super::solve::CONTENDER_RATIO`] of the best cost (the only ones the
/// polish considers), so 30 leaves a factor of 2. It drops 192 of them (2,961 local
/// iterations) and no fit of those files changes. The one it drops on the synthetic
/// dielectric (n = 1.8) is the metal basin at the top of n's grid (F ≈ 1), 45 times the
/// best, 12 iterations where the best basin takes 3.
pub(super) const FAR_BASIN: f64 = 30.0;

/// Grid points scored in one batch below which the batch runs on the calling thread.
pub(super) const PARALLEL_POINTS: usize = 32;

/// Variable projection over a grid of the nonlinear parameters that spans each one's whole
/// admissible range ([`crate::model::ParamSpec::grid`]): at each grid point the free linear
/// parameters of each channel (every lobe's ps, and pd) come from a weighted non-negative
/// linear least-squares solve ([`nnls::nnls`]; weights that linearise the loss at the data); each
/// point is then scored on the *declared* loss at those values, so a basin ranks by the cost
/// the fit minimises, not by its linearisation. (One lobe with one shape parameter and n
/// free on one channel, Torrance–Sparrow D1–D3 or GGX–Smith: the search visits the grid by
/// the linearised cost, [`linear::linearised_cost`], and only the points it then refines are scored
/// on the declared loss, from which the candidates come; on every bundled file the same
/// minima.) The grid's local minima (distinct basins) are
/// returned best first, at most [`CANDIDATES`] and none scored above [`FAR_BASIN`] times the
/// best, as solver variables. The grid is scored on a subsample of `full`'s rows
/// ([`INIT_ROWS`] per channel; `full` may itself be the local stage's subsample, whose
/// largest values are those of every row).
pub(super) fn global_init(
    full: &BrdfProblem,
    specs: &[&ParamSpec],
    opts: &FitOptions,
) -> Vec<Vec<f64>> {
    let s = Scorer::new(full, specs, opts, INIT_ROWS);
    let dims = &s.dims;
    // Two lobes of the same form with both coefficients free: the point (α1, α2) is the point
    // (α2, α1) with the lobes swapped, so only α1 ≤ α2 is scored.
    let strides: Vec<usize> = (0..dims.len())
        .map(|d| dims[d + 1..].iter().product())
        .collect();
    let mirror = mirror_axes(&s, specs);
    let ordered = |i: usize| {
        mirror.is_none_or(|(d1, d2)| (i / strides[d1]) % dims[d1] <= (i / strides[d2]) % dims[d2])
    };
    // Two GGX lobes: the linearised cost of every ordered point comes from its Gram sums with no
    // pass over the rows, and only the best [`two_lobe::TWO_LOBE_KEEP`] of them by it are scored on
    // the declared loss (a pass over the rows each, most of the grid's cost).
    let kept = s
        .two_lobes
        .as_ref()
        .filter(|_| mirror.is_some())
        .map(|t| two_lobe_prescreen(t, &s.p.layout[0], &s.ips, s.ipd, dims, ordered));
    let admissible = |i: usize| ordered(i) && kept.as_ref().is_none_or(|kept| kept[i]);
    // The points the search asks for, scored at the linear solve's (ps, pd) (on the declared
    // loss, an upper bound of its best score; or the linearised cost, `linearised`), then the
    // promising ones with (ps, pd) minimising the declared loss.
    use rayon::prelude::*;
    let mut scored: Vec<(f64, Vec<f64>)> = vec![(f64::INFINITY, Vec::new()); s.points.len()];
    // Two lobes: the whole (half) grid, as a lobe a coarse step narrower than its neighbours
    // can carry the basin (vch_golden_yellow b: α1 0.0076 with ps1 9e-4 beside α2 0.12, which
    // coarse to fine missed by 2 %).
    let coarse_above = if mirror.is_some() {
        usize::MAX
    } else {
        COARSE_ABOVE
    };
    let (first, found) = search_grid(dims, coarse_above, admissible, |idx| {
        // A batch of a few points (a box of the fine search) is not worth waking the pool.
        let sc: Vec<(f64, Vec<f64>)> = if idx.len() >= PARALLEL_POINTS {
            idx.par_iter().map(|&i| s.score_point(i, 0)).collect()
        } else {
            idx.iter().map(|&i| s.score_point(i, 0)).collect()
        };
        let out = sc.iter().map(|s| s.0).collect();
        for (&i, s) in idx.iter().zip(sc) {
            scored[i] = s;
        }
        out
    });
    // The grid's local minima by `scores`, best first: searched coarse to fine, those found.
    let minima = |scores: &[f64], limit: usize| match &found {
        None => grid_minima(scores, dims, limit),
        Some(found) => {
            let mut m = found.clone();
            m.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]).then(a.cmp(&b)));
            m.truncate(limit);
            m
        }
    };
    let mut refine = minima(&first, REFINED_POINTS);
    let mut order: Vec<usize> = (0..first.len()).filter(|&i| first[i].is_finite()).collect();
    order.sort_by(|&a, &b| first[a].total_cmp(&first[b]).then(a.cmp(&b)));
    refine.extend(order.into_iter().take(REFINED_POINTS));
    refine.sort_unstable();
    refine.dedup();
    let better: Vec<(usize, (f64, Vec<f64>))> = refine
        .par_iter()
        .map(|&i| (i, s.score_point(i, LINEAR_STEPS)))
        .collect();
    // Searched by the linearised cost: only the refined points carry the declared loss.
    if s.linearised {
        for s in &mut scored {
            s.0 = f64::INFINITY;
        }
    }
    for (i, s) in better {
        if s.0 <= scored[i].0 {
            scored[i] = s;
        }
    }
    let scores: Vec<f64> = scored.iter().map(|s| s.0).collect();
    let found = minima(&scores, CANDIDATES);
    let best = found.first().map_or(f64::INFINITY, |&i| scores[i]);
    found
        .into_iter()
        .filter(|&i| scores[i] <= FAR_BASIN * best)
        .map(|i| scored[i].1.clone())
        .collect()
}

/// The two shape axes of a grid whose points come in mirror pairs: two lobes of the same form
/// (GGX–Smith's two) on the same grid with both coefficients free on every channel, where the
/// point (α1, α2) is the point (α2, α1) with the lobes swapped; `None` for any other grid.
fn mirror_axes(s: &Scorer, specs: &[&ParamSpec]) -> Option<(usize, usize)> {
    let (nonlinear, ips) = (&s.nonlinear, &s.ips);
    (s.opts.kind == ModelKind::GgxSmith2)
        .then(|| {
            let axes: Vec<usize> = (0..nonlinear.len())
                .filter(|&d| specs[nonlinear[d].0].role == Role::Shape)
                .collect();
            let both_free =
                s.p.layout
                    .iter()
                    .all(|slots| ips.iter().all(|&i| matches!(slots[i], Slot::Free(_))));
            (axes.len() == 2 && both_free && nonlinear[axes[0]].1 == nonlinear[axes[1]].1)
                .then(|| (axes[0], axes[1]))
        })
        .flatten()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::problem;
    use crate::model::Distribution;

    /// A dielectric's lobe (the scipy benchmark's truth n = 1.8, c3 = 0.35, ps = 0.667,
    /// pd = 0.333; 10,000 hemisphere samples, 1 % noise): the grid's second minimum, the metal
    /// basin at the top of n's grid (F ≈ 1 at every angle), is not a candidate; the first,
    /// near the truth, is.
    #[test]
    fn far_basins_are_not_candidates() {
        use crate::model::Model;
        use crate::simulate::{Grid, simulate};
        let truth = [1.8, 0.35, 0.667, 0.333];
        let model = Model::new(ModelKind::TorranceSparrow, Distribution::D3, &truth).unwrap();
        let ds = simulate(&model, &Grid::Hemisphere(10_000).directions(1), 0.01, 1);
        let opts = FitOptions::new(ModelKind::TorranceSparrow);
        let rows = super::super::setup::channel_rows(&ds, 0, &opts);
        let lay = super::super::setup::layout(&[ds.channel_label(0)], &opts);
        let full = super::super::setup::problem(vec![rows], &lay, &opts);
        let work = full.subsample(problem::SUBSAMPLE_ROWS);
        let found = global_init(&work, &lay.specs, &opts);
        assert_eq!(lay.names[0], "n");
        let top = *lay.specs[0].grid_values().last().unwrap();
        let n: Vec<f64> = found
            .iter()
            .map(|x| full.transforms[0].apply(x[0]).0)
            .collect();
        assert!(!n.is_empty() && (n[0] - 1.8).abs() < 0.2, "{n:?}");
        assert!(
            n.iter().all(|&v| v < 0.5 * top),
            "{n:?} (top of the grid {top})"
        );
    }
}

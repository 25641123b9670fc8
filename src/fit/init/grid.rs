//! The grid of the nonlinear parameters and its search: the starting grid's points, its
//! local minima, and the coarse-to-fine search that scores only the points it needs.

use crate::model::ParamSpec;

/// Grids of more points than this (to score) are searched coarse to fine ([`search_grid`]):
/// Torrance–Sparrow's n × c (17 × 19, 323 points), GGX–Smith's α × n, ABC's n × b × c; except
/// two lobes' (ggx-smith-2's half grid α1 ≤ α2, 3,230 points).
pub(super) const COARSE_ABOVE: usize = 256;

/// Local minima of the coarse grid whose neighbourhoods are searched on the full grid.
pub(super) const COARSE_SEEDS: usize = 8;

/// The largest starting grid: beyond it the longest axis keeps every other value
/// ([`grid_points`]). Two shapes and an index (α1 × α2 × n, 19 × 19 × 17) stay whole.
pub(super) const GRID_LIMIT: usize = 8192;

/// The starting grid of the nonlinear free variables: which variables have a grid, the grid
/// sizes, and every grid point (row-major). While the product of their sizes exceeds
/// [`GRID_LIMIT`] (a joint fit with per-channel shape parameters) the longest grid (the first
/// of equals) keeps every other value.
pub(super) fn grid_points(specs: &[&ParamSpec], nfree: usize) -> GridPoints {
    let mut nonlinear: Vec<(usize, Vec<f64>)> = (0..nfree)
        .filter_map(|k| {
            let g = specs[k].grid_values();
            (!g.is_empty()).then_some((k, g))
        })
        .collect();
    // The longest grid is halved first (the first of equals), one at a time.
    while nonlinear.iter().map(|(_, g)| g.len()).product::<usize>() > GRID_LIMIT {
        let longest = (0..nonlinear.len())
            .max_by(|&a, &b| {
                nonlinear[a]
                    .1
                    .len()
                    .cmp(&nonlinear[b].1.len())
                    .then(b.cmp(&a))
            })
            .expect("a product over the limit has a grid");
        let g = &mut nonlinear[longest].1;
        *g = g.iter().step_by(2).copied().collect();
    }
    let dims: Vec<usize> = nonlinear.iter().map(|(_, g)| g.len()).collect();
    let width = nonlinear.len();
    let total: usize = dims.iter().product();
    let mut values = Vec::with_capacity(total * width);
    for i in 0..total {
        // Row-major: the last variable varies fastest.
        let mut rest = i;
        let start = values.len();
        values.resize(start + width, 0.0);
        for (d, (_, g)) in nonlinear.iter().enumerate().rev() {
            values[start + d] = g[rest % dims[d]];
            rest /= dims[d];
        }
    }
    (nonlinear, dims, Points { width, values })
}

/// The points of a grid, row-major, in one buffer (a grid of up to [`GRID_LIMIT`] points
/// allocates once, not once per point).
pub(super) struct Points {
    /// Values per point.
    width: usize,
    /// Every point's values, point after point.
    values: Vec<f64>,
}

impl Points {
    /// The number of points.
    pub(super) fn len(&self) -> usize {
        self.values.len().checked_div(self.width).unwrap_or(1)
    }

    /// Point `i`'s values.
    pub(super) fn get(&self, i: usize) -> &[f64] {
        &self.values[i * self.width..(i + 1) * self.width]
    }
}

/// Gridded variables with their values, the grid sizes, and the grid points.
pub(super) type GridPoints = (Vec<(usize, Vec<f64>)>, Vec<usize>, Points);

/// The local minima of a score tabulated on a grid (row-major over `dims`; a point is a
/// minimum when no neighbour along any axis scores lower), best first, at most `limit`; if
/// there are fewer than two, the best other point not next to a kept one is added.
pub(super) fn grid_minima(scores: &[f64], dims: &[usize], limit: usize) -> Vec<usize> {
    let strides: Vec<usize> = (0..dims.len())
        .map(|d| dims[d + 1..].iter().product())
        .collect();
    let coord = |i: usize, d: usize| (i / strides[d]) % dims[d];
    let neighbours = |i: usize| {
        let mut v = Vec::new();
        for d in 0..dims.len() {
            let c = coord(i, d);
            if c > 0 {
                v.push(i - strides[d]);
            }
            if c + 1 < dims[d] {
                v.push(i + strides[d]);
            }
        }
        v
    };
    let mut order: Vec<usize> = (0..scores.len())
        .filter(|&i| scores[i].is_finite())
        .collect();
    order.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]).then(a.cmp(&b)));
    let is_min = |i: usize| neighbours(i).iter().all(|&j| scores[i] <= scores[j]);
    let mut kept: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&i| is_min(i))
        .take(limit)
        .collect();
    for &i in &order {
        if kept.len() >= limit.min(2) {
            break;
        }
        let near = kept
            .iter()
            .any(|&k| (0..dims.len()).all(|d| coord(i, d).abs_diff(coord(k, d)) <= 1));
        if !near {
            kept.push(i);
        }
    }
    kept
}

/// The points of the box of half-width `radius` (in grid steps, clipped at the edges) around
/// point `i` of a grid (row-major over `dims`), `i` included.
pub(super) fn grid_box(i: usize, radius: usize, dims: &[usize]) -> Vec<usize> {
    let mut out = vec![0usize];
    let mut stride = 1;
    for d in (0..dims.len()).rev() {
        let c = (i / stride) % dims[d];
        let (lo, hi) = (c.saturating_sub(radius), (c + radius).min(dims[d] - 1));
        out = out
            .iter()
            .flat_map(|&o| (lo..=hi).map(move |v| o + v * stride))
            .collect();
        stride *= dims[d];
    }
    out.sort_unstable();
    out
}

/// Search a grid (row-major over `dims`) for its local minima, scoring only the points that
/// `admissible` admits, through `score` (the scores of the points asked, in that order).
/// Up to `coarse_above` admissible points, every one is scored. Beyond, coarse to fine:
/// the coarse grid (every other value of each axis, and its last) is scored; around each of
/// its best [`COARSE_SEEDS`] local minima the box of half-width 2 (one coarse step) is scored
/// on the full grid, and from the box's lowest point a descent scores the box of half-width 1
/// around the current point and moves to its lowest point until the current point is the
/// lowest of its box, a minimum of the full grid. Returns every point's score (+∞ where not
/// scored) and, coarse to fine, the minima found, best first: the descents' ends, then the
/// coarse grid's other local minima (basins not searched further, above every searched one).
pub(super) fn search_grid(
    dims: &[usize],
    coarse_above: usize,
    admissible: impl Fn(usize) -> bool,
    mut score: impl FnMut(&[usize]) -> Vec<f64>,
) -> (Vec<f64>, Option<Vec<usize>>) {
    let total: usize = dims.iter().product();
    let mut scores = vec![f64::INFINITY; total];
    let mut done = vec![false; total];
    let mut run = |idx: Vec<usize>, scores: &mut Vec<f64>, done: &mut Vec<bool>| {
        let idx: Vec<usize> = idx
            .into_iter()
            .filter(|&i| !done[i] && admissible(i))
            .collect();
        for (&i, s) in idx.iter().zip(score(&idx)) {
            scores[i] = s;
            done[i] = true;
        }
    };
    let all: Vec<usize> = (0..total).filter(|&i| admissible(i)).collect();
    if all.len() <= coarse_above {
        run(all, &mut scores, &mut done);
        return (scores, None);
    }
    // The coarse grid: coarse coordinate k is fine coordinate min(2k, last).
    let cdims: Vec<usize> = dims.iter().map(|&n| n / 2 + 1).collect();
    let fine = |ci: usize| {
        let (mut i, mut cs, mut fs) = (0, 1, 1);
        for d in (0..dims.len()).rev() {
            let k = (ci / cs) % cdims[d];
            i += (2 * k).min(dims[d] - 1) * fs;
            cs *= cdims[d];
            fs *= dims[d];
        }
        i
    };
    let coarse: Vec<usize> = (0..cdims.iter().product()).map(fine).collect();
    run(coarse.clone(), &mut scores, &mut done);
    let cscores: Vec<f64> = coarse.iter().map(|&i| scores[i]).collect();
    let minima: Vec<usize> = grid_minima(&cscores, &cdims, usize::MAX)
        .into_iter()
        .map(|ci| coarse[ci])
        .collect();
    let lowest = |b: &[usize], scores: &[f64]| {
        b.iter()
            .copied()
            .min_by(|&p, &q| scores[p].total_cmp(&scores[q]).then(p.cmp(&q)))
    };
    let mut found = Vec::new();
    for &seed in minima.iter().take(COARSE_SEEDS) {
        let b = grid_box(seed, 2, dims);
        run(b.clone(), &mut scores, &mut done);
        let mut at = lowest(&b, &scores).unwrap_or(seed);
        // Bounded: each move goes to a strictly lower point.
        for _ in 0..total {
            let b = grid_box(at, 1, dims);
            run(b.clone(), &mut scores, &mut done);
            let next = lowest(&b, &scores).unwrap_or(at);
            if !(scores[next] < scores[at]) {
                break;
            }
            at = next;
        }
        found.push(at);
    }
    found.sort_by(|&p, &q| scores[p].total_cmp(&scores[q]).then(p.cmp(&q)));
    found.dedup();
    found.extend(minima.iter().skip(COARSE_SEEDS));
    found.retain(|&i| scores[i].is_finite());
    (scores, Some(found))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Distribution, ModelKind};

    /// Two shape parameters and an index (19 × 19 × 17 = 6,137 ≤ 8,192 points) keep the whole
    /// grid; three and an index (116,603) halve the longest axis, the first of equals, one at a
    /// time: 10·19·19·17 = 61,370, 10·10·19·17 = 32,300, 10·10·10·17 = 17,000,
    /// 10·10·10·9 = 9,000, then 5·10·10·9 = 4,500.
    #[test]
    fn two_shapes_and_an_index_keep_the_whole_grid() {
        let specs = ModelKind::TorranceSparrow.params(Distribution::D3);
        let (n, c3) = (&specs[0], &specs[1]);
        let (grids, dims, points) = grid_points(&[c3, c3, n], 3);
        assert_eq!(dims, vec![19, 19, 17]);
        assert_eq!(points.len(), 19 * 19 * 17);
        // Row-major, the last variable fastest: point 1 · 17 + 2 is (c3₀, c3₁, n₂), the
        // last point every grid's last value.
        let (g0, g2) = (&grids[0].1, &grids[2].1);
        assert_eq!(points.get(17 + 2), &[g0[0], g0[1], g2[2]]);
        assert_eq!(points.get(19 * 19 * 17 - 1), &[g0[18], g0[18], g2[16]]);
        let (_, dims, points) = grid_points(&[c3, c3, c3, n], 4);
        assert_eq!(dims, vec![5, 10, 10, 9]);
        assert_eq!(points.len(), 4500);
    }

    /// Hand-worked: on a 3 × 4 grid the box of half-width 1 around (1, 0) is rows 0–2,
    /// columns 0–1; of half-width 2 around (0, 3), rows 0–2, columns 1–3.
    #[test]
    fn grid_box_by_hand() {
        assert_eq!(grid_box(4, 1, &[3, 4]), vec![0, 1, 4, 5, 8, 9]);
        assert_eq!(grid_box(3, 2, &[3, 4]), vec![1, 2, 3, 5, 6, 7, 9, 10, 11]);
        assert_eq!(grid_box(0, 1, &[1]), vec![0]);
    }

    /// Coarse to fine on a 19 × 19 × 17 grid: a broad bowl whose lowest point (5, 11, 7) has
    /// odd coordinates (off the coarse grid), and a narrow deeper well at (13, 3, 9), also odd,
    /// whose coarse neighbours are still lower than the bowl's: both found, the well the
    /// lowest, as the brute-force minimum over every point says; fewer than half the points
    /// scored, none inadmissible (the half i > j below 13), none twice, and every neighbour of
    /// the two minima scored.
    #[test]
    fn coarse_to_fine_finds_the_full_grids_minima() {
        let dims = [19usize, 19, 17];
        let at = |i: usize| [i / (19 * 17), (i / 17) % 19, i % 17];
        let f = |i: usize| {
            let c = at(i).map(|v| v as f64);
            let d2 = |p: [f64; 3]| (0..3).map(|k| (c[k] - p[k]).powi(2)).sum::<f64>();
            10.0 + 0.01 * d2([5.0, 11.0, 7.0]) - 9.0 * (-d2([13.0, 3.0, 9.0]) / 4.0).exp()
        };
        let total: usize = dims.iter().product();
        let admissible = |i: usize| at(i)[0] <= at(i)[1] || at(i)[0] >= 13;
        let mut asked = vec![0usize; total];
        let (scores, minima) = search_grid(&dims, COARSE_ABOVE, admissible, |idx| {
            idx.iter()
                .map(|&i| {
                    asked[i] += 1;
                    f(i)
                })
                .collect()
        });
        let brute = (0..total)
            .filter(|&i| admissible(i))
            .min_by(|&a, &b| f(a).total_cmp(&f(b)))
            .unwrap();
        assert_eq!(at(brute), [13, 3, 9]);
        let minima = minima.expect("searched coarse to fine");
        assert_eq!(minima[0], brute, "{:?}", at(minima[0]));
        assert_eq!(at(minima[1]), [5, 11, 7]);
        for &m in &minima[..2] {
            for j in grid_box(m, 1, &dims) {
                assert!(!admissible(j) || asked[j] == 1, "{:?}", at(j));
            }
        }
        let n: usize = asked.iter().sum();
        assert!(n < total / 2, "{n} of {total} scored");
        assert!((0..total).all(|i| asked[i] <= 1 && (admissible(i) || asked[i] == 0)));
        assert!((0..total).all(|i| (asked[i] == 1) == scores[i].is_finite()));
    }

    /// A small grid is scored whole.
    #[test]
    fn small_grids_are_scored_whole() {
        let (scores, minima) = search_grid(
            &[15, 17],
            COARSE_ABOVE,
            |_| true,
            |idx| vec![1.0; idx.len()],
        );
        assert!(scores.iter().all(|&s| s == 1.0) && minima.is_none());
    }
}

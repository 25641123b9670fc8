//! Two GGX lobes: which points of the α1 × α2 × n grid are worth scoring on the declared
//! loss, judged by the linearised cost from the Gram sums alone.

use super::linear::linear_coefficients;
use super::nnls::{linear_solve, nnls3, positive_solve3};
use super::tables::TwoLobeGram;
use crate::fit::problem::Slot;

/// The share of a two-lobe grid's ordered points (α1 ≤ α2) scored on the declared loss: the
/// best by the linearised cost (see [`two_lobe_prescreen`]). A tenth ends every
/// ggx-smith-2 fit of the bundled files (206 channels) at the cost a quarter gave, to 1e-9;
/// a twentieth ends one (mystique 500 nm) 1.3 % higher.
pub(super) const TWO_LOBE_KEEP: f64 = 0.1;

/// Which points of a two-lobe grid (α1 × α2 × n, row-major; `ordered` the points with
/// α1 ≤ α2) are scored on the declared loss: the best [`TWO_LOBE_KEEP`] of the ordered ones
/// by the linearised cost ½ cᵀGc − hᵀc at the linear solve's coefficients c, from the Gram
/// sums `t` alone (the weights linearise the declared loss at the data, so a basin of the
/// declared cost lies low in it; the quantity the linear solve minimises, up to a constant).
pub(super) fn two_lobe_prescreen(
    t: &TwoLobeGram,
    slots: &[Slot],
    ips: &[usize],
    ipd: usize,
    dims: &[usize],
    ordered: impl Fn(usize) -> bool + Sync,
) -> Vec<bool> {
    let (held, free) = linear_coefficients(slots, ips, ipd);
    let lin = two_lobe_linearised(t, &held, &free, dims, &ordered);
    let total = lin.len();
    let mut finite: Vec<f64> = lin.iter().copied().filter(|v| v.is_finite()).collect();
    let n = ((finite.len() as f64 * TWO_LOBE_KEEP).ceil() as usize).min(finite.len());
    if n == 0 {
        return (0..total).map(&ordered).collect();
    }
    let limit = *finite.select_nth_unstable_by(n - 1, f64::total_cmp).1;
    lin.iter().map(|&v| v <= limit).collect()
}

/// The linearised cost ½ cᵀGc − hᵀc at the linear solve's coefficients c (`held` values
/// where not `free`) at every point of a two-lobe grid (α1 × α2 × n, row-major), from the
/// Gram sums `t`; +∞ where not `ordered` or not finite.
fn two_lobe_linearised(
    t: &TwoLobeGram,
    held: &[f64],
    free: &[bool],
    dims: &[usize],
    ordered: impl Fn(usize) -> bool + Sync,
) -> Vec<f64> {
    let k = held.len();
    let (d1, d2) = (dims[1] * dims[2], dims[2]);
    let total: usize = dims.iter().product();
    // The points in parallel (each value is the same on any number of threads).
    use rayon::prelude::*;
    (0..total)
        .into_par_iter()
        .map(|i| {
            if !ordered(i) {
                return f64::INFINITY;
            }
            let (g, h) = t.gram3(i / d1, (i / d2) % dims[1], i % d2);
            // Every coefficient free: the interior minimum where it is positive (most
            // points), else face by face ([`nnls3`]); some held: the active-set solve.
            let interior = free.iter().all(|&f| f).then(|| positive_solve3(&g, &h));
            let c = match interior {
                Some(Some(c)) => c.to_vec(),
                Some(None) => nnls3(&g, &h).to_vec(),
                None => linear_solve(&g, &h, held, free),
            };
            let mut q = 0.0;
            for a in 0..k {
                q -= h[a] * c[a];
                for b in 0..k {
                    q += 0.5 * c[a] * g[a * k + b] * c[b];
                }
            }
            if q.is_finite() { q } else { f64::INFINITY }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::init::fixtures::spread_rows;
    use crate::fit::init::tables::LobeTables;
    use crate::model::{Distribution, ModelKind};

    /// Data made by a two-lobe model at a grid point (α1 = grid α 3, α2 = grid α 10, n = grid
    /// n 7; ps1 0.5, ps2 0.2, pd/π 0.1) are fitted exactly there: its linearised cost is
    /// the least possible, ½ Σ w (f − f)² − ½ Σ w f² = −½ Σ w f², no point is lower, and the
    /// prescreen keeps it among the ⌈3,230/4⌉ = 808 best ordered points (19·20/2 α pairs ×
    /// 17 n, and any tied with the last), none with α1 > α2.
    #[test]
    fn two_lobe_prescreen_keeps_the_generating_point() {
        let rows = spread_rows();
        let m = rows.len();
        let specs = ModelKind::GgxSmith2.params(Distribution::D3);
        let (alphas, ns) = (specs[0].grid_values(), specs[4].grid_values());
        let (na, nn) = (alphas.len(), ns.len());
        assert_eq!((na, nn), (19, 17));
        let t = LobeTables::new(&rows, &alphas, &ns);
        let (l1, l2, fr) = (
            t.lobe(alphas[3]).unwrap(),
            t.lobe(alphas[10]).unwrap(),
            t.fresnel(ns[7]).unwrap(),
        );
        let f: Vec<f64> = (0..m)
            .map(|r| fr[r] * (0.5 * l1[r] + 0.2 * l2[r]) + 0.1)
            .collect();
        let w: Vec<f64> = (0..m).map(|i| 0.5 + (i % 7) as f64 / 7.0).collect();
        let wf: Vec<f64> = (0..m).map(|i| w[i] * f[i]).collect();
        let g = TwoLobeGram::new(&t, &alphas, &ns, &w, &wf).expect("every value tabulated");
        let dims = [na, na, nn];
        let ordered = |i: usize| i / (na * nn) <= (i / nn) % na;
        let lin = two_lobe_linearised(&g, &[0.0; 3], &[true; 3], &dims, ordered);
        let at = 3 * na * nn + 10 * nn + 7;
        let least = -0.5 * (0..m).map(|r| w[r] * f[r] * f[r]).sum::<f64>();
        assert!(
            (lin[at] - least).abs() <= 1e-9 * least.abs(),
            "{} vs {least}",
            lin[at]
        );
        assert!(lin.iter().all(|&v| v >= least - 1e-9 * least.abs()));
        let slots = [
            Slot::Free(0),
            Slot::Free(1),
            Slot::Free(2),
            Slot::Free(3),
            Slot::Free(4),
            Slot::Free(5),
        ];
        let kept = two_lobe_prescreen(&g, &slots, &[1, 3], 5, &dims, ordered);
        assert!(kept[at]);
        // The best tenth, points tied with its last one included: at least ⌈3,230/10⌉ = 323,
        // and no point kept above one left out.
        let n = kept.iter().filter(|&&k| k).count();
        assert!(n >= 323, "{n} kept");
        assert!((0..kept.len()).all(|i| !kept[i] || ordered(i)));
        let worst_kept = (0..lin.len())
            .filter(|&i| kept[i])
            .map(|i| lin[i])
            .fold(f64::NEG_INFINITY, f64::max);
        let best_left = (0..lin.len())
            .filter(|&i| ordered(i) && !kept[i])
            .map(|i| lin[i])
            .fold(f64::INFINITY, f64::min);
        assert!(worst_kept < best_left, "{worst_kept} ≥ {best_left}");
    }
}

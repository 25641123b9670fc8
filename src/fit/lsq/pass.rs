//! One streaming pass over the residuals: the cost, or the normal equations JᵀWJ and JᵀWr,
//! summed over fixed chunks in chunk order (in parallel where the pass is long enough), so the
//! result is the same bytes whatever the thread count.

use super::problem::{Normal, Problem, Robust};
use rayon::prelude::*;

/// The most residuals in a chunk of a pass.
const CHUNK: usize = 4096;

/// The fewest chunks run in parallel: a MERL table's 16,512 rows and a 10k synthetic set are,
/// a 2,000-row subsample is not (its pass is too short to repay waking the other core).
const PARALLEL_CHUNKS: usize = 2;

/// `f` of every chunk of `m` residuals, in chunk order: in parallel when there are enough
/// chunks to repay waking the thread pool, else on this thread (the same values either way).
/// The chunks are equal (to a residual) and, when several, an even number: rayon halves the
/// list, so two cores take the same share (10,000 rows in four chunks of 2,500, not 4,096,
/// 4,096 and 1,808, of which one core took two). They depend on `m` alone, so every result
/// is the same on any number of threads.
fn map_chunks<T: Send>(m: usize, f: impl Fn(std::ops::Range<usize>) -> T + Sync) -> Vec<T> {
    let n = m.div_ceil(CHUNK);
    let n = if n >= PARALLEL_CHUNKS {
        n.next_multiple_of(2)
    } else {
        n
    };
    let range = |c: usize| c * m / n..(c + 1) * m / n;
    if n < PARALLEL_CHUNKS {
        (0..n).map(range).map(f).collect()
    } else {
        (0..n).into_par_iter().map(|c| f(range(c))).collect()
    }
}

/// Cost Σ ρ(r_i) at `x`; `None` where `x` is inadmissible or the cost is not finite.
pub fn cost<P: Problem>(p: &P, x: &[f64], robust: Robust) -> Option<f64> {
    let prep = p.prepare(x)?;
    let m = p.n_residuals();
    let parts: Vec<f64> = map_chunks(m, |r| p.cost_range(&prep, r, robust));
    let s: f64 = parts.iter().sum();
    s.is_finite().then_some(s)
}

/// Normal equations at `x` in one streaming pass; `None` if anything is not finite.
pub fn normal_equations<P: Problem>(p: &P, x: &[f64], robust: Robust) -> Option<Normal> {
    let prep = p.prepare(x)?;
    let n = p.dim();
    let m = p.n_residuals();
    let parts: Vec<Normal> = map_chunks(m, |r| {
        let mut acc = Normal {
            cost: 0.0,
            jtj: vec![0.0; n * n],
            jtr: vec![0.0; n],
        };
        p.accumulate(&prep, r, robust, &mut acc);
        acc
    });
    let mut out = Normal {
        cost: 0.0,
        jtj: vec![0.0; n * n],
        jtr: vec![0.0; n],
    };
    for part in &parts {
        out.cost += part.cost;
        for k in 0..n * n {
            out.jtj[k] += part.jtj[k];
        }
        for k in 0..n {
            out.jtr[k] += part.jtr[k];
        }
    }
    for a in 0..n {
        for b in 0..a {
            out.jtj[a * n + b] = out.jtj[b * n + a];
        }
    }
    let finite = out.cost.is_finite()
        && out.jtj.iter().all(|v| v.is_finite())
        && out.jtr.iter().all(|v| v.is_finite());
    finite.then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pass's chunks tile the residuals in order, none longer than [`CHUNK`], their lengths
    /// within one of each other, an even number of them once the pass runs in parallel (so
    /// rayon's halving gives two cores equal shares), a lone chunk below two chunks' worth.
    #[test]
    fn chunks_are_equal_and_even() {
        for m in [
            0, 1, 7, 2_000, 4_096, 4_097, 8_192, 10_000, 16_512, 20_000, 1_000_000,
        ] {
            let ranges = map_chunks(m, |r| r);
            let mut next = 0;
            for r in &ranges {
                assert_eq!(r.start, next, "m {m}");
                next = r.end;
            }
            assert_eq!(next, m, "m {m}");
            let lens: Vec<usize> = ranges.iter().map(|r| r.len()).collect();
            let (lo, hi) = (lens.iter().min(), lens.iter().max());
            if let (Some(&lo), Some(&hi)) = (lo, hi) {
                assert!(hi <= CHUNK && hi - lo <= 1, "m {m}: {lens:?}");
            }
            let want = match m {
                0 => 0,
                1..=4_096 => 1,
                _ => m.div_ceil(CHUNK).next_multiple_of(2),
            };
            assert_eq!(ranges.len(), want, "m {m}");
        }
        assert_eq!(map_chunks(10_000, |r| r.len()), vec![2_500; 4]);
    }
}

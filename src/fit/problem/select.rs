//! The indices of a range's largest values, found through block maxima (the rows a
//! subsample keeps).

/// The indices of the `k` largest values of `v` in `range` (ties to the lower index), in no
/// particular order. The k-th largest of the block maxima is a lower bound of the k-th largest
/// value, so only rows of blocks whose maximum reaches it are candidates; among them one
/// selection (linear time) finds the k-th largest value, and the rows above it, then the rows
/// equal to it in index order, are taken. The blocks (16–1,024 rows) are short enough that
/// there are about 4k of them: with fewer blocks than k the bound is void and every row would
/// be a candidate (the 62,500-row subsample of a million rows, k = 6,250, copied and selected
/// all million values). Values are compared as [`total_key`]s, the order of `f64::total_cmp`
/// (NaN and −0 included), so a block's maximum bounds every value in it.
pub(super) fn largest(v: &[f64], range: std::ops::Range<usize>, k: usize) -> Vec<usize> {
    if k == 0 || range.is_empty() {
        return Vec::new();
    }
    let block = (range.len() / (4 * k)).clamp(16, 1024);
    let maxima = block_maxima(&v[range.clone()], block);
    let floor = if maxima.len() > k {
        let mut m = maxima.clone();
        *m.select_nth_unstable_by(k - 1, |a, b| b.cmp(a)).1
    } else {
        i64::MIN
    };
    let mut cand: Vec<usize> = Vec::new();
    for (b, &max) in maxima.iter().enumerate() {
        if max < floor {
            continue;
        }
        let lo = range.start + b * block;
        cand.extend((lo..(lo + block).min(range.end)).filter(|&i| total_key(v[i]) >= floor));
    }
    if cand.len() <= k {
        return cand;
    }
    let keys: Vec<i64> = cand.iter().map(|&i| total_key(v[i])).collect();
    let t = *keys
        .clone()
        .select_nth_unstable_by(k - 1, |a, b| b.cmp(a))
        .1;
    // Every value above t, then the values equal to t by lower index (`cand` is in order).
    let mut out: Vec<usize> = cand
        .iter()
        .zip(&keys)
        .filter_map(|(&i, &key)| (key > t).then_some(i))
        .collect();
    let equal = cand.iter().zip(&keys).filter(|(_, key)| **key == t);
    out.extend(equal.map(|(&i, _)| i).take(k - out.len()));
    out
}

/// `x` as an integer in the order of `f64::total_cmp` (the standard library's own mapping:
/// negative values have their magnitude bits flipped).
#[inline]
fn total_key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ (((b >> 63) as u64) >> 1) as i64
}

/// The largest [`total_key`] of each `block` values of `v`; vectorised (a 64-bit integer
/// maximum), compiled for AVX-512 and AVX2 as well and picked at run time.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn block_maxima(v: &[f64], block: usize) -> Vec<i64> {
    v.chunks(block)
        .map(|c| c.iter().map(|&x| total_key(x)).max().unwrap_or(i64::MIN))
        .collect()
}

#[cfg(test)]
mod tests {
    /// The `k` largest values of a range equal the first `k` of the range sorted by value
    /// (largest first, ties to the lower index), with many ties and with more blocks than `k`
    /// (the block maxima's bound in use; blocks of 16 to 1,024 rows) or fewer.
    #[test]
    fn largest_matches_a_full_sort() {
        for (n, k, levels) in [
            (10_000, 200, 37),
            (10_000, 50, 1_000_000),
            (200_000, 5_000, 1_000_000),
            (200_000, 5_000, 40),
            (300_000, 100, 5_000),
            (5, 9, 3),
            (2_100, 2_100, 7),
        ] {
            // A deterministic scramble of `levels` values: many exact ties when levels is small.
            let v: Vec<f64> = (0..n)
                .map(|i: usize| ((i.wrapping_mul(2_654_435_761) >> 7) % levels) as f64 * 0.25 - 3.0)
                .collect();
            for range in [0..n, n / 3..n - n / 5] {
                let mut want: Vec<usize> = range.clone().collect();
                want.sort_by(|&a, &b| v[b].total_cmp(&v[a]).then(a.cmp(&b)));
                want.truncate(k);
                want.sort_unstable();
                let mut got = super::largest(&v, range.clone(), k);
                got.sort_unstable();
                assert_eq!(got, want, "n {n} k {k} range {range:?}");
            }
        }
        assert!(super::largest(&[1.0, 2.0], 0..2, 0).is_empty());
    }

    /// The same in the order of `f64::total_cmp` with NaN (either sign) and both zeros among
    /// the values: a block whose other values are all below the bound still yields its NaN
    /// (largest of all) and its +0 (above −0), as a full sort does.
    #[test]
    fn largest_orders_nan_and_signed_zeros_as_total_cmp() {
        let n = 20_000;
        let v: Vec<f64> = (0..n)
            .map(|i: usize| match i.wrapping_mul(2_654_435_761) % 997 {
                0 => f64::NAN,
                1 => -f64::NAN,
                2..=40 => 0.0,
                41..=80 => -0.0,
                r => -(r as f64),
            })
            .collect();
        for k in [5, 30, 60, 150, 400] {
            let mut want: Vec<usize> = (0..n).collect();
            want.sort_by(|&a, &b| v[b].total_cmp(&v[a]).then(a.cmp(&b)));
            want.truncate(k);
            want.sort_unstable();
            let mut got = super::largest(&v, 0..n, k);
            got.sort_unstable();
            assert_eq!(got, want, "k {k}");
        }
    }
}

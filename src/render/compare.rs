//! Image error: how far a rendering is from a reference, per pixel and over an object.
//!
//! - ꟻLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"), LDR
//!   version, NVIDIA's implementation ported to Rust ([`super::flip`], the `nv-flip` crate
//!   its test peer), on 8-bit sRGB images as written to PNG, at [`PIXELS_PER_DEGREE`].
//! - ΔE_ITP (ITU-R BT.2124-0, 2019), on linear BT.709 images shown on a display whose white
//!   (linear 1.0) is [`DISPLAY_WHITE_NITS`]; 1 is about one just-noticeable difference.
//! - RMSE of linear radiance.

/// ꟻLIP's viewing condition: 0.7 m from a 0.7 m wide 4K monitor, NVIDIA's default (≈ 67).
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// Luminance (cd/m²) of linear 1.0 on the display assumed by ΔE_ITP: an SDR reference
/// white (ITU-R BT.2035 uses 100 cd/m²). Values above 1 are clipped as a display clips them.
pub const DISPLAY_WHITE_NITS: f64 = 100.0;

pub use super::flip::FlipReference;
use crate::support::lanes::{self, LANES};

/// Per-pixel LDR-ꟻLIP error in [0, 1] between two 8-bit sRGB images (RGB, row-major), at
/// [`PIXELS_PER_DEGREE`]: NVIDIA's numbers ([`super::flip`]), computed around the pixels where
/// the images differ. A reference compared with many images is better prepared once
/// ([`FlipReference::new`]).
pub fn flip(reference: &[u8], test: &[u8], width: u32, height: u32) -> Vec<f32> {
    FlipReference::new(reference, width, height, PIXELS_PER_DEGREE).against(test)
}

/// SMPTE ST 2084 (PQ) inverse EOTF of an absolute luminance in cd/m², as BT.2100 gives it.
pub fn pq(nits: f64) -> f64 {
    let y = (nits / 10_000.0).max(0.0).powf(PQ_M1);
    ((PQ_C1 + PQ_C2 * y) / (1.0 + PQ_C3 * y)).powf(PQ_M2)
}

/// PQ's constants (SMPTE ST 2084; BT.2100 Table 4): m1, m2, c1, c2, c3.
const PQ_M1: f64 = 2610.0 / 16384.0;
const PQ_M2: f64 = 2523.0 / 4096.0 * 128.0;
const PQ_C1: f64 = 3424.0 / 4096.0;
const PQ_C2: f64 = 2413.0 / 4096.0 * 32.0;
const PQ_C3: f64 = 2392.0 / 4096.0 * 32.0;

/// [`pq`] of each lane, each power x^m as e^(m ln x) with the lanes' fdlibm `ln` and `exp`
/// ([`crate::support::lanes`]): within 10⁻¹³ relative of [`pq`], far below the `f32` the error maps
/// keep. Both are that far from the exact curve: the power m2 = 78.84 scales the rounding of
/// its base (a few ulp) by 79, so an ulp's difference in y^m1 moves the two apart.
#[inline(always)]
fn pq_lanes(nits: &[f64; LANES]) -> [f64; LANES] {
    let mut x = nits.map(|v| (v / 10_000.0).max(0.0));
    let ln_y = lanes::ln(&x);
    for l in 0..LANES {
        x[l] = PQ_M1 * ln_y[l];
    }
    let y = lanes::exp(&x);
    for l in 0..LANES {
        x[l] = (PQ_C1 + PQ_C2 * y[l]) / (1.0 + PQ_C3 * y[l]);
    }
    let ln_b = lanes::ln(&x);
    for l in 0..LANES {
        x[l] = PQ_M2 * ln_b[l];
    }
    lanes::exp(&x)
}

/// (I, T, P) of a linear BT.709 colour shown at [`DISPLAY_WHITE_NITS`]: BT.709 → BT.2020
/// (BT.2087), BT.2020 → LMS and ICtCp (BT.2100), T = Ct / 2 (BT.2124). PQ as `pq_lanes`
/// computes it, so a colour has the same ITP alone and in an image.
pub fn itp(rgb709: [f64; 3]) -> [f64; 3] {
    itp_lanes(&[rgb709; LANES])[0]
}

/// [`itp`] of [`LANES`] colours at once (the PQ curve of their L, M and S together), compiled
/// for AVX-512 and AVX2 as well and picked at run time; no fused multiply-adds are formed,
/// so every instruction set gives the same bits.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn itp_lanes(rgb709: &[[f64; 3]; LANES]) -> [[f64; 3]; LANES] {
    let mut lms = [[0.0f64; LANES]; 3];
    for (l, colour) in rgb709.iter().enumerate() {
        let c = colour.map(|v| v.clamp(0.0, 1.0) * DISPLAY_WHITE_NITS);
        let r = 0.6274 * c[0] + 0.3293 * c[1] + 0.0433 * c[2];
        let g = 0.0691 * c[0] + 0.9195 * c[1] + 0.0114 * c[2];
        let b = 0.0164 * c[0] + 0.0880 * c[1] + 0.8956 * c[2];
        lms[0][l] = (1688.0 * r + 2146.0 * g + 262.0 * b) / 4096.0;
        lms[1][l] = (683.0 * r + 2951.0 * g + 462.0 * b) / 4096.0;
        lms[2][l] = (99.0 * r + 309.0 * g + 3688.0 * b) / 4096.0;
    }
    let [l, m, s] = lms.map(|v| pq_lanes(&v));
    std::array::from_fn(|k| {
        [
            0.5 * l[k] + 0.5 * m[k],
            0.5 * (6610.0 * l[k] - 13613.0 * m[k] + 7003.0 * s[k]) / 4096.0,
            (17933.0 * l[k] - 17390.0 * m[k] - 543.0 * s[k]) / 4096.0,
        ]
    })
}

/// For each `i` in `0..n` that `wanted` selects, in order, `put(i, t)` with t the ITP of
/// `colour(i)`, computed [`LANES`] at a time.
fn itp_each(
    n: usize,
    wanted: impl Fn(usize) -> bool,
    colour: impl Fn(usize) -> [f64; 3],
    mut put: impl FnMut(usize, [f64; 3]),
) {
    let mut idx = [0usize; LANES];
    let mut k = 0;
    let mut flush = |idx: &[usize]| {
        let mut c = [[0.0f64; 3]; LANES];
        for (l, &i) in idx.iter().enumerate() {
            c[l] = colour(i);
        }
        let t = itp_lanes(&c);
        for (l, &i) in idx.iter().enumerate() {
            put(i, t[l]);
        }
    };
    for i in (0..n).filter(|&i| wanted(i)) {
        idx[k] = i;
        k += 1;
        if k == LANES {
            flush(&idx);
            k = 0;
        }
    }
    if k > 0 {
        flush(&idx[..k]);
    }
}

/// ΔE_ITP = 720 √(ΔI² + ΔT² + ΔP²) (BT.2124) between two linear BT.709 colours.
pub fn delta_e_itp(a: [f64; 3], b: [f64; 3]) -> f64 {
    itp_distance(itp(a), itp(b))
}

/// 720 √(ΔI² + ΔT² + ΔP²) between two (I, T, P) (BT.2124).
fn itp_distance(p: [f64; 3], q: [f64; 3]) -> f64 {
    720.0 * ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
}

/// Per-pixel ΔE_ITP between two linear images of equal size.
pub fn delta_e_itp_map(reference: &[[f32; 3]], test: &[[f32; 3]]) -> Vec<f32> {
    delta_e_itp_masked(reference, test, &[])
}

/// [`delta_e_itp_map`] where `mask` is true (0 elsewhere; every pixel when `mask` is empty):
/// what [`summarise`] over the same mask reads, at the cost of the masked pixels alone.
pub fn delta_e_itp_masked(reference: &[[f32; 3]], test: &[[f32; 3]], mask: &[bool]) -> Vec<f32> {
    delta_e_itp_against(reference, &itp_masked(reference, mask), test, mask)
}

/// [`itp`] of each pixel of a linear BT.709 image where `mask` is true (every pixel when it
/// is empty; zeros elsewhere): a reference's side of [`delta_e_itp_against`], computed once.
pub fn itp_masked(image: &[[f32; 3]], mask: &[bool]) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0f64; 3]; image.len()];
    itp_each(
        image.len(),
        |i| mask.is_empty() || mask[i],
        |i| image[i].map(f64::from),
        |i, t| out[i] = t,
    );
    out
}

/// [`delta_e_itp_masked`] with the reference's ITP given (`reference_itp` from [`itp_masked`]
/// over the same mask): the same numbers; a pixel equal in both images is 0 without its ITP.
pub fn delta_e_itp_against(
    reference: &[[f32; 3]],
    reference_itp: &[[f64; 3]],
    test: &[[f32; 3]],
    mask: &[bool],
) -> Vec<f32> {
    let n = reference.len().min(reference_itp.len()).min(test.len());
    let mut out = vec![0.0f32; n];
    itp_each(
        n,
        |i| (mask.is_empty() || mask[i]) && reference[i] != test[i],
        |i| test[i].map(f64::from),
        |i, t| out[i] = itp_distance(reference_itp[i], t) as f32,
    );
    out
}

/// Mean, 99th percentile and the share above `level` of `map` over the pixels where `mask`
/// is true (all pixels when `mask` is empty).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Summary {
    /// Mean.
    pub mean: f64,
    /// 99th percentile (nearest rank).
    pub p99: f64,
    /// Share of pixels above the level.
    pub above: f64,
}

/// [`Summary`] of an error map over a mask.
///
/// The values are summed in ascending order; the zeros (most of an error map outside the
/// object) are counted, not sorted: adding 0 changes no sum, so the mean is the same number.
pub fn summarise(map: &[f32], mask: &[bool], level: f64) -> Summary {
    let mut zeros = 0usize;
    let mut nan = false;
    // The nonzero values as keys in f32's total order (sign flips the rest, else the sign
    // bit is set), so an integer sort orders them; equal keys are equal values, so an
    // unstable sort gives the same sequence.
    let mut keys: Vec<u32> = Vec::new();
    for (i, &e) in map.iter().enumerate() {
        if mask.is_empty() || mask[i] {
            if e == 0.0 {
                zeros += 1;
            } else {
                nan |= e.is_nan();
                let b = e.to_bits();
                keys.push(if b >> 31 == 1 { !b } else { b | 1 << 31 });
            }
        }
    }
    let n = keys.len() + zeros;
    if n == 0 {
        return Summary {
            mean: 0.0,
            p99: 0.0,
            above: 0.0,
        };
    }
    let unkey = |k: u32| f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k }) as f64;
    let v: Vec<f64> = if nan {
        // A NaN's payload may change on widening: sort the widened values themselves.
        let mut v: Vec<f64> = keys.into_iter().map(unkey).collect();
        v.sort_by(f64::total_cmp);
        v
    } else {
        // Widening f32 → f64 is exact and keeps the order.
        radix_sort(&mut keys);
        keys.into_iter().map(unkey).collect()
    };
    // In the whole ascending order the zeros stand after the negative values.
    let negative = v.partition_point(|&e| e < 0.0);
    let at = |k: usize| match k {
        k if k < negative => v[k],
        k if k < negative + zeros => 0.0,
        k => v[k - zeros],
    };
    let rank = ((0.99 * n as f64).ceil() as usize).clamp(1, n);
    // A sum starts at −0; one that adds a zero is +0 where it ends at zero (+0 leaves every
    // other sum as it is).
    let sum = v.iter().sum::<f64>() + if zeros > 0 { 0.0 } else { -0.0 };
    Summary {
        mean: sum / n as f64,
        p99: at(rank - 1),
        above: v.iter().filter(|&&e| e > level).count() as f64 / n as f64,
    }
}

/// Sort `keys` ascending by their bytes, least significant first (four stable counting
/// passes; the same order as any sort, in linear time).
fn radix_sort(keys: &mut Vec<u32>) {
    let mut other = vec![0u32; keys.len()];
    for shift in [0, 8, 16, 24] {
        let mut start = [0usize; 257];
        for &k in keys.iter() {
            start[((k >> shift) & 0xff) as usize + 1] += 1;
        }
        for b in 0..256 {
            start[b + 1] += start[b];
        }
        for &k in keys.iter() {
            let b = ((k >> shift) & 0xff) as usize;
            other[start[b]] = k;
            start[b] += 1;
        }
        std::mem::swap(keys, &mut other);
    }
}

/// RMSE of linear radiance (all three channels) over the pixels where `mask` is true.
pub fn rmse(reference: &[[f32; 3]], test: &[[f32; 3]], mask: &[bool]) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for (i, (a, b)) in reference.iter().zip(test).enumerate() {
        if mask.is_empty() || mask[i] {
            s += (0..3).map(|k| ((a[k] - b[k]) as f64).powi(2)).sum::<f64>();
            n += 3;
        }
    }
    (s / n.max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    /// The radix sort orders as the standard library's sort, on keys spread over every byte,
    /// with repeats, and on an empty list.
    #[test]
    fn radix_sort_orders_as_the_standard_sort() {
        let mut x = 12345u32;
        let mut keys: Vec<u32> = (0..5000)
            .map(|i| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                if i % 7 == 0 { 42 } else { x >> (i % 29) }
            })
            .collect();
        let mut want = keys.clone();
        want.sort();
        super::radix_sort(&mut keys);
        assert_eq!(keys, want);
        let mut empty: Vec<u32> = Vec::new();
        super::radix_sort(&mut empty);
        assert!(empty.is_empty());
    }

    use super::*;

    /// Hand-worked from BT.2100 and BT.2124: a grey has L = M = S (the BT.2087 and LMS rows
    /// each sum to 1), so Ct = Cp = 0 (their coefficients sum to 0) and ΔE_ITP = 720 |ΔI| with
    /// I = PQ(Y). PQ(10,000 cd/m²) = ((c1 + c2)/(1 + c3))^m2 = 1 exactly, since c1 + c2 = 1 + c3;
    /// PQ(0) = c1^m2 = (3424/4096)^78.84375 = 7.309e-7.
    #[test]
    fn delta_e_itp_of_greys_by_hand() {
        assert!((pq(10_000.0) - 1.0).abs() < 1e-12);
        let pq0 = (3424.0f64 / 4096.0).powf(78.84375);
        assert!((pq0 - 7.309e-7).abs() < 1e-9, "{pq0}");
        assert!((pq(0.0) - pq0).abs() < 1e-15);
        // BT.2100 Table 4's example: 100 cd/m² encodes to PQ ≈ 0.5081.
        assert!((pq(100.0) - 0.5081).abs() < 1e-4, "{}", pq(100.0));
        // Black against white at 100 cd/m²: 720 (PQ(100) − PQ(0)).
        let d = delta_e_itp([0.0; 3], [1.0; 3]);
        assert!((d - 720.0 * (0.508_078 - pq0)).abs() < 1e-3, "{d}");
        assert_eq!(delta_e_itp([0.3; 3], [0.3; 3]), 0.0);
        // Symmetric.
        let (a, b) = ([0.2, 0.5, 0.1], [0.25, 0.4, 0.3]);
        assert_eq!(delta_e_itp(a, b), delta_e_itp(b, a));
    }

    /// The lanes' PQ (e^(m ln x) with fdlibm's ln and exp) agrees with the powers of `pq`
    /// (libm's `powf`) to 10⁻¹³ relative from 0 to beyond 10,000 cd/m², including 0, the
    /// smallest normal luminance and lanes that mix them.
    #[test]
    fn pq_lanes_match_the_powers() {
        let mut nits: Vec<f64> = vec![0.0, f64::MIN_POSITIVE, 1e-300, 1e-12, 10_000.0, 2e4];
        let mut v = 1e-9;
        while v < 2e4 {
            nits.push(v);
            v *= 1.013_7;
        }
        for chunk in nits.chunks(LANES) {
            let mut x = [0.0; LANES];
            x[..chunk.len()].copy_from_slice(chunk);
            let got = pq_lanes(&x);
            for (l, &n) in chunk.iter().enumerate() {
                let want = pq(n);
                assert!(
                    (got[l] - want).abs() <= 1e-13 * want,
                    "pq({n}): {} against {want}",
                    got[l]
                );
            }
        }
    }

    /// ΔE_ITP against a reference's precomputed ITP is, pixel for pixel, `delta_e_itp` of
    /// the two colours (0 where equal and outside the mask).
    #[test]
    fn delta_e_against_a_precomputed_reference() {
        let reference = [
            [0.2f32, 0.5, 0.1],
            [0.9, 0.9, 0.9],
            [0.0, 0.0, 0.0],
            [1.5, 0.3, 0.7],
        ];
        let test = [
            [0.25f32, 0.4, 0.3],
            [0.9, 0.9, 0.9],
            [0.5, 0.5, 0.5],
            [0.1, 0.2, 0.3],
        ];
        let mask = [true, true, true, false];
        let got = delta_e_itp_masked(&reference, &test, &mask);
        for i in 0..4 {
            let want = if mask[i] {
                delta_e_itp(reference[i].map(f64::from), test[i].map(f64::from)) as f32
            } else {
                0.0
            };
            assert_eq!(got[i], want, "{i}");
        }
        assert!(got[0] > 1.0 && got[1] == 0.0 && got[2] > 1.0);
    }

    /// Mostly zeros (an error map outside the object), with a few negative, positive and
    /// NaN values: the summary of a plain sort (the peer, written out here) to the bit.
    #[test]
    fn summary_of_mostly_zeros_equals_the_sorted_summary() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for n in [1usize, 2, 50, 101, 1000, 5000] {
            let map: Vec<f32> = (0..n)
                .map(|_| match rng.random_range(0..10) {
                    0 => -rng.random::<f32>(),
                    1 | 2 => rng.random::<f32>(),
                    3 if n > 100 => f32::NAN,
                    _ => 0.0,
                })
                .collect();
            let mask: Vec<bool> = (0..n).map(|_| rng.random_range(0..4) > 0).collect();
            for m in [&mask[..], &[][..]] {
                let mut v: Vec<f64> = (0..n)
                    .filter(|&i| m.is_empty() || m[i])
                    .map(|i| map[i] as f64)
                    .collect();
                v.sort_by(f64::total_cmp);
                let got = summarise(&map, m, 0.5);
                if v.is_empty() {
                    assert_eq!(got.p99, 0.0);
                    continue;
                }
                let rank = ((0.99 * v.len() as f64).ceil() as usize).clamp(1, v.len());
                let mean = v.iter().sum::<f64>() / v.len() as f64;
                let above = v.iter().filter(|&&e| e > 0.5).count() as f64 / v.len() as f64;
                assert_eq!(got.p99.to_bits(), v[rank - 1].to_bits(), "n {n}");
                assert_eq!(got.mean.to_bits(), mean.to_bits(), "n {n}");
                assert_eq!(got.above, above);
            }
        }
    }

    #[test]
    fn summary_over_a_mask() {
        let map: Vec<f32> = (0..200).map(|i| i as f32 / 100.0).collect();
        let mask: Vec<bool> = (0..200).map(|i| i >= 100).collect();
        let s = summarise(&map, &mask, 1.5);
        assert!((s.mean - 1.495).abs() < 1e-9);
        assert!((s.p99 - 1.98).abs() < 1e-6, "{s:?}");
        assert!((s.above - 0.49).abs() < 1e-9);
    }
}

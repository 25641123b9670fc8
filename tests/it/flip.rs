//! The Rust LDR-ꟻLIP (`brdfit::render::flip`, a port of NVIDIA's C++ with the reference's
//! side computed once) against its peer, NVIDIA's own implementation through the `nv-flip`
//! crate, pixel for pixel on several image pairs.

use brdfit::render::compare::{FlipReference, PIXELS_PER_DEGREE, flip};
use rand::{Rng, SeedableRng};

/// NVIDIA's LDR-ꟻLIP of two whole images (the peer).
fn nvidia(reference: &[u8], test: &[u8], w: u32, h: u32) -> Vec<f32> {
    let r = nv_flip::FlipImageRgb8::with_data(w, h, reference);
    let t = nv_flip::FlipImageRgb8::with_data(w, h, test);
    nv_flip::flip(r, t, PIXELS_PER_DEGREE).to_vec()
}

/// Random 8-bit images of `w`×`h`: `test` equals `reference` (itself random, not a constant
/// background) except in the pixels `patch` (x0, y0, x1, y1, inclusive).
fn images(w: usize, h: usize, patch: [usize; 4], seed: u64) -> (Vec<u8>, Vec<u8>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let reference: Vec<u8> = (0..3 * w * h).map(|_| rng.random()).collect();
    let mut test = reference.clone();
    for y in patch[1]..=patch[3] {
        for x in patch[0]..=patch[2] {
            for c in 0..3 {
                test[3 * (y * w + x) + c] = rng.random();
            }
        }
    }
    (reference, test)
}

/// A grey sphere-like highlight (smooth, as the renders are): brightness `gain` times a
/// Gaussian bump at (cx, cy) of width `s`, clipped to 255.
fn bump(w: usize, h: usize, c: (f64, f64), s: f64, gain: f64) -> Vec<u8> {
    let mut v = Vec::with_capacity(3 * w * h);
    for y in 0..h {
        for x in 0..w {
            let d2 = (x as f64 - c.0).powi(2) + (y as f64 - c.1).powi(2);
            let g = (gain * (-d2 / (2.0 * s * s)).exp()).min(255.0).round() as u8;
            v.extend([g, g, g]);
        }
    }
    v
}

/// Equal to 1e-6 (NVIDIA's C++ and the port differ by at most an ulp in a few pixels).
fn assert_close(got: &[f32], want: &[f32], what: &str) {
    assert_eq!(got.len(), want.len());
    let mut worst = 0.0f32;
    let mut differ = 0;
    for (a, b) in got.iter().zip(want) {
        worst = worst.max((a - b).abs());
        differ += usize::from(a.to_bits() != b.to_bits());
    }
    assert!(
        want.iter().any(|&e| e > 0.0) || got.iter().all(|&e| e == 0.0),
        "{what}"
    );
    assert!(
        worst <= 1e-6,
        "{what}: largest difference {worst}, {differ} pixels differ"
    );
}

/// Differences in the middle, at a corner, at an edge and in a single pixel of a textured
/// image, the whole image different, and identical images (all 0): NVIDIA's numbers.
#[test]
fn flip_equals_nvidia_on_random_images() {
    let (w, h) = (150usize, 120usize);
    for (k, patch) in [
        [60, 50, 80, 65],
        [0, 0, 4, 3],
        [140, 30, 149, 40],
        [75, 60, 75, 60],
        [0, 0, 149, 119],
    ]
    .into_iter()
    .enumerate()
    {
        let (r, t) = images(w, h, patch, k as u64);
        let want = nvidia(&r, &t, w as u32, h as u32);
        assert!(want.iter().any(|&e| e > 0.0));
        assert_close(
            &flip(&r, &t, w as u32, h as u32),
            &want,
            &format!("patch {patch:?}"),
        );
    }
    let (r, _) = images(w, h, [0, 0, 0, 0], 9);
    let same = flip(&r, &r, w as u32, h as u32);
    assert!(same.iter().all(|&e| e == 0.0));
    assert_eq!(same, nvidia(&r, &r, w as u32, h as u32));
}

/// One prepared reference against several smooth test images (shifted, brighter and
/// narrower highlights, black): each NVIDIA's numbers, as if prepared afresh.
#[test]
fn one_reference_against_many_smooth_images() {
    let (w, h) = (96usize, 80usize);
    let r = bump(w, h, (40.0, 38.0), 12.0, 300.0);
    let prepared = FlipReference::new(&r, w as u32, h as u32, PIXELS_PER_DEGREE);
    for (k, t) in [
        bump(w, h, (42.0, 37.0), 12.0, 300.0),
        bump(w, h, (40.0, 38.0), 12.0, 240.0),
        bump(w, h, (40.0, 38.0), 6.0, 500.0),
        vec![0u8; 3 * w * h],
    ]
    .iter()
    .enumerate()
    {
        let want = nvidia(&r, t, w as u32, h as u32);
        assert!(want.iter().any(|&e| e > 0.1), "case {k}");
        assert_close(&prepared.against(t), &want, &format!("case {k}"));
    }
}

/// Two single-pixel differences at opposite corners of a textured image: the window spans
/// the whole image but most of it lies beyond the filters' reach of either difference, where
/// the error is exactly 0 (not converted); everywhere NVIDIA's numbers.
#[test]
fn sparse_differences_far_apart_give_nvidias_numbers() {
    let (w, h) = (120usize, 100usize);
    let (r, mut t) = images(w, h, [0, 0, 0, 0], 11);
    t.copy_from_slice(&r);
    for (x, y) in [(3usize, 4usize), (112, 93)] {
        let i = 3 * (y * w + x);
        t[i] = r[i].wrapping_add(90);
        t[i + 2] = r[i + 2].wrapping_add(40);
    }
    let want = nvidia(&r, &t, w as u32, h as u32);
    let prepared = FlipReference::new(&r, w as u32, h as u32, PIXELS_PER_DEGREE);
    let got = prepared.against(&t);
    assert_close(&got, &want, "two far differences");
    // Beyond the reach (11 pixels at 67 pixels per degree) of both, NVIDIA's error is 0 too.
    assert_eq!(got[50 * w + 60], 0.0);
    assert_eq!(want[50 * w + 60], 0.0);
    assert!(got[4 * w + 3] > 0.0 && got[93 * w + 112] > 0.0);
}

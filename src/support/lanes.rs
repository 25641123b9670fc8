//! Elementary functions on [`LANES`] numbers at once, written in plain arithmetic and bit
//! operations so the compiler turns each into vector instructions (the fitter's hot loops call
//! them; `f64::ln` and `f64::sin_cos` are library calls the compiler cannot vectorise).
//!
//! Both follow fdlibm (Sun Microsystems, 1993; the algorithms of glibc and musl): `ln` is
//! `__ieee754_log` (< 1 ulp); `sin_cos` is the Cody–Waite reduction by π/2 in three parts with
//! the `__kernel_sin` / `__kernel_cos` polynomials on [−π/4, π/4] (a few ulp for |x| < 2²⁰ π/2).
//! Lanes outside those domains fall back to the standard library, so every input gives the
//! standard answer to within those bounds.

// The polynomial and π/2 constants are fdlibm's, digit for digit as published.
#![allow(clippy::excessive_precision)]

/// Numbers handled together (a multiple of every SIMD width in use: 2, 4 and 8 doubles).
pub const LANES: usize = 8;

/// ln(x) of each lane (fdlibm `__ieee754_log`: x = 2^k m, √½ ≤ m < √2, f = m − 1,
/// s = f/(2 + f), ln m = f − (f²/2 − s(f²/2 + R(s²)))). Lanes that are not finite and
/// normal (≤ 0, subnormal, ∞, NaN) get [`f64::ln`].
#[inline(always)]
pub fn ln(x: &[f64; LANES]) -> [f64; LANES] {
    const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-01;
    const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
    const LG1: f64 = 6.666_666_666_666_735_130e-01;
    const LG2: f64 = 3.999_999_999_940_941_908e-01;
    const LG3: f64 = 2.857_142_874_366_239_149e-01;
    const LG4: f64 = 2.222_219_843_214_978_396e-01;
    const LG5: f64 = 1.818_357_216_161_805_012e-01;
    const LG6: f64 = 1.531_383_769_920_937_332e-01;
    const LG7: f64 = 1.479_819_860_511_658_591e-01;
    // 2^52: adding the exponent bits to its pattern converts an integer without an int→float op.
    const TWO52: f64 = 4_503_599_627_370_496.0;
    let mut out = [0.0f64; LANES];
    let mut bad = false;
    for l in 0..LANES {
        let v = x[l];
        bad |= !(f64::MIN_POSITIVE..f64::INFINITY).contains(&v);
        let bits = v.to_bits();
        let mant = bits & 0x000f_ffff_ffff_ffff;
        // i = 2^52 when the mantissa is ≥ √2: then m is halved and k raised by one.
        let i = (mant + 0x0009_5f64_0000_0000) & 0x0010_0000_0000_0000;
        let m = f64::from_bits(mant | (i ^ 0x3ff0_0000_0000_0000));
        let e = (bits >> 52) + (i >> 52);
        let k = f64::from_bits(e | 0x4330_0000_0000_0000) - (TWO52 + 1023.0);
        let f = m - 1.0;
        let s = f / (2.0 + f);
        let z = s * s;
        let w = z * z;
        let t1 = w * (LG2 + w * (LG4 + w * LG6));
        let t2 = z * (LG1 + w * (LG3 + w * (LG5 + w * LG7)));
        let r = t2 + t1;
        let hfsq = 0.5 * f * f;
        out[l] = k * LN2_HI - ((hfsq - (s * (hfsq + r) + k * LN2_LO)) - f);
    }
    if bad {
        for l in 0..LANES {
            if !(f64::MIN_POSITIVE..f64::INFINITY).contains(&x[l]) {
                out[l] = x[l].ln();
            }
        }
    }
    out
}

/// ln(1 + y) of each lane, for y ≥ 0 (the log loss): ln u with u = 1 + y, plus fdlibm
/// `log1p`'s correction (y − (u − 1))/u for the rounding of u. Returns (ln(1 + y), 1/(1 + y)).
#[inline(always)]
pub fn ln_1p(y: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    let mut u = [0.0f64; LANES];
    for l in 0..LANES {
        u[l] = 1.0 + y[l];
    }
    let mut out = ln(&u);
    let mut iu = [0.0f64; LANES];
    for l in 0..LANES {
        iu[l] = 1.0 / u[l];
        out[l] += (y[l] - (u[l] - 1.0)) * iu[l];
    }
    (out, iu)
}

/// e^x of each lane (fdlibm `__ieee754_exp`: x = k ln2 + r, |r| ≤ ½ ln2, with ln2 in two
/// parts; e^r = 1 + r + r c/(2 − c), c = r − r² P(r²); e^x = 2^k e^r). k is rounded to
/// nearest by adding and subtracting 1.5 · 2^52, whose bit pattern then holds k. Lanes below
/// −746 give 0 (e^x < 2⁻¹⁰⁷⁶, half the least subnormal, rounds to 0: a sharp lobe far from its
/// peak, common in the fitter's kernels, stays on the fast path); other lanes outside
/// [−708, 709] (where 2^k would not be a normal number) or not finite get [`f64::exp`].
#[inline(always)]
pub fn exp(x: &[f64; LANES]) -> [f64; LANES] {
    const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-01;
    const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
    const INV_LN2: f64 = std::f64::consts::LOG2_E;
    const P1: f64 = 1.666_666_666_666_660_190_37e-01;
    const P2: f64 = -2.777_777_777_701_559_338_42e-03;
    const P3: f64 = 6.613_756_321_437_934_361_17e-05;
    const P4: f64 = -1.653_390_220_546_525_153_90e-06;
    const P5: f64 = 4.138_136_797_057_238_460_39e-08;
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let mut out = [0.0f64; LANES];
    let mut bad = false;
    for l in 0..LANES {
        let v = x[l];
        let zero = v < -746.0;
        bad |= !zero && !(-708.0..=709.0).contains(&v);
        // Out-of-range lanes are computed at 0 and replaced below.
        let v = if (-708.0..=709.0).contains(&v) {
            v
        } else {
            0.0
        };
        let t = v * INV_LN2 + SHIFT;
        let kf = t - SHIFT;
        let k = (t.to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64);
        let hi = v - kf * LN2_HI;
        let lo = kf * LN2_LO;
        let r = hi - lo;
        let z = r * r;
        let c = r - z * (P1 + z * (P2 + z * (P3 + z * (P4 + z * P5))));
        let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
        let e = y * f64::from_bits(((k + 1023) as u64) << 52);
        out[l] = if zero { 0.0 } else { e };
    }
    if bad {
        for l in 0..LANES {
            if !(x[l] < -746.0) && !(-708.0..=709.0).contains(&x[l]) {
                out[l] = x[l].exp();
            }
        }
    }
    out
}

/// (sin x, cos x) of each lane: x = jπ/2 + r with a Cody–Waite reduction in three parts, then
/// fdlibm's kernel polynomials for sin r and cos r, and the quadrant j mod 4 picks the signs.
/// Lanes with |x| ≥ 2²⁰ π/2 (or not finite) get [`f64::sin_cos`].
#[inline(always)]
pub fn sin_cos(x: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    const PIO2_1: f64 = 1.570_796_326_734_125_614_17e+00;
    const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
    const PIO2_2T: f64 = 2.022_266_248_795_950_631_54e-21;
    const S1: f64 = -1.666_666_666_666_663_243_48e-01;
    const S2: f64 = 8.333_333_333_322_489_461_24e-03;
    const S3: f64 = -1.984_126_982_985_794_931_34e-04;
    const S4: f64 = 2.755_731_370_707_006_767_89e-06;
    const S5: f64 = -2.505_076_025_340_686_341_24e-08;
    const S6: f64 = 1.589_690_995_211_550_102_21e-10;
    const C1: f64 = 4.166_666_666_666_660_190_37e-02;
    const C2: f64 = -1.388_888_888_887_410_957_49e-03;
    const C3: f64 = 2.480_158_728_947_672_941_97e-05;
    const C4: f64 = -2.755_731_435_139_066_330_35e-07;
    const C5: f64 = 2.087_572_321_298_174_827_90e-09;
    const C6: f64 = -1.135_964_755_778_819_482_76e-11;
    // 1.5·2^52: adding it rounds to an integer, whose low bits are then the quadrant.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    const LIMIT: f64 = 1_647_099.0; // < 2^20 π/2
    let mut s = [0.0f64; LANES];
    let mut c = [0.0f64; LANES];
    let mut bad = false;
    for l in 0..LANES {
        let v = x[l];
        bad |= !(v.abs() < LIMIT);
        let t = v * std::f64::consts::FRAC_2_PI + ROUND;
        let q = t.to_bits() & 3;
        let j = t - ROUND;
        // r = x − j π/2 (fdlibm's second reduction round, good to 118 bits): π/2 in parts of
        // 33 bits, so j·PIO2_1 and j·PIO2_2 are exact for |j| < 2^20.
        let r1 = v - j * PIO2_1;
        let w1 = j * PIO2_2;
        let r2 = r1 - w1;
        let w2 = j * PIO2_2T - ((r1 - r2) - w1);
        let r = r2 - w2;
        let z = r * r;
        let w = z * z;
        // __kernel_sin without the tail: sin r = r + r z (S1 + z (S2 + …)).
        let rs = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
        let sr = r + z * r * (S1 + z * rs);
        // __kernel_cos: cos r = 1 − r²/2 + r⁴ (C1 + …), the subtraction split for accuracy.
        let rc = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
        let hz = 0.5 * z;
        let ww = 1.0 - hz;
        let cr = ww + (((1.0 - ww) - hz) + z * rc);
        // Quadrant q: sin x = (sin r, cos r, −sin r, −cos r)[q], cos x = (cos r, −sin r, …)[q].
        let (a, b) = if q & 1 == 1 { (cr, sr) } else { (sr, cr) };
        s[l] = if q & 2 == 2 { -a } else { a };
        c[l] = if (q + 1) & 2 == 2 { -b } else { b };
    }
    if bad {
        for l in 0..LANES {
            if !(x[l].abs() < LIMIT) {
                (s[l], c[l]) = x[l].sin_cos();
            }
        }
    }
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        (a - b).abs() / (b.abs().max(f64::MIN_POSITIVE) * f64::EPSILON)
    }

    #[test]
    fn ln_matches_the_standard_library() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut worst: f64 = 0.0;
        for _ in 0..20_000 {
            let mut x = [0.0; LANES];
            for v in x.iter_mut() {
                // Log-uniform over 1e-300 … 1e300, plus values right around 1.
                *v = if rng.random_bool(0.3) {
                    1.0 + rng.random_range(-1e-3..1e-3)
                } else {
                    10f64.powf(rng.random_range(-300.0..300.0))
                };
            }
            let y = ln(&x);
            for l in 0..LANES {
                let want = x[l].ln();
                // ulps of the result, or absolute 1 ulp of 1 near x = 1 where ln x → 0.
                let err = ulps(y[l], want).min((y[l] - want).abs() / f64::EPSILON);
                worst = worst.max(err);
            }
        }
        assert!(worst <= 1.0, "worst ln error {worst} ulp");
    }

    #[test]
    fn exp_matches_the_standard_library() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        let mut worst: f64 = 0.0;
        for _ in 0..20_000 {
            let mut x = [0.0; LANES];
            for v in x.iter_mut() {
                // The whole range, plus values near 0 and near the reduction's half-way points.
                *v = match rng.random_range(0..4) {
                    0 => rng.random_range(-750.0..750.0),
                    // Far below the underflow (a sharp lobe away from its peak): exactly 0.
                    3 => -(10f64.powf(rng.random_range(2.8..12.0))),
                    1 => rng.random_range(-1e-6..1e-6),
                    _ => rng.random_range(-40.0..40.0),
                };
            }
            let y = exp(&x);
            for l in 0..LANES {
                worst = worst.max(ulps(y[l], x[l].exp()));
            }
        }
        assert!(worst <= 1.0, "worst exp error {worst} ulp");
        let odd = [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -745.5,
            710.0,
            0.0,
            -0.0,
            1.0,
        ];
        let y = exp(&odd);
        for l in 0..LANES {
            let want = odd[l].exp();
            assert!(
                y[l] == want || (y[l].is_nan() && want.is_nan()) || ulps(y[l], want) <= 1.0,
                "exp({}) = {} not {want}",
                odd[l],
                y[l]
            );
        }
        assert!(ulps(exp(&[1.0; LANES])[0], std::f64::consts::E) <= 1.0);
    }

    #[test]
    fn ln_special_values_fall_back() {
        let x = [
            0.0,
            -1.0,
            f64::INFINITY,
            f64::NAN,
            1e-310,
            1.0,
            2.0,
            f64::MAX,
        ];
        let y = ln(&x);
        for l in 0..LANES {
            let want = x[l].ln();
            assert!(
                y[l] == want || (y[l].is_nan() && want.is_nan()) || ulps(y[l], want) <= 1.0,
                "ln({}) = {} not {}",
                x[l],
                y[l],
                want
            );
        }
    }

    #[test]
    fn ln_1p_matches_the_standard_library() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        for _ in 0..20_000 {
            let mut y = [0.0; LANES];
            for v in y.iter_mut() {
                *v = 10f64.powf(rng.random_range(-20.0..6.0));
            }
            let (got, _) = ln_1p(&y);
            for l in 0..LANES {
                let want = y[l].ln_1p();
                assert!(
                    ulps(got[l], want) <= 2.0,
                    "ln_1p({}) = {} not {}",
                    y[l],
                    got[l],
                    want
                );
            }
        }
    }

    #[test]
    fn sin_cos_match_the_standard_library() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut worst: f64 = 0.0;
        for k in 0..20_000 {
            let mut x = [0.0; LANES];
            for v in x.iter_mut() {
                *v = match k % 3 {
                    0 => rng.random_range(-7.0..7.0),
                    1 => rng.random_range(-1e5..1e5),
                    // Near multiples of π/2, where the reduction cancels.
                    _ => {
                        rng.random_range(-40i32..40) as f64 * std::f64::consts::FRAC_PI_2
                            + rng.random_range(-1e-9..1e-9)
                    }
                };
            }
            let (s, c) = sin_cos(&x);
            for l in 0..LANES {
                let (ws, wc) = x[l].sin_cos();
                // Relative to the larger of |sin|, |cos| (= the function's scale here).
                worst = worst.max((s[l] - ws).abs().max((c[l] - wc).abs()) / f64::EPSILON);
            }
        }
        assert!(worst <= 2.0, "worst sin/cos error {worst} ulp of 1");
        let x = [0.0, -0.0, 1e7, -3e9, f64::INFINITY, f64::NAN, 1e-300, 2.0];
        let (s, c) = sin_cos(&x);
        for l in 0..LANES {
            let (ws, wc) = x[l].sin_cos();
            assert!((s[l] - ws).abs() <= 1e-15 || (s[l].is_nan() && ws.is_nan()));
            assert!((c[l] - wc).abs() <= 1e-15 || (c[l].is_nan() && wc.is_nan()));
        }
    }
}

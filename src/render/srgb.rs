//! The sRGB transfer function, and 8-bit sRGB bytes of a linear image by table lookup.

use super::Image;

/// sRGB transfer function of a linear value in [0, 1].
pub fn srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0 + 0.5) as u8
}

/// 8-bit sRGB bytes of a linear image: [`srgb`] of each channel, looked up instead of
/// computed with a power: the code at the start of the value's bucket (its `f32` bit pattern
/// shifted right by [`SRGB_BUCKET_BITS`]) raised past the steps ([`srgb_steps`]) the value
/// reaches within the bucket. The same bytes as [`srgb`] wherever [`srgb`] never decreases.
pub fn to_srgb8(img: &Image) -> Vec<u8> {
    let (steps, start) = (srgb_steps(), srgb_bucket_codes());
    let code = |v: f32| -> u8 {
        if !(v > 0.0) {
            return 0;
        }
        if v >= 1.0 {
            return 255;
        }
        let mut c = start[(v.to_bits() >> SRGB_BUCKET_BITS) as usize];
        while c < 255 && v >= steps[c as usize] {
            c += 1;
        }
        c
    };
    img.pixels
        .iter()
        .flat_map(|p| [code(p[0]), code(p[1]), code(p[2])])
        .collect()
}

/// Bit patterns of [0, 1) per bucket of [`to_srgb8`]'s table, as a shift (2¹⁴ patterns: the
/// buckets are narrower than the gaps between steps, at most 10⁻³ wide near 1 where codes
/// are 9·10⁻³ apart, so a lookup passes at most one step).
pub const SRGB_BUCKET_BITS: u32 = 14;

/// [`srgb`] of the first value of each bucket of [`to_srgb8`]'s table.
fn srgb_bucket_codes() -> &'static [u8] {
    static CODES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    CODES.get_or_init(|| {
        (0..=1.0f32.to_bits() >> SRGB_BUCKET_BITS)
            .map(|b| srgb(f32::from_bits(b << SRGB_BUCKET_BITS)))
            .collect()
    })
}

/// Where [`srgb`] steps: entry k − 1 is the least `f32` whose code is k (k = 1…255), found by
/// bisection on the bit patterns of [0, 1] (ordered as the numbers are).
pub fn srgb_steps() -> &'static [f32; 255] {
    static STEPS: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    STEPS.get_or_init(|| {
        let mut steps = [0.0f32; 255];
        for (k, step) in (1..=255u8).zip(steps.iter_mut()) {
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if srgb(f32::from_bits(mid)) >= k {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *step = f32::from_bits(hi);
        }
        steps
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table's codes are [`srgb`]'s own at every step (the value there and the bit
    /// patterns 300 either side), at a stride through every `f32` of [0, 1], at each bucket's
    /// first and last value, and beyond.
    #[test]
    fn srgb_codes_from_the_steps_equal_the_transfer_function() {
        let mut values = vec![f32::NAN, f32::NEG_INFINITY, -1.0, -0.0, 0.0, 1.0, 2.0];
        values.push(f32::INFINITY);
        for &t in srgb_steps() {
            let b = t.to_bits();
            values.extend((b - 300..=b + 300).map(f32::from_bits));
        }
        values.extend((0..=1.0f32.to_bits()).step_by(997).map(f32::from_bits));
        for b in 0..=1.0f32.to_bits() >> SRGB_BUCKET_BITS {
            let first = b << SRGB_BUCKET_BITS;
            values.push(f32::from_bits(first));
            values.push(f32::from_bits(first + (1 << SRGB_BUCKET_BITS) - 1));
        }
        let img = Image {
            width: values.len() as u32,
            height: 1,
            pixels: values.iter().map(|&v| [v, v, v]).collect(),
            rays: [0; 4],
        };
        let codes = to_srgb8(&img);
        for (k, &v) in values.iter().enumerate() {
            assert_eq!(codes[3 * k], srgb(v), "at {v:e} ({:#x})", v.to_bits());
        }
        // Hand-worked: code 1 from half a code of 12.92 v, code 255 from 254.5/255 of
        // 1.055 v^(1/2.4) − 0.055.
        let s = srgb_steps();
        assert!((s[0] - 0.5 / 255.0 / 12.92).abs() < 1e-8, "{}", s[0]);
        let top = ((254.5 / 255.0 + 0.055) / 1.055f64).powf(2.4) as f32;
        assert!((s[254] - top).abs() < 1e-6, "{} against {top}", s[254]);
    }
}

//! Catmull–Rom resampling of 8-bit RGB images (the bytes of the `image` crate's resize).

/// The Catmull–Rom kernel (Keys 1981; the Mitchell–Netravali cubic with B = 0, C = ½), in
/// `f32` as the `image` crate writes it.
fn catmull_rom(x: f32) -> f32 {
    let a = x.abs();
    let k = if a < 1.0 {
        9.0 * a.powi(3) + -15.0 * a.powi(2) + 6.0
    } else if a < 2.0 {
        -3.0 * a.powi(3) + 15.0 * a.powi(2) + -24.0 * a + 12.0
    } else {
        0.0
    };
    k / 6.0
}

/// The taps of one output coordinate of a resampling from `from` to `to` samples: the first
/// input index and the normalised weights (the support widened by the ratio when shrinking).
fn resample_taps(from: usize, to: usize) -> Vec<(usize, Vec<f32>)> {
    let ratio = from as f32 / to as f32;
    let sratio = if ratio < 1.0 { 1.0 } else { ratio };
    let support = 2.0 * sratio;
    (0..to)
        .map(|o| {
            let centre = (o as f32 + 0.5) * ratio;
            let left = ((centre - support).floor() as i64).clamp(0, from as i64 - 1);
            let right = ((centre + support).ceil() as i64).clamp(left + 1, from as i64);
            let centre = centre - 0.5;
            let mut ws: Vec<f32> = (left..right)
                .map(|i| catmull_rom((i as f32 - centre) / sratio))
                .collect();
            let sum = ws.iter().fold(0.0f32, |s, &w| s + w);
            ws.iter_mut().for_each(|w| *w /= sum);
            (left as usize, ws)
        })
        .collect()
}

/// An 8-bit RGB image of `(sw, sh)` pixels resampled to `(tw, th)` with the Catmull–Rom
/// filter: the bytes of the `image` crate's `imageops::resize(…, FilterType::CatmullRom)`
/// (columns first into `f32`, then rows, each sum in the same order, rounded half away from
/// zero), with both passes running along rows (that crate's second pass walks down columns).
pub fn resize_catmull_rom(
    src: &[u8],
    (sw, sh): (usize, usize),
    (tw, th): (usize, usize),
) -> Vec<u8> {
    if (sw, sh) == (tw, th) {
        return src.to_vec();
    }
    if sw == 0 || sh == 0 {
        return vec![0; 3 * tw * th];
    }
    // Columns: output row o is the weighted sum of input rows left.., a row at a time.
    let mut mid = vec![0.0f32; 3 * sw * th];
    for ((left, ws), out) in resample_taps(sh, th)
        .iter()
        .zip(mid.chunks_exact_mut(3 * sw))
    {
        for (k, &wt) in ws.iter().enumerate() {
            let row = &src[3 * sw * (left + k)..3 * sw * (left + k + 1)];
            for (t, &v) in out.iter_mut().zip(row) {
                *t += v as f32 * wt;
            }
        }
    }
    // Rows: each output pixel of a row from its taps along that row.
    let taps = resample_taps(sw, tw);
    let mut out = vec![0u8; 3 * tw * th];
    for (row, dst) in mid.chunks_exact(3 * sw).zip(out.chunks_exact_mut(3 * tw)) {
        for ((left, ws), px) in taps.iter().zip(dst.chunks_exact_mut(3)) {
            let mut t = [0.0f32; 3];
            for (k, &wt) in ws.iter().enumerate() {
                let p = &row[3 * (left + k)..3 * (left + k) + 3];
                for c in 0..3 {
                    t[c] += p[c] * wt;
                }
            }
            for c in 0..3 {
                px[c] = t[c].clamp(0.0, 255.0).round() as u8;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-major resampler gives the `image` crate's `resize` bytes (the reference it reproduces)
    /// for shrinking, enlarging, mixed, equal and tiny sizes, on pseudo-random images with
    /// hard edges (0 and 255 runs, where the kernel's negative lobes clamp).
    #[test]
    fn catmull_rom_resize_equals_the_image_crates() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut byte = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            match state % 8 {
                0 => 0,
                1 => 255,
                _ => (state >> 32) as u8,
            }
        };
        for (src, dst) in [
            ((512, 512), (256, 256)),
            ((37, 37), (256, 256)),
            ((300, 200), (256, 97)),
            ((256, 256), (256, 256)),
            ((1, 1), (4, 4)),
            ((5, 9), (3, 2)),
            ((64, 3), (7, 11)),
        ] {
            let px: Vec<u8> = (0..3 * src.0 * src.1).map(|_| byte()).collect();
            let img = image::RgbImage::from_raw(src.0 as u32, src.1 as u32, px.clone()).unwrap();
            let peer = image::imageops::resize(
                &img,
                dst.0 as u32,
                dst.1 as u32,
                image::imageops::FilterType::CatmullRom,
            )
            .into_raw();
            let ours = resize_catmull_rom(&px, src, dst);
            let differ = ours.iter().zip(&peer).filter(|(a, b)| a != b).count();
            assert_eq!((ours.len(), differ), (peer.len(), 0), "{src:?} → {dst:?}");
        }
    }
}

//! Rendered images on disk and compared: the size limit, the finite-pixel check, PNG and EXR
//! output, and the RMS difference.

use super::{Image, to_srgb8};

/// Largest image side rendered without an explicit permission (`--allow-large-image`).
pub const MAX_SIDE: u32 = 8192;
/// Largest pixel count rendered without an explicit permission: 16 M pixels.
pub const MAX_PIXELS: u64 = 1 << 24;

/// An error for an image beyond [`MAX_SIDE`] on a side or [`MAX_PIXELS`] in all, unless
/// `allow_large` (rendering keeps about 35 bytes a pixel, so 16 M pixels take about 0.6 GB).
pub fn check_image_size(width: u32, height: u32, allow_large: bool) -> Result<(), String> {
    let pixels = width as u64 * height as u64;
    if !allow_large && (width > MAX_SIDE || height > MAX_SIDE || pixels > MAX_PIXELS) {
        return Err(format!(
            "the image would be {width}×{height} ({:.1} M pixels), above the limit of {MAX_SIDE} on a side and {} M pixels (about 35 bytes of memory a pixel)\n  fix: render smaller, or allow it with --allow-large-image",
            pixels as f64 / 1e6,
            MAX_PIXELS >> 20
        ));
    }
    Ok(())
}

/// An error unless every pixel of `img` is finite: how many are not, and the first (x, y).
pub fn check_finite(img: &Image) -> anyhow::Result<()> {
    let bad = img
        .pixels
        .iter()
        .filter(|p| p.iter().any(|v| !v.is_finite()))
        .count();
    if let Some(k) = img
        .pixels
        .iter()
        .position(|p| p.iter().any(|v| !v.is_finite()))
    {
        let w = img.width.max(1) as usize;
        anyhow::bail!(
            "the rendered image has {bad} pixels that are not finite numbers (the first at x = {}, y = {}: {:?}); nothing was written\n  fix: lower the values that overflow: light intensity, colours or the material's parameters",
            k % w,
            k / w,
            img.pixels[k]
        );
    }
    Ok(())
}

/// Write `base.png` (sRGB 8-bit) and `base.exr` (linear f32), atomically; returns both paths.
/// An image holding a NaN or infinite pixel is refused (an error, no file): the message gives
/// how many and the first.
pub fn save(img: &Image, base: &std::path::Path) -> anyhow::Result<[std::path::PathBuf; 2]> {
    check_finite(img)
        .map_err(|e| anyhow::anyhow!("{}: {e}", base.with_extension("exr").display()))?;
    let png = crate::support::png::encode_png(img.width, img.height, &to_srgb8(img))?;
    // The encoder's buffer at the uncompressed size (a growing one copies itself as it
    // doubles), and the pixels as one flat copy.
    let mut exr = std::io::Cursor::new(Vec::with_capacity(12 * img.pixels.len() + 4096));
    let data: Vec<f32> = img.pixels.as_flattened().to_vec();
    let buf = image::Rgb32FImage::from_raw(img.width, img.height, data)
        .ok_or_else(|| anyhow::anyhow!("image size mismatch"))?;
    image::DynamicImage::ImageRgb32F(buf)
        .write_to(&mut exr, image::ImageFormat::OpenExr)
        .map_err(|e| anyhow::anyhow!("EXR encoding failed: {e}"))?;
    // Both encoded, then both written, the PNG last: when it cannot be written (a full disk)
    // the EXR just written is removed, so a failure leaves neither file of this image.
    let exr_path = base.with_extension("exr");
    crate::support::output::write_bytes_atomic(&exr_path, exr.get_ref())?;
    if let Err(e) = crate::support::output::write_bytes_atomic(&base.with_extension("png"), &png) {
        let _ = std::fs::remove_file(&exr_path);
        return Err(e.into());
    }
    Ok([base.with_extension("png"), exr_path])
}

/// Root-mean-square difference of two linear images (all channels).
pub fn rmse(a: &Image, b: &Image) -> f64 {
    let n = a.pixels.len().min(b.pixels.len()).max(1);
    let s: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (0..3).map(|k| ((p[k] - q[k]) as f64).powi(2)).sum::<f64>())
        .sum();
    (s / (3 * n) as f64).sqrt()
}

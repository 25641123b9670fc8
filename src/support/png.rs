//! PNG bytes of 8-bit RGB pixels, and the embedded DejaVu Sans font that labels every drawn
//! image (charts and contact sheets), registered once with plotters so the same input gives
//! the same bytes on every machine.

use anyhow::{Result, anyhow};

/// The embedded font's TrueType bytes (DejaVu Sans, shipped with the crate).
pub(crate) static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Register the embedded font with plotters (once per process).
pub fn register_font_once() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font shipped with the crate.
        let _ =
            plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, FONT);
    });
}

/// PNG bytes of an 8-bit RGB buffer.
pub fn encode_png(w: u32, h: u32, rgb: &[u8]) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| anyhow!("PNG encoding failed: {e}"))?;
    Ok(out)
}

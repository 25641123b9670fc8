//! Text on bitmaps drawn by brdfit, not by plotters' font code: [`OwnText`] wraps a plotters
//! backend and rasterises every text with the embedded DejaVu Sans (ab_glyph), each glyph
//! placed at its pixel bounds floored, so every glyph shares one baseline and starts at its
//! left bearing. plotters 0.3.7 truncates those offsets toward zero and drops the bearing (full
//! stops and commas then sit up to 2 px above the baseline); drawing the text here gives every
//! build the same PNGs, whatever copy of plotters it links (a crate using brdfit as a path or
//! registry dependency included).

use super::png::FONT;
use ab_glyph::{Font, FontRef, ScaleFont};
use plotters::coord::Shift;
use plotters::prelude::{BitMapBackend, DrawingArea, IntoDrawingArea};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};

/// A plotters backend whose texts brdfit rasterises itself (see the module documentation);
/// everything else goes to the wrapped backend unchanged.
pub struct OwnText<B>(pub B);

/// A drawing area over an RGB buffer of `size` (width, height) pixels, its texts drawn by
/// [`OwnText`]: the bitmap every chart and contact sheet is drawn on.
pub fn bitmap_area(
    buf: &mut [u8],
    size: (u32, u32),
) -> DrawingArea<OwnText<BitMapBackend<'_>>, Shift> {
    OwnText(BitMapBackend::with_buffer(buf, size)).into_drawing_area()
}

/// Each inked pixel of `text` at `size` (pixels) in the embedded font: (x, y, coverage), from
/// the origin plotters uses (the text's left edge, half the size above the baseline). Kerning
/// and advances as plotters' own layout, so the text fills the box plotters reserved for it.
pub fn glyph_pixels(text: &str, size: f64) -> Vec<(i32, i32, f32)> {
    let Ok(font) = FontRef::try_from_slice(FONT) else {
        return Vec::new();
    };
    let font = font.as_scaled(size as f32);
    let mut out = Vec::new();
    let mut pen = 0f32;
    let mut prev = None;
    for c in text.chars() {
        if let Some(pc) = prev {
            pen += font.kern(font.glyph_id(pc), font.glyph_id(c));
        }
        prev = Some(c);
        if let Some(q) = font.outline_glyph(font.scaled_glyph(c)) {
            let rect = q.px_bounds();
            // Floored, not truncated toward zero: one baseline for every glyph; the bitmap
            // starts at the glyph's bounds, its left bearing included.
            let dy = ((size as f32) / 2.0 + rect.min.y).floor() as i32;
            let dx = (pen + rect.min.x).floor() as i32;
            q.draw(|x, y, a| out.push((x as i32 + dx, y as i32 + dy, a)));
        }
        pen += font.h_advance(font.glyph_id(c));
    }
    out
}

impl<B: DrawingBackend> DrawingBackend for OwnText<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    /// plotters' own text drawing (`DrawingBackend::draw_text`'s default: the anchor, the
    /// rotation and clipping to the area), with the glyphs of [`glyph_pixels`].
    fn draw_text<TStyle: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        let (w, h) = self.get_size();
        for (x, y, a) in glyph_pixels(text, style.size()) {
            let (x, y) = trans.transform(x + dx - min_x, y + dy - min_y);
            let (x, y) = (pos.0 + x, pos.1 + y);
            if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                self.0.draw_pixel((x, y), color.mix(a as f64))?;
            }
        }
        Ok(())
    }

    fn estimate_text_size<TStyle: BackendTextStyle>(
        &self,
        text: &str,
        style: &TStyle,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        self.0.estimate_text_size(text, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }
}

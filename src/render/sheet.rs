//! Blinn's Figure 7: the eight images, and the labelled contact sheet that lays them out with
//! the edge-lit crescents cropped and zoomed.

use super::{AntiAlias, Image, Lighting, fig7_scene, resize_catmull_rom, to_srgb8};
use crate::model::Model;

/// The eight images of Blinn's Figure 7: `{aluminium,mgo}-{front,edge}-{phong,ts}`, with the
/// Torrance–Sparrow models given and Phong with equal β ([`crate::model::equal_beta_phong`]).
pub fn fig7_images(
    aluminium: &Model,
    mgo: &Model,
    res: u32,
    aa: AntiAlias,
) -> Vec<(String, Image)> {
    fig7_images_with_progress(aluminium, mgo, res, aa, &|| {})
}

/// [`fig7_images`], calling `progress` once per finished image row (8 × `res` calls in all).
pub fn fig7_images_with_progress(
    aluminium: &Model,
    mgo: &Model,
    res: u32,
    aa: AntiAlias,
    progress: &(dyn Fn() + Sync),
) -> Vec<(String, Image)> {
    let mut out = Vec::new();
    for (mat, ts) in [("aluminium", aluminium), ("mgo", mgo)] {
        for (lname, lighting) in [("front", Lighting::Front), ("edge", Lighting::Edge)] {
            for (mname, m) in [("phong", crate::model::equal_beta_phong(ts)), ("ts", *ts)] {
                let mut s = fig7_scene(m, lighting, res);
                s.antialias = aa;
                out.push((format!("{mat}-{lname}-{mname}"), s.render(progress)));
            }
        }
    }
    out
}

/// The square crop (x0, y0, side) of the images that holds every pixel brighter than `level`
/// (sRGB, in any image) with a margin: the whole image unless the visible part is small, so a thin
/// edge-lit crescent is shown large. The whole image is (0, 0, longer side): [`zoom_crop`]
/// centres a non-square image in that square.
pub fn visible_crop(srgb: &[Vec<u8>], w: u32, h: u32, level: u8) -> (u32, u32, u32) {
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = 3 * (y * w + x) as usize;
            if srgb.iter().any(|s| s[i..i + 3].iter().any(|&v| v > level)) {
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
    }
    // The whole image: a square as large as its longer side, which `zoom_crop` fills by
    // centring the image in it (a 384×256 scene shown whole, not its left square).
    let whole = (0, 0, w.max(h));
    if x1 < x0 {
        return whole;
    }
    let side = ((x1 - x0).max(y1 - y0) + 1 + w / 16).max(w / 8);
    if side * 10 > w.min(h) * 7 {
        return whole;
    }
    let cx = (x0 + x1) / 2;
    let cy = (y0 + y1) / 2;
    let left = cx.saturating_sub(side / 2).min(w - side);
    let top = cy.saturating_sub(side / 2).min(h - side);
    (left, top, side)
}

/// The square `side`×`side` crop at (`cx`, `cy`) of an 8-bit RGB image `w` pixels wide,
/// resampled to `tile`×`tile` with a smooth filter (Catmull–Rom bicubic, as the `image`
/// crate's `imageops::resize`, whose support widens when it shrinks: [`resize_catmull_rom`]):
/// a zoomed crescent shows smooth edges, not blocks of pixels. The crop is clamped to the
/// image, but for the whole image ([`visible_crop`]'s (0, 0, longer side)), which is centred
/// in the square.
pub fn zoom_crop(rgb: &[u8], w: u32, (cx, cy, side): (u32, u32, u32), tile: u32) -> Vec<u8> {
    let h = (rgb.len() / 3) as u32 / w.max(1);
    if (cx, cy) == (0, 0) && side > w.min(h) && side >= w.max(h) && w > 0 && h > 0 {
        // The whole image centred in a black square as large as its longer side.
        let side = side as usize;
        let (w, h) = (w as usize, h as usize);
        let (ox, oy) = ((side - w) / 2, (side - h) / 2);
        let mut square = vec![0u8; 3 * side * side];
        for y in 0..h {
            let to = 3 * ((y + oy) * side + ox);
            square[to..to + 3 * w].copy_from_slice(&rgb[3 * y * w..3 * (y + 1) * w]);
        }
        return resize_catmull_rom(&square, (side, side), (tile as usize, tile as usize));
    }
    let (cx, cy) = (cx.min(w.saturating_sub(1)), cy.min(h.saturating_sub(1)));
    let side = side.min(w - cx).min(h - cy).max(1) as usize;
    let (w, cx, cy) = (w as usize, cx as usize, cy as usize);
    let mut crop = Vec::with_capacity(3 * side * side);
    for y in cy..cy + side {
        crop.extend_from_slice(&rgb[3 * (y * w + cx)..3 * (y * w + cx + side)]);
    }
    resize_catmull_rom(&crop, (side, side), (tile as usize, tile as usize))
}

/// A labelled contact sheet (PNG bytes) of Figure 7 images laid out as Blinn's figure: rows
/// aluminium and MgO, columns front/edge × Phong/Torrance–Sparrow.
pub fn contact_sheet(images: &[(String, Image)]) -> anyhow::Result<Vec<u8>> {
    use plotters::prelude::*;
    let tile = 256u32;
    let (cols, rows) = (4u32, 2u32);
    let (top, left, gap) = (60u32, 110u32, 8u32);
    let (w, h) = (left + cols * (tile + gap), top + rows * (tile + gap + 24));
    let mut buf = vec![0u8; (w * h * 3) as usize];
    for px in buf.chunks_mut(3) {
        px.copy_from_slice(&[255, 255, 255]);
    }
    // The edge-lit images (columns 3 and 4) of each row share one crop around the lit
    // crescent, so its thin highlight is large enough to compare.
    let crop = |r: usize| {
        let edge: Vec<Vec<u8>> = images
            .iter()
            .skip(4 * r + 2)
            .take(2)
            .map(|(_, i)| to_srgb8(i))
            .collect();
        match images.get(4 * r + 2) {
            Some((_, i)) if edge.len() == 2 => {
                // The highlight: pixels above half the brightest (the ambient-lit rest of
                // the sphere stays below).
                let top = edge.iter().flatten().copied().max().unwrap_or(0);
                visible_crop(&edge, i.width, i.height, top / 2)
            }
            Some((_, i)) => (0, 0, i.width.min(i.height)),
            None => (0, 0, 1),
        }
    };
    let crops = [crop(0), crop(1)];
    for (k, (_, img)) in images.iter().enumerate().take(8) {
        let (r, c) = (k as u32 / 4, k as u32 % 4);
        let (x0, y0) = (left + c * (tile + gap), top + r * (tile + gap + 24));
        let (cx, cy, side) = if c >= 2 {
            crops[r as usize]
        } else {
            (0, 0, img.width.min(img.height))
        };
        // Smooth resampling of the (cropped) image onto the tile.
        let zoomed = zoom_crop(&to_srgb8(img), img.width, (cx, cy, side), tile);
        for y in 0..tile {
            let o = (((y0 + y) * w + x0) * 3) as usize;
            let i = (3 * y * tile) as usize;
            buf[o..o + 3 * tile as usize].copy_from_slice(&zoomed[i..i + 3 * tile as usize]);
        }
    }
    {
        crate::support::png::register_font_once();
        let root = crate::support::glyphs::bitmap_area(&mut buf, (w, h));
        let font = ("sans-serif", 16).into_font();
        let t = |s: &str, x: u32, y: u32, size: f64| {
            root.draw(&Text::new(
                s.to_string(),
                (x as i32, y as i32),
                ("sans-serif", size).into_font(),
            ))
        };
        let e = |r: Result<(), _>| r.map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"));
        e(root.draw(&Text::new(
            "Blinn 1977, Figure 7: Phong against Torrance–Sparrow (equal β)".to_string(),
            (10, 8),
            font,
        )))?;
        for (c, label) in [
            "front lit, Phong",
            "front lit, Torrance–Sparrow",
            "edge lit, Phong",
            "edge lit, Torrance–Sparrow",
        ]
        .iter()
        .enumerate()
        {
            e(t(label, left + c as u32 * (tile + gap) + 4, 36, 14.0))?;
        }
        for (r, label) in ["aluminium", "MgO"].iter().enumerate() {
            e(t(
                label,
                8,
                top + r as u32 * (tile + gap + 24) + tile / 2,
                16.0,
            ))?;
        }
        for (k, (name, img)) in images.iter().enumerate().take(8) {
            let (r, c) = (k as u32 / 4, k as u32 % 4);
            let side = if c >= 2 {
                crops[r as usize].2
            } else {
                img.width
            };
            let name = if side < img.width.min(img.height) {
                format!("{name}, zoomed ×{:.1}", img.width as f64 / side as f64)
            } else {
                name.clone()
            };
            e(t(
                &name,
                left + c * (tile + gap) + 4,
                top + r * (tile + gap + 24) + tile + 4,
                12.0,
            ))?;
        }
        root.present()
            .map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"))?;
    }
    crate::support::png::encode_png(w, h, &buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 384×256 scene (a test object at its right, another at its left, both large enough
    /// for the whole image to be shown): the tile holds both, the image centred (its top and
    /// bottom 64 of 384 rows black). Cropped to its left square, the right object was lost.
    #[test]
    fn a_wide_scene_is_shown_whole() {
        let (w, h) = (384u32, 256u32);
        let mut rgb = vec![0u8; 3 * (w * h) as usize];
        for y in 60..200 {
            for x in (20..80).chain(300..370) {
                let i = 3 * (y * w + x) as usize;
                rgb[i..i + 3].copy_from_slice(&[255, 255, 255]);
            }
        }
        let crop = visible_crop(std::slice::from_ref(&rgb), w, h, 8);
        assert_eq!(crop, (0, 0, 384));
        let tile = zoom_crop(&rgb, w, crop, 96);
        let at = |x: usize, y: usize| tile[3 * (y * 96 + x)];
        // x 300–370 of 384 → 75–92 of 96; 20–80 → 5–20; y 60–200 (+64) → 31–66.
        assert!(at(84, 48) > 200 && at(12, 48) > 200, "both objects shown");
        assert!(at(48, 48) < 20 && at(84, 8) < 20 && at(84, 90) < 20);
    }
}

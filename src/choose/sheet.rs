//! The contact sheet of a case: each render over its ꟻLIP map, labelled, with the colour
//! scale and the threshold.

use super::{CaseImages, CaseResult, FitUsed, ThresholdJson, verdict};
use rayon::prelude::*;

/// Magma colour of an error in [0, `max`] (NVIDIA ꟻLIP's map stretched to `max`; errors
/// above it take the brightest colour).
pub(super) fn magma(lut: &[u8], e: f32, max: f32) -> [u8; 3] {
    let i = (((e / max).clamp(0.0, 1.0) * 255.0).round() as usize).min(255);
    [lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]]
}

/// The top of the contact sheet's ꟻLIP colour scale: the median of the models' ꟻLIP 99th
/// percentiles `p99` (the upper one of an even count), rounded up to two significant digits,
/// within [0.01, 1]. So the maps use the colours where the models' errors lie (on a fixed
/// 0–1 scale errors of 0.03 were black), and one far-off model (Lambert at 0.6) does not
/// darken the others; the worse half of the models saturate at the brightest colour. The
/// bar shows the value.
pub fn flip_scale(p99: &[f64]) -> f64 {
    let mut v: Vec<f64> = p99.iter().copied().filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let worst = v.get(v.len() / 2).copied().unwrap_or(0.0);
    if worst <= 0.01 {
        return 0.01;
    }
    if worst >= 1.0 {
        return 1.0;
    }
    let step = 10f64.powf(worst.log10().floor() - 1.0);
    // The 1e-9 keeps a value already on the grid (0.034) from rounding up a step.
    ((worst / step - 1e-9).ceil() * step).min(1.0)
}

/// The contact sheet of a case, 4 columns wide so its text stays legible where the report
/// shows it: each cell is a render over its ꟻLIP map (magma, 0 to [`flip_scale`]), labelled
/// with the model and its 99th percentiles; the reference's cell holds the colour bar with
/// its scale instead of a map. A small visible region (an edge-lit crescent) is shown zoomed
/// with a smooth filter ([`crate::render::zoom_crop`]), and the title says so.
pub(super) fn contact_sheet(
    case: &CaseResult,
    imgs: &CaseImages,
    th: &ThresholdJson,
) -> anyhow::Result<Vec<u8>> {
    let srgb: Vec<Vec<u8>> = imgs
        .renders
        .par_iter()
        .map(|(_, i)| crate::render::to_srgb8(i))
        .collect();
    let (iw, ih) = (imgs.renders[0].1.width, imgs.renders[0].1.height);
    let crop = crate::render::visible_crop(&srgb, iw, ih, 8);
    let layout = Layout::new(case, imgs, th, (iw, ih), crop.2);
    let mut buf = vec![255u8; (layout.w * layout.h * 3) as usize];
    let p99: Vec<f64> = case.models.iter().map(|m| m.flip_p99).collect();
    let scale = flip_scale(&p99);
    draw_tiles(&mut buf, &layout, &srgb, imgs, (iw, crop), scale);
    draw_labels(&mut buf, &layout, case, th, scale)?;
    crate::plot::encode_png(layout.w, layout.h, &buf)
}

/// Where everything of a contact sheet goes (pixels).
struct Layout {
    /// Side of a tile.
    tile: u32,
    /// Gap between cells and around the sheet.
    gap: u32,
    /// Height of a cell's label above its tiles.
    label_h: u32,
    /// Cells per row.
    cols: u32,
    /// Sheet width and height.
    w: u32,
    h: u32,
    /// Top of the first row of cells.
    top: u32,
    /// Top of the verdict's reason.
    reason_y: u32,
    /// Height of a cell: label, render, map.
    cell_h: u32,
    /// Cells: the reference, then each candidate.
    n: u32,
    /// The title's and the reason's lines.
    title: Vec<String>,
    reason: Vec<String>,
    /// The colour bar spans x = `bar.0` … `bar.1` of the reference's lower tile.
    bar: (u32, u32),
}

impl Layout {
    /// The sheet's layout for `case`, its images `(iw, ih)` shown cropped to a square of
    /// `side` pixels.
    fn new(
        case: &CaseResult,
        imgs: &CaseImages,
        th: &ThresholdJson,
        (iw, ih): (u32, u32),
        side: u32,
    ) -> Layout {
        let (tile, gap, label_h) = (256u32, 14u32, 40u32);
        let cols = 4u32;
        let w = gap + cols * (tile + gap);
        // The title (20 px, about 11 px a character) and the verdict's reason (13 px, about 7 px
        // a character) wrapped to the sheet's width, 24 and 17 px a line; the tiles start below.
        let zoom = if side < iw.min(ih) {
            format!(", images zoomed ×{:.1}", iw.min(ih) as f64 / side as f64)
        } else {
            String::new()
        };
        let title = verdict::wrap(
            &format!(
                "{} lit: {} ({} ≤ {}{zoom})",
                case.case,
                case.answer(),
                th.metric,
                th.value
            ),
            (w - 2 * gap) as usize / 11,
        );
        let reason = verdict::wrap(&case.reason, (w - 2 * gap) as usize / 7);
        let reason_y = 38 + 24 * (title.len().max(1) as u32 - 1);
        let top = reason_y + 8 + 17 * reason.len().max(1) as u32;
        let n = imgs.renders.len() as u32;
        let rows = n.div_ceil(cols);
        let cell_h = label_h + 2 * tile + 8;
        let h = top + rows * (cell_h + gap);
        Layout {
            tile,
            gap,
            label_h,
            cols,
            w,
            h,
            top,
            reason_y,
            cell_h,
            n,
            title,
            reason,
            bar: (8u32, tile - 9),
        }
    }

    /// The top left corner of cell `k`.
    fn origin(&self, k: u32) -> (u32, u32) {
        (
            self.gap + (k % self.cols) * (self.tile + self.gap),
            self.top + (k / self.cols) * (self.cell_h + self.gap),
        )
    }
}

/// Each cell's zoomed render and ꟻLIP map (magma, 0 to `scale`) into `buf`, and the colour
/// bar under the reference; `crop` is the square of the `iw`-wide images shown.
fn draw_tiles(
    buf: &mut [u8],
    layout: &Layout,
    srgb: &[Vec<u8>],
    imgs: &CaseImages,
    (iw, crop): (u32, (u32, u32, u32)),
    scale: f64,
) {
    let (tile, w, label_h) = (layout.tile, layout.w, layout.label_h);
    let lut = nv_flip::magma_lut().to_vec();
    let put = |buf: &mut [u8], x: u32, y: u32, c: [u8; 3]| {
        let o = ((y * w + x) * 3) as usize;
        buf[o..o + 3].copy_from_slice(&c);
    };
    let (bar0, bar1) = layout.bar;
    // Each cell's zoomed render and map in parallel (each deterministic), then laid out.
    let tiles: Vec<(Vec<u8>, Option<Vec<u8>>)> = (0..layout.n as usize)
        .into_par_iter()
        .map(|k| {
            let render = crate::render::zoom_crop(&srgb[k], iw, crop, tile);
            let map = (k > 0).then(|| {
                let coloured: Vec<u8> = imgs.flip_maps[k - 1]
                    .iter()
                    .flat_map(|&e| magma(&lut, e, scale as f32))
                    .collect();
                crate::render::zoom_crop(&coloured, iw, crop, tile)
            });
            (render, map)
        })
        .collect();
    for (k, (render, map)) in (0..layout.n).zip(tiles) {
        let (x0, y0) = layout.origin(k);
        for y in 0..tile {
            for x in 0..tile {
                let i = 3 * (y * tile + x) as usize;
                put(
                    buf,
                    x0 + x,
                    y0 + label_h + y,
                    [render[i], render[i + 1], render[i + 2]],
                );
                let below = y0 + label_h + tile + 8 + y;
                if let Some(m) = &map {
                    put(buf, x0 + x, below, [m[i], m[i + 1], m[i + 2]]);
                } else if (tile / 2..tile / 2 + 20).contains(&y) && (bar0..=bar1).contains(&x) {
                    let e = (x - bar0) as f32 / (bar1 - bar0) as f32 * scale as f32;
                    put(buf, x0 + x, below, magma(&lut, e, scale as f32));
                }
            }
        }
    }
}

/// The sheet's drawing area on `buf`.
type Sheet<'a> = plotters::prelude::DrawingArea<
    crate::support::glyphs::OwnText<plotters::prelude::BitMapBackend<'a>>,
    plotters::coord::Shift,
>;

/// A drawing error as an error of the sheet.
fn drawn<E: std::fmt::Debug>(r: Result<(), E>) -> anyhow::Result<()> {
    r.map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"))
}

/// Text `s` at (`x`, `y`) in sans-serif of `size` px.
fn text(root: &Sheet, s: String, x: u32, y: u32, size: f64) -> anyhow::Result<()> {
    use plotters::prelude::*;
    drawn(root.draw(&Text::new(
        s,
        (x as i32, y as i32),
        ("sans-serif", size).into_font(),
    )))
}

/// The title, the verdict's reason and every cell's label onto `buf`.
fn draw_labels(
    buf: &mut [u8],
    layout: &Layout,
    case: &CaseResult,
    th: &ThresholdJson,
    scale: f64,
) -> anyhow::Result<()> {
    crate::plot::register_font_once();
    let (gap, reason_y) = (layout.gap, layout.reason_y);
    let root = crate::support::glyphs::bitmap_area(buf, (layout.w, layout.h));
    for (i, line) in layout.title.iter().enumerate() {
        text(&root, line.clone(), gap, 12 + 24 * i as u32, 20.0)?;
    }
    for (i, line) in layout.reason.iter().enumerate() {
        text(&root, line.clone(), gap, reason_y + 17 * i as u32, 13.0)?;
    }
    for k in 0..layout.n {
        let (x0, y0) = layout.origin(k);
        if k == 0 {
            reference_labels(&root, layout, case, th, scale)?;
            continue;
        }
        let m = &case.models[k as usize - 1];
        let mark = if case.chosen.as_deref() == Some(&m.model) {
            " ✔ chosen"
        } else {
            ""
        };
        let global = if m.used == FitUsed::Global {
            " (global fit)"
        } else {
            ""
        };
        text(
            &root,
            format!("{}{global}{mark}", m.model),
            x0,
            y0 + 2,
            16.0,
        )?;
        text(
            &root,
            format!(
                "ꟻLIP p99 {:.3}   ΔE_ITP p99 {:.2}",
                m.flip_p99, m.delta_e_itp_p99
            ),
            x0,
            y0 + 21,
            14.0,
        )?;
    }
    root.present()
        .map_err(|e| anyhow::anyhow!("drawing failed: {e:?}"))
}

/// The reference's cell's label, and its colour bar's title, ticks and threshold mark.
fn reference_labels(
    root: &Sheet,
    layout: &Layout,
    case: &CaseResult,
    th: &ThresholdJson,
    scale: f64,
) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let (tile, label_h) = (layout.tile, layout.label_h);
    let (bar0, bar1) = layout.bar;
    let (x0, y0) = layout.origin(0);
    text(
        root,
        format!("reference ({})", case.reference),
        x0,
        y0 + 2,
        16.0,
    )?;
    let bar_y = y0 + label_h + tile + 8 + tile / 2;
    text(
        root,
        "ꟻLIP error, 0 to the models' median p99".into(),
        x0 + 8,
        bar_y - 42,
        14.0,
    )?;
    text(
        root,
        format!(
            "(brightest: {} or more)",
            crate::model::significant(scale, 2)
        ),
        x0 + 8,
        bar_y - 24,
        14.0,
    )?;
    let at = |v: f64| x0 + bar0 + ((v / scale) * (bar1 - bar0) as f64).round() as u32;
    let half = crate::model::significant(scale / 2.0, 2);
    let top = crate::model::significant(scale, 2);
    text(root, "0".into(), at(0.0), bar_y + 26, 14.0)?;
    text(
        root,
        half.clone(),
        at(scale / 2.0) - 4 * half.len() as u32,
        bar_y + 26,
        14.0,
    )?;
    text(
        root,
        top.clone(),
        at(scale) - 8 * top.len() as u32,
        bar_y + 26,
        14.0,
    )?;
    // The threshold's ꟻLIP level, where the scale reaches it.
    if th.metric.starts_with("flip") && th.value > 0.0 && th.value < scale {
        let x = at(th.value);
        drawn(root.draw(&PathElement::new(
            vec![(x as i32, bar_y as i32 - 4), (x as i32, bar_y as i32 + 24)],
            RGBColor(0, 160, 255).stroke_width(2),
        )))?;
        text(
            root,
            format!("threshold {}", th.value),
            x.saturating_sub(30).max(x0),
            bar_y + 44,
            13.0,
        )?;
    }
    Ok(())
}

//! Charts: polar reflection distributions in the plane of incidence (Blinn 1977, Figures 5
//! and 6), residual, slice and albedo plots, and the study charts. Each chart is computed as
//! plain data first (tested on its own), then drawn with plotters to SVG and PNG with the
//! embedded DejaVu Sans font, so the same input gives the same bytes on every machine.
//!
//! Here: the [`Chart`] trait and [`save`], which writes a chart as SVG and PNG. The charts
//! live in their own modules: [`lobe_chart`] and [`blinn_figure`] (lobes), [`XyChart`]
//! (x–y charts), [`albedo_chart`], [`residual_charts`] and [`SliceChart`].

mod albedo;
mod labels;
mod lobe;
mod residual;
mod series;
mod slice;
mod svg;
mod xy;

pub use crate::support::glyphs::{OwnText, bitmap_area};
pub use crate::support::png::{encode_png, register_font_once};
pub use albedo::{ALBEDO_AGREEMENT, ALBEDO_CELLS, albedo, albedo_chart, measured_albedo};
pub use labels::{log_tick, needs_leader, place_label, tick};
pub use lobe::{
    InPlane, LobeChart, LobePanel, LobeQuantity, LobeSeries, blinn_figure, blinn_figure_models,
    curve_max, in_plane_samples, lobe_chart, lobe_curve,
};
pub use residual::{RESIDUAL_FILES, binned_quantiles, residual_charts, residual_points};
pub use series::{MEASURED, line_style};
pub use slice::{SliceChart, slice_grids};
pub use svg::svg_text_to_paths;
pub use xy::XyChart;

use crate::support::output::write_bytes_atomic;
use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// A chart that can draw itself on any plotters backend.
pub trait Chart {
    /// Pixel size (width, height).
    fn size(&self) -> (u32, u32);
    /// Draw on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

/// A drawing error as an `anyhow::Error` (for `map_err` in every chart's `draw`).
pub(crate) fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("drawing failed: {e:?}")
}

/// Render `chart` to `base.svg` and `base.png` (written atomically); returns both paths.
pub fn save(chart: &impl Chart, base: &Path) -> Result<(PathBuf, PathBuf)> {
    register_font_once();
    let (w, h) = chart.size();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        chart.draw(&root)?;
        root.present().map_err(err)?;
    }
    let mut px = vec![0u8; (w * h * 3) as usize];
    {
        let root = bitmap_area(&mut px, (w, h));
        chart.draw(&root)?;
        root.present().map_err(err)?;
    }
    let svg = svg_text_to_paths(&svg);
    let svg_path = base.with_extension("svg");
    let png_path = base.with_extension("png");
    write_bytes_atomic(&svg_path, svg.as_bytes())?;
    write_bytes_atomic(&png_path, &encode_png(w, h, &px)?)?;
    Ok((svg_path, png_path))
}

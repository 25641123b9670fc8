//! The θh × θd image slice (BRDF Explorer's) of data and model side by side.

use super::xy::range_of;
use super::{Chart, err};
use crate::data::Dataset;
use crate::model::{Geometry, Model};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::f64::consts::PI;

/// θh × θd image (BRDF Explorer's image slice) of data and model side by side: `n`×`n` bins
/// over [0°, 90°)², each bin the mean log10 f_r of its samples (data) or the model at the bin
/// centre with φd = 90° (fit); NaN where a bin has no sample.
pub fn slice_grids(ds: &Dataset, c: usize, model: &Model, n: usize) -> (Vec<f64>, Vec<f64>) {
    let vals = ds.brdf_values(c);
    let mut sum = vec![0.0; n * n];
    let mut cnt = vec![0usize; n * n];
    for k in 0..ds.len() {
        if !(vals[k] > 0.0) {
            continue;
        }
        let hd = crate::data::merl::std_to_half_diff(ds.angles(k));
        let i = ((hd[0] / (0.5 * PI)) * n as f64) as usize;
        let j = ((hd[2] / (0.5 * PI)) * n as f64) as usize;
        if i < n && j < n {
            sum[i * n + j] += vals[k].log10();
            cnt[i * n + j] += 1;
        }
    }
    let data: Vec<f64> = sum
        .iter()
        .zip(&cnt)
        .map(|(s, c)| if *c > 0 { s / *c as f64 } else { f64::NAN })
        .collect();
    let fit: Vec<f64> = (0..n * n)
        .map(|ij| {
            let (i, j) = (ij / n, ij % n);
            let th = (i as f64 + 0.5) / n as f64 * 0.5 * PI;
            let td = (j as f64 + 0.5) / n as f64 * 0.5 * PI;
            let a = crate::data::merl::half_diff_to_std(th, 0.0, td, 0.5 * PI);
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            let f = model.brdf(&g);
            if g.visible() && f > 0.0 {
                f.log10()
            } else {
                f64::NAN
            }
        })
        .collect();
    (data, fit)
}

/// Two images side by side with a shared colour scale.
#[derive(Clone, Debug)]
pub struct SliceChart {
    /// Title.
    pub title: String,
    /// Grid size.
    pub n: usize,
    /// Left image (data) and right image (fit), row-major, indexed `[θh][θd]`.
    pub images: [Vec<f64>; 2],
}

fn colormap(t: f64) -> RGBColor {
    // A perceptually ordered dark-blue → yellow ramp (piecewise linear, viridis-like).
    const STOPS: [(f64, [f64; 3]); 5] = [
        (0.0, [68.0, 1.0, 84.0]),
        (0.25, [59.0, 82.0, 139.0]),
        (0.5, [33.0, 145.0, 140.0]),
        (0.75, [94.0, 201.0, 98.0]),
        (1.0, [253.0, 231.0, 37.0]),
    ];
    let t = t.clamp(0.0, 1.0);
    let k = STOPS.iter().position(|s| s.0 >= t).unwrap_or(4).max(1);
    let (a, b) = (STOPS[k - 1], STOPS[k]);
    let u = (t - a.0) / (b.0 - a.0);
    let c = |i: usize| (a.1[i] + u * (b.1[i] - a.1[i])).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

impl Chart for SliceChart {
    fn size(&self) -> (u32, u32) {
        (900, 470)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(&self.title, ("sans-serif", 18)).map_err(err)?;
        let (lo, hi) = range_of(self.images.iter().flatten().copied(), false);
        let areas = root.split_evenly((1, 2));
        for (k, area) in areas.iter().enumerate() {
            let mut chart = ChartBuilder::on(area)
                .caption(
                    if k == 0 {
                        "data: mean log₁₀ f_r per bin"
                    } else {
                        "fit: log₁₀ f_r at φd = 90°"
                    },
                    ("sans-serif", 14),
                )
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(44)
                .build_cartesian_2d(0f64..90f64, 0f64..90f64)
                .map_err(err)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("θd (degrees)")
                .y_desc("θh (degrees)")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            let n = self.n;
            let step = 90.0 / n as f64;
            chart
                .draw_series((0..n * n).map(|ij| {
                    let (i, j) = (ij / n, ij % n);
                    let v = self.images[k][ij];
                    let color = if v.is_finite() {
                        colormap((v - lo) / (hi - lo).max(1e-12))
                    } else {
                        RGBColor(200, 200, 200)
                    };
                    Rectangle::new(
                        [
                            (j as f64 * step, i as f64 * step),
                            ((j + 1) as f64 * step, (i + 1) as f64 * step),
                        ],
                        color.filled(),
                    )
                }))
                .map_err(err)?;
        }
        root.draw(&Text::new(
            format!("colour: log₁₀ f_r from {lo:.2} (dark) to {hi:.2} (yellow); grey = no sample"),
            (20, 440),
            ("sans-serif", 12),
        ))
        .map_err(err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colormap_ends() {
        assert_eq!(colormap(0.0), RGBColor(68, 1, 84));
        assert_eq!(colormap(1.0), RGBColor(253, 231, 37));
    }
}

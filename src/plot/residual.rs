//! Residuals of a fit: the points, their charts against θh, θd and θi, and binned quantiles.

use super::{LobeSeries, XyChart};
use crate::data::Dataset;
use crate::model::{Geometry, Model};

/// Residuals of a model on channel `c`: (θh, θd, θi in degrees, residual of the loss).
pub fn residual_points(ds: &Dataset, c: usize, model: &Model, log_loss: bool) -> Vec<[f64; 4]> {
    let vals = ds.brdf_values(c);
    (0..ds.len())
        .filter(|&k| vals[k].is_finite())
        .filter_map(|k| {
            let a = ds.angles(k);
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            if !g.visible() {
                return None;
            }
            let f = model.brdf(&g);
            let r = if log_loss {
                (g.nl * f).ln_1p() - (g.nl * vals[k]).ln_1p()
            } else {
                f - vals[k]
            };
            let hd = crate::data::merl::std_to_half_diff(a);
            Some([hd[0].to_degrees(), hd[2].to_degrees(), a[0].to_degrees(), r])
        })
        .collect()
}

/// The file names (without extension) of the [`residual_charts`], against θh, θd and θi.
pub const RESIDUAL_FILES: [&str; 3] = ["residual-theta-h", "residual-theta-d", "residual-theta-i"];

/// Residual charts against θh, θd and θi.
pub fn residual_charts(label: &str, pts: &[[f64; 4]]) -> Vec<(String, XyChart)> {
    ["θh", "θd", "θi"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let file = RESIDUAL_FILES[k];
            let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p[k], p[3])).collect();
            let q = binned_quantiles(&xy, 30);
            let line = |label: &str, f: fn(&[f64; 4]) -> f64| LobeSeries {
                label: label.into(),
                points: q.iter().map(|b| (b[0], f(b))).collect(),
                markers: false,
            };
            (
                file.to_string(),
                XyChart {
                    title: format!("Residuals of {label} against {name}"),
                    x_label: format!("{name} (degrees)"),
                    y_label: "residual r (loss units)".into(),
                    series: vec![
                        LobeSeries {
                            label: format!("samples ({})", xy.len()),
                            points: xy,
                            markers: true,
                        },
                        line("binned median", |b| b[2]),
                        line("10 % and 90 % of each bin", |b| b[1]),
                        line("", |b| b[3]),
                    ],
                    log_x: false,
                    log_y: false,
                    hline: Some((0.0, "r = 0".into())),
                },
            )
        })
        .collect()
}

/// Quantiles of y in `bins` equal-width bins of x: (bin centre, 10 %, 50 %, 90 %) for each bin
/// holding at least 5 finite points (nearest-rank quantiles).
pub fn binned_quantiles(xy: &[(f64, f64)], bins: usize) -> Vec<[f64; 4]> {
    let finite: Vec<(f64, f64)> = xy
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    let (lo, hi) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    if finite.is_empty() || bins == 0 || hi <= lo {
        return Vec::new();
    }
    let width = (hi - lo) / bins as f64;
    let mut groups = vec![Vec::new(); bins];
    for (x, y) in finite {
        groups[(((x - lo) / width) as usize).min(bins - 1)].push(y);
    }
    let q = |v: &[f64], p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    groups
        .iter_mut()
        .enumerate()
        .filter(|(_, g)| g.len() >= 5)
        .map(|(i, g)| {
            g.sort_by(f64::total_cmp);
            [
                lo + (i as f64 + 0.5) * width,
                q(g, 0.1),
                q(g, 0.5),
                q(g, 0.9),
            ]
        })
        .collect()
}

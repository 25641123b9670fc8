//! Directional albedo: of a model by quadrature, of the samples by cells of equal projected
//! solid angle, and the chart of both.

use super::{LobeSeries, XyChart};
use crate::data::Dataset;
use crate::model::Model;
use std::f64::consts::PI;

/// Directional albedo ρ(θi) = ∫ f_r cosθo dω_o at θi in degrees
/// ([`crate::model::albedo::directional_albedo`]).
pub fn albedo(model: &Model, theta_i_deg: f64) -> f64 {
    crate::model::albedo::directional_albedo(model, theta_i_deg.to_radians())
}

/// Rings (equal projected solid angle) and relative-azimuth sectors (over the full circle,
/// each sample counted at ±Δφ) of the cells [`measured_albedo`] integrates over.
pub const ALBEDO_CELLS: (usize, usize) = (6, 16);

/// Largest relative difference between the two quadratures of [`measured_albedo`] (sectors
/// as they are, and turned by half a sector) for an estimate to be given.
pub const ALBEDO_AGREEMENT: f64 = 0.05;

/// Directional albedo estimated from the samples themselves, at each incidence angle the
/// sampling allows. The samples within ±2.5° of θi = 0°, 5°, …, 85° are sorted into cells of
/// equal projected solid angle over the outgoing hemisphere: 6 rings with sin²θo = k/6 × 16
/// sectors of relative azimuth, each sample counted at +Δφ and −Δφ (isotropy). Then
/// ρ(θi) ≈ (π / cells) Σ_cells f̄_cell, f̄_cell the mean over the cell's four sub-rings (equal
/// projected solid angle) of their samples' mean f_r, so that a sampling denser in part of a
/// ring (1° steps in θo, or uniform in solid angle) does not weigh that part more.
///
/// A value is given only where the sampling resolves the integrand: every cell holds two
/// samples or more, no sample outweighs all the others of its cell together, and the
/// quadrature with the sectors turned by half a sector agrees within [`ALBEDO_AGREEMENT`].
/// A narrow highlight caught by one column of a coarse grid (MERL's 15° azimuth steps) stands
/// in for far more than its area, and the turned sectors split it differently, so such a θi
/// gets none; nor does a file sampled in the plane of incidence alone. Returns (θi in
/// degrees, ρ).
pub fn measured_albedo(ds: &Dataset, c: usize) -> Vec<(f64, f64)> {
    let vals = ds.brdf_values(c);
    let mut out = Vec::new();
    for k in 0..18 {
        let centre = 5.0 * k as f64;
        // (sin²θo, Δφ in [0, π], f_r) of the samples at this θi.
        let samples: Vec<(f64, f64, f64)> = vals
            .iter()
            .enumerate()
            .filter_map(|(j, v)| {
                let [ti, pi, to, po] = ds.angles(j);
                if !v.is_finite() || (ti.to_degrees() - centre).abs() > 2.5 || to >= 0.5 * PI {
                    return None;
                }
                let dphi = (po - pi).rem_euclid(2.0 * PI);
                let dphi = if dphi > PI { 2.0 * PI - dphi } else { dphi };
                Some((to.sin().powi(2), dphi, *v))
            })
            .collect();
        if let (Some(a), Some(b)) = (
            cell_quadrature(&samples, 0.0),
            cell_quadrature(&samples, 0.5),
        ) && (a - b).abs() <= ALBEDO_AGREEMENT * a.abs()
        {
            out.push((centre, a));
        }
    }
    out
}

/// The cell quadrature of [`measured_albedo`] with the sectors turned by `shift` sectors;
/// `None` where a cell is not resolved.
fn cell_quadrature(samples: &[(f64, f64, f64)], shift: f64) -> Option<f64> {
    const SUB: usize = 4;
    let (rings, sectors) = ALBEDO_CELLS;
    let cells = rings * sectors;
    let mut sum = vec![0.0; cells * SUB];
    let mut count = vec![0usize; cells * SUB];
    let mut peak = vec![0.0f64; cells];
    let width = 2.0 * PI / sectors as f64;
    for &(u, dphi, v) in samples {
        let fine = ((u * (rings * SUB) as f64) as usize).min(rings * SUB - 1);
        let (ring, sub) = (fine / SUB, fine % SUB);
        // At Δφ = 0 or π the two are one direction: count it once.
        let both = [dphi, 2.0 * PI - dphi];
        let phis = if dphi == 0.0 || dphi == PI {
            &both[..1]
        } else {
            &both[..]
        };
        for &phi in phis {
            let sector = ((phi / width + shift).floor() as usize) % sectors;
            let cell = ring * sectors + sector;
            sum[cell * SUB + sub] += v;
            count[cell * SUB + sub] += 1;
            peak[cell] = peak[cell].max(v);
        }
    }
    let mut rho = 0.0;
    for cell in 0..cells {
        let subs = cell * SUB..(cell + 1) * SUB;
        let n: usize = count[subs.clone()].iter().sum();
        let raw: f64 = sum[subs.clone()].iter().sum();
        if n < 2 || 2.0 * peak[cell] > raw {
            return None;
        }
        let means: Vec<f64> = subs
            .filter(|&i| count[i] > 0)
            .map(|i| sum[i] / count[i] as f64)
            .collect();
        rho += means.iter().sum::<f64>() / means.len() as f64;
    }
    Some(PI / cells as f64 * rho)
}

/// Albedo chart of a model: ρ(θi) for θi = 0…85°, with the energy limit ρ = 1 marked.
pub fn albedo_chart(
    label: &str,
    model: &Model,
    measured: &[(f64, f64)],
) -> (XyChart, Vec<(f64, f64)>) {
    let pts: Vec<(f64, f64)> = (0..=17)
        .map(|k| (5.0 * k as f64, albedo(model, 5.0 * k as f64)))
        .collect();
    let mut series = vec![LobeSeries {
        label: format!("{model}"),
        points: pts.clone(),
        markers: false,
    }];
    if !measured.is_empty() {
        series.push(LobeSeries {
            label: "estimated from the samples (cell quadrature)".into(),
            points: measured.to_vec(),
            markers: true,
        });
    }
    let chart = XyChart {
        title: format!("Directional albedo of {label}"),
        x_label: "incidence angle θi (degrees)".into(),
        y_label: "directional albedo ρ(θi) = ∫ f_r cosθo dω".into(),
        series,
        log_x: false,
        log_y: false,
        hline: None,
    };
    // The axis follows the curves; the energy limit is drawn only where it is near enough to
    // be read against them (a curve at 0.02–0.3 would otherwise lie on the bottom edge).
    let top = pts.iter().chain(measured).map(|p| p.1).fold(0.0, f64::max);
    let chart = if top > 0.7 {
        XyChart {
            hline: Some((1.0, "energy limit ρ = 1".into())),
            ..chart
        }
    } else {
        XyChart {
            title: format!("{} (energy limit ρ = 1 far above)", chart.title),
            ..chart
        }
    };
    (chart, pts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Distribution, ModelKind};

    #[test]
    fn lambert_albedo_is_pd() {
        for pd in [0.2, 0.5, 0.9] {
            let m = Model::new(ModelKind::Lambert, Distribution::D3, &[pd]).unwrap();
            for ti in [0.0, 30.0, 75.0] {
                assert!(
                    (albedo(&m, ti) - pd).abs() < 1e-3,
                    "pd {pd} θi {ti}: {}",
                    albedo(&m, ti)
                );
            }
        }
    }
}

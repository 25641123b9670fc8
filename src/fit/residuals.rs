//! A fit's residuals, sample by sample: the rows `fit --residuals` writes. The samples are the
//! ones the fit used (finite value, within `max_theta`, positive weight, light and eye above
//! the surface: the filter of the fit's setup), the model is [`FitResult::model_for`]
//! evaluated by [`Model::brdf`], and the residual is the fit's loss ([`Loss`]), so that
//! ½ Σ weight · residual² is the fit's `cost`.

use super::problem::Loss;
use super::result::FitResult;
use super::setup::sample_weights;
use crate::data::Dataset;
use crate::model::{Geometry, Model};
use std::io::Write;

/// One sample of one channel as a fit saw it.
#[derive(Clone, Debug, PartialEq)]
pub struct Residual {
    /// The sample's index in the data set.
    pub sample: usize,
    /// θi, φi, θo, φo in radians.
    pub angles: [f64; 4],
    /// The channel's name ([`Dataset::channel_label`]).
    pub channel: String,
    /// The measured value as f_r (1/sr), converted from the file's quantity.
    pub measured: f64,
    /// The model's f_r at the sample's directions.
    pub model: f64,
    /// The residual in the fit's loss: ln(1 + cosθi f_model) − ln(1 + cosθi f_data) (log) or
    /// f_model − f_data (linear).
    pub residual: f64,
    /// The sample's weight in the loss (1 unless weighted).
    pub weight: f64,
}

/// The residuals of `fit` on the samples of `ds` it used, in sample order for each of its
/// channels (a joint fit of several: channel after channel). `max_theta_deg` is the fit's
/// `--max-theta`. Refused when the fit names a channel the data do not have.
pub fn residuals(
    ds: &Dataset,
    fit: &FitResult,
    max_theta_deg: Option<f64>,
) -> Result<Vec<Residual>, String> {
    let names: Vec<String> = (0..ds.channels.len())
        .map(|c| ds.channel_label(c))
        .collect();
    // A channel name may itself hold a comma: the whole label first.
    let wanted: Vec<&str> = if names.contains(&fit.channel) {
        vec![fit.channel.as_str()]
    } else {
        fit.channel.split(',').collect()
    };
    let weights = sample_weights(ds, fit.weights);
    let max = max_theta_deg.map_or(f64::INFINITY, f64::to_radians);
    let mut out = Vec::new();
    for (j, want) in wanted.iter().enumerate() {
        let c = names.iter().position(|n| n == want).ok_or_else(|| {
            format!(
                "the fit is of channel {want}, which the data do not have (they have {})",
                names.join(", ")
            )
        })?;
        let m: Model = fit.model_for(j);
        for k in 0..ds.len() {
            let a = ds.angles(k);
            let (si, ci) = a[0].sin_cos();
            let (so, co) = a[2].sin_cos();
            let v = ds.channels[c].values[k] * ds.quantity.to_brdf_factor(ci);
            let w = weights.as_ref().map_or(1.0, |w| w[k]);
            // The fit's own filter (setup's fill_rows).
            let g = Geometry::from_cosines(ci, co, si * so * (a[3] - a[1]).cos() + ci * co);
            if !(v.is_finite() && !(a[0] > max) && !(a[2] > max) && w > 0.0 && g.visible()) {
                continue;
            }
            let f = m.brdf(&g);
            out.push(Residual {
                sample: k,
                angles: a,
                channel: want.to_string(),
                measured: v,
                model: f,
                residual: fit.loss.term(f, ci).0 - fit.loss.target(v, ci),
                weight: w,
            });
        }
    }
    Ok(out)
}

/// Write residual rows as CSV: the angles in degrees under brdfit's column names
/// (`theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg`), then `model` (when `models` is given: each
/// row's fit label, for a file of several fits), `channel`, `measured_brdf`, `model_brdf` (f_r
/// in 1/sr), `residual` and `weight`. `comments` go first as `#` lines.
pub fn write_residuals_csv(
    w: &mut dyn Write,
    comments: &[String],
    fits: &[(String, Vec<Residual>)],
    models: bool,
) -> std::io::Result<()> {
    use crate::data::degrees;
    for c in comments {
        writeln!(w, "# {}", c.replace(['\n', '\r'], " "))?;
    }
    write!(w, "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,")?;
    if models {
        write!(w, "model,")?;
    }
    writeln!(w, "channel,measured_brdf,model_brdf,residual,weight")?;
    for (label, rows) in fits {
        for r in rows {
            let a = r.angles.map(degrees);
            write!(w, "{},{},{},{},", a[0], a[1], a[2], a[3])?;
            if models {
                write!(w, "{},", csv_field(label))?;
            }
            writeln!(
                w,
                "{},{},{},{},{}",
                csv_field(&r.channel),
                r.measured,
                r.model,
                r.residual,
                r.weight
            )?;
        }
    }
    Ok(())
}

/// A text field of a CSV row, quoted where it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// What the `residual` column of a fit in `loss` is, for the file's header.
pub fn residual_definition(loss: Loss) -> &'static str {
    match loss {
        Loss::Log => "residual = ln(1 + cosθi model_brdf) − ln(1 + cosθi measured_brdf) (log loss)",
        Loss::Linear => "residual = model_brdf − measured_brdf (linear loss)",
        Loss::Pixel => {
            "residual = φ(cosθi model_brdf) − φ(cosθi measured_brdf), φ the sRGB encoding clipped at 1 (pixel loss)"
        }
    }
}

/// Whether `fit` can have been made from `ds`: refused (`Err`, with what differs) where the
/// fit used more samples of its channel than `ds` has usable; a note (`Ok(Some)`) where it
/// used as many but its cost on them (each sample's residual by [`residuals`], without
/// `--max-theta`) is not the cost it reports — a fit of other values at the same angles, or
/// a fit file whose parameters were edited, which is still a model to draw. Fewer samples
/// than usable (a fit with `--max-theta`) and a fit of channels `ds` lacks are not judged
/// here (`Ok(None)`).
pub fn check_fitted_to(ds: &Dataset, fit: &FitResult) -> Result<Option<String>, String> {
    let Ok(rows) = residuals(ds, fit, None) else {
        return Ok(None);
    };
    let (m, used) = (rows.len(), fit.samples_used);
    if used > m {
        return Err(format!(
            "the {} fit used {used} samples of channel {}, and these data have {m} usable",
            fit.label(),
            fit.channel
        ));
    }
    let cost = 0.5
        * rows
            .iter()
            .map(|r| r.weight * r.residual * r.residual)
            .sum::<f64>();
    // The fit's own kernels and Model::brdf part in the 9th digit at worst (tests/it).
    if used == m && (cost - fit.cost).abs() > 1e-6 * fit.cost.abs().max(1e-300) {
        return Ok(Some(format!(
            "the {} fit reports cost {} on {used} samples of channel {}, and its cost on these \
             data's {m} is {}",
            fit.label(),
            crate::model::significant(fit.cost, 6),
            fit.channel,
            crate::model::significant(cost, 6)
        )));
    }
    Ok(None)
}

//! The stability heatmap: configurations against methods, each cell the share of starts
//! reaching the global minimum, failures by kind.

use super::stability::{StabilityRow, configurations, stability_row};
use crate::fit::lsq::Method;

/// The stability heatmap: one row per configuration (noise × sampling pattern), one column
/// per method ([`Method::ALL`]), in two panels: with the global initialisation, and from the
/// random start alone. Each cell is coloured by the share of starts reaching the global
/// minimum and labelled `hits/starts` with the failures by kind (b wrong basin, s stalled,
/// ⊥ at or out of a bound, ∞ non-finite).
#[derive(Clone, Debug)]
pub struct StabilityHeatmap {
    /// Title.
    pub title: String,
    /// Row labels, top to bottom.
    pub rows: Vec<String>,
    /// The methods of the columns, left to right.
    pub cols: Vec<Method>,
    /// Panels, top to bottom: (title, global initialisation on, cells row-major).
    pub panels: Vec<(String, bool, Vec<HeatCell>)>,
}

/// One heatmap cell: hits, starts and its label.
pub type HeatCell = (usize, usize, String);

/// [`StabilityHeatmap`] of the study's rows.
pub fn stability_chart(title: &str, rows: &[StabilityRow]) -> StabilityHeatmap {
    let configs = configurations(rows);
    let panel = |global: bool| {
        let mut cells = Vec::new();
        for &config in &configs {
            for m in Method::ALL {
                cells.push(stability_row(rows, config, m, global).map_or(
                    (0, 0, "–".into()),
                    |r| {
                        let mut why = Vec::new();
                        for (n, mark) in [
                            (r.wrong_basin, "b"),
                            (r.stalled, "s"),
                            (r.at_bound, "⊥"),
                            (r.failures, "∞"),
                        ] {
                            if n > 0 {
                                why.push(format!("{n}{mark}"));
                            }
                        }
                        (
                            r.hits,
                            r.starts,
                            format!("{}/{} {}", r.hits, r.starts, why.join(" ")),
                        )
                    },
                ));
            }
        }
        cells
    };
    StabilityHeatmap {
        title: title.to_string(),
        rows: configs
            .iter()
            .enumerate()
            .map(|(k, (n, p))| format!("{}. {:.0} % noise, {}", k + 1, n * 100.0, p.name()))
            .collect(),
        cols: Method::ALL.to_vec(),
        panels: vec![
            (
                "with the global initialisation (grid, then the local method)".into(),
                true,
                panel(true),
            ),
            ("from the random start alone".into(), false, panel(false)),
        ],
    }
}

/// Geometry of the heatmap: left margin, top of the first panel, cell width and height, and
/// the height of a panel's heading.
const HEAT: (i32, i32, i32, i32, i32) = (240, 60, 118, 26, 74);

impl crate::plot::Chart for StabilityHeatmap {
    fn size(&self) -> (u32, u32) {
        let (left, top, cw, ch, head) = HEAT;
        let panel = head + ch * self.rows.len() as i32;
        (
            (left + cw * self.cols.len() as i32 + 12) as u32,
            (top + panel * self.panels.len() as i32 + 8) as u32,
        )
    }

    fn draw<DB: plotters::prelude::DrawingBackend>(
        &self,
        root: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    ) -> anyhow::Result<()> {
        use plotters::prelude::*;
        root.fill(&WHITE).map_err(crate::plot::err)?;
        let (left, top, cw, ch, head) = HEAT;
        let font = |size: f64| ("sans-serif", size).into_font();
        let text = |s: &str, at: (i32, i32), size: f64| {
            root.draw(&Text::new(s.to_string(), at, font(size)))
                .map_err(crate::plot::err)
        };
        text(&self.title, (12, 10), 18.0)?;
        text(
            "cell: starts reaching the global minimum / starts; failures: b wrong basin, s stalled, ⊥ at or out of a bound, ∞ non-finite",
            (12, 36),
            12.0,
        )?;
        for (p, (title, _, cells)) in self.panels.iter().enumerate() {
            let y0 = top + p as i32 * (head + ch * self.rows.len() as i32);
            text(title, (12, y0 + 14), 15.0)?;
            // Two-line column heads: whose solver, then which.
            for (c, m) in self.cols.iter().enumerate() {
                let (who, what) = match m.name().strip_prefix("argmin-") {
                    Some(rest) => ("argmin", rest),
                    None => ("brdfit", m.name()),
                };
                let x = left + c as i32 * cw + 6;
                text(who, (x, y0 + 38), 12.0)?;
                text(what, (x, y0 + 53), 13.0)?;
            }
            for (r, label) in self.rows.iter().enumerate() {
                let y = y0 + head + r as i32 * ch;
                text(label, (12, y + 6), 13.0)?;
                for c in 0..self.cols.len() {
                    let (hits, starts, label) = &cells[r * self.cols.len() + c];
                    let share = if *starts > 0 {
                        *hits as f64 / *starts as f64
                    } else {
                        0.0
                    };
                    // Red (none) through yellow to green (all).
                    let colour = RGBColor(
                        (255.0 * (1.0 - share).clamp(0.0, 1.0).sqrt()) as u8,
                        (200.0 * share.sqrt()) as u8 + 40,
                        90,
                    );
                    let x = left + c as i32 * cw;
                    root.draw(&Rectangle::new(
                        [(x, y), (x + cw - 2, y + ch - 2)],
                        colour.mix(0.55).filled(),
                    ))
                    .map_err(crate::plot::err)?;
                    text(label, (x + 5, y + 6), 13.0)?;
                }
            }
        }
        Ok(())
    }
}

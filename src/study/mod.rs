//! Studies: where each method is fast, accurate, or fails.
//!
//! - [`speed_accuracy`]: every method × model on one data set — fit time and work against final
//!   cost and, with a known truth, parameter error; the Pareto front of time against cost.
//! - [`stability`]: for each method, the share of seeded random starts that reach the global
//!   minimum, with and without the global initialisation, across noise levels and sampling
//!   patterns of synthetic data drawn from the data set's own Torrance–Sparrow fit (or its
//!   known truth).

mod render;
mod speed;
mod speed_chart;
mod stability;
mod stability_chart;

use crate::data::Dataset;
use crate::model::{Distribution, Model, ModelKind};

pub use render::{
    RenderRow, rays_at_error, render_chart, render_study, render_study_scenes,
    render_study_scenes_with_progress, render_study_with_progress, render_tables,
};
pub use speed::{
    ONCE_EVALUATIONS, ONCE_STARTS, SpeedRow, pareto, runs_once, scipy_peer, speed_accuracy,
    speed_accuracy_with_progress, speed_tables, study_models,
};
pub use speed_chart::{COST_FLOOR, SpeedChart, SpeedPanel, SpeedPoint, method_colour, speed_chart};
pub use stability::{
    Pattern, STABILITY_CELLS, STABILITY_CONFIGURATIONS, StabilityRow, stability, stability_tables,
    stability_with_progress,
};
pub use stability_chart::{HeatCell, StabilityHeatmap, stability_chart};

/// The model a synthetic file was made from, from its `truth:` comment (written by
/// `brdfit simulate`), if any.
pub fn parse_truth(ds: &Dataset) -> Option<Model> {
    let line = ds
        .meta
        .comments
        .iter()
        .find_map(|c| c.strip_prefix("truth:"))?;
    let mut words = line.split_whitespace();
    let kind = ModelKind::parse(words.next()?)?;
    let mut dist = Distribution::D3;
    let mut set = Vec::new();
    for w in words {
        if let Some(d) = w.strip_prefix('(').and_then(|d| d.strip_suffix(')')) {
            dist = Distribution::parse(d)?;
        } else if let Some((k, v)) = w.split_once('=') {
            set.push((k.to_string(), v.parse().ok()?));
        }
    }
    Model::from_named(kind, dist, &set).ok()
}

//! A fit file's format, below the fitter and every consumer of fits: its JSON read strictly
//! (duplicate keys refused), the check of one fit object (known keys, the model's parameters
//! each present once, finite and within their declared [`ParamSpec`](crate::model::ParamSpec)
//! bounds), what a consumer asks of a file ([`Want`]), channel names, and the picked channels
//! as one colour material ([`Colour`]). Reading fits into `FitResult`s and picking among them
//! is `fit`'s (`fit::read_fit_file`, `fit::pick`).

mod check;
mod colour;
mod strict;

pub(crate) use check::check_fit_object;
pub use colour::{ChannelModel, Colour, colour_of};
pub use strict::parse_strict;

use crate::model::{Distribution, ModelKind};

/// Directional albedo above 1 by more than this marks a fit not usable (`fit::physical`,
/// rule 2), and a scene material given by `params` is rendered with a warning: ten times the
/// albedo quadrature's worst error on a sharp lobe (tests/it/albedo.rs).
pub const ALBEDO_MARGIN: f64 = 1e-3;

/// A fit file that cannot be used, with the fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}\n  fix: {fix}")]
pub struct FitFileError {
    /// What is wrong (naming the key or the line).
    pub message: String,
    /// What to do.
    pub fix: String,
}

/// A [`FitFileError`] of `message` and `fix`.
pub(crate) fn err(message: impl Into<String>, fix: impl Into<String>) -> FitFileError {
    FitFileError {
        message: message.into(),
        fix: fix.into(),
    }
}

/// The fix for a file that is not a fit file at all.
pub(crate) const WRITTEN_BY: &str = "give a file written by brdfit fit --json (or brdfit report)";

/// How a JSON value is named in an error ("a number", "a list", …).
pub(crate) fn kind_of(v: &serde_json::Value) -> &'static str {
    match v {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Number(_) => "a number",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Array(_) => "a list",
        serde_json::Value::Object(_) => "an object",
    }
}

/// What a consumer asks of a fit file: a model (and distribution), a channel, and whether a fit
/// marked not usable may be used.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Want {
    /// The model to take (None: the only one, or the recommended one of a `--model all` file).
    pub model: Option<ModelKind>,
    /// Its distribution (None: d3 where the file holds several, else the one it holds).
    pub dist: Option<Distribution>,
    /// The channel to take (None: every channel in the file).
    pub channel: Option<String>,
    /// Use a fit marked not usable (or not verified) anyway.
    pub allow_unusable: bool,
}

/// True when a channel name names no channel but the file's one quantity (a single-channel
/// CSV's `brdf` column and the like): any two such names are the same channel.
pub fn is_unnamed_channel(c: &str) -> bool {
    matches!(c, "" | "value" | "brdf" | "brdf_cos" | "rfactor")
}

/// Whether a fit's channel `fit` is the data's channel `data`.
pub fn same_channel(fit: &str, data: &str) -> bool {
    let y = |c: &str| {
        ["y", "cie-y", "ciey"]
            .iter()
            .any(|n| c.eq_ignore_ascii_case(n))
    };
    fit.eq_ignore_ascii_case(data)
        || (is_unnamed_channel(fit) && is_unnamed_channel(data))
        || (y(fit) && y(data))
}

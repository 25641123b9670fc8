//! The check of one fit object before it is read: known keys, a known model and
//! distribution, and every parameter of the model present once, finite and within its bounds.

use super::{FitFileError, WRITTEN_BY, err, kind_of};
use crate::model::{Distribution, Model, ModelKind};

/// Keys a fit object may have (every version of brdfit wrote a subset of these).
const KEYS: &[&str] = &[
    "model",
    "distribution",
    "loss",
    "method",
    "channel",
    "weights",
    "weighted",
    "params",
    "stderr",
    "correlation",
    "free",
    "cost",
    "rmse",
    "samples_used",
    "iterations",
    "evaluations",
    "termination",
    "seconds",
    "geometry_seconds",
    "solve_seconds",
    "statistics_seconds",
    "warnings",
    "bic",
    "aic",
    "n_free",
    "ranges",
    "intervals",
    "interval_level",
    "at_bound",
    "kkt_violation",
    "verified",
    "verify_starts",
    "verify_best_cost",
    "verify_loss",
    "unusable",
];

/// Check one fit object before it is read: known keys, a known model and distribution, and
/// `params` holding each parameter of the model once (per channel for a joint fit of
/// several channels, `NAME_<channel>`), finite and within the model's declared bounds.
pub(crate) fn check_fit_object(v: &serde_json::Value) -> Result<(), FitFileError> {
    let obj = v.as_object().ok_or_else(|| {
        err(
            format!("a fit is {}, not an object", kind_of(v)),
            WRITTEN_BY,
        )
    })?;
    if let Some(k) = obj.keys().find(|k| !KEYS.contains(&k.as_str())) {
        return Err(err(
            format!("unknown key '{k}'"),
            format!(
                "remove it (or correct its spelling); a fit's keys are {}",
                KEYS.join(", ")
            ),
        ));
    }
    let (kind, dist) = model_and_dist(obj)?;
    let channels: Vec<&str> = match obj.get("channel") {
        None => vec![""],
        Some(serde_json::Value::String(s)) => s.split(',').collect(),
        Some(x) => {
            return Err(err(
                format!("key 'channel' is {}, not a channel name", kind_of(x)),
                "write the channel's name, e.g. \"channel\": \"g\"",
            ));
        }
    };
    let params = match obj.get("params") {
        Some(serde_json::Value::Object(p)) => p,
        None => {
            return Err(err(
                "no 'params' key",
                format!(
                    "add \"params\": {{{}}} with the fitted values",
                    names_text(kind, dist)
                ),
            ));
        }
        Some(x) => {
            return Err(err(
                format!("key 'params' is {}, not an object", kind_of(x)),
                format!("write \"params\": {{{}}}", names_text(kind, dist)),
            ));
        }
    };
    check_params(params, kind, dist, &channels)?;
    for key in ["unusable", "warnings"] {
        if let Some(x) = obj.get(key)
            && !x
                .as_array()
                .is_some_and(|a| a.iter().all(serde_json::Value::is_string))
        {
            return Err(err(
                format!("key '{key}' is {}, not a list of strings", kind_of(x)),
                format!("write \"{key}\": [\"…\"] (or [] )"),
            ));
        }
    }
    if let Some(x) = obj.get("verified")
        && !x.is_boolean()
    {
        return Err(err(
            format!("key 'verified' is {}, not true or false", kind_of(x)),
            "write \"verified\": true or false",
        ));
    }
    Ok(())
}

/// The object's model and distribution (D3 where it gives none), each known and the
/// distribution one the model takes.
fn model_and_dist(
    obj: &serde_json::Map<String, serde_json::Value>,
) -> Result<(ModelKind, Distribution), FitFileError> {
    let model_text = match obj.get("model") {
        None => return Err(err("no 'model' key", model_fix())),
        Some(serde_json::Value::String(s)) => s.as_str(),
        Some(x) => {
            return Err(err(
                format!("key 'model' is {}, not a model name", kind_of(x)),
                model_fix(),
            ));
        }
    };
    let kind = ModelKind::parse(model_text).ok_or_else(|| {
        err(
            format!("key 'model': unknown model '{model_text}'"),
            model_fix(),
        )
    })?;
    let dist = match obj.get("distribution") {
        // Fit JSON of the earliest versions has no distribution: D3 was the only one.
        None => Distribution::D3,
        Some(x) => {
            let d = x.as_str().and_then(Distribution::parse).ok_or_else(|| {
                let names: Vec<&str> = ModelKind::TorranceSparrow
                    .distributions()
                    .iter()
                    .map(|d| d.name())
                    .collect();
                err(
                    format!("key 'distribution': unknown distribution {x}"),
                    format!(
                        "write one of {} (d3 for models without a choice)",
                        names.join(", ")
                    ),
                )
            })?;
            if kind.has_distribution() && !kind.distributions().contains(&d) {
                return Err(err(
                    format!(
                        "key 'distribution': {kind} takes no distribution {}",
                        d.name()
                    ),
                    format!(
                        "write one of {}",
                        kind.distributions()
                            .iter()
                            .map(|d| d.name())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
            d
        }
    };
    Ok((kind, dist))
}

/// `params` holding each parameter of `kind` once (per channel for a joint fit of several
/// `channels`, `NAME_<channel>`), finite, within the model's declared bounds, and with the
/// lobes in order.
fn check_params(
    params: &serde_json::Map<String, serde_json::Value>,
    kind: ModelKind,
    dist: Distribution,
    channels: &[&str],
) -> Result<(), FitFileError> {
    // Each parameter once: under its own name, or (a joint fit) once per channel.
    let specs = kind.params(dist);
    let mut expected: Vec<(String, &crate::model::ParamSpec)> = Vec::new();
    for spec in specs {
        if params.contains_key(spec.name) || channels.len() == 1 {
            expected.push((spec.name.to_string(), spec));
        } else {
            for c in channels {
                expected.push((format!("{}_{c}", spec.name), spec));
            }
        }
    }
    for k in params.keys() {
        if !expected.iter().any(|(e, _)| e == k) {
            return Err(err(
                format!("params: unknown parameter '{k}' for {}", kind.label(dist)),
                format!(
                    "remove it; {} has {}",
                    kind.label(dist),
                    expected
                        .iter()
                        .map(|(e, _)| e.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
    }
    for (name, spec) in &expected {
        let x = params.get(name).ok_or_else(|| {
            err(
                format!(
                    "params: parameter '{name}' of {} is missing",
                    kind.label(dist)
                ),
                format!("add \"{name}\": VALUE ({})", spec.bounds_text()),
            )
        })?;
        let val = x.as_f64().ok_or_else(|| {
            err(
                format!("params.{name} is {}, not a finite number", kind_of(x)),
                format!("write a number ({})", spec.bounds_text()),
            )
        })?;
        if !spec.in_fit_box(val) {
            return Err(err(
                format!(
                    "params.{name} = {} is outside the range a fit can return: {}",
                    crate::model::exact(val),
                    spec.fit_box_text()
                ),
                format!("refit, or write a value with {}", spec.fit_box_text()),
            ));
        }
    }
    // The lobes' order (ggx-smith-2: alpha1 ≤ alpha2), per channel.
    for c in channels {
        let vals: Vec<f64> = specs
            .iter()
            .map(|spec| {
                let own = params.get(spec.name);
                let per = params.get(&format!("{}_{c}", spec.name));
                own.or(per).and_then(|x| x.as_f64()).unwrap_or(f64::NAN)
            })
            .collect();
        if let Err(e) = Model::check_order(kind, &vals) {
            let crate::model::ModelError::Order { what, fix, .. } = e else {
                continue;
            };
            let on = if channels.len() > 1 {
                format!(" (channel {c})")
            } else {
                String::new()
            };
            return Err(err(format!("params: {what}{on}"), fix));
        }
    }
    Ok(())
}

fn model_fix() -> String {
    format!("write \"model\": one of {}", ModelKind::names())
}

fn names_text(kind: ModelKind, dist: Distribution) -> String {
    kind.param_names(dist)
        .iter()
        .map(|n| format!("\"{n}\": …"))
        .collect::<Vec<_>>()
        .join(", ")
}

//! Fit files read strictly, and the one place a consumer picks the fit it uses.
//!
//! [`read_fit_file`] parses the text (refusing duplicate keys, which `serde_json::Value` would
//! silently collapse), checks every fit with [`FitResult::from_json`] (known keys, the model's
//! parameters each present once, finite and within their declared [`ParamSpec`] bounds) and
//! [`pick`] chooses, by model and channel, the fits a consumer uses, refusing a fit marked not
//! usable unless asked to take it.

use super::{FitResult, rank};
use crate::model::{Distribution, Model, ModelKind};
use serde::de::{self, Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use std::fmt;

/// A fit file that cannot be used, with the fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}\n  fix: {fix}")]
pub struct FitFileError {
    /// What is wrong (naming the key or the line).
    pub message: String,
    /// What to do.
    pub fix: String,
}

fn err(message: impl Into<String>, fix: impl Into<String>) -> FitFileError {
    FitFileError {
        message: message.into(),
        fix: fix.into(),
    }
}

/// The fix for a file that is not a fit file at all.
const WRITTEN_BY: &str = "give a file written by brdfit fit --json (or brdfit report)";

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
    "at_bound",
    "kkt_violation",
    "verified",
    "verify_starts",
    "verify_best_cost",
    "verify_loss",
    "unusable",
];

/// A JSON value parsed with duplicate keys refused (serde_json reports the line and column).
struct Strict(serde_json::Value);

impl<'de> Deserialize<'de> for Strict {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(StrictVisitor)
    }
}

struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = Strict;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Strict, E> {
        Ok(Strict(v.into()))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Strict, E> {
        Ok(Strict(v.into()))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Strict, E> {
        Ok(Strict(v.into()))
    }
    fn visit_f64<E>(self, v: f64) -> Result<Strict, E> {
        Ok(Strict(v.into()))
    }
    fn visit_str<E>(self, v: &str) -> Result<Strict, E> {
        Ok(Strict(v.into()))
    }
    fn visit_unit<E>(self) -> Result<Strict, E> {
        Ok(Strict(serde_json::Value::Null))
    }
    fn visit_none<E>(self) -> Result<Strict, E> {
        Ok(Strict(serde_json::Value::Null))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut a: A) -> Result<Strict, A::Error> {
        let mut out = Vec::new();
        while let Some(Strict(v)) = a.next_element()? {
            out.push(v);
        }
        Ok(Strict(out.into()))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<Strict, A::Error> {
        let mut out = serde_json::Map::new();
        while let Some(k) = a.next_key::<String>()? {
            if out.contains_key(&k) {
                return Err(de::Error::custom(format!(
                    "duplicate key '{k}' (a JSON object names each key once; which value is meant?)"
                )));
            }
            let Strict(v) = a.next_value()?;
            out.insert(k, v);
        }
        Ok(Strict(out.into()))
    }
}

/// Parse JSON text with duplicate keys refused.
pub fn parse_strict(text: &str) -> Result<serde_json::Value, FitFileError> {
    serde_json::from_str::<Strict>(text)
        .map(|s| s.0)
        .map_err(|e| {
            let fix = if e.to_string().starts_with("duplicate key") {
                "keep one of the two entries".to_string()
            } else {
                WRITTEN_BY.to_string()
            };
            err(format!("not a valid fit JSON: {e}"), fix)
        })
}

/// Read a fit file's text: one fit object, or `{"fits": [...]}` with at least one fit. Every
/// fit is checked by [`FitResult::from_json`]; the error names the fit (`fits[2]`) and key.
pub fn read_fit_file(text: &str) -> Result<Vec<FitResult>, FitFileError> {
    let v = parse_strict(text)?;
    let obj = v.as_object().ok_or_else(|| {
        err(
            format!("the fit JSON is {}, not an object", kind_of(&v)),
            WRITTEN_BY,
        )
    })?;
    match obj.get("fits") {
        Some(list) => {
            if let Some(k) = obj.keys().find(|k| *k != "fits") {
                return Err(err(
                    format!("key '{k}' beside 'fits': a file of several fits holds only 'fits'"),
                    format!("remove '{k}' (or move it into one of the fits)"),
                ));
            }
            let list = list.as_array().ok_or_else(|| {
                err(
                    format!("key 'fits' is {}, not a list of fits", kind_of(list)),
                    WRITTEN_BY,
                )
            })?;
            if list.is_empty() {
                return Err(err(
                    "key 'fits' is an empty list: the file holds no fit",
                    "write the fits with brdfit fit --json (or give one fit object)",
                ));
            }
            list.iter()
                .enumerate()
                .map(|(i, f)| {
                    FitResult::from_json(f).map_err(|e| FitFileError {
                        message: format!("fits[{i}]: {}", e.message),
                        fix: e.fix,
                    })
                })
                .collect()
        }
        None => Ok(vec![FitResult::from_json(&v)?]),
    }
}

fn kind_of(v: &serde_json::Value) -> &'static str {
    match v {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Number(_) => "a number",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Array(_) => "a list",
        serde_json::Value::Object(_) => "an object",
    }
}

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
    // Each parameter once: under its own name, or (a joint fit) once per channel.
    let specs = kind.params(dist);
    let mut expected: Vec<(String, &crate::model::ParamSpec)> = Vec::new();
    for spec in specs {
        if params.contains_key(spec.name) || channels.len() == 1 {
            expected.push((spec.name.to_string(), spec));
        } else {
            for c in &channels {
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
    for c in &channels {
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

/// One channel of the picked fits: its name, its model, and the fit it comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct PickedChannel {
    /// Channel name (empty or a quantity name such as `brdf` for a single-channel file).
    pub channel: String,
    /// The fitted model of this channel.
    pub model: Model,
    /// The fit it comes from (for a joint fit, the joint fit).
    pub fit: FitResult,
}

/// The fits a consumer uses: one model, one entry per channel in file order, and what was
/// chosen for the user (notes for stderr).
#[derive(Clone, Debug, PartialEq)]
pub struct Picked {
    /// One entry per channel.
    pub channels: Vec<PickedChannel>,
    /// What was chosen without being asked, one sentence each.
    pub notes: Vec<String>,
}

impl Picked {
    /// Model label, e.g. `ggx-smith` or `torrance-sparrow (d3)`.
    pub fn label(&self) -> String {
        self.channels[0].fit.label()
    }

    /// The channel names, comma-separated.
    pub fn channel_names(&self) -> String {
        self.channels
            .iter()
            .map(|c| c.channel.as_str())
            .collect::<Vec<_>>()
            .join(",")
    }
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

/// Pick from a fit file's fits what `want` asks: the fits of one model, one per channel (every
/// channel of the file, or `want.channel`). Without `want.model` a file of one model gives that
/// model; a file of several (`fit --model all`) gives the recommended one (fewest parameters
/// within 2 BIC of the best, over the channels: the model most channels recommend), said in
/// [`Picked::notes`]. A fit marked not usable, or whose random-start verification failed, is
/// refused unless `want.allow_unusable`.
pub fn pick(fits: &[FitResult], want: &Want) -> Result<Picked, FitFileError> {
    // Channels in file order, each with its fits (joint fits expanded per channel).
    let mut channels: Vec<(String, Vec<(usize, usize)>)> = Vec::new();
    for (i, f) in fits.iter().enumerate() {
        for (c, name) in f.channel.split(',').enumerate() {
            match channels.iter_mut().find(|(n, _)| n == name) {
                Some((_, v)) => v.push((i, c)),
                None => channels.push((name.to_string(), vec![(i, c)])),
            }
        }
    }
    let names = || {
        channels
            .iter()
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Some(want_c) = &want.channel {
        let keep: Vec<_> = channels
            .iter()
            .filter(|(n, _)| same_channel(n, want_c))
            .cloned()
            .collect();
        if keep.is_empty() {
            return Err(err(
                format!(
                    "no fit of channel {want_c}: the file holds channel(s) {}",
                    names()
                ),
                format!(
                    "pick one of them with --channel, or fit channel {want_c}: brdfit fit DATA --channel {want_c} --json OUT"
                ),
            ));
        }
        channels = keep;
    }
    // The models on offer, in file order.
    let mut models: Vec<(ModelKind, Distribution)> = Vec::new();
    for f in fits {
        if !models.contains(&(f.model, f.dist)) {
            models.push((f.model, f.dist));
        }
    }
    let offered = || {
        models
            .iter()
            .map(|(k, d)| k.label(*d))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut notes = Vec::new();
    // A distribution asked without a model names the model that takes it (torrance-sparrow):
    // taking the file's recommendation would silently drop --distribution.
    let want_model = want.model.or_else(|| {
        let d = want.dist?;
        let kind = *ModelKind::ALL
            .iter()
            .find(|k| k.has_distribution() && k.distributions().contains(&d))?;
        notes.push(format!(
            "using the {} fit: --distribution {} is a {kind} option",
            kind.label(d),
            d.name()
        ));
        Some(kind)
    });
    let chosen: (ModelKind, Distribution) = match want_model {
        Some(kind) => {
            let of_kind: Vec<_> = models.iter().filter(|(k, _)| *k == kind).collect();
            let exact = of_kind.iter().find(|(_, d)| {
                Some(*d) == want.dist || (want.dist.is_none() && *d == Distribution::D3)
            });
            match (exact, of_kind.as_slice()) {
                (Some(m), _) => {
                    if want.dist.is_none() && of_kind.len() > 1 {
                        notes.push(format!(
                            "using {} of the file's {} fits ({}); choose another with --distribution",
                            kind.label(m.1),
                            kind,
                            of_kind
                                .iter()
                                .map(|(_, d)| d.name())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ));
                    }
                    **m
                }
                (None, [only]) if want.dist.is_none() => **only,
                _ => {
                    let asked = match want.dist {
                        Some(d) if kind.has_distribution() => kind.label(d),
                        _ => kind.to_string(),
                    };
                    let flags = match want.dist {
                        Some(d) if kind.has_distribution() => {
                            format!("--model {kind} --distribution {}", d.name())
                        }
                        _ => format!("--model {kind}"),
                    };
                    return Err(err(
                        format!("no fit of model {asked}: the file holds {}", offered()),
                        format!(
                            "pick one of them with --model (and --distribution), or fit that model: brdfit fit DATA {flags} --json OUT"
                        ),
                    ));
                }
            }
        }
        None if models.len() == 1 => models[0],
        None => {
            // The recommendation of each channel; the model most channels recommend.
            let mut votes: Vec<((ModelKind, Distribution), usize)> = Vec::new();
            for (_, entries) in &channels {
                let row: Vec<FitResult> = entries.iter().map(|(i, _)| fits[*i].clone()).collect();
                if let (_, Some(r)) = rank(&row) {
                    let m = (row[r].model, row[r].dist);
                    match votes.iter_mut().find(|(k, _)| *k == m) {
                        Some((_, n)) => *n += 1,
                        None => votes.push((m, 1)),
                    }
                }
            }
            let Some(&(m, n)) = votes.iter().max_by_key(|(_, n)| *n) else {
                return Err(err(
                    format!(
                        "the file holds {} fits and none is usable, so none is recommended",
                        offered()
                    ),
                    "pick one with --model and add --allow-unusable to use it anyway",
                ));
            };
            let of = if channels.len() > 1 {
                format!(" ({n} of {} channels recommend it)", channels.len())
            } else {
                String::new()
            };
            notes.push(format!(
                "using the recommended model {}{of} of the file's {}; choose another with --model",
                m.0.label(m.1),
                offered()
            ));
            m
        }
    };
    let mut out = Vec::new();
    for (name, entries) in &channels {
        let Some(&(i, c)) = entries
            .iter()
            .find(|(i, _)| (fits[*i].model, fits[*i].dist) == chosen)
        else {
            return Err(err(
                format!(
                    "channel {name} has no fit of {} in the file",
                    chosen.0.label(chosen.1)
                ),
                "pick that channel's model with --model, or one channel with --channel",
            ));
        };
        let f = &fits[i];
        let mut why: Vec<String> = f.unusable.clone();
        if f.verification.as_ref().is_some_and(|v| !v.verified) && why.is_empty() {
            why.push("its random-start verification found a lower cost (verified: false)".into());
        }
        let model = f.model_for(c);
        // The declared bounds are the fitter's box (pd may exceed 1, ps is open above): the
        // material must also exist (pd ≤ 1, directional albedo ≤ 1, no lobe held down by F ≈ 0).
        for p in super::physical::model_problems(&model) {
            if !why.contains(&p) {
                why.push(p);
            }
        }
        if !why.is_empty() {
            if !want.allow_unusable {
                return Err(err(
                    format!(
                        "the {} fit of channel {name} is marked not usable: {}",
                        f.label(),
                        why.join("; ")
                    ),
                    "refit (e.g. with --verify 8), pick another with --model, or add --allow-unusable to use it anyway",
                ));
            }
            notes.push(format!(
                "using the {} fit of channel {name} although it is marked not usable (--allow-unusable): {}",
                f.label(),
                why.join("; ")
            ));
        }
        out.push(PickedChannel {
            channel: name.clone(),
            model,
            fit: f.clone(),
        });
    }
    Ok(Picked {
        channels: out,
        notes,
    })
}

/// Pick one channel for a consumer that draws or uses one: `want.channel`, else the data's
/// channel `data_channel` when given, else the file's only channel, else (an RGB or spectral
/// file) the channel the report uses (CIE Y, else green), said in the notes; refused with the
/// fix when the file holds no fit of the data's channel.
pub fn pick_one(
    fits: &[FitResult],
    want: &Want,
    data_channel: Option<&str>,
) -> Result<Picked, FitFileError> {
    if let (Some(w), Some(d)) = (&want.channel, data_channel)
        && !same_channel(w, d)
    {
        return Err(err(
            format!("--channel {w} picks a fit of channel {w}, but the data's channel is {d}"),
            format!("load the data's channel {w} too (--channel {w} applies to both)"),
        ));
    }
    let target = want.channel.as_deref().or(data_channel);
    match target {
        Some(c) => {
            let held = channel_list(fits);
            if let Some(d) = data_channel
                && want.channel.is_none()
                && !held.split(',').any(|h| same_channel(h, d))
            {
                let first = match held.split(',').next().unwrap_or("") {
                    "y" => "cie-y",
                    c => c,
                };
                let d = if d.is_empty() { "(unnamed)" } else { d };
                return Err(err(
                    format!(
                        "the fit is of channel {held} but the data's channel is {d}: a fit compared with another channel's data is meaningless"
                    ),
                    // Data of one unnamed channel has no channel {first} to load.
                    if d == "(unnamed)" {
                        "fit this data and use that fit: brdfit fit DATA --json OUT".to_string()
                    } else {
                        format!(
                            "load the fit's channel with --channel {first}, or fit channel {d}: brdfit fit DATA --channel {d} --json OUT"
                        )
                    },
                ));
            }
            pick(
                fits,
                &Want {
                    channel: Some(c.to_string()),
                    ..want.clone()
                },
            )
        }
        None => {
            let mut p = pick(
                fits,
                &Want {
                    channel: None,
                    ..want.clone()
                },
            )?;
            if p.channels.len() > 1 {
                let pos = ["cie-y", "y", "g", "green"].iter().find_map(|w| {
                    p.channels
                        .iter()
                        .position(|c| c.channel.eq_ignore_ascii_case(w))
                });
                let Some(pos) = pos else {
                    return Err(err(
                        format!(
                            "the file holds fits of {} channels ({}) and this command uses one",
                            p.channels.len(),
                            p.channel_names()
                        ),
                        "pick one with --channel",
                    ));
                };
                p.notes.push(format!(
                    "the file holds fits of channels {}; using channel {} (choose another with --channel)",
                    p.channel_names(),
                    p.channels[pos].channel
                ));
                let keep = p.channels.swap_remove(pos);
                p.channels = vec![keep];
            }
            Ok(p)
        }
    }
}

fn channel_list(fits: &[FitResult]) -> String {
    let mut v: Vec<&str> = Vec::new();
    for f in fits {
        for c in f.channel.split(',') {
            if !v.contains(&c) {
                v.push(c);
            }
        }
    }
    v.join(",")
}

/// Picked fits as one colour material: a lobe shared by the channels, with each channel's ps
/// and pd in linear sRGB.
#[derive(Clone, Debug, PartialEq)]
pub struct Colour {
    /// The lobe (its ps and pd are those of the reference channel).
    pub model: Model,
    /// The diffuse coefficient pd in linear sRGB.
    pub pd: [f64; 3],
    /// The specular coefficient ps in linear sRGB (0 for a model without one; ps1 of
    /// ggx-smith-2).
    pub ps: [f64; 3],
    /// The second lobe's specular coefficient in linear sRGB (ps2 of ggx-smith-2; 0 for a model
    /// with one lobe).
    pub ps2: [f64; 3],
    /// How the channels became colour, and the compromise where their lobes differ.
    pub notes: Vec<String>,
    /// False when the channels' lobes differ and one stands for all (a compromise).
    pub exact: bool,
}

impl Colour {
    /// One model as a grey material (the same ps and pd in r, g, b).
    pub fn grey(m: &Model) -> Colour {
        Colour {
            model: *m,
            pd: [m.pd(); 3],
            ps: [specular(m, 0); 3],
            ps2: [specular(m, 1); 3],
            notes: vec![],
            exact: true,
        }
    }

    /// True when r, g and b are the same (a grey material).
    pub fn is_grey(&self) -> bool {
        self.pd.iter().all(|&v| v == self.pd[0])
            && self.ps.iter().all(|&v| v == self.ps[0])
            && self.ps2.iter().all(|&v| v == self.ps2[0])
    }

    /// The model of colour channel `c` (0 = red, 1 = green, 2 = blue).
    pub fn channel_model(&self, c: usize) -> Model {
        let mut m = self.model;
        let mut lobe = 0;
        for (i, spec) in m.kind.params(m.dist).iter().enumerate() {
            match spec.role {
                crate::model::Role::Diffuse => m.p[i] = self.pd[c],
                crate::model::Role::Specular => {
                    m.p[i] = if lobe == 0 { self.ps[c] } else { self.ps2[c] };
                    lobe += 1;
                }
                _ => {}
            }
        }
        m
    }
}

/// The `k`-th specular coefficient of `m` (ps, or ps1 and ps2 of ggx-smith-2), 0 if it has none.
fn specular(m: &Model, k: usize) -> f64 {
    m.specs()
        .iter()
        .zip(m.params())
        .filter(|(s, _)| s.role == crate::model::Role::Specular)
        .nth(k)
        .map_or(0.0, |(_, v)| *v)
}

/// A wavelength channel's λ in nm (`550nm` → 550).
fn wavelength(name: &str) -> Option<f64> {
    name.strip_suffix("nm")?.trim().parse().ok()
}

/// CIE 1931 x̄(λ) and z̄(λ) by the multi-lobe fit of Wyman, Sloan & Shirley, "Simple Analytic
/// Approximations to the CIE XYZ Color Matching Functions", JCGT 2(2), 2013, eq. 2 (ȳ comes
/// from the CIE table, [`crate::data::cie_ybar`]).
fn cie_xbar_zbar(l: f64) -> (f64, f64) {
    let g = |mu: f64, s1: f64, s2: f64| {
        let t = (l - mu) / if l < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    (
        1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
        1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8),
    )
}

/// Weights of each channel in linear sRGB: r, g, b channels directly; wavelength channels
/// through the CIE 1931 functions (equal-energy spectrum, XYZ → linear sRGB of IEC 61966-2-1),
/// each of R, G, B normalised so that a spectrum of 1 everywhere is (1, 1, 1).
fn rgb_weights(names: &[&str]) -> Option<(Vec<[f64; 3]>, String)> {
    let lower: Vec<String> = names.iter().map(|n| n.to_ascii_lowercase()).collect();
    let is = |i: usize, a: &str, b: &str| lower[i] == a || lower[i] == b;
    if names.len() == 3 && is(0, "r", "red") && is(1, "g", "green") && is(2, "b", "blue") {
        let w = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        return Some((w, "channels r, g, b as linear RGB".into()));
    }
    let lambdas: Vec<f64> = names.iter().map(|n| wavelength(n)).collect::<Option<_>>()?;
    if lambdas.len() < 3 {
        return None;
    }
    const M: [[f64; 3]; 3] = [
        [3.2406, -1.5372, -0.4986],
        [-0.9689, 1.8758, 0.0415],
        [0.0557, -0.2040, 1.0570],
    ];
    let mut w: Vec<[f64; 3]> = lambdas
        .iter()
        .map(|&l| {
            let (x, z) = cie_xbar_zbar(l);
            let xyz = [x, crate::data::cie_ybar(l), z];
            let mut rgb = [0.0; 3];
            for (k, row) in M.iter().enumerate() {
                rgb[k] = row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2];
            }
            rgb
        })
        .collect();
    for k in 0..3 {
        let s: f64 = w.iter().map(|x| x[k]).sum();
        if s.abs() < 1e-12 {
            return None;
        }
        for x in &mut w {
            x[k] /= s;
        }
    }
    Some((
        w,
        format!(
            "{} wavelength channels through the CIE 1931 functions to linear sRGB (white = a flat spectrum)",
            names.len()
        ),
    ))
}

impl Picked {
    /// The picked channels as one colour material ([`Colour`]): one channel as grey; r, g, b
    /// as themselves; wavelength channels through CIE 1931 to linear sRGB. Where the channels'
    /// lobes (index and shape parameters) differ, the lobe of the brightest-weighted channel
    /// (green, or the wavelength nearest 555 nm) stands for all, with each channel's own ps and
    /// pd, and the notes say so.
    pub fn colour(&self) -> Result<Colour, FitFileError> {
        let ch = &self.channels;
        let model = ch[0].model;
        if ch.len() == 1 {
            return Ok(Colour::grey(&model));
        }
        let names: Vec<&str> = ch.iter().map(|c| c.channel.as_str()).collect();
        let (w, how) = rgb_weights(&names).ok_or_else(|| {
            err(
                format!(
                    "the fits of channels {} do not make a colour (r, g, b or wavelengths are needed)",
                    names.join(", ")
                ),
                "export one channel with --channel",
            )
        })?;
        // The reference lobe: the channel with the largest green weight.
        let reference = (0..ch.len())
            .max_by(|&a, &b| w[a][1].total_cmp(&w[b][1]))
            .unwrap_or(0);
        let mut notes = vec![format!("colour from {how}")];
        let specs = model.kind.params(model.dist);
        let mut differs = Vec::new();
        for (i, spec) in specs.iter().enumerate() {
            if matches!(
                spec.role,
                crate::model::Role::Diffuse | crate::model::Role::Specular
            ) {
                continue;
            }
            let vals: Vec<f64> = ch.iter().map(|c| c.model.p[i]).collect();
            let r = vals[reference];
            if vals
                .iter()
                .any(|v| (v - r).abs() > 1e-9 * r.abs().max(1e-300))
            {
                let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min);
                let hi = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                differs.push(format!(
                    "{} {}…{}",
                    spec.name,
                    crate::model::readable(lo),
                    crate::model::readable(hi)
                ));
            }
        }
        let exact = differs.is_empty();
        // Each channel's (ps, pd): its own where the lobe is shared; otherwise refitted under the
        // reference lobe to that channel's own model (keeping a channel's ps with another
        // channel's lobe and index can be wrong many times over).
        let mut coef: Vec<(f64, f64, f64)> = ch
            .iter()
            .map(|c| (specular(&c.model, 0), c.model.pd(), specular(&c.model, 1)))
            .collect();
        if !exact {
            let mut errors = Vec::new();
            let lobe = &ch[reference].model;
            // Two lobes keep the reference channel's ratio ps2 : ps1.
            let total = specular(lobe, 0) + specular(lobe, 1);
            let lobes = lobe
                .specs()
                .iter()
                .filter(|s| s.role == crate::model::Role::Specular)
                .count();
            let share = |k: usize| {
                if total > 0.0 {
                    specular(lobe, k) / total
                } else if k < lobes {
                    1.0 / lobes as f64
                } else {
                    0.0
                }
            };
            for (k, c) in ch.iter().enumerate() {
                let (ps, pd, median) = refit_reflectances(lobe, &c.model);
                coef[k] = (ps * share(0), pd, ps * share(1));
                errors.push(format!(
                    "{} {}",
                    c.channel,
                    crate::model::readable(100.0 * median)
                ));
            }
            notes.push(format!(
                "compromise: the channels' lobes differ ({}); the lobe of channel {} (n, shape) stands for all, each channel's ps and pd refitted to its own model under it; median f_r error per channel, %: {}. For the exact lobe of one channel export it with --channel, or fit the shape jointly with fit --shared",
                differs.join(", "),
                ch[reference].channel,
                errors.join(", ")
            ));
        }
        // A spectrum outside the sRGB gamut has a negative linear component: it is clamped to
        // 0, and a note says so.
        let mut mix = |name: &str, pick: fn(&(f64, f64, f64)) -> f64| -> [f64; 3] {
            let mut out = [0.0; 3];
            for (c, wc) in coef.iter().zip(&w) {
                let v = pick(c);
                for k in 0..3 {
                    out[k] += wc[k] * v;
                }
            }
            if out.iter().any(|&x| x < 0.0) {
                let show = |v: [f64; 3]| v.map(crate::model::readable).join(", ");
                notes.push(format!(
                    "outside the sRGB gamut: {name} in linear sRGB is ({}); its negative part is clamped to 0, giving ({})",
                    show(out),
                    show(out.map(|x| x.max(0.0)))
                ));
            }
            out.map(|x| x.max(0.0))
        };
        let (pd, ps, ps2) = (mix("pd", |c| c.1), mix("ps", |c| c.0), mix("ps2", |c| c.2));
        Ok(Colour {
            model: ch[reference].model,
            pd,
            ps,
            ps2,
            notes,
            exact,
        })
    }
}

/// The (ps, pd) ≥ 0 that make `lobe`'s model closest to `target` in relative f_r
/// (Σ ((ps S + pd D − f) / f)² over θi 10–80° in 10° steps, θo 0–85° in 5° steps, Δφ 0–180° in
/// 15° steps, where S and D are `lobe` with (ps, pd) = (1, 0) and (0, 1): f_r is linear in both),
/// and the median relative error that remains. With two lobes ps is their sum, split as in
/// `lobe` (ps1 : ps2 held).
fn refit_reflectances(lobe: &Model, target: &Model) -> (f64, f64, f64) {
    use crate::model::{Geometry, Role};
    let total = specular(lobe, 0) + specular(lobe, 1);
    let with = |ps: f64, pd: f64| {
        let mut m = *lobe;
        let specs = m.specs();
        let lobes = specs.iter().filter(|s| s.role == Role::Specular).count();
        for (i, s) in specs.iter().enumerate() {
            if s.role == Role::Specular {
                let share = if total > 0.0 {
                    lobe.p[i] / total
                } else {
                    1.0 / lobes as f64
                };
                m.p[i] = ps * share;
            }
        }
        if let Some(i) = m.kind.index_of(m.dist, Role::Diffuse) {
            m.p[i] = pd;
        }
        m
    };
    let (spec, diff) = (with(1.0, 0.0), with(0.0, 1.0));
    let mut rows = Vec::new();
    for ti in (1..=8).map(|k| f64::from(k * 10).to_radians()) {
        for to in (0..=17).map(|k| f64::from(k * 5).to_radians()) {
            for dp in (0..=12).map(|k| f64::from(k * 15).to_radians()) {
                let g = Geometry::from_angles(ti, 0.0, to, std::f64::consts::PI - dp);
                let f = target.brdf(&g);
                if f.is_finite() && f > 0.0 {
                    rows.push((spec.brdf(&g) / f, diff.brdf(&g) / f));
                }
            }
        }
    }
    // Non-negative least squares in two unknowns: the unconstrained solution, else the better
    // of the two one-variable fits.
    let (mut ss, mut sd, mut dd, mut s1, mut d1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(a, b) in &rows {
        ss += a * a;
        sd += a * b;
        dd += b * b;
        s1 += a;
        d1 += b;
    }
    let cost = |ps: f64, pd: f64| -> f64 {
        rows.iter()
            .map(|&(a, b)| (ps * a + pd * b - 1.0).powi(2))
            .sum()
    };
    let det = ss * dd - sd * sd;
    let mut best = (0.0, 0.0);
    if det.abs() > 1e-300 {
        let ps = (s1 * dd - d1 * sd) / det;
        let pd = (d1 * ss - s1 * sd) / det;
        if ps >= 0.0 && pd >= 0.0 {
            best = (ps, pd);
        }
    }
    if best == (0.0, 0.0) {
        let only_s = (if ss > 0.0 { (s1 / ss).max(0.0) } else { 0.0 }, 0.0);
        let only_d = (0.0, if dd > 0.0 { (d1 / dd).max(0.0) } else { 0.0 });
        best = if cost(only_s.0, only_s.1) <= cost(only_d.0, only_d.1) {
            only_s
        } else {
            only_d
        };
    }
    let mut rel: Vec<f64> = rows
        .iter()
        .map(|&(a, b)| (best.0 * a + best.1 * b - 1.0).abs())
        .collect();
    rel.sort_by(f64::total_cmp);
    let median = rel.get(rel.len() / 2).copied().unwrap_or(f64::NAN);
    (best.0, best.1, median)
}

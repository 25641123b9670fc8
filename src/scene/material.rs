//! A scene file's materials: a model with its `params`, or a fit file's fit (picked by model and
//! channel, several channels as colour), with colour, textures and Whitted's weights.

use super::lines::{AtLine, K, Lines, line_of};
use super::spec::MaterialSpec;
use super::values::{closed, color, not_for, positive};
use super::{MAX_ALBEDO, MAX_FREQUENCY};
use crate::model::{Distribution, Model, ModelKind, exact};
use crate::render::{Checker, Material, RoughnessTexture};
use anyhow::{Context, Result, anyhow};
use glam::DVec3;
use std::collections::BTreeMap;
use std::path::Path;

/// Material `name`'s model from its `params` (spans into `text`), each value within the
/// bounds a fit file's are read with ([`crate::model::ParamSpec::in_fit_box`]) and the whole
/// within [`MAX_ALBEDO`]; errors name the line, the key and the fix ([`AtLine`]).
fn model_params(
    name: &str,
    kind: ModelKind,
    dist: Distribution,
    params: &toml::Spanned<BTreeMap<String, toml::Spanned<f64>>>,
    text: &str,
    notes: &mut Vec<String>,
) -> Result<Model> {
    let at = |span: std::ops::Range<usize>, what: String, fix: String| AtLine {
        line: line_of(text, span.start),
        msg: format!("material {name}: {what}\n  fix: {fix}"),
    };
    let label = kind.label(dist);
    let names = kind.param_names(dist).join(", ");
    let specs = kind.params(dist);
    for (k, v) in params.get_ref() {
        let Some(spec) = specs.iter().find(|s| s.name == k) else {
            return Err(at(
                v.span(),
                format!("`params.{k}`: {label} has no parameter {k}"),
                format!("remove {k}; {label} takes {names}"),
            )
            .into());
        };
        let x = *v.get_ref();
        if !spec.in_fit_box(x) {
            return Err(at(
                v.span(),
                format!(
                    "`params.{k}` = {} is outside the range a fit can return: {}",
                    exact(x),
                    spec.fit_box_text()
                ),
                format!("write a value with {}", spec.fit_box_text()),
            )
            .into());
        }
    }
    let set: Vec<(String, f64)> = params
        .get_ref()
        .iter()
        .map(|(k, v)| (k.clone(), *v.get_ref()))
        .collect();
    let model = Model::from_named(kind, dist, &set).map_err(|e| {
        let fix = match &e {
            crate::model::ModelError::Missing { name: p, .. } => {
                format!("add {p} to params ({label} takes {names})")
            }
            crate::model::ModelError::Order { fix, .. } => fix.clone(),
            _ => format!("give {names} within their bounds"),
        };
        at(params.span(), format!("`params`: {e}"), fix)
    })?;
    let (t, a) = crate::model::albedo::max_albedo(&model);
    if !(a <= MAX_ALBEDO) {
        return Err(at(
            params.span(),
            format!(
                "`params` give a directional albedo of {} at θi = {t}° (the material would reflect that many times the light it receives, and the image overflow)",
                crate::model::readable(a)
            ),
            format!(
                "lower ps or pd: the albedo may be at most {} (a physical material's is at most 1)",
                exact(MAX_ALBEDO)
            ),
        )
        .into());
    }
    // fit's physical rule (`fit::physical`, rule 2): above 1 by more than the quadrature's
    // margin reflects more light than it receives; rendered as given, with a warning.
    if a > 1.0 + crate::model::fitfile::ALBEDO_MARGIN {
        notes.push(format!(
            "warning: {}",
            at(
                params.span(),
                format!(
                    "`params` give a directional albedo of {} at θi = {t}°: the material reflects more light than it receives (rendered as given)",
                    crate::model::readable(a)
                ),
                "lower ps or pd until the albedo is at most 1, as a physical material's is".into(),
            )
        ));
    }
    Ok(model)
}

/// Material `name`'s `distribution` key, or an error naming the ones there are.
fn distribution(name: &str, d: &str) -> Result<Distribution> {
    Distribution::parse(d).ok_or_else(|| {
        anyhow!("material {name}: unknown distribution '{d}'\n  fix: use d1, d2, d3 or abc")
    })
}

/// Material `name` of the file, checked and built (`dir` resolves its fit file).
pub(super) fn material(
    name: &str,
    m: &MaterialSpec,
    dir: &Path,
    lines: &Lines,
    notes: &mut Vec<String>,
) -> Result<Material> {
    let key = |k: &str| format!("`materials.{name}.{k}`");
    // Each error at the line of its key (a key not given: the material's own line).
    let at = |k: &str| lines.at(&[K("materials"), K(name), K(k)]);
    // A colour fit: the lobe with ps = pd = 1, its channels' pd and ps as colours.
    let mut fit_colour = (DVec3::ONE, DVec3::ONE);
    let model = match (&m.fit, &m.model) {
        (Some(_), Some(_)) => {
            return Err(at("fit")(anyhow!(
                "material {name} has both `model` and `fit`\n  fix: keep one: the fit file gives the model and its parameters"
            )));
        }
        (Some(fit), None) => {
            not_for(
                &format!("material {name}"),
                &[("params", m.params.is_some())],
                "the fit file gives the parameters (`distribution` and `fit_model` pick one fit of several)",
            )
            .map_err(at("params"))?;
            let p = dir.join(fit);
            let (model, diffuse, specular) = fit_material(name, m, &p, notes).map_err(at("fit"))?;
            fit_colour = (diffuse, specular);
            model
        }
        (None, Some(kind)) => {
            not_for(
                &format!("material {name}"),
                &[
                    ("fit_model", m.fit_model.is_some()),
                    ("fit_channel", m.fit_channel.is_some()),
                    ("fit_allow_unusable", m.fit_allow_unusable.is_some()),
                ],
                "it picks from a fit file, and this material gives `model`",
            )
            .map_err(at("model"))?;
            let kind = ModelKind::parse(kind).ok_or_else(|| {
                at("model")(anyhow!(
                    "material {name}: unknown model '{kind}'\n  fix: use one of {}",
                    ModelKind::names()
                ))
            })?;
            let dist = match &m.distribution {
                Some(d) if kind != ModelKind::TorranceSparrow => {
                    return Err(at("distribution")(anyhow!(
                        "material {name}: `distribution` = \"{d}\" applies to torrance-sparrow only\n  fix: remove it"
                    )));
                }
                Some(d) => distribution(name, d).map_err(at("distribution"))?,
                None => Distribution::D3,
            };
            let Some(params) = &m.params else {
                return Err(at("params")(anyhow!(
                    "material {name} needs `params`\n  fix: add params = {{ … }} with {}",
                    kind.param_names(dist).join(", ")
                )));
            };
            model_params(name, kind, dist, params, lines.text, notes)?
        }
        (None, None) => {
            return Err(at("model")(anyhow!(
                "material {name} has neither `model` nor `fit`\n  fix: add model = \"lambert\" and params = {{ pd = 0.5 }}, or fit = \"FILE.json\""
            )));
        }
    };
    let roughness = match &m.roughness {
        None => None,
        Some(r) => {
            if (model.kind, model.dist) != (ModelKind::TorranceSparrow, Distribution::D3) {
                return Err(at("roughness")(anyhow!(
                    "material {name}: `roughness` modulates Blinn's D3 and applies to torrance-sparrow d3 only, this is {} {}\n  fix: remove it or use model = \"torrance-sparrow\"",
                    model.kind,
                    model.dist.name()
                )));
            }
            Some(RoughnessTexture {
                cmin: closed(&key("roughness.cmin"), r.cmin, 1e-3, 1.0).map_err(at("roughness"))?,
                frequency: closed(&key("roughness.frequency"), r.frequency, 0.0, MAX_FREQUENCY)
                    .map_err(at("roughness"))?,
            })
        }
    };
    Ok(Material {
        name: name.to_string(),
        model,
        color: match &m.color {
            Some(c) => color(&key("color"), c, 1.0).map_err(at("color"))?,
            None => DVec3::ONE,
        } * fit_colour.0,
        specular: fit_colour.1,
        checker: match &m.checker {
            None => None,
            Some(c) => Some(Checker {
                size: positive(&key("checker.size"), c.size, MAX_FREQUENCY)
                    .map_err(at("checker"))?,
                color0: color(&key("checker.color0"), &c.color0, 1.0).map_err(at("checker"))?,
                color1: color(&key("checker.color1"), &c.color1, 1.0).map_err(at("checker"))?,
            }),
        },
        ks: closed(&key("ks"), m.ks.unwrap_or(0.0), 0.0, 1.0).map_err(at("ks"))?,
        kt: closed(&key("kt"), m.kt.unwrap_or(0.0), 0.0, 1.0).map_err(at("kt"))?,
        ior: closed(&key("ior"), m.ior.unwrap_or(1.5), 0.01, 100.0).map_err(at("ior"))?,
        roughness,
        measured: None,
    })
}

/// A material's fit: the file read strictly, the model and channel picked by `fit_model` and
/// `fit_channel` (see [`crate::fit::pick`]); several channels become colour (the shared lobe
/// with ps = pd = 1, and their pd and ps as diffuse and specular colours). What was picked
/// for the user and any colour compromise are said on stderr.
fn fit_material(
    name: &str,
    m: &MaterialSpec,
    p: &Path,
    notes: &mut Vec<String>,
) -> Result<(Model, DVec3, DVec3)> {
    use crate::fit::{pick, read_fit_file};
    use crate::model::fitfile::Want;
    let text =
        crate::support::input::read_to_string_limited(p, crate::support::input::Input::FitJson)
            .with_context(|| format!("material {name}: cannot read fit {}", p.display()))?;
    let at = |e: &dyn std::fmt::Display| anyhow!("material {name}: {}: {e}", p.display());
    let fits = read_fit_file(&text).map_err(|e| at(&e))?;
    let model = match &m.fit_model {
        None => None,
        Some(k) => Some(ModelKind::parse(k).ok_or_else(|| {
            anyhow!(
                "material {name}: fit_model: unknown model '{k}'\n  fix: use one of {}",
                ModelKind::names()
            )
        })?),
    };
    let dist = match &m.distribution {
        None => None,
        Some(d) => Some(distribution(name, d)?),
    };
    let want = Want {
        model,
        dist,
        channel: m.fit_channel.clone(),
        allow_unusable: m.fit_allow_unusable.unwrap_or(false),
    };
    let picked = pick(&fits, &want).map_err(|e| {
        at(&e
            .to_string()
            .replace("add --allow-unusable", "set fit_allow_unusable = true")
            .replace("with --model", "with fit_model")
            .replace("(and --distribution)", "(and distribution)")
            .replace("with --channel", "with fit_channel"))
    })?;
    let colour = picked
        .colour()
        .map_err(|e| at(&e.to_string().replace("with --channel", "with fit_channel")))?;
    for n in picked.notes.iter().chain(&colour.notes) {
        notes.push(format!(
            "material {name}: {}: {}",
            p.display(),
            n.replace("--model", "fit_model")
                .replace("--channel", "fit_channel")
        ));
    }
    if colour.is_grey() {
        return Ok((colour.model, DVec3::ONE, DVec3::ONE));
    }
    let lobe = colour.channel_model(0);
    let mut unit = lobe;
    // A second lobe (ggx-smith-2's ps2) keeps its ratio to the first, ps2 : ps1 over r, g, b.
    let (s1, s2) = (
        colour.ps.iter().sum::<f64>(),
        colour.ps2.iter().sum::<f64>(),
    );
    let ratio = if s1 > 0.0 { s2 / s1 } else { 1.0 };
    if (0..3).any(|c| (colour.ps2[c] - ratio * colour.ps[c]).abs() > 1e-9 * s2.max(1e-300)) {
        eprintln!(
            "note: material {name}: {}: the two lobes' colours differ; rendered with ps2 = {} ps1 in every channel (their ratio over r + g + b)",
            p.display(),
            crate::model::readable(ratio)
        );
    }
    let mut lobe_no = 0;
    for (i, spec) in lobe.kind.params(lobe.dist).iter().enumerate() {
        match spec.role {
            crate::model::Role::Diffuse => unit.p[i] = 1.0,
            crate::model::Role::Specular => {
                unit.p[i] = if lobe_no == 0 { 1.0 } else { ratio };
                lobe_no += 1;
            }
            _ => {}
        }
    }
    Ok((
        unit,
        DVec3::from_array(colour.pd),
        DVec3::from_array(colour.ps),
    ))
}

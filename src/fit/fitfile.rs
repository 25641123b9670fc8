//! Fits read from a fit file, and the one place a consumer picks the fit it uses.
//!
//! [`read_fit_file`] parses the text strictly ([`parse_strict`]: duplicate keys, which
//! `serde_json::Value` would silently collapse, are refused), checks every fit with
//! [`FitResult::from_json`] (known keys, the model's parameters each present once, finite and
//! within their declared [`ParamSpec`](crate::model::ParamSpec) bounds) and [`pick`] chooses,
//! by model and channel, the fits a consumer uses, refusing a fit marked not usable unless
//! asked to take it. The file's format itself (the strict parser, the check of a fit object,
//! [`Want`], [`Colour`]) is [`crate::model::fitfile`]'s.

use super::{FitResult, rank};
pub(crate) use crate::model::fitfile::check_fit_object;
use crate::model::fitfile::{ChannelModel, WRITTEN_BY, colour_of, err, kind_of};
pub use crate::model::fitfile::{
    Colour, FitFileError, Want, is_unnamed_channel, parse_strict, same_channel,
};
use crate::model::{Distribution, Model, ModelKind};

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

/// A file's channels in file order, each with its fits (fit index, channel index within the
/// fit).
type Channels = Vec<(String, Vec<(usize, usize)>)>;

/// Pick from a fit file's fits what `want` asks: the fits of one model, one per channel (every
/// channel of the file, or `want.channel`). Without `want.model` a file of one model gives that
/// model; a file of several (`fit --model all`) gives the recommended one (fewest parameters
/// within 2 BIC of the best, over the channels: the model most channels recommend), said in
/// [`Picked::notes`]. A fit marked not usable, or whose random-start verification failed, is
/// refused unless `want.allow_unusable`.
pub fn pick(fits: &[FitResult], want: &Want) -> Result<Picked, FitFileError> {
    let channels = channels_of(fits, want)?;
    let mut notes = Vec::new();
    let chosen = chosen_model(fits, want, &channels, &mut notes)?;
    let mut out = Vec::new();
    for (name, entries) in &channels {
        out.push(picked_channel(
            fits, want, name, entries, chosen, &mut notes,
        )?);
    }
    Ok(Picked {
        channels: out,
        notes,
    })
}

/// The channels [`pick`] takes: every channel of the file in file order (joint fits expanded
/// per channel), or the one `want.channel` names.
fn channels_of(fits: &[FitResult], want: &Want) -> Result<Channels, FitFileError> {
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
    Ok(channels)
}

/// The model and distribution [`pick`] takes: the one asked, the file's only one, or the
/// recommended one of a file of several; what was chosen for the user goes to `notes`.
fn chosen_model(
    fits: &[FitResult],
    want: &Want,
    channels: &[(String, Vec<(usize, usize)>)],
    notes: &mut Vec<String>,
) -> Result<(ModelKind, Distribution), FitFileError> {
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
    Ok(match want_model {
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
            for (_, entries) in channels {
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
    })
}

/// The fit of model `chosen` of channel `name` (its `entries` in `fits`), refused when marked
/// not usable unless `want.allow_unusable` (then said in `notes`).
fn picked_channel(
    fits: &[FitResult],
    want: &Want,
    name: &str,
    entries: &[(usize, usize)],
    chosen: (ModelKind, Distribution),
    notes: &mut Vec<String>,
) -> Result<PickedChannel, FitFileError> {
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
    Ok(PickedChannel {
        channel: name.to_string(),
        model,
        fit: f.clone(),
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

impl Picked {
    /// The picked channels as one colour material ([`Colour`]): one channel as grey; r, g, b
    /// as themselves; wavelength channels through CIE 1931 to linear sRGB. Where the channels'
    /// lobes (index and shape parameters) differ, the lobe of the brightest-weighted channel
    /// (green, or the wavelength nearest 555 nm) stands for all, with each channel's own ps and
    /// pd, and the notes say so.
    pub fn colour(&self) -> Result<Colour, FitFileError> {
        let channels: Vec<ChannelModel> = self
            .channels
            .iter()
            .map(|c| ChannelModel {
                channel: c.channel.clone(),
                model: c.model,
            })
            .collect();
        colour_of(&channels)
    }
}

//! Stage 1 of a fit: each channel's usable rows (geometry computed once), the layout of the
//! solver variables, the checks that the data can determine them, and the least-squares
//! problem over every channel's rows.

use super::options::{FitError, FitOptions, Weighting, fit_error};
use super::problem::{self, BrdfProblem, Loss, RowWriter, Rows, Slot, Transform};
use crate::data::Dataset;
use crate::model::{Geometry, Model, ParamSpec, Role};
use crate::support::lanes::{self, LANES};
use crate::support::setting::Setting;

/// One channel's usable samples, converted to f_r.
#[derive(Clone)]
pub(super) struct ChannelRows {
    pub(super) name: String,
    pub(super) rows: Rows,
    /// θi when every row has the same incidence angle.
    pub(super) one_incidence: Option<f64>,
    pub(super) all_zero: bool,
}

pub(super) fn channel_rows(ds: &Dataset, c: usize, opts: &FitOptions) -> ChannelRows {
    let vals = &ds.channels[c].values;
    let max = opts.max_theta_deg.map(f64::to_radians);
    let weights = sample_weights(ds, opts.weights);
    let weighted = weights
        .as_ref()
        .is_some_and(|w| w.iter().any(|&v| v != 1.0));
    // Geometry of every sample, in parallel over fixed chunks joined in sample order.
    let rows = Rows::par_fill(ds.len(), weighted, |range, out| {
        fill_rows(ds, vals, weights.as_deref(), max, opts.loss, range, out)
    });
    // ln(1 + 0) = 0 and f = 0: a zero target is a zero value under either loss. (On many rows
    // the two scans side by side: 8 MB each for a million rows.)
    let first = rows.nl.first().copied();
    let zero = || rows.target.iter().all(|&t| t == 0.0);
    let one = || first.is_some_and(|c0| rows.nl.iter().all(|c| (c - c0).abs() < 1e-12));
    let (all_zero, one_incidence) = if rows.len() > 1 << 16 {
        rayon::join(zero, one)
    } else {
        (zero(), one())
    };
    ChannelRows {
        name: ds.channel_label(c),
        rows,
        one_incidence: one_incidence.then(|| first.unwrap_or(1.0).acos()),
        all_zero,
    }
}

/// Each sample's weight in the loss under `how`: the file's weights column (`None`: every
/// sample 1), or with [`Weighting::SolidAngle`] that times [`solid_angle_weights`].
pub(super) fn sample_weights(ds: &Dataset, how: Weighting) -> Option<Vec<f64>> {
    match how {
        Weighting::File => ds.weights.clone(),
        Weighting::SolidAngle => {
            let mut w = solid_angle_weights(ds);
            if let Some(file) = &ds.weights {
                for (a, b) in w.iter_mut().zip(file) {
                    *a *= b;
                }
            }
            Some(w)
        }
    }
}

/// The quadrature weight of each sample of a grid: the measure of its cell in
/// (cosθi, cosθo, |φo − φi|), i.e. the solid angle sinθi sinθo dθi dθo dφ the sample stands
/// for, scaled to a mean of 1. Computed from the data's own spacing, nested: the cell of a θi
/// runs halfway to the neighbouring θi values of the data (at the ends, half a step out, within
/// 0–90°; a lone value spans 0–90°), the cell of a θo likewise among the θo values at that θi,
/// and the cell of |φo − φi| (folded into 0–180°, where an isotropic model cannot tell ±φ
/// apart) among the values at that (θi, θo), within 0–180°. Samples at the same (θi, θo,
/// |Δφ|) (to 0.01°) share their cell. Meant for goniometer grids, whose dense θo axis and
/// samples near the pole (θo = 0 at every φ) would otherwise outweigh the rest of the
/// hemisphere; for scattered samples each θi is its own cell and the weight reduces to the
/// spacing in θi.
pub fn solid_angle_weights(ds: &Dataset) -> Vec<f64> {
    use std::collections::BTreeMap;
    use std::f64::consts::PI;
    let n = ds.len();
    // Keys: the angles in hundredths of a degree (the tables print 68° as 67.9998).
    let key = |x: f64| (x.to_degrees() * 100.0).round() as i64;
    let fold = |d: f64| {
        let d = d.rem_euclid(std::f64::consts::TAU);
        if d > PI { std::f64::consts::TAU - d } else { d }
    };
    let keys: Vec<[i64; 3]> = (0..n)
        .map(|k| {
            let a = ds.angles(k);
            [key(a[0]), key(a[2]), key(fold(a[3] - a[1]))]
        })
        .collect();
    // Each distinct value's cell measure among `values` (sorted, distinct keys) within
    // [0, hi] (degrees × 100), measured by `m(lower, upper)` in radians.
    let cells = |values: &[i64], hi: f64, m: &dyn Fn(f64, f64) -> f64| -> Vec<f64> {
        let v: Vec<f64> = values.iter().map(|&x| x as f64 / 100.0).collect();
        let rad = |d: f64| d.clamp(0.0, hi).to_radians();
        (0..v.len())
            .map(|j| {
                if v.len() == 1 {
                    return m(0.0, hi.to_radians());
                }
                let lo = if j == 0 {
                    v[0] - 0.5 * (v[1] - v[0])
                } else {
                    0.5 * (v[j - 1] + v[j])
                };
                let up = if j + 1 == v.len() {
                    v[j] + 0.5 * (v[j] - v[j - 1])
                } else {
                    0.5 * (v[j] + v[j + 1])
                };
                m(rad(lo), rad(up))
            })
            .collect()
    };
    let polar = |a: f64, b: f64| a.cos() - b.cos();
    let azimuth = |a: f64, b: f64| b - a;
    // Nested groups: θi → θo → |Δφ| → the samples there.
    let mut tree: BTreeMap<i64, BTreeMap<i64, BTreeMap<i64, Vec<usize>>>> = BTreeMap::new();
    for (k, [ti, to, dp]) in keys.iter().enumerate() {
        tree.entry(*ti)
            .or_default()
            .entry(*to)
            .or_default()
            .entry(*dp)
            .or_default()
            .push(k);
    }
    let mut w = vec![0.0; n];
    let ti_keys: Vec<i64> = tree.keys().copied().collect();
    let wi = cells(&ti_keys, 90.0, &polar);
    for ((_, by_to), wi) in tree.iter().zip(wi) {
        let to_keys: Vec<i64> = by_to.keys().copied().collect();
        let wo = cells(&to_keys, 90.0, &polar);
        for ((_, by_dp), wo) in by_to.iter().zip(wo) {
            let dp_keys: Vec<i64> = by_dp.keys().copied().collect();
            let wp = cells(&dp_keys, 180.0, &azimuth);
            for ((_, samples), wp) in by_dp.iter().zip(wp) {
                for &k in samples {
                    w[k] = wi * wo * wp / samples.len() as f64;
                }
            }
        }
    }
    let mean = w.iter().sum::<f64>() / n.max(1) as f64;
    if mean > 0.0 {
        for x in &mut w {
            *x /= mean;
        }
    }
    w
}

/// The rows of samples `range` of channel values `vals` that a fit keeps, pushed to `out`.
/// [`LANES`] samples at a time, so the trigonometry and logarithms vectorise; compiled for
/// AVX-512 and AVX2 as well and picked at run time.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn fill_rows(
    ds: &Dataset,
    vals: &[f64],
    weights: Option<&[f64]>,
    max: Option<f64>,
    loss: Loss,
    range: std::ops::Range<usize>,
    out: &mut RowWriter,
) {
    let q = ds.quantity;
    // LANES samples at a time, so the trigonometry and logarithms vectorise.
    let mut k = range.start;
    while k < range.end {
        let n = (range.end - k).min(LANES);
        let (mut ti, mut to, mut dphi) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for l in 0..n {
            let a = ds.angles(k + l);
            (ti[l], to[l], dphi[l]) = (a[0], a[2], a[3] - a[1]);
        }
        let (si, ci) = lanes::sin_cos(&ti);
        let (so, co) = lanes::sin_cos(&to);
        let (_, cp) = lanes::sin_cos(&dphi);
        let mut v = [0.0; LANES];
        let mut y = [0.0; LANES];
        for l in 0..n {
            v[l] = match q {
                crate::data::Quantity::Brdf => vals[k + l],
                _ => vals[k + l] * q.to_brdf_factor(ci[l]),
            };
            y[l] = ci[l] * v[l];
        }
        let target = match loss {
            Loss::Log => lanes::ln_1p(&y).0,
            Loss::Linear => v,
            Loss::Pixel => y.map(|x| problem::pixel(x).0),
        };
        // L·E = sinθi sinθo cos(φo − φi) + cosθi cosθo. Columns in the order of [`RowWriter`].
        let mut col = [[0.0; LANES]; 8];
        let mut keep = [false; LANES];
        let mut w = [1.0; LANES];
        if let Some(ws) = weights {
            w[..n].copy_from_slice(&ws[k..k + n]);
            // √weight only where there are weights (a square root per row is not free).
            col[7] = w.map(f64::sqrt);
        }
        let m = max.unwrap_or(f64::INFINITY);
        for l in 0..LANES {
            let g = Geometry::from_cosines(ci[l], co[l], si[l] * so[l] * cp[l] + ci[l] * co[l]);
            let inside = !(ti[l] > m) & !(to[l] > m);
            keep[l] = (l < n) & v[l].is_finite() & inside & (w[l] > 0.0) & g.visible();
            [
                col[0][l], col[1][l], col[2][l], col[3][l], col[4][l], col[5][l],
            ] = [g.nl, g.ne, g.nh, g.eh, g.re, g.g_ne];
            col[6][l] = target[l];
        }
        if keep.iter().all(|&x| x) {
            // The usual case: the whole block is kept, written a lane vector at a time.
            out.push_block(&col);
        } else {
            for l in (0..n).filter(|&l| keep[l]) {
                out.push_lane(&col, l);
            }
        }
        k += n;
    }
}
/// A reported parameter: its name (with `_<channel>` when per channel) and its slot.
#[derive(Clone, Debug)]
pub(super) struct Entry {
    pub(super) name: String,
    pub(super) slot: Slot,
}

/// The solver variables of a fit: which model parameters are held, shared or per channel.
pub(super) struct Layout {
    pub(super) transforms: Vec<Transform>,
    pub(super) names: Vec<String>,
    pub(super) specs: Vec<&'static ParamSpec>,
    pub(super) slots: Vec<[Slot; crate::model::MAX_PARAMS]>,
    pub(super) entries: Vec<Entry>,
}

/// Step 1: lay out the solver variables. A held parameter is fixed in every channel; with one
/// channel (or `shared`) a parameter is one variable, otherwise one per channel.
pub(super) fn layout(channels: &[String], opts: &FitOptions) -> Layout {
    let specs = opts.kind.params(opts.dist);
    let multi = channels.len() > 1;
    let mut lay = Layout {
        transforms: Vec::new(),
        names: Vec::new(),
        specs: Vec::new(),
        slots: vec![[Slot::Fixed(0.0); crate::model::MAX_PARAMS]; channels.len()],
        entries: Vec::new(),
    };
    let held = |name: &str| opts.fix.iter().rev().find(|(k, _)| k == name).map(|f| f.1);
    let shared = |name: &str| opts.shared.iter().any(|s| s == name);
    let add = |lay: &mut Layout, j: usize, name: String, chans: std::ops::Range<usize>| {
        let k = lay.transforms.len();
        lay.transforms.push(Transform::of(&specs[j]));
        lay.specs.push(&specs[j]);
        lay.names.push(name.clone());
        for c in chans {
            lay.slots[c][j] = Slot::Free(k);
        }
        lay.entries.push(Entry {
            name,
            slot: Slot::Free(k),
        });
    };
    for (j, spec) in specs.iter().enumerate() {
        if let Some(v) = held(spec.name) {
            for l in lay.slots.iter_mut() {
                l[j] = Slot::Fixed(v);
            }
            lay.entries.push(Entry {
                name: spec.name.to_string(),
                slot: Slot::Fixed(v),
            });
        } else if !multi || shared(spec.name) {
            add(&mut lay, j, spec.name.to_string(), 0..channels.len());
        }
    }
    for (c, ch) in channels.iter().enumerate() {
        for (j, spec) in specs.iter().enumerate() {
            if multi && !shared(spec.name) && held(spec.name).is_none() {
                add(&mut lay, j, format!("{}_{ch}", spec.name), c..c + 1);
            }
        }
    }
    lay
}

/// Step 2: refuse data that cannot determine the free parameters.
pub(super) fn check_data(
    chans: &[ChannelRows],
    lay: &Layout,
    opts: &FitOptions,
    label: &str,
) -> Result<(), FitError> {
    let m: usize = chans.iter().map(|c| c.rows.len()).sum();
    let nfree = lay.transforms.len();
    if m <= nfree {
        return Err(fit_error(
            format!("channel {label}: {m} usable samples for {nfree} free parameters"),
            "a fit needs more samples than free parameters: check the largest angle used, the negative policy, or hold some parameters",
        )
        .with(Setting::MaxTheta));
    }
    if chans.iter().all(|c| c.all_zero) {
        return Err(fit_error(
            format!("channel {label}: every value is zero"),
            "there is no reflectance to fit; check the channel and the file",
        ));
    }
    let index = opts
        .kind
        .index_of(opts.dist, Role::Index)
        .filter(|&i| matches!(lay.slots[0][i], Slot::Free(_)));
    if let Some(index) = index
        && let Some(t) = chans[0].one_incidence
        && chans
            .iter()
            .all(|c| c.one_incidence.is_some_and(|x| (x - t).abs() < 1e-9))
    {
        return Err(fit_error(
            format!(
                "channel {label}: every sample has θi = {:.2}°; the Fresnel index n cannot be separated from ps at one incidence angle",
                t.to_degrees()
            ),
            "add samples at other incidence angles, or hold the index at a value",
        )
        .with(Setting::Hold(
            opts.kind.params(opts.dist)[index].name.into(),
        )));
    }
    Ok(())
}

/// Step 3: the least-squares problem over every channel's rows.
pub(super) fn problem(chans: Vec<ChannelRows>, lay: &Layout, opts: &FitOptions) -> BrdfProblem {
    let mut starts = vec![0];
    let mut rows = Rows::default();
    for c in chans {
        if rows.is_empty() {
            rows = c.rows;
        } else {
            rows.extend(&c.rows);
        }
        starts.push(rows.len());
    }
    // The template's values are placeholders: each parameter's declared start.
    let declared: Vec<f64> = opts
        .kind
        .params(opts.dist)
        .iter()
        .map(|s| s.start)
        .collect();
    let mut template =
        Model::new(opts.kind, opts.dist, &declared).expect("declared starts are valid");
    template.fast_pow = opts.fast_pow;
    BrdfProblem {
        template,
        rows: std::sync::Arc::new(rows),
        starts,
        layout: lay.slots.clone(),
        transforms: lay.transforms.clone(),
        loss: opts.loss,
        watch: opts.watch.clone(),
    }
}

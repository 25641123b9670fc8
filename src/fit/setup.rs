//! Stage 1 of a fit: each channel's usable rows (geometry computed once), the layout of the
//! solver variables, the checks that the data can determine them, and the least-squares
//! problem over every channel's rows.

use super::*;

/// One channel's usable samples, converted to f_r.
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
    let weighted = ds
        .weights
        .as_ref()
        .is_some_and(|w| w.iter().any(|&v| v != 1.0));
    // Geometry of every sample, in parallel over fixed chunks joined in sample order.
    let rows = Rows::par_fill(ds.len(), weighted, |range, cols| {
        fill_rows(ds, vals, max, opts.loss, range, cols)
    });
    // ln(1 + 0) = 0 and f = 0: a zero target is a zero value under either loss.
    let all_zero = rows.target.iter().all(|&t| t == 0.0);
    let first = rows.nl.first().copied();
    let one_incidence = first.is_some_and(|c0| rows.nl.iter().all(|c| (c - c0).abs() < 1e-12));
    ChannelRows {
        name: ds.channel_label(c),
        rows,
        one_incidence: one_incidence.then(|| first.unwrap_or(1.0).acos()),
        all_zero,
    }
}

/// Rows of samples `range` of channel values `vals` written to the front of `cols` (the
/// layout of [`Rows::write`]); returns how many were kept. [`LANES`] samples at a time, so
/// the trigonometry and logarithms vectorise; compiled for AVX-512 and AVX2 as well and picked
/// at run time.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn fill_rows(
    ds: &Dataset,
    vals: &[f64],
    max: Option<f64>,
    loss: Loss,
    range: std::ops::Range<usize>,
    mut cols: [&mut [f64]; 8],
) -> usize {
    let q = ds.quantity;
    let mut kept = 0;
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
        // L·E = sinθi sinθo cos(φo − φi) + cosθi cosθo. Columns in the order of [`Rows::write`].
        let mut col = [[0.0; LANES]; 8];
        let mut keep = [false; LANES];
        let mut w = [1.0; LANES];
        if let Some(ws) = &ds.weights {
            w[..n].copy_from_slice(&ws[k..k + n]);
        }
        let m = max.unwrap_or(f64::INFINITY);
        for l in 0..LANES {
            let g = Geometry::from_cosines(ci[l], co[l], si[l] * so[l] * cp[l] + ci[l] * co[l]);
            let inside = !(ti[l] > m) & !(to[l] > m);
            keep[l] = (l < n) & v[l].is_finite() & inside & (w[l] > 0.0) & g.visible();
            [
                col[0][l], col[1][l], col[2][l], col[3][l], col[4][l], col[5][l],
            ] = [g.nl, g.ne, g.nh, g.eh, g.re, g.g_ne];
            (col[6][l], col[7][l]) = (target[l], w[l].sqrt());
        }
        if keep.iter().all(|&x| x) {
            // The usual case: the whole block is kept, written a lane vector at a time.
            for (c, x) in cols.iter_mut().zip(&col) {
                c[kept..kept + LANES].copy_from_slice(x);
            }
            kept += LANES;
        } else {
            for l in 0..n {
                if keep[l] {
                    for (c, x) in cols.iter_mut().zip(&col) {
                        c[kept] = x[l];
                    }
                    kept += 1;
                }
            }
        }
        k += n;
    }
    kept
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
    }
}

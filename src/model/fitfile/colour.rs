//! Picked fits as one colour material: the channels' weights in linear sRGB (r, g, b, or
//! wavelengths through the CIE 1931 functions), and a shared lobe where the channels' differ.

use super::{FitFileError, err};
use crate::model::Model;

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

/// One picked channel as [`colour_of`] reads it: its name and its fitted model.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelModel {
    /// Channel name.
    pub channel: String,
    /// The fitted model of this channel.
    pub model: Model,
}

/// Picked channels as one colour material ([`Colour`]): one channel as grey; r, g, b
/// as themselves; wavelength channels through CIE 1931 to linear sRGB. Where the channels'
/// lobes (index and shape parameters) differ, the lobe of the brightest-weighted channel
/// (green, or the wavelength nearest 555 nm) stands for all, with each channel's own ps and
/// pd, and the notes say so.
pub fn colour_of(ch: &[ChannelModel]) -> Result<Colour, FitFileError> {
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

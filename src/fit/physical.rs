//! Only physical fits in use: the rules that mark a fit not usable because the material it
//! describes could not exist, whatever its cost.
//!
//! 1. **pd > 1**: the Lambertian part alone reflects more light than arrives.
//! 2. **Directional albedo above 1** at any θi of
//!    [`ALBEDO_THETA_I_DEG`](crate::model::albedo::ALBEDO_THETA_I_DEG) (0°–85°), by the
//!    quadrature of [`directional_albedo`](crate::model::albedo::directional_albedo), with a
//!    margin of [`ALBEDO_MARGIN`] for its error (a model the coarse rule shows clearly
//!    below 1, [`clearly_below_one`], needs no fine quadrature).
//! 3. **A lobe held down by F ≈ 0**: the Fresnel index is at or near its lower bound 1.0001
//!    (n ≤ [`LOWEST_INDEX`], F0 ≤ 2.5e-5, below any solid's) and the same fit with F = 1 (the
//!    index at its upper bound, which every real index approaches at grazing incidence) has
//!    a directional albedo above 1 + [`ALBEDO_MARGIN`]: the data fix only the product ps·F,
//!    the fit reached it with a vanishing F and a huge ps, and the material it names does not
//!    exist (MERL steel, edge lit: GGX α 0.0075, n = 1.0001, ps = 10217; MERL aluminium,
//!    edge lit: Torrance–Sparrow D3 c3 0.013, n = 1.00022, ps = 3.2e6).

use super::result::FitResult;
use crate::model::albedo::{albedos, coarse_albedos, max_albedo};
use crate::model::{Model, Role, readable};

pub use crate::model::fitfile::ALBEDO_MARGIN;

/// A model whose albedo by the coarse rule ([`coarse_albedos`]) is at most this share of
/// 1 + [`ALBEDO_MARGIN`] at every θi passes rule 2 without the fine quadrature: the coarse
/// rule is within 1 % of the fine one on every model tested (tests/it/albedo.rs), five times
/// less than this slack, so the verdict is the fine quadrature's. Above it (or not a number),
/// the fine quadrature decides.
pub const COARSE_PASS: f64 = 0.95;

/// True when the coarse rule shows the directional albedo of `m` clearly below 1 at every θi
/// (see [`COARSE_PASS`]).
pub fn clearly_below_one(m: &Model) -> bool {
    coarse_albedos(m)
        .iter()
        .all(|&(_, a)| a <= COARSE_PASS * (1.0 + ALBEDO_MARGIN))
}

/// An index at or below this is "at its lower bound" for rule 3: F0 = ((n − 1)/(n + 1))² ≤
/// 2.5e-5, below any solid's (the lowest, silica aerogels, reach n ≈ 1.01–1.05).
pub const LOWEST_INDEX: f64 = 1.01;

/// Why the model of one channel is not a physical material (empty when it is).
pub fn model_problems(m: &Model) -> Vec<String> {
    let mut out = Vec::new();
    let pd = m.pd();
    if pd > 1.0 {
        out.push(format!(
            "pd = {} > 1: the diffuse part alone reflects more light than it receives",
            readable(pd)
        ));
    } else if !clearly_below_one(m) {
        let (t, a) = max_albedo(m);
        if !(a <= 1.0 + ALBEDO_MARGIN) {
            out.push(format!(
                "directional albedo {} > 1 at θi = {t}°: the fit reflects more light than it \
                 receives",
                readable(a)
            ));
        }
    }
    if let Some(k) = m.kind.index_of(m.dist, Role::Index) {
        let spec = &m.specs()[k];
        let n = m.p[k];
        if n <= LOWEST_INDEX {
            let mut unit = m.params().to_vec();
            unit[k] = spec.hi;
            let unit = m.with_params(&unit);
            let (t, a) = albedos(&unit)
                .into_iter()
                .fold((0.0, 0.0), |b, x| if x.1 > b.1 { x } else { b });
            if a > 1.0 + ALBEDO_MARGIN {
                // Every lobe's coefficient (two-lobe models: ps1 and ps2), named.
                let ps: Vec<String> = m
                    .specs()
                    .iter()
                    .zip(m.params())
                    .filter(|(s, _)| s.role == Role::Specular)
                    .map(|(s, v)| format!("{} = {}", s.name, readable(*v)))
                    .collect();
                out.push(format!(
                    "n = {} is at or near its lower bound, where F ≈ 0 holds the lobe down: with F = 1 \
                     (any real index at grazing incidence) {} would give a directional \
                     albedo of {} at θi = {t}°; fix n to a physical index (--fix n=1.5) or \
                     fit another model",
                    crate::model::significant(n, 5),
                    ps.join(", "),
                    readable(a)
                ));
            }
        }
    }
    out
}

/// Why a fit is not a physical material, for every channel it holds (prefixed `channel C:`
/// when it holds several).
pub fn problems(f: &FitResult) -> Vec<String> {
    let chans: Vec<&str> = f.channel.split(',').collect();
    let mut out = Vec::new();
    for (c, name) in chans.iter().enumerate() {
        for why in model_problems(&f.model_for(c)) {
            out.push(if chans.len() > 1 {
                format!("channel {name}: {why}")
            } else {
                why
            });
        }
    }
    out
}

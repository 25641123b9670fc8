//! The checks of single values of a scene file: ranges, colours, positions, directions, and
//! keys required or not applicable; each error names the key and the fix.

use super::MAX_COORD;
use super::spec::ColorSpec;
use crate::model::exact;
use anyhow::{Result, anyhow, bail};
use glam::DVec3;

/// `v` within [lo, hi] (and finite), or an error naming `key`.
pub(super) fn closed(key: &str, v: f64, lo: f64, hi: f64) -> Result<f64> {
    if v >= lo && v <= hi {
        Ok(v)
    } else {
        bail!(
            "{key} = {} is out of range\n  fix: give a finite number from {} to {}",
            exact(v),
            exact(lo),
            exact(hi)
        )
    }
}

/// `v` within (0, hi] (and finite), or an error naming `key`.
pub(super) fn positive(key: &str, v: f64, hi: f64) -> Result<f64> {
    if v > 0.0 && v <= hi {
        Ok(v)
    } else {
        bail!(
            "{key} = {} is out of range\n  fix: give a finite number greater than 0 and at most {}",
            exact(v),
            exact(hi)
        )
    }
}

/// An integer setting within [lo, hi].
pub(super) fn count(key: &str, v: u32, lo: u32, hi: u32) -> Result<u32> {
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        bail!("{key} = {v} is out of range\n  fix: give a whole number from {lo} to {hi}")
    }
}

/// A colour (a number is grey) with every component in [0, hi].
pub(super) fn color(key: &str, c: &ColorSpec, hi: f64) -> Result<DVec3> {
    let v = match c {
        ColorSpec::Grey(g) => [*g; 3],
        ColorSpec::Rgb(c) => *c,
    };
    if v.iter().all(|x| *x >= 0.0 && *x <= hi) {
        Ok(DVec3::from_array(v))
    } else {
        bail!(
            "{key} = {v:?} is out of range\n  fix: give a number or [r, g, b], each finite from 0 to {}",
            exact(hi)
        )
    }
}

/// A position: three finite coordinates of magnitude at most [`MAX_COORD`].
pub(super) fn position(key: &str, v: [f64; 3]) -> Result<DVec3> {
    if v.iter().all(|x| x.abs() <= MAX_COORD) {
        Ok(DVec3::from_array(v))
    } else {
        bail!(
            "{key} = {v:?} is out of range\n  fix: give three finite coordinates of magnitude at most {}",
            exact(MAX_COORD)
        )
    }
}

/// A direction: finite, not zero; returned normalised.
pub(super) fn direction(key: &str, v: [f64; 3]) -> Result<DVec3> {
    let d = DVec3::from_array(v);
    if v.iter().all(|x| x.abs() <= MAX_COORD) && d.length() > 1e-12 {
        Ok(d.normalize())
    } else {
        bail!(
            "{key} = {v:?} is not a direction\n  fix: give three finite numbers, not all zero, of magnitude at most {}",
            exact(MAX_COORD)
        )
    }
}

/// A required key of a kind of light or object.
pub(super) fn need<T: Copy>(v: Option<T>, owner: &str, key: &str) -> Result<T> {
    v.ok_or_else(|| anyhow!("{owner} needs `{key}`\n  fix: add {key} = … to it"))
}

/// Refuse keys given that do not apply to this kind of light, object or mode.
pub(super) fn not_for(owner: &str, keys: &[(&str, bool)], hint: &str) -> Result<()> {
    if let Some((k, _)) = keys.iter().find(|(_, given)| *given) {
        bail!("{owner}: `{k}` does not apply here\n  fix: remove it ({hint})");
    }
    Ok(())
}

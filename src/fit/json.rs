//! Serde helpers for the fit JSON: name → value lists written as JSON objects in model order,
//! and floats that may be infinite or undefined written as `null` (JSON has no ∞ or NaN).

use serde::de::{Deserializer, MapAccess, Visitor};
use serde::ser::{SerializeMap, Serializer};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::marker::PhantomData;

/// `Vec<(String, T)>` as a JSON object, in order.
pub(crate) mod pairs {
    use super::*;

    /// Write the pairs as an object.
    pub(crate) fn serialize<S: Serializer, T: Serialize>(
        v: &[(String, T)],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(v.len()))?;
        for (k, x) in v {
            m.serialize_entry(k, x)?;
        }
        m.end()
    }

    /// Read an object's entries in order.
    pub(crate) fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
        d: D,
    ) -> Result<Vec<(String, T)>, D::Error> {
        struct V<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
            type Value = Vec<(String, T)>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an object")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<Self::Value, A::Error> {
                let mut out = Vec::new();
                while let Some((k, v)) = a.next_entry()? {
                    out.push((k, v));
                }
                Ok(out)
            }
        }
        d.deserialize_map(V(PhantomData))
    }
}

/// An `f64` that may be non-finite: `null` is read back as NaN (serde_json writes ±∞ and NaN
/// as `null`).
pub(crate) mod float {
    use super::*;

    /// Write the number (non-finite as `null`).
    pub(crate) fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else {
            s.serialize_none()
        }
    }

    /// Read a number or `null` (NaN).
    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

/// `Vec<f64>` whose entries may be non-finite (see [`float`]).
pub(crate) mod floats {
    use super::*;

    /// Write the numbers (non-finite as `null`).
    pub(crate) fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let o: Vec<Option<f64>> = v.iter().map(|x| x.is_finite().then_some(*x)).collect();
        o.serialize(s)
    }

    /// Read numbers or `null`s (NaN).
    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        let o = Vec::<Option<f64>>::deserialize(d)?;
        Ok(o.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
    }
}

/// `Vec<Vec<f64>>` whose entries may be non-finite (see [`float`]).
pub(crate) mod matrix {
    use super::*;

    /// Write the rows (non-finite entries as `null`).
    pub(crate) fn serialize<S: Serializer>(v: &[Vec<f64>], s: S) -> Result<S::Ok, S::Error> {
        let o: Vec<Vec<Option<f64>>> = v
            .iter()
            .map(|r| r.iter().map(|x| x.is_finite().then_some(*x)).collect())
            .collect();
        o.serialize(s)
    }

    /// Read rows of numbers or `null`s (NaN).
    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Vec<f64>>, D::Error> {
        let o = Vec::<Vec<Option<f64>>>::deserialize(d)?;
        Ok(o.into_iter()
            .map(|r| r.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
            .collect())
    }
}

/// Profiled ranges `(name, lo, hi)` as an object name → `[lo, hi]`, an open end (±∞) as
/// `null`.
pub(crate) mod ranges {
    use super::*;

    /// Write the ranges.
    pub(crate) fn serialize<S: Serializer>(
        v: &[(String, f64, f64)],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(v.len()))?;
        for (k, lo, hi) in v {
            let e = [lo.is_finite().then_some(*lo), hi.is_finite().then_some(*hi)];
            m.serialize_entry(k, &e)?;
        }
        m.end()
    }

    /// Read the ranges (`null` → −∞ below, +∞ above).
    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Vec<(String, f64, f64)>, D::Error> {
        let p: Vec<(String, [Option<f64>; 2])> = pairs::deserialize(d)?;
        Ok(p.into_iter()
            .map(|(k, [lo, hi])| {
                (
                    k,
                    lo.unwrap_or(f64::NEG_INFINITY),
                    hi.unwrap_or(f64::INFINITY),
                )
            })
            .collect())
    }
}

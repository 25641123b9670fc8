//! Neural-BRDF networks (Sztrajman, Rainer, Ritschel & Weyrich, "Neural BRDF Representation
//! and Importance Sampling", Computer Graphics Forum 40(6), 2021): one small MLP per material
//! that approximates a measured BRDF, evaluated anywhere, so one truth can be sampled at any
//! grid (a goniometer's, a dense MERL table's).
//!
//! The network (as in the weights file's `format` and its authors' code): input
//! x = (sin θh, 0, cos θh, dx, dy, dz), the half vector at φh = 0 and the difference vector d
//! of Rusinkiewicz's coordinates (Rusinkiewicz 1998; d is the light direction in the frame
//! whose pole is the half vector, [`crate::data::merl::std_to_half_diff`]); two hidden ReLU
//! layers and a linear output, y = ((x W1 + b1)⁺ W2 + b2)⁺ W3 + b3; f_r (RGB, 1/sr) =
//! max(e^y − 1, 0).
//!
//! Weights file: JSON `{"materials": {"merl/steel": {"W1": [[…]], "b1": […], "W2", "b2",
//! "W3", "b3"}, …}}`, W stored input-major (W1 is 6 rows of H1).

use super::{DataError, io_error};
use std::path::Path;

/// The widest layer a network may have.
const MAX_WIDTH: usize = 64;

/// One material's network.
#[derive(Clone, Debug, PartialEq)]
pub struct Nbrdf {
    /// The material's key in the weights file (`merl/steel`).
    pub name: String,
    /// Layers as (weights input-major, biases, outputs).
    layers: Vec<(Vec<f64>, Vec<f64>)>,
}

/// Read a JSON file as a value, with the file and line of a syntax error.
fn read_json(path: &Path) -> Result<serde_json::Value, DataError> {
    crate::support::input::check_regular(path, crate::support::input::Input::Data)?;
    let text = std::fs::read_to_string(path).map_err(|e| io_error(path, &e))?;
    parse_json(path, &text)
}

/// Parse a weights file's text (`path` names it in messages).
fn parse_json(path: &Path, text: &str) -> Result<serde_json::Value, DataError> {
    serde_json::from_str(text).map_err(|e| {
        DataError::new(
            path,
            Some(e.line() as u64),
            format!("not valid JSON: {e}"),
            "give the Neural-BRDF weights file (nbrdf_weights.json)",
        )
    })
}

/// The `materials` object of a weights file.
fn materials<'a>(
    path: &Path,
    v: &'a serde_json::Value,
) -> Result<&'a serde_json::Map<String, serde_json::Value>, DataError> {
    v.get("materials")
        .and_then(|m| m.as_object())
        .ok_or_else(|| {
            DataError::new(
                path,
                None,
                "key `materials`: missing or not an object of networks",
                "give the Neural-BRDF weights file: {\"materials\": {\"merl/steel\": {\"W1\": …}}}",
            )
        })
}

/// The material names in a weights file, in file order.
pub fn material_names(path: &Path) -> Result<Vec<String>, DataError> {
    let v = read_json(path)?;
    Ok(materials(path, &v)?.keys().cloned().collect())
}

/// Every network of a weights file's text, in file order (`path` names the file in messages).
pub fn parse_all(path: &Path, text: &str) -> Result<Vec<Nbrdf>, DataError> {
    let v = parse_json(path, text)?;
    materials(path, &v)?
        .iter()
        .map(|(k, m)| Nbrdf::from_json(path, k, m))
        .collect()
}

/// Every network of a weights file, in file order.
pub fn load_all(path: &Path) -> Result<Vec<Nbrdf>, DataError> {
    crate::support::input::check_regular(path, crate::support::input::Input::Data)?;
    let text = std::fs::read_to_string(path).map_err(|e| io_error(path, &e))?;
    parse_all(path, &text)
}

/// Edit distance, for "did you mean" in messages.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for j in 0..b.len() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != b[j]))
                .min(row[j] + 1)
                .min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

impl Nbrdf {
    /// Load the network of `material` from a weights file. The name is the file's key
    /// (`merl/steel`) or, when unambiguous, its last part (`steel`).
    pub fn load(path: &Path, material: &str) -> Result<Nbrdf, DataError> {
        let v = read_json(path)?;
        let mats = materials(path, &v)?;
        let key = if mats.contains_key(material) {
            material.to_string()
        } else {
            let tail: Vec<&String> = mats
                .keys()
                .filter(|k| k.rsplit('/').next() == Some(material))
                .collect();
            match tail.as_slice() {
                [one] => (*one).clone(),
                [] => {
                    let near = mats
                        .keys()
                        .min_by_key(|k| {
                            distance(k, material)
                                .min(distance(k.rsplit('/').next().unwrap_or(k), material))
                        })
                        .cloned()
                        .unwrap_or_default();
                    return Err(DataError::new(
                        path,
                        None,
                        format!(
                            "key `materials`: no material `{material}` among its {} networks",
                            mats.len()
                        ),
                        format!("did you mean --material {near}?"),
                    ));
                }
                many => {
                    return Err(DataError::new(
                        path,
                        None,
                        format!(
                            "key `materials`: `{material}` names {} networks ({})",
                            many.len(),
                            many.iter()
                                .map(|s| s.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                        format!("give the full name, e.g. --material {}", many[0]),
                    ));
                }
            }
        };
        Self::from_json(path, &key, &mats[&key])
    }

    /// The network from its JSON object (`W1`, `b1`, `W2`, `b2`, `W3`, `b3`), checked: 6 inputs,
    /// each layer's rows as long as the next bias, 3 outputs, every number finite.
    fn from_json(path: &Path, key: &str, m: &serde_json::Value) -> Result<Nbrdf, DataError> {
        let bad = |what: &str, msg: String| {
            DataError::new(
                path,
                None,
                format!("key `materials.{key}.{what}`: {msg}"),
                "the network must be MLP 6→H1→H2→3: W1 6×H1, b1 H1, W2 H1×H2, b2 H2, W3 H2×3, b3 3, all finite numbers",
            )
        };
        let numbers = |what: &str, v: Option<&serde_json::Value>| -> Result<Vec<f64>, DataError> {
            let arr = v
                .and_then(|v| v.as_array())
                .ok_or_else(|| bad(what, "missing or not a list".into()))?;
            arr.iter()
                .enumerate()
                .map(|(i, x)| {
                    x.as_f64()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| bad(what, format!("entry {i} is not a finite number")))
                })
                .collect()
        };
        let mut layers = Vec::new();
        let mut inputs = 6;
        for l in 1..=3 {
            let (wk, bk) = (format!("W{l}"), format!("b{l}"));
            let b = numbers(&bk, m.get(&bk))?;
            let rows = m
                .get(&wk)
                .and_then(|v| v.as_array())
                .ok_or_else(|| bad(&wk, "missing or not a list of rows".into()))?;
            if rows.len() != inputs {
                return Err(bad(
                    &wk,
                    format!("{} rows, expected {inputs} (one per input)", rows.len()),
                ));
            }
            let mut w = Vec::with_capacity(inputs * b.len());
            for (i, r) in rows.iter().enumerate() {
                let r = numbers(&format!("{wk}[{i}]"), Some(r))?;
                if r.len() != b.len() {
                    return Err(bad(
                        &wk,
                        format!("row {i} has {} entries, {bk} has {}", r.len(), b.len()),
                    ));
                }
                w.extend(r);
            }
            if b.len() > MAX_WIDTH {
                return Err(bad(
                    &bk,
                    format!("{} units, at most {MAX_WIDTH} are supported", b.len()),
                ));
            }
            inputs = b.len();
            layers.push((w, b));
        }
        if inputs != 3 {
            return Err(bad("b3", format!("{inputs} outputs, expected 3 (r, g, b)")));
        }
        Ok(Nbrdf {
            name: key.to_string(),
            layers,
        })
    }

    /// f_r (r, g, b in 1/sr) for light at (θi, φi) and view at (θo, φo), radians, the network
    /// as it is (with L as Rusinkiewicz's incoming direction); 0 where either is below the
    /// horizon.
    pub fn eval(&self, a: [f64; 4]) -> [f64; 3] {
        if !(a[0] < std::f64::consts::FRAC_PI_2 && a[2] < std::f64::consts::FRAC_PI_2) {
            return [0.0; 3];
        }
        let [th, _, td, pd] = super::merl::std_to_half_diff(a);
        let d = super::direction(td, pd);
        let mut x = [0.0; MAX_WIDTH];
        x[..6].copy_from_slice(&[th.sin(), 0.0, th.cos(), d[0], d[1], d[2]]);
        let mut inputs = 6;
        for (k, (w, b)) in self.layers.iter().enumerate() {
            let mut y = [0.0; MAX_WIDTH];
            y[..b.len()].copy_from_slice(b);
            for (i, xi) in x[..inputs].iter().enumerate() {
                for (j, yj) in y[..b.len()].iter_mut().enumerate() {
                    *yj += xi * w[i * b.len() + j];
                }
            }
            if k + 1 < self.layers.len() {
                for yj in &mut y[..b.len()] {
                    *yj = yj.max(0.0);
                }
            }
            x = y;
            inputs = b.len();
        }
        [0, 1, 2].map(|c| (x[c].exp() - 1.0).max(0.0))
    }

    /// The network made reciprocal and isotropic-symmetric: the mean of f(L, E), f(E, L) and
    /// their mirror images in the plane of incidence (E at azimuth 2φi − φo). The truth for a
    /// reciprocal, isotropic model or table (the networks themselves are not exactly either).
    pub fn eval_symmetric(&self, a: [f64; 4]) -> [f64; 3] {
        let [ti, pi, to, po] = a;
        let pm = 2.0 * pi - po;
        let mut out = [0.0; 3];
        for c in [
            [ti, pi, to, po],
            [to, po, ti, pi],
            [ti, pi, to, pm],
            [to, pm, ti, pi],
        ] {
            let f = self.eval(c);
            for k in 0..3 {
                out[k] += 0.25 * f[k];
            }
        }
        out
    }
}

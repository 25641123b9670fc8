//! ASTM E1392 text: `KEY value` header lines ending with `VARS name,name,…`, then
//! comma-separated rows with angles in radians (`theta_i,phi_i,theta_s,phi_s,<channels>`).

use super::{DataError, Dataset, NegativePolicy, Quantity, RowSink, parse_number, read_text};
use std::path::Path;

const FIX_VARS: &str = "the header must end with a line like \
     'VARS theta_i,phi_i,theta_s,phi_s,<value columns>' (angles in radians)";

pub(crate) fn load_astm(path: &Path, policy: NegativePolicy) -> Result<Dataset, DataError> {
    let text = read_text(path)?;
    let mut lines = text.lines().enumerate().map(|(i, l)| (i as u64 + 1, l));
    let header = read_header(path, &mut lines)?;
    let Some((vars_line, names)) = header.vars else {
        return Err(DataError::new(
            path,
            None,
            "no VARS line in the ASTM header",
            FIX_VARS,
        ));
    };
    let quantity = quantity(path, header.meas.as_deref())?;
    check_vars(path, vars_line, &names)?;
    let channels: Vec<(String, Option<f64>)> = names[4..]
        .iter()
        .map(|n| {
            let wl = n.strip_suffix("nm").and_then(|w| w.parse::<f64>().ok());
            let name = if names.len() == 5 && wl.is_none() {
                String::new()
            } else {
                n.clone()
            };
            (name, wl)
        })
        .collect();
    let mut ds = Dataset::new(quantity, channels);
    ds.meta.comments = header.comments;
    ds.meta.material = header.material;
    let ds = read_rows(path, policy, ds, &names, lines)?;
    if let Some((ln, n)) = header.num_points
        && n != ds.len()
    {
        return Err(DataError::new(
            path,
            Some(ln),
            format!("NUM_POINTS says {n} but the file holds {} rows", ds.len()),
            "the file may be truncated: fetch it again, or correct NUM_POINTS",
        ));
    }
    Ok(ds)
}

/// What the header lines say, read up to and including the `VARS` line.
struct Header {
    /// The header lines as comments (the first 1,000, each cut at 500 characters).
    comments: Vec<String>,
    /// `SAMPLE_NAME`.
    material: Option<String>,
    /// `NUM_POINTS` and its line.
    num_points: Option<(u64, usize)>,
    /// `MEAS_NAME`.
    meas: Option<String>,
    /// The `VARS` line's number and its names, lower case.
    vars: Option<(u64, Vec<String>)>,
}

/// Read the header from `lines` (numbered from 1), stopping after the `VARS` line.
fn read_header<'a>(
    path: &Path,
    lines: &mut impl Iterator<Item = (u64, &'a str)>,
) -> Result<Header, DataError> {
    let mut comments = Vec::new();
    let mut material = None;
    let mut num_points: Option<(u64, usize)> = None;
    let mut meas: Option<String> = None;
    let mut vars: Option<(u64, Vec<String>)> = None;
    for (ln, raw) in lines {
        let l = raw.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let (key, value) = l.split_once(char::is_whitespace).unwrap_or((l, ""));
        let value = value.trim();
        match key {
            "VARS" => {
                vars = Some((
                    ln,
                    value
                        .split(',')
                        .map(|s| s.trim().to_ascii_lowercase())
                        .collect(),
                ));
                break;
            }
            "NUM_POINTS" => {
                let n = value.parse::<usize>().map_err(|_| {
                    DataError::new(
                        path,
                        Some(ln),
                        format!("NUM_POINTS '{value}' is not a count"),
                        "NUM_POINTS must be a non-negative integer",
                    )
                })?;
                num_points = Some((ln, n));
            }
            "MEAS_NAME" => meas = Some(value.to_string()),
            "SAMPLE_NAME" => material = Some(value.to_string()),
            _ => {}
        }
        if key
            .chars()
            .any(|c| c.is_ascii_digit() || c == ',' || c == '.')
            && key.parse::<f64>().is_ok()
        {
            return Err(DataError::new(
                path,
                Some(ln),
                "data row before the VARS line",
                FIX_VARS,
            ));
        }
        if comments.len() < 1000 {
            comments.push(l.chars().take(500).collect::<String>());
        }
    }
    Ok(Header {
        comments,
        material,
        num_points,
        meas,
        vars,
    })
}

/// The quantity `MEAS_NAME` names (f_r when there is none).
fn quantity(path: &Path, meas: Option<&str>) -> Result<Quantity, DataError> {
    match meas.map(|m| m.to_ascii_uppercase()) {
        None => Ok(Quantity::Brdf),
        Some(m) if m == "BRDF" => Ok(Quantity::Brdf),
        Some(m) if m == "BRDF*COS" || m == "CCBRDF" => Ok(Quantity::BrdfCos),
        Some(m) => Err(DataError::new(
            path,
            None,
            format!("MEAS_NAME '{m}' is not a quantity brdfit reads"),
            "brdfit reads MEAS_NAME BRDF (f_r) or BRDF*COS; convert the file to brdfit CSV \
             and name the value columns brdf, brdf_cos or rfactor",
        )),
    }
}

/// Check the `VARS` names (on line `vars_line`): the four angles, then at least one value.
fn check_vars(path: &Path, vars_line: u64, names: &[String]) -> Result<(), DataError> {
    const ANGLES: [[&str; 2]; 4] = [
        ["theta_i", "theta_i"],
        ["phi_i", "phi_i"],
        ["theta_s", "theta_r"],
        ["phi_s", "phi_r"],
    ];
    if names.len() < 5 {
        return Err(DataError::new(
            path,
            Some(vars_line),
            format!(
                "VARS lists {} columns; need 4 angles and at least one value",
                names.len()
            ),
            FIX_VARS,
        ));
    }
    for (k, alts) in ANGLES.iter().enumerate() {
        if !alts.contains(&names[k].as_str()) {
            return Err(DataError::new(
                path,
                Some(vars_line),
                format!(
                    "VARS column {} is '{}', expected {}",
                    k + 1,
                    names[k],
                    alts[0]
                ),
                FIX_VARS,
            ));
        }
    }
    Ok(())
}

/// The data rows of `lines` (after the header) into `ds`, one field per name of `names`.
fn read_rows<'a>(
    path: &Path,
    policy: NegativePolicy,
    ds: Dataset,
    names: &[String],
    lines: impl Iterator<Item = (u64, &'a str)>,
) -> Result<Dataset, DataError> {
    let nv = names.len() - 4;
    let mut sink = RowSink::new(path, policy, ds);
    let mut vals = vec![0.0; nv];
    for (ln, raw) in lines {
        let l = raw.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = l.split(',').collect();
        if fields.len() != names.len() {
            return Err(DataError::new(
                path,
                Some(ln),
                format!(
                    "the row has {} fields but VARS lists {}",
                    fields.len(),
                    names.len()
                ),
                "give every row one comma-separated field per VARS name",
            ));
        }
        let mut a = [0.0; 4];
        for k in 0..4 {
            a[k] = parse_number(path, ln, &names[k], fields[k])?;
        }
        for (c, f) in fields[4..].iter().enumerate() {
            vals[c] = parse_number(path, ln, &names[4 + c], f)?;
        }
        sink.push(ln, a, &vals, None)?;
    }
    sink.finish()
}

//! brdfit CSV: a header with unit-carrying angle columns and quantity-naming value columns.
//!
//! ```text
//! # comment lines are allowed anywhere a line starts with '#'
//! theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,brdf_r,brdf_g,brdf_b,weight
//! 30,0,30,180,1.25,1.1,0.9,1
//! ```
//! Angle columns: `theta_i`, `phi_i`, `theta_o`, `phi_o`, each with `_deg` or `_rad`.
//! Value columns: `brdf` (f_r), `brdf_cos` (f_r cosθi) or `rfactor` (π f_r), optionally with a
//! channel suffix `_r`, `_g`, `_b`, `_y` or `_<λ>nm`. An optional `weight` column. An empty
//! value field marks a missing value. The columns `plan_rank` and `plan_share` (written by
//! `brdfit plan`) are read past.

use super::{DataError, Dataset, NegativePolicy, Quantity, RowSink, io_error, open, parse_number};
use crate::support::output::{write_atomic, write_error};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

enum Col {
    Angle(usize, f64),
    Value(usize),
    Weight,
    Ignored,
}

const ANGLE_NAMES: [&str; 4] = ["theta_i", "phi_i", "theta_o", "phi_o"];

/// Split a value column name into its quantity and channel suffix.
fn parse_value_column(name: &str) -> Option<(Quantity, String)> {
    let (q, rest) = if let Some(r) = name.strip_prefix("brdf_cos") {
        (Quantity::BrdfCos, r)
    } else if let Some(r) = name.strip_prefix("rfactor") {
        (Quantity::RFactor, r)
    } else if let Some(r) = name.strip_prefix("brdf") {
        (Quantity::Brdf, r)
    } else {
        return None;
    };
    if rest.is_empty() {
        return Some((q, String::new()));
    }
    let suffix = rest.strip_prefix('_')?;
    let ok = matches!(suffix, "r" | "g" | "b" | "y")
        || suffix
            .strip_suffix("nm")
            .is_some_and(|w| w.parse::<f64>().is_ok_and(|w| w > 0.0 && w.is_finite()));
    ok.then(|| (q, suffix.to_string()))
}

fn wavelength_of(suffix: &str) -> Option<f64> {
    suffix.strip_suffix("nm")?.parse().ok()
}

const HEADER_FIX: &str = "the header needs theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg (or _rad) \
     and value columns named brdf, brdf_cos or rfactor (optionally _r/_g/_b/_y/_<λ>nm), \
     plus an optional weight column";

/// Load a brdfit CSV. With `values = false` only the angle columns are read (for `eval`).
pub(crate) fn load_csv(
    path: &Path,
    policy: NegativePolicy,
    values: bool,
) -> Result<Dataset, DataError> {
    let mut reader = BufReader::with_capacity(1 << 16, open(path)?);
    // A UTF-8 BOM is accepted.
    if reader
        .fill_buf()
        .map_err(|e| io_error(path, &e))?
        .starts_with(b"\xEF\xBB\xBF")
    {
        reader.consume(3);
    }
    // Leading comment lines carry metadata; keep them and count lines.
    let (comments, offset) = leading_comments(path, &mut reader)?;
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .comment(Some(b'#'))
        .flexible(false)
        .from_reader(reader);
    let header_line = offset + 1;
    // Fields are trimmed here rather than by the reader (`csv::Trim::All` builds a new record
    // for every row: a third of the time to read a million rows).
    let headers: csv::StringRecord = match rdr.headers() {
        Ok(h) => h.iter().map(str::trim).collect(),
        Err(e) => return Err(csv_error(path, offset, e)),
    };
    if headers.is_empty() || (headers.len() == 1 && headers[0].is_empty()) {
        return Err(DataError::new(
            path,
            None,
            "the file has no header line",
            HEADER_FIX,
        ));
    }
    if headers.len() == 1 && headers[0].contains(';') {
        return Err(DataError::new(
            path,
            Some(header_line),
            "the fields are separated by ';' (a spreadsheet export with decimal commas?)",
            "brdfit reads comma-separated values with '.' as the decimal point: re-export as CSV \
             with ',' between fields and '.' decimals",
        ));
    }
    let (cols, channels, quantity) = parse_header(path, &headers, header_line, values)?;
    let mut ds = Dataset::new(quantity.unwrap_or(Quantity::Brdf), channels);
    ds.meta.comments = comments;
    ds.meta.material = ds
        .meta
        .comments
        .iter()
        .find_map(|c| c.strip_prefix("material:").map(|m| m.trim().to_string()));
    let nch = ds.channels.len();
    let mut sink = RowSink::new(path, policy, ds);
    let mut record = csv::StringRecord::new();
    let mut vals = vec![0.0; nch];
    loop {
        match rdr.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_error(path, offset, e)),
        }
        let line = offset + record.position().map_or(0, |p| p.line());
        let mut angles = [0.0; 4];
        let mut weight = None;
        for (field, (col, name)) in record.iter().zip(cols.iter().zip(headers.iter())) {
            let field = field.trim();
            match col {
                Col::Angle(k, f) => {
                    if field.is_empty() {
                        return Err(DataError::new(
                            path,
                            Some(line),
                            format!("column {name}: empty angle"),
                            "every row needs all four angles",
                        ));
                    }
                    angles[*k] = parse_number(path, line, name, field)? * f;
                }
                Col::Value(c) => {
                    vals[*c] = if field.is_empty() {
                        f64::NAN
                    } else {
                        parse_number(path, line, name, field)?
                    };
                }
                Col::Weight => weight = Some(parse_number(path, line, name, field)?),
                Col::Ignored => {}
            }
        }
        sink.push(line, angles, &vals, weight)?;
    }
    let mut ds = sink.finish()?;
    let degrees = cols
        .iter()
        .any(|c| matches!(c, Col::Angle(_, f) if *f != 1.0));
    if degrees && let Some(w) = degrees_look_like_radians(&ds) {
        ds.meta.warnings.push(format!("{}: {w}", path.display()));
    }
    Ok(ds)
}

/// A file that declares degrees but whose every θ lies within [0, π/2] and every φ within
/// [−2π, 2π] (as read in degrees) most likely holds radians: the mix-up in words, or `None`.
/// Needs at least 2 samples and some θ above 0.2° (a near-normal-only set is left alone).
pub(crate) fn degrees_look_like_radians(ds: &Dataset) -> Option<String> {
    use std::f64::consts::{FRAC_PI_2, PI};
    if ds.len() < 2 {
        return None;
    }
    // Angles are stored in radians: a value v read in degrees is v·π/180.
    let max_of = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let theta = max_of(&ds.theta_i).max(max_of(&ds.theta_o)).to_degrees();
    let phi = max_of(&ds.phi_i).max(max_of(&ds.phi_o)).to_degrees();
    let tol = 1e-6;
    (theta > 0.2 && theta <= FRAC_PI_2 + tol && phi <= 2.0 * PI + tol).then(|| {
        format!(
            "the angle columns say degrees (_deg), but every θ lies within 0…{theta:.4}° and every \
             φ within ±{phi:.4}°: these look like radians\n  fix: rename the columns to \
             theta_i_rad, phi_i_rad, theta_o_rad, phi_o_rad; or, if they really are degrees, pass \
             --trust-units"
        )
    })
}

/// What a header declares: each column's role, the value channels (name, wavelength) and
/// the quantity.
type Header = (Vec<Col>, Vec<(String, Option<f64>)>, Option<Quantity>);

/// The columns of a header line: what each column holds, the value channels (name and
/// wavelength) and the quantity; an error names the line and the fix.
fn parse_header(
    path: &Path,
    headers: &csv::StringRecord,
    header_line: u64,
    values: bool,
) -> Result<Header, DataError> {
    let mut cols = Vec::with_capacity(headers.len());
    let mut angle_seen = [false; 4];
    let mut channels: Vec<(String, Option<f64>)> = Vec::new();
    let mut quantity: Option<Quantity> = None;
    for raw in headers.iter() {
        let name = raw.trim().to_ascii_lowercase();
        if let Some(k) = ANGLE_NAMES.iter().position(|a| name.starts_with(a)) {
            let rest = &name[ANGLE_NAMES[k].len()..];
            let factor = match rest {
                "_deg" => std::f64::consts::PI / 180.0,
                "_rad" => 1.0,
                _ => {
                    return Err(DataError::new(
                        path,
                        Some(header_line),
                        format!("angle column '{raw}' has no unit"),
                        format!(
                            "angle columns need a unit: rename {0} to {0}_deg or {0}_rad",
                            ANGLE_NAMES[k]
                        ),
                    ));
                }
            };
            if angle_seen[k] {
                return Err(DataError::new(
                    path,
                    Some(header_line),
                    format!("angle column {} appears twice", ANGLE_NAMES[k]),
                    "keep one column per angle",
                ));
            }
            angle_seen[k] = true;
            cols.push(Col::Angle(k, factor));
        } else if name == "plan_rank" || name == "plan_share" {
            // Written by `brdfit plan` beside the angles.
            cols.push(Col::Ignored);
        } else if name == "weight" {
            cols.push(if values { Col::Weight } else { Col::Ignored });
        } else if let Some((q, suffix)) = parse_value_column(&name) {
            if !values {
                cols.push(Col::Ignored);
                continue;
            }
            if let Some(q0) = quantity
                && q0 != q
            {
                return Err(DataError::new(
                    path,
                    Some(header_line),
                    format!(
                        "value columns mix quantities ({} and {})",
                        q0.column(),
                        q.column()
                    ),
                    "keep one quantity per file: all brdf, all brdf_cos or all rfactor",
                ));
            }
            quantity = Some(q);
            if channels.iter().any(|(n, _)| *n == suffix) {
                return Err(DataError::new(
                    path,
                    Some(header_line),
                    format!("value column '{raw}' appears twice"),
                    "give each channel one column",
                ));
            }
            cols.push(Col::Value(channels.len()));
            let wl = wavelength_of(&suffix);
            channels.push((suffix, wl));
        } else {
            return Err(DataError::new(
                path,
                Some(header_line),
                format!("unknown column '{raw}'"),
                HEADER_FIX,
            ));
        }
    }
    let missing: Vec<String> = (0..4)
        .filter(|&k| !angle_seen[k])
        .map(|k| format!("{}_deg", ANGLE_NAMES[k]))
        .collect();
    if !missing.is_empty() {
        return Err(DataError::new(
            path,
            Some(header_line),
            format!("missing angle column(s): {}", missing.join(", ")),
            HEADER_FIX,
        ));
    }
    if values && channels.is_empty() {
        return Err(DataError::new(
            path,
            Some(header_line),
            "no value column (brdf, brdf_cos or rfactor)",
            HEADER_FIX,
        ));
    }
    Ok((cols, channels, quantity))
}

/// Leading comment and blank lines: their text (at most 1,000 lines of 500 characters) and
/// how many lines they took.
fn leading_comments(
    path: &Path,
    reader: &mut BufReader<crate::support::input::Limited<std::fs::File>>,
) -> Result<(Vec<String>, u64), DataError> {
    let mut comments = Vec::new();
    let mut offset: u64 = 0;
    loop {
        let buf = reader.fill_buf().map_err(|e| io_error(path, &e))?;
        if buf.is_empty() || !(buf[0] == b'#' || buf[0] == b'\n' || buf[0] == b'\r') {
            break;
        }
        let mut line = Vec::new();
        reader
            .read_until(b'\n', &mut line)
            .map_err(|e| io_error(path, &e))?;
        offset += 1;
        let text = String::from_utf8_lossy(&line);
        let t = text.trim_start_matches('#').trim();
        if !t.is_empty() && comments.len() < 1000 {
            comments.push(t.chars().take(500).collect::<String>());
        }
    }
    Ok((comments, offset))
}

fn csv_error(path: &Path, offset: u64, e: csv::Error) -> DataError {
    let line = e.position().map(|p| offset + p.line());
    match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => DataError::new(
            path,
            line,
            format!("the row has {len} fields but the header has {expected_len}"),
            "give every row one field per header column (a missing value is an empty field)",
        ),
        csv::ErrorKind::Utf8 { .. } => DataError::new(
            path,
            line,
            "the line is not valid UTF-8 text",
            "save the file as UTF-8 text",
        ),
        csv::ErrorKind::Io(err) => io_error(path, err),
        _ => DataError::new(
            path,
            line,
            format!("malformed CSV: {e}"),
            "fix the CSV syntax",
        ),
    }
}

/// Read only the four angle columns of a CSV (for `brdfit eval`).
pub fn load_directions(path: &Path) -> Result<Dataset, DataError> {
    let mut ds = load_csv(path, NegativePolicy::Mask, false)?;
    ds.meta.source = path.display().to_string();
    ds.meta.format = "csv".into();
    Ok(ds)
}

/// Write a dataset as brdfit CSV (angles in degrees, values as stored; missing values empty),
/// atomically (temporary file, then rename).
pub fn write_csv(ds: &Dataset, path: &Path) -> Result<(), DataError> {
    write_atomic(path, |w| write_csv_to(ds, w)).map_err(|e| write_error(path, &e))
}

/// An angle in degrees as written: rounded to 1e-11° so that a grid angle stored in radians
/// prints as `30`, not `29.999999999999996` (far below any goniometer's resolution).
pub(crate) fn degrees(rad: f64) -> f64 {
    let d = (rad.to_degrees() * 1e11).round() / 1e11;
    if d == 0.0 { 0.0 } else { d }
}

/// Write a dataset as brdfit CSV to any writer.
pub fn write_csv_to(ds: &Dataset, w: &mut dyn Write) -> std::io::Result<()> {
    if !ds.meta.source.is_empty() {
        writeln!(w, "# source: {}", ds.meta.source)?;
    }
    if let Some(m) = &ds.meta.material {
        writeln!(w, "# material: {m}")?;
    }
    for c in &ds.meta.comments {
        if !c.starts_with("material:") && !c.starts_with("source:") {
            writeln!(w, "# {}", c.replace(['\n', '\r'], " "))?;
        }
    }
    write!(w, "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg")?;
    for c in &ds.channels {
        if c.name.is_empty() {
            write!(w, ",{}", ds.quantity.column())?;
        } else {
            write!(w, ",{}_{}", ds.quantity.column(), c.name)?;
        }
    }
    if ds.weights.is_some() {
        write!(w, ",weight")?;
    }
    writeln!(w)?;
    for k in 0..ds.len() {
        let a = ds.angles(k);
        write!(
            w,
            "{},{},{},{}",
            degrees(a[0]),
            degrees(a[1]),
            degrees(a[2]),
            degrees(a[3])
        )?;
        for c in &ds.channels {
            let v = c.values[k];
            if v.is_nan() {
                write!(w, ",")?;
            } else {
                write!(w, ",{v}")?;
            }
        }
        if let Some(wt) = &ds.weights {
            write!(w, ",{}", wt[k])?;
        }
        writeln!(w)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_column_names() {
        assert_eq!(
            parse_value_column("brdf"),
            Some((Quantity::Brdf, "".into()))
        );
        assert_eq!(
            parse_value_column("brdf_cos_g"),
            Some((Quantity::BrdfCos, "g".into()))
        );
        assert_eq!(
            parse_value_column("rfactor_550nm"),
            Some((Quantity::RFactor, "550nm".into()))
        );
        assert_eq!(parse_value_column("brdf_x"), None);
        assert_eq!(parse_value_column("brdfs"), None);
    }
}

//! Cornell / pbrt-v2 spectral text (`.brdf`): `#` comments; the wavelength count; the
//! wavelengths; then records `theta_i phi_i theta_s phi_s v[count]`, angles in radians, f_r.

use super::{DataError, Dataset, NegativePolicy, Quantity, RowSink, parse_number, read_text};
use std::path::Path;

const FIX: &str = "a Cornell .brdf file holds the wavelength count, the wavelengths, then records \
     of theta_i phi_i theta_s phi_s and one value per wavelength (angles in radians)";

pub(crate) fn load_cornell(path: &Path, policy: NegativePolicy) -> Result<Dataset, DataError> {
    let text = read_text(path)?;
    let mut comments = Vec::new();
    // Token stream with line numbers; comments run from '#' to the end of the line.
    let mut tokens = text.lines().enumerate().flat_map(|(i, l)| {
        let (data, comment) = match l.find('#') {
            Some(p) => (&l[..p], Some(l[p + 1..].trim())),
            None => (l, None),
        };
        if let Some(c) = comment
            && !c.is_empty()
            && comments.len() < 1000
        {
            comments.push(c.to_string());
        }
        data.split_whitespace().map(move |t| (i as u64 + 1, t))
    });
    let Some((ln, first)) = tokens.next() else {
        return Err(DataError::new(path, None, "the file holds no numbers", FIX));
    };
    let count = first
        .parse::<usize>()
        .ok()
        .filter(|&n| (1..=100_000).contains(&n))
        .ok_or_else(|| {
            DataError::new(
                path,
                Some(ln),
                format!("the wavelength count '{first}' is not an integer in 1..100000"),
                FIX,
            )
        })?;
    let mut wls = Vec::with_capacity(count);
    for _ in 0..count {
        let Some((ln, t)) = tokens.next() else {
            return Err(DataError::new(
                path,
                None,
                "the file ends inside the wavelength list",
                FIX,
            ));
        };
        wls.push(parse_number(path, ln, "wavelength", t)?);
    }
    let channels = wls.iter().map(|w| (format!("{w}nm"), Some(*w))).collect();
    let ds = Dataset::new(Quantity::Brdf, channels);
    let mut sink = RowSink::new(path, policy, ds);
    let mut vals = vec![0.0; count];
    const NAMES: [&str; 4] = ["theta_i", "phi_i", "theta_s", "phi_s"];
    'records: loop {
        let mut a = [0.0; 4];
        let mut line0 = 0;
        for (k, name) in NAMES.iter().enumerate() {
            match tokens.next() {
                None if k == 0 => break 'records,
                None => {
                    return Err(DataError::new(
                        path,
                        Some(line0),
                        "the file ends inside a record",
                        "the file may be truncated: each record needs 4 angles and one value per wavelength",
                    ));
                }
                Some((ln, t)) => {
                    if k == 0 {
                        line0 = ln;
                    }
                    a[k] = parse_number(path, ln, name, t)?;
                }
            }
        }
        for (c, v) in vals.iter_mut().enumerate() {
            let Some((ln, t)) = tokens.next() else {
                return Err(DataError::new(
                    path,
                    Some(line0),
                    format!("the record ends after {c} of {count} values"),
                    "the file may be truncated: each record needs 4 angles and one value per wavelength",
                ));
            };
            *v = parse_number(path, ln, &format!("{}nm", wls[c]), t)?;
        }
        sink.push(line0, a, &vals, None)?;
    }
    drop(tokens);
    let mut ds = sink.finish()?;
    ds.meta.material = comments.get(1).cloned();
    ds.meta.comments = comments;
    Ok(ds)
}

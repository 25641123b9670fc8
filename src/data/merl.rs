//! MERL `.binary` BRDF tables (Matusik et al. 2003), reader and writer.
//!
//! Layout: three little-endian i32 dimensions (90, 90, 180) for (θh, θd, φd), then three
//! planes (R, G, B) of f64, each 90·90·180 values, φd fastest. Stored values are scaled:
//! f_r = value · (1/1500, 1.15/1500, 1.66/1500) for R, G, B. θh bins are non-linear
//! (index = √(θh/90°)·90), θd bins linear over [0°, 90°), φd bins linear over [0°, 180°)
//! using reciprocity (φd and φd + 180° share a cell). Negative cells are missing samples.

use super::{DataError, Dataset, Quantity, io_error, open};
use crate::support::output::{write_atomic, write_error};
use std::f64::consts::{FRAC_PI_2, PI};
use std::io::{Read, Write};
use std::path::Path;

/// Bins in θh.
pub const THETA_H: usize = 90;
/// Bins in θd.
pub const THETA_D: usize = 90;
/// Bins in φd (half a turn, by reciprocity).
pub const PHI_D: usize = 180;
/// Cells per channel.
pub const CELLS: usize = THETA_H * THETA_D * PHI_D;
/// Scale from a stored value to f_r, per channel R, G, B.
pub const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// True when the first 12 bytes are the standard MERL header (90, 90, 180).
pub fn looks_like_merl(head: &[u8]) -> bool {
    head.len() >= 12 && dims(head) == [90, 90, 180]
}

fn dims(head: &[u8]) -> [i32; 3] {
    let d = |k: usize| i32::from_le_bytes(head[4 * k..4 * k + 4].try_into().expect("4 bytes"));
    [d(0), d(1), d(2)]
}

fn rot_y(v: [f64; 3], a: f64) -> [f64; 3] {
    let (s, c) = a.sin_cos();
    [v[0] * c + v[2] * s, v[1], -v[0] * s + v[2] * c]
}

fn rot_z(v: [f64; 3], a: f64) -> [f64; 3] {
    let (s, c) = a.sin_cos();
    [v[0] * c - v[1] * s, v[0] * s + v[1] * c, v[2]]
}

fn angles_of(v: [f64; 3]) -> (f64, f64) {
    (v[2].clamp(-1.0, 1.0).acos(), v[1].atan2(v[0]))
}

/// Rusinkiewicz half/difference angles → (θi, φi, θo, φo), isotropic (φh = 0 gives φi, φo
/// relative to the half vector's azimuth).
pub fn half_diff_to_std(theta_h: f64, phi_h: f64, theta_d: f64, phi_d: f64) -> [f64; 4] {
    let h = super::direction(theta_h, phi_h);
    let d = super::direction(theta_d, phi_d);
    let wi = rot_z(rot_y(d, theta_h), phi_h);
    let k = 2.0 * (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]);
    let wo = [k * h[0] - wi[0], k * h[1] - wi[1], k * h[2] - wi[2]];
    let (ti, pi) = angles_of(wi);
    let (to, po) = angles_of(wo);
    [ti, pi, to, po]
}

/// (θi, φi, θo, φo) → (θh, φh, θd, φd).
pub fn std_to_half_diff(a: [f64; 4]) -> [f64; 4] {
    let wi = super::direction(a[0], a[1]);
    let wo = super::direction(a[2], a[3]);
    let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt().max(1e-300);
    let h = [s[0] / len, s[1] / len, s[2] / len];
    let (th, ph) = angles_of(h);
    let d = rot_y(rot_z(wi, -ph), -th);
    let (td, pd) = angles_of(d);
    [th, ph, td, pd]
}

/// Cell index of a direction pair, following MERL's `BRDFRead.cpp` lookup.
pub fn cell_index(a: [f64; 4]) -> usize {
    let [th, _, td, mut pd] = std_to_half_diff(a);
    let ih = if th <= 0.0 {
        0
    } else {
        ((th / FRAC_PI_2).sqrt() * THETA_H as f64) as usize
    }
    .min(THETA_H - 1);
    let id = ((td / FRAC_PI_2 * THETA_D as f64).max(0.0) as usize).min(THETA_D - 1);
    if pd < 0.0 {
        pd += PI;
    }
    let ip = ((pd / PI * PHI_D as f64).max(0.0) as usize).min(PHI_D - 1);
    ip + PHI_D * (id + THETA_D * ih)
}

/// The direction pair at the centre of a cell (in index space), (θi, φi, θo, φo).
pub fn cell_center(cell: usize) -> [f64; 4] {
    let ip = cell % PHI_D;
    let id = (cell / PHI_D) % THETA_D;
    let ih = cell / (PHI_D * THETA_D);
    let u = (ih as f64 + 0.5) / THETA_H as f64;
    let th = u * u * FRAC_PI_2;
    let td = (id as f64 + 0.5) / THETA_D as f64 * FRAC_PI_2;
    let pd = (ip as f64 + 0.5) / PHI_D as f64 * PI;
    half_diff_to_std(th, 0.0, td, pd)
}

fn err(path: &Path, msg: impl Into<String>, fix: &str) -> DataError {
    DataError::new(path, None, msg, fix)
}

/// Read a MERL `.binary` as RGB f_r samples: one sample per cell whose directions are both
/// above the surface and which holds a value in at least one channel.
pub fn load_merl(path: &Path) -> Result<Dataset, DataError> {
    let mut f = open(path)?;
    let len = f.file().metadata().map_err(|e| io_error(path, &e))?.len();
    let mut head = [0u8; 12];
    if len < 12 {
        return Err(err(
            path,
            format!("the file is {len} bytes, shorter than the 12-byte MERL header"),
            "the file is truncated or not a MERL .binary: fetch it again",
        ));
    }
    f.read_exact(&mut head).map_err(|e| io_error(path, &e))?;
    let d = dims(&head);
    if d != [90, 90, 180] {
        return Err(err(
            path,
            format!(
                "the header gives dimensions {}×{}×{}, not 90×90×180",
                d[0], d[1], d[2]
            ),
            "brdfit reads the standard MERL layout (90×90×180); check that this is a MERL .binary",
        ));
    }
    let want = 12 + (3 * CELLS * 8) as u64;
    if len != want {
        return Err(err(
            path,
            format!("the file is {len} bytes; a 90×90×180 MERL table is {want} bytes"),
            if len < want {
                "the file is truncated: fetch it again"
            } else {
                "the file has trailing bytes: check that it is a single MERL table"
            },
        ));
    }
    let mut bytes = vec![0u8; 3 * CELLS * 8];
    f.read_exact(&mut bytes).map_err(|e| io_error(path, &e))?;
    let value = |c: usize, i: usize| {
        let o = 8 * (c * CELLS + i);
        f64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"))
    };
    let mut ds = Dataset::new(
        Quantity::Brdf,
        vec![("r".into(), None), ("g".into(), None), ("b".into(), None)],
    );
    let mut negatives = 0;
    for cell in 0..CELLS {
        let raw = [value(0, cell), value(1, cell), value(2, cell)];
        if raw.iter().any(|v| !v.is_finite()) {
            return Err(err(
                path,
                format!("cell {cell} holds a non-finite value"),
                "the file is damaged: fetch it again",
            ));
        }
        let nneg = raw.iter().filter(|v| **v < 0.0).count();
        negatives += nneg;
        if nneg == 3 {
            continue;
        }
        let a = cell_center(cell);
        if a[0] >= FRAC_PI_2 || a[2] >= FRAC_PI_2 {
            continue;
        }
        let vals: Vec<f64> = (0..3)
            .map(|c| {
                if raw[c] < 0.0 {
                    f64::NAN
                } else {
                    raw[c] * SCALE[c]
                }
            })
            .collect();
        ds.push(a, &vals);
    }
    if ds.is_empty() {
        return Err(err(
            path,
            "every cell is negative (missing) or below the horizon",
            "the table holds no measurements; check the file",
        ));
    }
    ds.negatives = negatives;
    ds.meta.material = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    Ok(ds)
}

/// Tabulate a dataset into MERL cells (the mean f_r of the samples in each cell; empty cells
/// −1). RGB data fills the three planes; a single channel fills all three.
pub fn tabulate(ds: &Dataset) -> Result<Vec<[f64; 3]>, String> {
    let chans: Vec<usize> = match ds.channels.len() {
        1 => vec![0, 0, 0],
        3 => {
            let names: Vec<&str> = ds.channels.iter().map(|c| c.name.as_str()).collect();
            if names != ["r", "g", "b"] {
                return Err(format!(
                    "MERL holds r, g, b; this data has channels {}",
                    ds.channel_names()
                ));
            }
            vec![0, 1, 2]
        }
        _ => {
            return Err(format!(
                "MERL holds r, g, b; this data has {} channels ({}): reduce it to one channel",
                ds.channels.len(),
                ds.channel_names()
            ));
        }
    };
    let brdf: Vec<Vec<f64>> = (0..ds.channels.len()).map(|c| ds.brdf_values(c)).collect();
    let mut sum = vec![[0.0f64; 3]; CELLS];
    let mut count = vec![[0u32; 3]; CELLS];
    for k in 0..ds.len() {
        let cell = cell_index(ds.angles(k));
        for (p, &c) in chans.iter().enumerate() {
            let v = brdf[c][k];
            if v.is_finite() {
                sum[cell][p] += v;
                count[cell][p] += 1;
            }
        }
    }
    Ok(sum
        .iter()
        .zip(&count)
        .map(|(s, n)| {
            let mut out = [-1.0; 3];
            for p in 0..3 {
                if n[p] > 0 {
                    out[p] = s[p] / n[p] as f64;
                }
            }
            out
        })
        .collect())
}

/// Write a dataset as MERL `.binary` (see [`tabulate`]), atomically.
pub fn write_merl(ds: &Dataset, path: &Path) -> Result<(), DataError> {
    let cells = tabulate(ds).map_err(|m| {
        DataError::new(
            path,
            None,
            m,
            "reduce the data to one channel or to r, g, b first",
        )
        .with_setting(crate::support::setting::Setting::Channel)
    })?;
    refuse_unstorable(ds, &cells, path)?;
    write_atomic(path, |w: &mut dyn Write| {
        for d in [90i32, 90, 180] {
            w.write_all(&d.to_le_bytes())?;
        }
        for (p, scale) in SCALE.iter().enumerate() {
            for c in &cells {
                let v = if c[p] < 0.0 { -1.0 } else { c[p] / scale };
                w.write_all(&v.to_le_bytes())?;
            }
        }
        Ok(())
    })
    .map_err(|e| write_error(path, &e))
}

/// Refuse a table whose stored value (f_r / [`SCALE`]) is not a finite 64-bit float in some
/// cell: the file would hold `inf`, which [`load_merl`] refuses as damaged. The error names
/// the input file and its largest sample in that cell (its number, directions and f_r), and
/// nothing is written to `output`.
fn refuse_unstorable(ds: &Dataset, cells: &[[f64; 3]], output: &Path) -> Result<(), DataError> {
    let Some((cell, plane)) = cells.iter().enumerate().find_map(|(i, c)| {
        (0..3)
            .find(|&p| c[p] >= 0.0 && !(c[p] / SCALE[p]).is_finite())
            .map(|p| (i, p))
    }) else {
        return Ok(());
    };
    // The channel that fills this plane: one channel fills all three.
    let chan = if ds.channels.len() == 1 { 0 } else { plane };
    let brdf = ds.brdf_values(chan);
    let largest = (0..ds.len())
        .filter(|&k| cell_index(ds.angles(k)) == cell && brdf[k].is_finite())
        .max_by(|&a, &b| brdf[a].total_cmp(&brdf[b]));
    let input = if ds.meta.source.is_empty() {
        output.to_path_buf()
    } else {
        std::path::PathBuf::from(&ds.meta.source)
    };
    let at = largest.map_or_else(String::new, |k| {
        let a = ds.angles(k).map(f64::to_degrees);
        let name = &ds.channels[chan].name;
        let name = if name.is_empty() {
            String::new()
        } else {
            format!(" ({name})")
        };
        format!(
            "sample {} (θi {:.4}°, φi {:.4}°, θo {:.4}°, φo {:.4}°) has f_r = {:e}{name}; ",
            k + 1,
            a[0],
            a[1],
            a[2],
            a[3],
            brdf[k]
        )
    });
    Err(DataError::new(
        &input,
        None,
        format!(
            "{at}a MERL .binary stores f_r × {:.0} as a 64-bit float, which overflows to \
             infinity for this cell (largest finite: {:e}); nothing was written to {}",
            1.0 / SCALE[plane],
            f64::MAX,
            output.display()
        ),
        "check the values' units and scale (a BRDF above 1e6 /sr is rarely measured), or \
         write CSV instead (an output ending in .csv holds any finite value)",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_are_merl_constants() {
        // BRDFRead.cpp: RED_SCALE 1/1500, GREEN_SCALE 1.15/1500, BLUE_SCALE 1.66/1500.
        assert_eq!(SCALE[0], 1.0 / 1500.0);
        assert_eq!(SCALE[1], 1.15 / 1500.0);
        assert_eq!(SCALE[2], 1.66 / 1500.0);
        assert!((SCALE[1] * 1500.0 - 1.15).abs() < 1e-15);
    }

    #[test]
    fn half_diff_round_trip_and_cells() {
        for &a in &[
            [0.3, 0.0, 0.5, 2.0],
            [1.2, 0.4, 0.2, -2.5],
            [0.7, 0.0, 0.7, std::f64::consts::PI],
        ] {
            let hd = std_to_half_diff(a);
            let b = half_diff_to_std(hd[0], hd[1], hd[2], hd[3]);
            let (wi, wo) = (
                crate::data::direction(a[0], a[1]),
                crate::data::direction(a[2], a[3]),
            );
            let (vi, vo) = (
                crate::data::direction(b[0], b[1]),
                crate::data::direction(b[2], b[3]),
            );
            for k in 0..3 {
                assert!((wi[k] - vi[k]).abs() < 1e-12 && (wo[k] - vo[k]).abs() < 1e-12);
            }
        }
        // The mirror configuration has θh = 0 and θd = θi.
        let hd = std_to_half_diff([0.7, 0.0, 0.7, std::f64::consts::PI]);
        assert!(hd[0].abs() < 1e-7 && (hd[2] - 0.7).abs() < 1e-12);
        // Every cell centre maps back to its own cell.
        for cell in (0..CELLS).step_by(997) {
            assert_eq!(cell_index(cell_center(cell)), cell, "cell {cell}");
        }
        // θh bins are √-spaced: θh = 1° falls in bin floor(√(1/90)·90) = 9.
        let a = half_diff_to_std(1f64.to_radians(), 0.0, 0.3, 0.5);
        assert_eq!(cell_index(a) / (PHI_D * THETA_D), 9);
    }
}

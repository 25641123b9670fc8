//! RGL's `.bsdf` material files (Dupuy & Jakob 2018, "An adaptive parameterization for efficient
//! material acquisition and rendering", ACM TOG 37(6)), as Mitsuba 3's `measured` plugin reads
//! them: a tensor file (the header `tensor_file\0`, version 1.0, then named, typed, shaped
//! fields) holding, per incidence (φi, θi), tables over the unit square of the microfacet normal
//! m, u = (√(θm · 2/π), (φm − φi + π)/2π).
//!
//! Mitsuba evaluates f_r cosθo as `rgb(vndf⁻¹(u))`, times `ndf(u)/(4 sigma(u_i))` when the
//! file's `jacobian` flag is set, each table interpolated bilinearly on its grid and linearly
//! between incidence angles. brdfit writes the model itself in that form: `vndf` and
//! `luminance` uniform (so vndf⁻¹ is the identity and importance sampling is uniform in u),
//! `jacobian` 0, and `rgb` holding f_r cosθo of each channel at each grid vertex.

use std::f64::consts::{FRAC_PI_2, PI};

/// Mitsuba's `Struct::Type` codes of the two element types the format uses.
const UINT8: u8 = 1;
const FLOAT32: u8 = 10;

/// One field of a tensor file.
struct Field {
    name: &'static str,
    dtype: u8,
    shape: Vec<u64>,
    data: Vec<u8>,
}

fn floats(name: &'static str, shape: Vec<u64>, v: &[f64]) -> Field {
    Field {
        name,
        dtype: FLOAT32,
        shape,
        data: v.iter().flat_map(|x| (*x as f32).to_le_bytes()).collect(),
    }
}

/// The bytes of a tensor file (Mitsuba 3's `TensorFile`): header, field table (name length
/// u16, name, rank u16, type u8, offset u64, shape u64 × rank), then each field's data at an
/// offset aligned to 8 bytes, little-endian.
fn tensor_file(fields: &[Field]) -> Vec<u8> {
    let mut head = b"tensor_file\0".to_vec();
    head.extend([1, 0]);
    head.extend((fields.len() as u32).to_le_bytes());
    let table: usize = fields
        .iter()
        .map(|f| 2 + f.name.len() + 2 + 1 + 8 + 8 * f.shape.len())
        .sum();
    let align = |x: usize| x.div_ceil(8) * 8;
    let mut offset = align(head.len() + table);
    let mut offsets = Vec::with_capacity(fields.len());
    for f in fields {
        offsets.push(offset);
        offset = align(offset + f.data.len());
    }
    for (f, off) in fields.iter().zip(&offsets) {
        head.extend((f.name.len() as u16).to_le_bytes());
        head.extend(f.name.as_bytes());
        head.extend((f.shape.len() as u16).to_le_bytes());
        head.push(f.dtype);
        head.extend((*off as u64).to_le_bytes());
        for s in &f.shape {
            head.extend(s.to_le_bytes());
        }
    }
    for (f, off) in fields.iter().zip(&offsets) {
        head.resize(*off, 0);
        head.extend(&f.data);
    }
    head
}

/// Incidence angles of the written tables (θi = 0…90° in 2° steps).
pub const RGL_THETAS: usize = 46;

/// Grid vertices per side of each written table over u.
pub const RGL_RES: usize = 64;

/// An isotropic RGB material as an RGL `.bsdf` (RGB form, the `rgb` field Mitsuba 3's RGB
/// variants read): `f(wi, wo)` gives f_r of the three channels for unit directions above a
/// surface of normal +z; `description` is stored as the file's description.
pub fn write_rgb(f: &dyn Fn([f64; 3], [f64; 3]) -> [f64; 3], description: &str) -> Vec<u8> {
    let (nt, n) = (RGL_THETAS, RGL_RES);
    let thetas: Vec<f64> = (0..nt)
        .map(|k| FRAC_PI_2 * k as f64 / (nt - 1) as f64)
        .collect();
    let mut rgb = vec![0.0; nt * 3 * n * n];
    for (t, &ti) in thetas.iter().enumerate() {
        let wi = [ti.sin(), 0.0, ti.cos()];
        for row in 0..n {
            // Rows: φm − φi from −π to π; columns: θm = (π/2) u².
            let phi = (2.0 * row as f64 / (n - 1) as f64 - 1.0) * PI;
            for col in 0..n {
                let u = col as f64 / (n - 1) as f64;
                let th = FRAC_PI_2 * u * u;
                let m = [th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos()];
                let im = wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2];
                let wo = [0, 1, 2].map(|k| 2.0 * im * m[k] - wi[k]);
                if im <= 0.0 || wo[2] <= 0.0 || wi[2] <= 0.0 {
                    continue;
                }
                let v = f(wi, wo);
                for c in 0..3 {
                    rgb[((t * 3 + c) * n + row) * n + col] = v[c] * wo[2];
                }
            }
        }
    }
    let (nt64, n64) = (nt as u64, n as u64);
    let ones = |k: usize| vec![1.0; k];
    let fields = [
        Field {
            name: "description",
            dtype: UINT8,
            shape: vec![description.len() as u64],
            data: description.as_bytes().to_vec(),
        },
        floats("theta_i", vec![nt64], &thetas),
        floats("phi_i", vec![1], &[0.0]),
        floats("ndf", vec![n64, n64], &ones(n * n)),
        floats("sigma", vec![n64, n64], &ones(n * n)),
        floats("vndf", vec![1, nt64, n64, n64], &ones(nt * n * n)),
        floats("luminance", vec![1, nt64, n64, n64], &ones(nt * n * n)),
        floats("rgb", vec![1, nt64, 3, n64, n64], &rgb),
        Field {
            name: "jacobian",
            dtype: UINT8,
            shape: vec![1],
            data: vec![0],
        },
    ];
    tensor_file(&fields)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header and field table by hand: one u8 field of two bytes.
    #[test]
    fn tensor_file_layout_by_hand() {
        let b = tensor_file(&[Field {
            name: "ab",
            dtype: UINT8,
            shape: vec![2],
            data: vec![7, 9],
        }]);
        // 12 + 2 + 4 = 18 header bytes; the table: 2 + 2 + 2 + 1 + 8 + 8 = 23; data at 48.
        assert_eq!(&b[..12], b"tensor_file\0");
        assert_eq!(&b[12..18], &[1, 0, 1, 0, 0, 0]);
        assert_eq!(&b[18..22], &[2, 0, b'a', b'b']);
        assert_eq!(&b[22..25], &[1, 0, UINT8]);
        assert_eq!(u64::from_le_bytes(b[25..33].try_into().unwrap()), 48);
        assert_eq!(u64::from_le_bytes(b[33..41].try_into().unwrap()), 2);
        assert_eq!(b.len(), 50);
        assert_eq!(&b[48..], &[7, 9]);
    }
}

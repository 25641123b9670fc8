//! The inverse Phong reflection model (the Phong article, "Inverse Phong reflection model"):
//! from an image, known lighting and known ambient and diffuse constants, estimate the surface
//! normals along a line, then integrate them into a relative height profile.
//!
//! Along a line of pixels with unit in-image direction u, and the view direction z (toward the
//! viewer), the cylinder case assumes the normal lies in the (u, z) plane: N = (n_u, n_z),
//! |N| = 1. Each pixel gives (I − Ca)/Cd = L_u n_u + L_z n_z, two solutions
//! θ = ψ ± acos(s/ℓ) with (L_u, L_z) = ℓ (cos ψ, sin ψ); none when s > ℓ or s ≤ 0 (the value is
//! outside the model's range, or the point is in its own shadow: flagged, not invented). The kept one is chosen by continuity along the
//! line, the first by the prior (`convex`: normals tilt away from the line's middle). With a
//! second image under another light, the two equations fix N without the ambiguity
//! (photometric stereo along the line). The general case (three unknown normal components) is
//! under-determined from one image.
//!
//! Heights: the surface z(u) has normal ∝ (−dz/du, 1), so dz/du = −n_u/n_z, integrated with the
//! trapezoid rule at the pixel size.

/// Prior on the shape for the first pixel of the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Prior {
    /// Bulging toward the viewer.
    #[default]
    Convex,
    /// Hollow.
    Concave,
}

/// One pixel of the inversion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelNormal {
    /// Position along the line (pixels from its start).
    pub t: f64,
    /// Measured intensity.
    pub intensity: f64,
    /// Both candidate normals (n_u, n_z); NaN where no solution exists.
    pub candidates: [[f64; 2]; 2],
    /// The chosen normal, NaN when flagged.
    pub normal: [f64; 2],
    /// Relative height (NaN when flagged).
    pub height: f64,
    /// No solution: the intensity is outside the model's range.
    pub flagged: bool,
}

/// Invert intensities sampled along a line. `light` = (L_u, L_z): the light direction's
/// components along the line and toward the viewer; `ca`, `cd`: ambient and diffuse
/// constants; `pixel` the pixel size in world units.
pub fn invert_line(
    values: &[f64],
    light: [f64; 2],
    ca: f64,
    cd: f64,
    pixel: f64,
    prior: Prior,
) -> Vec<PixelNormal> {
    let ell = (light[0] * light[0] + light[1] * light[1]).sqrt();
    let psi = light[1].atan2(light[0]);
    let mid = (values.len() as f64 - 1.0) / 2.0;
    let mut out: Vec<PixelNormal> = Vec::with_capacity(values.len());
    // Continuity: the angle θ = atan2(n_z, n_u) of the next normal is extrapolated from the trend
    // of the kept ones, so where the two solution branches touch (N along the light's
    // projection) the branch that keeps turning the same way is followed, not the one that
    // turns back.
    let mut hist: Vec<(f64, f64)> = Vec::new(); // (pixel, θ) of kept normals
    for (k, &i) in values.iter().enumerate() {
        let s = (i - ca) / cd;
        let nan = [f64::NAN, f64::NAN];
        // The model's range: Ca < I ≤ Ca + Cd·|L| (at or below Ca the point is in its own
        // shadow, where any normal facing away from the light fits).
        let (cands, ok) = if cd != 0.0 && ell > 0.0 && s > 0.0 && s <= ell && s.is_finite() {
            let a = (s / ell).clamp(-1.0, 1.0).acos();
            let c = |th: f64| [th.cos(), th.sin()];
            ([c(psi + a), c(psi - a)], true)
        } else {
            ([nan, nan], false)
        };
        // Only normals facing the viewer are surfaces we can see.
        let facing: Vec<[f64; 2]> = cands.iter().copied().filter(|n| ok && n[1] > 0.0).collect();
        let angle = |n: &[f64; 2]| n[1].atan2(n[0]);
        let chosen = match (facing.len(), hist.len()) {
            (0, _) => None,
            (1, _) => Some(facing[0]),
            (_, 0) => {
                let want = if prior == Prior::Convex {
                    (k as f64 - mid).signum()
                } else {
                    -(k as f64 - mid).signum()
                };
                facing
                    .iter()
                    .copied()
                    .max_by(|a, b| (a[0] * want).total_cmp(&(b[0] * want)))
            }
            (_, h) => {
                // Trend over the last (up to) 8 kept pixels, carried across flagged gaps.
                let (kl, tl) = hist[h - 1];
                let (k0, t0) = hist[h.saturating_sub(9)];
                let slope = if kl > k0 { (tl - t0) / (kl - k0) } else { 0.0 };
                let pred = tl + slope * (k as f64 - kl);
                facing
                    .iter()
                    .copied()
                    .min_by(|a, b| (angle(a) - pred).abs().total_cmp(&(angle(b) - pred).abs()))
            }
        };
        if let Some(n) = chosen {
            hist.push((k as f64, angle(&n)));
        }
        out.push(PixelNormal {
            t: k as f64,
            intensity: i,
            candidates: cands,
            normal: chosen.unwrap_or(nan),
            height: f64::NAN,
            flagged: chosen.is_none(),
        });
    }
    integrate(&mut out, pixel);
    out
}

/// Photometric stereo along the line: two images under lights `l1`, `l2` (each (L_u, L_z)):
/// the 2×2 system L·N = s gives N directly (then normalised).
pub fn invert_line_two_lights(
    v1: &[f64],
    v2: &[f64],
    l1: [f64; 2],
    l2: [f64; 2],
    ca: f64,
    cd: f64,
    pixel: f64,
) -> Vec<PixelNormal> {
    let det = l1[0] * l2[1] - l1[1] * l2[0];
    let mut out: Vec<PixelNormal> = v1
        .iter()
        .zip(v2)
        .enumerate()
        .map(|(k, (&a, &b))| {
            let (s1, s2) = ((a - ca) / cd, (b - ca) / cd);
            let n = [
                (s1 * l2[1] - s2 * l1[1]) / det,
                (l1[0] * s2 - l2[0] * s1) / det,
            ];
            let len = (n[0] * n[0] + n[1] * n[1]).sqrt();
            let ok = det.abs() > 1e-12 && len.is_finite() && len > 1e-9 && n[1] > 0.0;
            let n = if ok {
                [n[0] / len, n[1] / len]
            } else {
                [f64::NAN, f64::NAN]
            };
            PixelNormal {
                t: k as f64,
                intensity: a,
                candidates: [n, n],
                normal: n,
                height: f64::NAN,
                flagged: !ok,
            }
        })
        .collect();
    integrate(&mut out, pixel);
    out
}

/// Trapezoid integration of dz/du = −n_u/n_z over the valid pixels (flagged pixels keep NaN
/// and are bridged by the neighbouring slopes).
fn integrate(px: &mut [PixelNormal], pixel: f64) {
    let slope = |p: &PixelNormal| -p.normal[0] / p.normal[1];
    let mut z = 0.0;
    let mut last: Option<(f64, f64)> = None; // (t, slope)
    for p in px.iter_mut() {
        if p.flagged || !p.normal[1].is_finite() || p.normal[1] <= 1e-9 {
            continue;
        }
        let s = slope(p);
        if let Some((t0, s0)) = last {
            z += 0.5 * (s0 + s) * (p.t - t0) * pixel;
        }
        p.height = z;
        last = Some((p.t, s));
    }
}

/// Sample an image (linear RGB luminance, row-major) along the pixel line from `a` to `b`
/// (inclusive, one sample per pixel step along the longer axis): (positions, values).
pub fn sample_line(
    width: u32,
    height: u32,
    lum: &[f64],
    a: (u32, u32),
    b: (u32, u32),
) -> Vec<((u32, u32), f64)> {
    let (dx, dy) = (b.0 as f64 - a.0 as f64, b.1 as f64 - a.1 as f64);
    let n = dx.abs().max(dy.abs()).round() as usize;
    (0..=n)
        .filter_map(|k| {
            let t = if n == 0 { 0.0 } else { k as f64 / n as f64 };
            let (x, y) = (
                (a.0 as f64 + t * dx).round() as i64,
                (a.1 as f64 + t * dy).round() as i64,
            );
            (x >= 0 && y >= 0 && (x as u32) < width && (y as u32) < height).then(|| {
                (
                    (x as u32, y as u32),
                    lum[y as usize * width as usize + x as usize],
                )
            })
        })
        .collect()
}

/// CSV of the inversion: pixel, x, y, intensity, both candidates, chosen normal, height, flag.
pub fn to_csv(px: &[PixelNormal], pos: &[(u32, u32)]) -> String {
    let f = |v: f64| {
        if v.is_finite() {
            format!("{v}")
        } else {
            String::new()
        }
    };
    let mut s =
        String::from("pixel,x,y,intensity,n1_u,n1_z,n2_u,n2_z,normal_u,normal_z,height,flagged\n");
    for (k, p) in px.iter().enumerate() {
        let (x, y) = pos.get(k).copied().unwrap_or((0, 0));
        s.push_str(&format!(
            "{k},{x},{y},{},{},{},{},{},{},{},{},{}\n",
            f(p.intensity),
            f(p.candidates[0][0]),
            f(p.candidates[0][1]),
            f(p.candidates[1][0]),
            f(p.candidates[1][1]),
            f(p.normal[0]),
            f(p.normal[1]),
            f(p.height),
            p.flagged
        ));
    }
    s
}

/// An image as linear luminance (the mean of R, G, B) row by row: EXR is linear; PNG and other
/// 8-bit formats are sRGB-decoded (IEC 61966-2-1) unless `linear`. Returns width, height and
/// the values, or the reader's message.
pub fn luminance_image(
    path: &std::path::Path,
    linear: bool,
) -> Result<(u32, u32, Vec<f64>), String> {
    // A pipe or a device would block or never end: regular files only.
    crate::support::input::check_regular(path, crate::support::input::Input::Data)
        .map_err(|e| e.message)?;
    let img = image::open(path).map_err(|e| e.to_string())?;
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let rgb = img.to_rgb32f();
    let dec = |v: f32| -> f64 {
        let v = v as f64;
        if is_exr || linear {
            v
        } else if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    let lum = rgb
        .pixels()
        .map(|px| (dec(px.0[0]) + dec(px.0[1]) + dec(px.0[2])) / 3.0)
        .collect();
    Ok((rgb.width(), rgb.height(), lum))
}

/// The (position, height) pairs of a truth CSV with a header line: the first two numeric
/// columns of every line that has them.
pub fn read_truth_csv(text: &str) -> Vec<(f64, f64)> {
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let mut it = l.split(',');
            Some((
                it.next()?.trim().parse().ok()?,
                it.next()?.trim().parse().ok()?,
            ))
        })
        .collect()
}

#[cfg(test)]
mod io_tests {
    use super::*;

    /// sRGB decoding against the standard's values: code 0.5 → 0.2140, 0.04 (linear segment)
    /// → 0.04/12.92; `linear` keeps the code.
    #[test]
    fn luminance_decodes_srgb() {
        let dir = std::env::temp_dir().join(format!("brdfit-lum-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("g.png");
        let img = image::RgbImage::from_raw(2, 1, vec![128, 128, 128, 10, 10, 10]).unwrap();
        img.save(&p).unwrap();
        let (w, h, v) = luminance_image(&p, false).unwrap();
        assert_eq!((w, h), (2, 1));
        let c: f64 = 128.0 / 255.0;
        assert!((v[0] - ((c + 0.055) / 1.055).powf(2.4)).abs() < 1e-6);
        assert!((v[0] - 0.2158605).abs() < 1e-6, "{}", v[0]);
        assert!((v[1] - 10.0 / 255.0 / 12.92).abs() < 1e-7);
        let (_, _, lin) = luminance_image(&p, true).unwrap();
        assert!((lin[0] - c).abs() < 1e-6);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn truth_csv_skips_header_and_bad_lines() {
        let t = read_truth_csv("t,h\n0,1.5\nx,y\n2, 3\n");
        assert_eq!(t, vec![(0.0, 1.5), (2.0, 3.0)]);
    }
}

//! LDR-ꟻLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images",
//! Proc. ACM CGIT 3(2)) with the reference's side computed once.
//!
//! A port of NVIDIA's C++ (`FLIP::image<float>::FLIP` in `nv-flip-sys` 0.1.1, the code the
//! `nv-flip` crate runs), operation for operation in `f32`: sRGB → linear RGB → XYZ → YCxCz
//! (§4.1), the contrast sensitivity filters (§4.1, Table 1: Gaussians of scale b₁, b₂ in
//! YCxCz, separated as NVIDIA separates them), clamp to linear RGB, CIELab with the Hunt
//! adjustment and the HyAB distance (§4.2), its compression to [0, 1] (q_c = 0.7, p_c = 0.4,
//! p_t = 0.95), and the edge and point features of the luminance (first and second
//! derivatives of a Gaussian of σ = ½ w ppd, w = 0.082; §4.3), error = ΔE_c^(1 − ΔE_f).
//! Filters clamp at the image's border and sum in NVIDIA's order, so the numbers are NVIDIA's
//! (`tests/it/flip.rs` compares them with the `nv-flip` crate).
//!
//! A reference compared with many images ([`FlipReference`]) keeps its filtered colours and
//! features; each comparison filters the test image only around the pixels where the two
//! differ (ꟻLIP is 0 farther than the filters reach from every difference).

/// ꟻLIP's constants (Andersson et al. 2020, §4: q_c, p_c, p_t, w, q_f).
const GQC: f32 = 0.7;
const GPC: f32 = 0.4;
const GPT: f32 = 0.95;
const GW: f32 = 0.082;
const GQF: f32 = 0.5;
/// π (NVIDIA's 3.14159265358979f is this `f32`).
const PI: f32 = std::f32::consts::PI;
/// D65 white and its inverse, NVIDIA's values.
#[allow(clippy::excessive_precision)]
const ILLUMINANT: [f32; 3] = [0.950428545, 1.000000000, 1.088900371];
#[allow(clippy::excessive_precision)]
const INV_ILLUMINANT: [f32; 3] = [1.052156925, 1.000000000, 0.918357670];

/// The separated filters at one viewing distance: the colour filters (Y and Cx; the two
/// Gaussians of Cz) and the feature filter (Gaussian, its first and second derivatives).
struct Filters {
    ycx: Vec<[f32; 2]>,
    cz: Vec<[f32; 2]>,
    feature: Vec<[f32; 3]>,
    /// The largest colour difference, HyAB(green, blue)^q_c, and p_c times it.
    cmax: f32,
    pccmax: f32,
}

/// NVIDIA's Gaussian in the paper's form: a √(π/b) exp(−π² x² / b).
fn gaussian_ab(x2: f32, a: f32, b: f32) -> f32 {
    a * (PI / b).sqrt() * (-(PI * PI) * x2 / b).exp()
}

/// The square root of [`gaussian_ab`]'s amplitude times its exponential (NVIDIA's
/// `GaussianSqrt`, which separates Cz's sum of two Gaussians).
fn gaussian_sqrt(x2: f32, a: f32, b: f32) -> f32 {
    (a * (PI / b).sqrt()).sqrt() * (-(PI * PI) * x2 / b).exp()
}

impl Filters {
    fn new(ppd: f32) -> Filters {
        // Colour: radius from the largest scale parameter b = 0.04 (Table 1).
        let radius = (3.0 * (0.04f32 / (2.0 * (PI * PI))).sqrt() * ppd).ceil() as i32;
        let dx = 1.0 / ppd;
        let (mut ycx, mut cz) = (Vec::new(), Vec::new());
        let (mut sum_ycx, mut sum_cz) = ([0.0f32; 2], [0.0f32; 2]);
        for x in 0..2 * radius + 1 {
            let ix = (x - radius) as f32 * dx;
            let ix2 = ix * ix;
            let a = [gaussian_ab(ix2, 1.0, 0.0047), gaussian_ab(ix2, 1.0, 0.0053)];
            let b = [
                gaussian_sqrt(ix2, 34.1, 0.04),
                gaussian_sqrt(ix2, 13.5, 0.025),
            ];
            for k in 0..2 {
                sum_ycx[k] += a[k];
                sum_cz[k] += b[k];
            }
            ycx.push(a);
            cz.push(b);
        }
        let norm_ycx = [1.0 / sum_ycx[0], 1.0 / sum_ycx[1]];
        let norm_cz = 1.0 / (sum_cz[0] * sum_cz[0] + sum_cz[1] * sum_cz[1]).sqrt();
        for (a, b) in ycx.iter_mut().zip(&mut cz) {
            *a = [a[0] * norm_ycx[0], a[1] * norm_ycx[1]];
            *b = [b[0] * norm_cz, b[1] * norm_cz];
        }
        // Features: σ = ½ w ppd, radius ⌈3σ⌉; the Gaussian sums to 1, the derivatives'
        // positive and negative weights to 1 and −1.
        let sd = 0.5 * GW * ppd;
        let radius = (3.0 * sd).ceil() as i32;
        let mut feature = Vec::new();
        let (mut g_sum, mut dg_neg, mut dg_pos, mut ddg_neg, mut ddg_pos) =
            (0.0f32, 0.0, 0.0, 0.0, 0.0);
        for x in 0..2 * radius + 1 {
            let xx = (x - radius) as f32;
            let g = (-(xx * xx) / (2.0 * sd * sd)).exp();
            g_sum += g;
            let dg = -xx * g;
            if dg > 0.0 {
                dg_pos += dg;
            } else {
                dg_neg -= dg;
            }
            let ddg = (xx * xx / (sd * sd) - 1.0) * g;
            if ddg > 0.0 {
                ddg_pos += ddg;
            } else {
                ddg_neg -= ddg;
            }
            feature.push([g, dg, ddg]);
        }
        for p in &mut feature {
            *p = [
                p[0] / g_sum,
                p[1] / if p[1] > 0.0 { dg_pos } else { dg_neg },
                p[2] / if p[2] > 0.0 { ddg_pos } else { ddg_neg },
            ];
        }
        let green = hunt(xyz_to_lab(linear_rgb_to_xyz([0.0, 1.0, 0.0])));
        let blue = hunt(xyz_to_lab(linear_rgb_to_xyz([0.0, 0.0, 1.0])));
        let cmax = hyab(green, blue).powf(GQC);
        Filters {
            ycx,
            cz,
            feature,
            cmax,
            pccmax: GPC * cmax,
        }
    }

    /// The larger of the two filters' radii (pixels).
    fn reach(&self) -> usize {
        self.ycx.len().max(self.feature.len()) / 2
    }
}

/// NVIDIA's `Max`: `a` where `a > b`, else `b`.
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// NVIDIA's clamp to [0, 1] (`Min(Max(v, 0), 1)`; NaN becomes 0).
fn clamp01(v: f32) -> f32 {
    let v = if v > 0.0 { v } else { 0.0 };
    if v > 1.0 { 1.0 } else { v }
}

/// Linear RGB → XYZ (D65; NVIDIA's coefficients).
fn linear_rgb_to_xyz(c: [f32; 3]) -> [f32; 3] {
    const A: [[f32; 3]; 3] = [
        [
            10_135_552.0 / 24_577_794.0,
            8_788_810.0 / 24_577_794.0,
            4_435_075.0 / 24_577_794.0,
        ],
        [
            2_613_072.0 / 12_288_897.0,
            8_788_810.0 / 12_288_897.0,
            887_015.0 / 12_288_897.0,
        ],
        [
            1_425_312.0 / 73_733_382.0,
            8_788_810.0 / 73_733_382.0,
            70_074_185.0 / 73_733_382.0,
        ],
    ];
    A.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

/// XYZ → linear RGB (D65; NVIDIA's coefficients).
#[allow(clippy::excessive_precision)]
fn xyz_to_linear_rgb(c: [f32; 3]) -> [f32; 3] {
    const A: [[f32; 3]; 3] = [
        [3.241003275, -1.537398934, -0.498615861],
        [-0.969224334, 1.875930071, 0.041554224],
        [0.055639423, -0.204011202, 1.057148933],
    ];
    A.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

/// XYZ → CIELab (D65).
fn xyz_to_lab(c: [f32; 3]) -> [f32; 3] {
    let delta = 6.0f32 / 29.0;
    let delta2 = delta * delta;
    let delta3 = delta * delta2;
    let factor = 1.0 / (3.0 * delta2);
    let term = 4.0f32 / 29.0;
    let f = |v: f32| {
        if v > delta3 {
            v.powf(1.0 / 3.0)
        } else {
            factor * v + term
        }
    };
    let [x, y, z] = [0, 1, 2].map(|k| f(c[k] * INV_ILLUMINANT[k]));
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

/// XYZ → YCxCz (D65).
fn xyz_to_ycxcz(c: [f32; 3]) -> [f32; 3] {
    let [x, y, z] = [0, 1, 2].map(|k| c[k] * INV_ILLUMINANT[k]);
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

/// YCxCz → XYZ (D65).
fn ycxcz_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let y = (c[0] + 16.0) / 116.0;
    let cx = c[1] / 500.0;
    let cz = c[2] / 200.0;
    [
        (y + cx) * ILLUMINANT[0],
        y * ILLUMINANT[1],
        (y - cz) * ILLUMINANT[2],
    ]
}

/// Lab with the Hunt adjustment of a and b (× 0.01 L).
fn hunt(lab: [f32; 3]) -> [f32; 3] {
    [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
}

/// HyAB distance: |ΔL| + √(Δa² + Δb²).
fn hyab(p: [f32; 3], q: [f32; 3]) -> f32 {
    (p[0] - q[0]).abs() + ((p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2])).sqrt()
}

/// The linear value of each 8-bit sRGB code (NVIDIA's `sRGB2LinearRGB` of code / 255).
fn linear_of_codes() -> [f32; 256] {
    std::array::from_fn(|k| {
        let s = k as f32 / 255.0;
        if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        }
    })
}

/// An image's YCxCz over a rectangle (x0, y0, x1, y1 inclusive) of a `width`-wide 8-bit
/// sRGB image, row by row.
struct Patch {
    data: Vec<[f32; 3]>,
    x0: usize,
    y0: usize,
    stride: usize,
}

impl Patch {
    fn new(srgb: &[u8], width: usize, rect: [usize; 4], lut: &[f32; 256]) -> Patch {
        let [x0, y0, x1, y1] = rect;
        let mut data = Vec::with_capacity((x1 + 1 - x0) * (y1 + 1 - y0));
        for y in y0..=y1 {
            for x in x0..=x1 {
                let i = 3 * (y * width + x);
                let rgb = [
                    lut[srgb[i] as usize],
                    lut[srgb[i + 1] as usize],
                    lut[srgb[i + 2] as usize],
                ];
                data.push(xyz_to_ycxcz(linear_rgb_to_xyz(rgb)));
            }
        }
        Patch {
            data,
            x0,
            y0,
            stride: x1 + 1 - x0,
        }
    }

    fn at(&self, x: usize, y: usize) -> [f32; 3] {
        self.data[(y - self.y0) * self.stride + x - self.x0]
    }
}

/// Per pixel of a window: the filtered colour (Lab with Hunt) and the edge and point values.
struct Planes {
    lab: Vec<[f32; 3]>,
    features: Vec<[f32; 2]>,
}

/// Row `y` of the image from column x0 − r to x0 + cw − 1 + r (clamped to the `w`-wide image),
/// one channel each: Y, Cx, Cz and the normalised luminance the features read.
#[inline(always)]
fn padded_row(
    img: &Patch,
    y: usize,
    (x0, cw): (usize, usize),
    r: usize,
    w: usize,
) -> [Vec<f32>; 4] {
    let mut p = [
        Vec::with_capacity(cw + 2 * r),
        Vec::with_capacity(cw + 2 * r),
        Vec::with_capacity(cw + 2 * r),
        Vec::with_capacity(cw + 2 * r),
    ];
    for j in 0..cw + 2 * r {
        let x = (x0 as isize + j as isize - r as isize).clamp(0, w as isize - 1) as usize;
        let c = img.at(x, y);
        p[0].push(c[0]);
        p[1].push(c[1]);
        p[2].push(c[2]);
        p[3].push(c[0] * (1.0f32 / 116.0) + 16.0f32 / 116.0);
    }
    p
}

/// [`Planes`] of the window `win` (x0, y0, x1, y1 inclusive; row by row) of a `w`×`h` image
/// whose YCxCz `img` covers the window widened by the filters' reach (clipped to the image).
/// Where `need` (one flag a window pixel, row by row) is given and false, the pixel's colour
/// and features are left 0 (its filtered sums are made, not converted).
///
/// Each pass sums a pixel's taps in NVIDIA's order, from 0, with the column or row each tap
/// reads clamped to the image; the loops run over the taps outside and the pixels of a row
/// inside (the same sums, vectorised). Compiled for AVX-512 and AVX2 as well and picked at run
/// time: wider vectors add each pixel's taps in the same order (Rust forms no fused
/// multiply-adds), so every instruction set gives the same bits.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn planes(
    img: &Patch,
    w: usize,
    h: usize,
    win: [usize; 4],
    f: &Filters,
    need: Option<&[bool]>,
) -> Planes {
    let [x0, y0, x1, y1] = win;
    let cw = x1 + 1 - x0;
    let rows = y1 + 1 - y0;
    let r = f.reach();
    let clampy = |y: isize| y.clamp(0, h as isize - 1) as usize;
    let padded = |y: usize| padded_row(img, y, (x0, cw), r, w);
    // Colour: x pass on the rows the y pass reads, then the y pass.
    let rc = f.ycx.len() / 2;
    let (ry0, ry1) = (
        clampy(y0 as isize - rc as isize),
        clampy(y1 as isize + rc as isize),
    );
    let n = (ry1 + 1 - ry0) * cw;
    let mut inter = [
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
    ];
    // Features: the same on their own rows (first and second derivative in x, Gaussian for
    // the y pass).
    let rf = f.feature.len() / 2;
    let (fy0, fy1) = (
        clampy(y0 as isize - rf as isize),
        clampy(y1 as isize + rf as isize),
    );
    let nf = (fy1 + 1 - fy0) * cw;
    let mut finter = [vec![0.0f32; nf], vec![0.0f32; nf], vec![0.0f32; nf]];
    for y in ry0.min(fy0)..=ry1.max(fy1) {
        let p = padded(y);
        if (ry0..=ry1).contains(&y) {
            let o = (y - ry0) * cw;
            let [i0, i1, i2, i3] = &mut inter;
            let (i0, i1, i2, i3) = (
                &mut i0[o..o + cw],
                &mut i1[o..o + cw],
                &mut i2[o..o + cw],
                &mut i3[o..o + cw],
            );
            for (k, (a, b)) in f.ycx.iter().zip(&f.cz).enumerate() {
                let s = r - rc + k;
                let (py, pcx, pcz) = (&p[0][s..s + cw], &p[1][s..s + cw], &p[2][s..s + cw]);
                for j in 0..cw {
                    i0[j] += a[0] * py[j];
                    i1[j] += a[1] * pcx[j];
                    i2[j] += b[0] * pcz[j];
                    i3[j] += b[1] * pcz[j];
                }
            }
        }
        if (fy0..=fy1).contains(&y) {
            let o = (y - fy0) * cw;
            let [dx, ddx, g] = &mut finter;
            let (dx, ddx, g) = (&mut dx[o..o + cw], &mut ddx[o..o + cw], &mut g[o..o + cw]);
            for (k, wt) in f.feature.iter().enumerate() {
                let s = r - rf + k;
                let v = &p[3][s..s + cw];
                for j in 0..cw {
                    dx[j] += wt[1] * v[j];
                    ddx[j] += wt[2] * v[j];
                    g[j] += wt[0] * v[j];
                }
            }
        }
    }
    let mut lab = Vec::with_capacity(cw * rows);
    let mut features = Vec::with_capacity(cw * rows);
    let mut s = [
        vec![0.0f32; cw],
        vec![0.0f32; cw],
        vec![0.0f32; cw],
        vec![0.0f32; cw],
    ];
    let mut d = [
        vec![0.0f32; cw],
        vec![0.0f32; cw],
        vec![0.0f32; cw],
        vec![0.0f32; cw],
    ];
    for y in y0..=y1 {
        s.iter_mut().chain(&mut d).for_each(|v| v.fill(0.0));
        {
            let [s0, s1, s2, s3] = &mut s;
            for (k, (a, b)) in f.ycx.iter().zip(&f.cz).enumerate() {
                let o = (clampy(y as isize + k as isize - rc as isize) - ry0) * cw;
                let (i0, i1) = (&inter[0][o..o + cw], &inter[1][o..o + cw]);
                let (i2, i3) = (&inter[2][o..o + cw], &inter[3][o..o + cw]);
                for j in 0..cw {
                    s0[j] += a[0] * i0[j];
                    s1[j] += a[1] * i1[j];
                    s2[j] += b[0] * i2[j];
                    s3[j] += b[1] * i3[j];
                }
            }
        }
        {
            let [dx, ddx, dy, ddy] = &mut d;
            for (k, wt) in f.feature.iter().enumerate() {
                let o = (clampy(y as isize + k as isize - rf as isize) - fy0) * cw;
                let (ix, iddx, ig) = (
                    &finter[0][o..o + cw],
                    &finter[1][o..o + cw],
                    &finter[2][o..o + cw],
                );
                for j in 0..cw {
                    dx[j] += wt[0] * ix[j];
                    ddx[j] += wt[0] * iddx[j];
                    dy[j] += wt[1] * ig[j];
                    ddy[j] += wt[2] * ig[j];
                }
            }
        }
        for j in 0..cw {
            if need.is_some_and(|n| !n[(y - y0) * cw + j]) {
                lab.push([0.0; 3]);
                features.push([0.0; 2]);
                continue;
            }
            let c = [s[0][j], s[1][j], s[2][j] + s[3][j]];
            let rgb = xyz_to_linear_rgb(ycxcz_to_xyz(c)).map(clamp01);
            lab.push(hunt(xyz_to_lab(linear_rgb_to_xyz(rgb))));
            let (dx, ddx, dy, ddy) = (d[0][j], d[1][j], d[2][j], d[3][j]);
            features.push([(dx * dx + dy * dy).sqrt(), (ddx * ddx + ddy * ddy).sqrt()]);
        }
    }
    Planes { lab, features }
}

/// ꟻLIP of one pixel from both images' filtered colours and features (NVIDIA's colour
/// difference, its compression, and the feature-weighted exponent).
fn pixel_error(f: &Filters, lab: [[f32; 3]; 2], feat: [[f32; 2]; 2]) -> f32 {
    let (cmax, pccmax) = (f.cmax, f.pccmax);
    let (r_lab, t_lab, r_feat, t_feat) = (lab[0], lab[1], feat[0], feat[1]);
    let mut cd = hyab(r_lab, t_lab).powf(GQC);
    if cd < pccmax {
        cd *= GPT / pccmax;
    } else {
        cd = GPT + ((cd - pccmax) / (cmax - pccmax)) * (1.0 - GPT);
    }
    let edge = (r_feat[0] - t_feat[0]).abs();
    let point = (r_feat[1] - t_feat[1]).abs();
    let fd = ((1.0 / 2.0f32.sqrt()) * max(edge, point)).powf(GQF);
    cd.powf(1.0 - fd)
}

/// A reference image prepared for LDR-ꟻLIP against any number of test images: its 8-bit
/// sRGB pixels, filtered colours and features, at a viewing distance of `ppd` pixels per degree.
pub struct FlipReference {
    width: usize,
    height: usize,
    srgb: Vec<u8>,
    planes: Planes,
    filters: Filters,
    lut: [f32; 256],
}

impl FlipReference {
    /// Prepare `srgb` (8-bit sRGB, RGB, row-major, `width`×`height`).
    pub fn new(srgb: &[u8], width: u32, height: u32, ppd: f32) -> FlipReference {
        let (w, h) = (width as usize, height as usize);
        let filters = Filters::new(ppd);
        let lut = linear_of_codes();
        let whole = [0, 0, w.saturating_sub(1), h.saturating_sub(1)];
        let planes = if w * h == 0 {
            Planes {
                lab: Vec::new(),
                features: Vec::new(),
            }
        } else {
            planes(
                &Patch::new(srgb, w, whole, &lut),
                w,
                h,
                whole,
                &filters,
                None,
            )
        };
        FlipReference {
            width: w,
            height: h,
            srgb: srgb.to_vec(),
            planes,
            filters,
            lut,
        }
    }

    /// Per-pixel LDR-ꟻLIP error in [0, 1] of `test` (8-bit sRGB of the same size) against
    /// the reference: NVIDIA's numbers. Computed on the smallest window holding every pixel
    /// where the images differ, widened by the filters' reach (clipped to the image), and 0
    /// elsewhere: a pixel beyond the reach of every difference sees equal neighbourhoods in
    /// both images, equal filtered colours and features, and ꟻLIP 0^1 = 0. For the same
    /// reason a window pixel with no difference within the reach (in x and in y) is 0 without
    /// converting its filtered colour.
    pub fn against(&self, test: &[u8]) -> Vec<f32> {
        let (w, h) = (self.width, self.height);
        let mut map = vec![0.0f32; w * h];
        let mut window: Option<[usize; 4]> = None;
        let mut differs = vec![false; w * h];
        for y in 0..h {
            let row = 3 * y * w..3 * (y + 1) * w;
            if self.srgb[row.clone()] == test[row] {
                continue;
            }
            for x in 0..w {
                let i = 3 * (y * w + x);
                if self.srgb[i..i + 3] != test[i..i + 3] {
                    differs[y * w + x] = true;
                    let b = window.get_or_insert([x, y, x, y]);
                    *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
                }
            }
        }
        let Some([x0, y0, x1, y1]) = window else {
            return map;
        };
        let r = self.filters.reach();
        let win = [
            x0.saturating_sub(r),
            y0.saturating_sub(r),
            (x1 + r).min(w - 1),
            (y1 + r).min(h - 1),
        ];
        let need = within_reach(&differs, w, win, r);
        // The test's YCxCz where the window's filters read: the window widened once more.
        let read = [
            win[0].saturating_sub(r),
            win[1].saturating_sub(r),
            (win[2] + r).min(w - 1),
            (win[3] + r).min(h - 1),
        ];
        let patch = Patch::new(test, w, read, &self.lut);
        let t = planes(&patch, w, h, win, &self.filters, Some(&need));
        let cw = win[2] + 1 - win[0];
        for (k, (t_lab, t_feat)) in t.lab.iter().zip(&t.features).enumerate() {
            if !need[k] {
                continue;
            }
            let i = (win[1] + k / cw) * w + win[0] + k % cw;
            map[i] = pixel_error(
                &self.filters,
                [self.planes.lab[i], *t_lab],
                [self.planes.features[i], *t_feat],
            );
        }
        map
    }
}

/// Per pixel of the window `win` (x0, y0, x1, y1 inclusive; row by row) of a `w`-wide
/// image: whether a pixel flagged in `differs` lies within `r` of it in x and in y (all a
/// ꟻLIP filter of that reach reads), by running counts along rows, then along columns.
fn within_reach(differs: &[bool], w: usize, win: [usize; 4], r: usize) -> Vec<bool> {
    let [x0, y0, x1, y1] = win;
    let h = differs.len() / w.max(1);
    let cw = x1 + 1 - x0;
    // The rows a window row's column test reads.
    let (ry0, ry1) = (y0.saturating_sub(r), (y1 + r).min(h - 1));
    // Along rows: a difference within r columns.
    let mut near_x = vec![false; (ry1 + 1 - ry0) * cw];
    let mut count = vec![0u32; w + 1];
    for y in ry0..=ry1 {
        let row = &differs[y * w..(y + 1) * w];
        for (x, &d) in row.iter().enumerate() {
            count[x + 1] = count[x] + d as u32;
        }
        for j in 0..cw {
            let x = x0 + j;
            let (a, b) = (x.saturating_sub(r), (x + r).min(w - 1));
            near_x[(y - ry0) * cw + j] = count[b + 1] > count[a];
        }
    }
    // Along columns: a row within r rows with a difference near in x.
    let mut col = vec![0u32; (ry1 + 2 - ry0) * cw];
    for k in 0..ry1 + 1 - ry0 {
        for j in 0..cw {
            col[(k + 1) * cw + j] = col[k * cw + j] + near_x[k * cw + j] as u32;
        }
    }
    let mut need = Vec::with_capacity(cw * (y1 + 1 - y0));
    for y in y0..=y1 {
        let (a, b) = (y.saturating_sub(r).max(ry0) - ry0, (y + r).min(ry1) - ry0);
        for j in 0..cw {
            need.push(col[(b + 1) * cw + j] > col[a * cw + j]);
        }
    }
    need
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// [`within_reach`] against the definition checked pixel by pixel: a flagged pixel at
    /// most `r` away in x and in y, on windows at the border, inside, and the whole image.
    #[test]
    fn within_reach_is_the_flagged_pixels_widened_by_the_reach() {
        let (w, h, r) = (37usize, 29usize, 4usize);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for density in [0.002, 0.02, 0.2] {
            let differs: Vec<bool> = (0..w * h).map(|_| rng.random_bool(density)).collect();
            for win in [
                [0, 0, w - 1, h - 1],
                [5, 3, 20, 17],
                [30, 20, 36, 28],
                [0, 10, 8, 12],
            ] {
                let got = within_reach(&differs, w, win, r);
                let mut want = Vec::new();
                for y in win[1]..=win[3] {
                    for x in win[0]..=win[2] {
                        want.push((0..h).any(|yy| {
                            (0..w).any(|xx| {
                                differs[yy * w + xx] && xx.abs_diff(x) <= r && yy.abs_diff(y) <= r
                            })
                        }));
                    }
                }
                assert_eq!(got, want, "density {density}, window {win:?}");
            }
        }
    }
}

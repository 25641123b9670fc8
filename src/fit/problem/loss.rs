//! The residual a fit minimises: the [`Loss`] and its pixel form.

/// Which residual the fit minimises (½ Σ r²).
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Default,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Loss {
    /// r = ln(1 + cosθi f_model) − ln(1 + cosθi f_data) (default; balances peak and tail).
    #[default]
    Log,
    /// r = f_model − f_data.
    Linear,
    /// What a pixel shows: r = φ(cosθi f_model) − φ(cosθi f_data), φ = [`pixel`], the sRGB
    /// encoding of the radiance of a unit irradiance clipped (smoothly) at 1 as a PNG clips it.
    /// For scene-weighted fits whose data are scaled to the scene's exposure (`choose`); not on
    /// the command line. The global initialisation does not take it: give a start and
    /// `local_only`.
    #[value(skip)]
    Pixel,
}

/// Width of the smooth clip of [`pixel`] (in linear radiance).
pub const PIXEL_CLIP_WIDTH: f64 = 0.02;

/// The display value of linear radiance `x` and its derivative: the sRGB transfer function
/// (IEC 61966-2-1: 12.92 x up to 0.0031308, else 1.055 x^(1/2.4) − 0.055) of x clipped at 1
/// by the smooth minimum c(x) = −δ ln(e^(−x/δ) + e^(−1/δ)), δ = [`PIXEL_CLIP_WIDTH`] (c → x
/// below 1 − 3δ, → 1 above 1 + 3δ, c' = 1/(1 + e^((x − 1)/δ)) > 0, so the gradient exists where
/// a PNG saturates).
#[inline]
pub fn pixel(x: f64) -> (f64, f64) {
    let d = PIXEL_CLIP_WIDTH;
    // c = 1 − δ ln(1 + e^((1 − x)/δ)) written to stay finite for any x.
    let t = (1.0 - x) / d;
    let (c, dc) = if t > 0.0 {
        (x - d * (-t).exp().ln_1p(), 1.0 / (1.0 + (-t).exp()))
    } else {
        (1.0 - d * t.exp().ln_1p(), t.exp() / (1.0 + t.exp()))
    };
    if c <= 0.003_130_8 {
        (12.92 * c, 12.92 * dc)
    } else {
        let p = c.powf(1.0 / 2.4);
        (1.055 * p - 0.055, 1.055 / 2.4 * p / c * dc)
    }
}

impl Loss {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Loss::Log => "log",
            Loss::Linear => "linear",
            Loss::Pixel => "pixel",
        }
    }

    /// Parse `log` or `linear`.
    pub fn parse(s: &str) -> Option<Self> {
        <Self as clap::ValueEnum>::from_str(s, true).ok()
    }

    /// The data-side term: ln(1 + cosθi f) or f.
    #[inline]
    pub fn target(self, f: f64, cos_i: f64) -> f64 {
        match self {
            Loss::Log => (cos_i * f).ln_1p(),
            Loss::Linear => f,
            Loss::Pixel => pixel(cos_i * f).0,
        }
    }

    /// The residual's model term at f and its derivative with respect to f.
    #[inline]
    pub fn term(self, f: f64, cos_i: f64) -> (f64, f64) {
        match self {
            Loss::Log => {
                let fm = cos_i * f;
                (fm.ln_1p(), cos_i / (1.0 + fm))
            }
            Loss::Linear => (f, 1.0),
            Loss::Pixel => {
                let (v, d) = pixel(cos_i * f);
                (v, d * cos_i)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    /// The pixel value against the sRGB standard's own numbers (IEC 61966-2-1: 0.5 linear is
    /// 0.735357 encoded, 0.0031308 is 0.0404500, 0.2 is 0.484529), saturation at 1 (a PNG's
    /// 255) for radiance well above 1, and the derivative against central differences,
    /// positive everywhere, across the clip.
    #[test]
    fn pixel_is_srgb_smoothly_clipped() {
        use super::pixel;
        for (x, want) in [(0.5, 0.735_357), (0.003_130_8, 0.040_45), (0.2, 0.484_529)] {
            assert!((pixel(x).0 - want).abs() < 2e-6, "{x}: {}", pixel(x).0);
        }
        assert!((pixel(3.0).0 - 1.0).abs() < 1e-12);
        assert!((pixel(1e300).0 - 1.0).abs() < 1e-12 && pixel(1e300).1 >= 0.0);
        assert!(pixel(0.0).0.abs() < 1e-12);
        for k in 1..400 {
            let x = k as f64 * 0.005;
            let h = 1e-6;
            let fd = (pixel(x + h).0 - pixel(x - h).0) / (2.0 * h);
            let d = pixel(x).1;
            assert!(d > 0.0, "{x}");
            if (x - 0.003_130_8).abs() > 1e-5 {
                assert!((fd - d).abs() < 1e-5 * (1.0 + d), "{x}: {d} vs {fd}");
            }
        }
    }
}

//! Solver variables against model parameters: the [`Transform`] that keeps each parameter's
//! bounds by construction.

use crate::model::{ParamSpec, Scale};

/// How a free solver variable u maps to a model parameter θ, and the box u lives in.
///
/// Made from a parameter's [`ParamSpec`]: linear parameters (ps, pd) are solver variables
/// themselves, boxed by their bounds (a bound-constrained solver lets them reach and leave 0);
/// shape parameters are fitted on a log scale, θ = offset + e^u, whose derivative never vanishes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The mapping.
    pub scale: Scale,
    /// Lower bound of θ.
    pub lo: f64,
    /// Upper bound of θ.
    pub hi: f64,
}

impl Transform {
    /// θ = u without bounds (for statistics in natural parameters).
    pub const IDENTITY: Transform = Transform {
        scale: Scale::Linear,
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// The transform of a declared parameter.
    pub fn of(spec: &ParamSpec) -> Self {
        Transform {
            scale: spec.scale,
            lo: spec.lo,
            hi: spec.hi,
        }
    }

    /// θ(u) and dθ/du. On a log scale θ is capped at the upper bound: u at its bound gives
    /// offset + e^ln(hi − offset), which rounding can put an ulp above hi (n = 1e7 + 1e-8), a
    /// value the fit file reader rightly refuses.
    #[inline]
    pub fn apply(self, u: f64) -> (f64, f64) {
        match self.scale {
            Scale::Linear => (u, 1.0),
            Scale::Log { offset } => {
                let e = u.exp();
                ((offset + e).min(self.hi), e)
            }
        }
    }

    /// u(θ), the inverse, with θ first brought inside the bounds.
    pub fn invert(self, v: f64) -> f64 {
        let (lo, hi) = self.bounds();
        let u = match self.scale {
            Scale::Linear => v,
            Scale::Log { offset } => (v - offset).max(1e-300).ln(),
        };
        u.clamp(lo, hi)
    }

    /// The box on u.
    pub fn bounds(self) -> (f64, f64) {
        match self.scale {
            Scale::Linear => (self.lo, self.hi),
            Scale::Log { offset } => ((self.lo - offset).ln(), (self.hi - offset).ln()),
        }
    }

    /// A step u may always take in one Levenberg–Marquardt iteration: 1 on a log scale (a
    /// factor e), 0 on a linear one (purely relative).
    pub fn step_scale(self) -> f64 {
        match self.scale {
            Scale::Linear => 0.0,
            Scale::Log { .. } => 1.0,
        }
    }
}

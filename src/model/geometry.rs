//! The geometry of one light/eye configuration: the dot products every model evaluates from,
//! and Blinn's masking term.

pub use crate::data::direction;

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The parameter-independent dot products of one light/eye configuration.
///
/// Computed once per sample (fit) or per shading point (render); every model evaluates from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// N·L, cosine of the incidence angle.
    pub nl: f64,
    /// N·E, cosine of the viewing angle.
    pub ne: f64,
    /// N·H, cosine of the angle α between the normal and the half vector.
    pub nh: f64,
    /// E·H (= L·H), cosine of the incidence angle on the micro-facet.
    pub eh: f64,
    /// R·E with R = 2(N·L)N − L, Phong's mirror-direction cosine.
    pub re: f64,
    /// G/(N·E), Blinn's masking over the viewing cosine in his division-safe form
    /// ([`g_over_ne`]), cached because it does not depend on any model parameter.
    pub g_ne: f64,
}

impl Geometry {
    /// Geometry from the cosines N·L, N·E and L·E of unit vectors (N the surface normal).
    #[inline]
    pub fn from_cosines(nl: f64, ne: f64, le: f64) -> Self {
        // |L+E|² = 2 + 2 L·E; H·E = (1 + L·E)/|L+E|; N·H = (N·L + N·E)/|L+E|.
        // Written with selects rather than branches, so loops over many samples vectorise.
        let len2 = (2.0 + 2.0 * le).max(0.0);
        let ok = len2 > 1e-300;
        let inv = if ok {
            1.0 / (if ok { len2 } else { 1.0 }).sqrt()
        } else {
            0.0
        };
        let (nh, eh) = ((nl + ne) * inv, ((1.0 + le) * inv).max(0.0));
        let mut g = Geometry {
            nl,
            ne,
            nh: nh.clamp(-1.0, 1.0),
            eh: eh.min(1.0),
            re: 2.0 * nl * ne - le,
            g_ne: 0.0,
        };
        g.g_ne = g_over_ne(&g);
        g
    }

    /// Geometry from unit vectors: normal `n`, light `l` and eye `e`.
    pub fn from_vectors(n: [f64; 3], l: [f64; 3], e: [f64; 3]) -> Self {
        Self::from_cosines(dot(n, l), dot(n, e), dot(l, e))
    }

    /// Geometry for incidence (θi, φi) and view (θo, φo), in radians.
    pub fn from_angles(theta_i: f64, phi_i: f64, theta_o: f64, phi_o: f64) -> Self {
        // L·E = sinθi sinθo cos(φo − φi) + cosθi cosθo: three trigonometric calls.
        let (si, ci) = theta_i.sin_cos();
        let (so, co) = theta_o.sin_cos();
        Self::from_cosines(ci, co, si * so * (phi_o - phi_i).cos() + ci * co)
    }

    /// True where the BRDF is defined: light and eye both above the surface.
    #[inline]
    pub fn visible(&self) -> bool {
        self.nl > 0.0 && self.ne > 0.0
    }
}

/// Blinn's geometrical attenuation G = min(1, 2(N·H)(N·E)/(E·H), 2(N·H)(N·L)/(E·H)).
pub fn geometric_attenuation(g: &Geometry) -> f64 {
    if g.eh <= 0.0 {
        return 0.0;
    }
    let gb = 2.0 * g.nh * g.ne / g.eh;
    let gc = 2.0 * g.nh * g.nl / g.eh;
    1.0f64.min(gb).min(gc).max(0.0)
}

/// G/(N·E) in Blinn's division-safe form ("Computational considerations"): the minimum of
/// Ga, Gb, Gc is chosen before any division, so N·E → 0 never divides by zero where G → 0.
#[inline]
pub fn g_over_ne(g: &Geometry) -> f64 {
    let (nl, ne, nh, eh) = (g.nl, g.ne, g.nh, g.eh);
    // Pick the numerator and denominator of the smallest term first, then divide once:
    // Gb/N·E = 1/N·E; Ga/N·E = 2 N·H/E·H where N·E < N·L; Gc/N·E = 2 N·H N·L/(E·H N·E).
    let masked = 2.0 * ne.min(nl) * nh < eh;
    let (num, den) = match (masked, ne < nl) {
        (false, _) => (1.0, ne),
        (true, true) => (2.0 * nh, eh),
        (true, false) => (2.0 * nh * nl, eh * ne),
    };
    let ok = ne > 0.0 && nl > 0.0 && eh > 0.0;
    if ok {
        num / if ok { den } else { 1.0 }
    } else {
        0.0
    }
}

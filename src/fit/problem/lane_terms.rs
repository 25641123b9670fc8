//! Terms the lane kernels share, written without branches so each lane loop vectorises:
//! exact Fresnel with its n-derivative, and Torrance–Sparrow D3's specular term.

/// Exact Fresnel reflectance of an index `n` at cos θ = `eh` and its n-derivative, without
/// branches (`n2m1` = n² − 1): F = ½ (g−c)²/(g+c)² [1 + (c(g+c)−1)²/(c(g−c)+1)²],
/// g = √(n² + c² − 1) (Blinn 1977, eq. 5; Cook & Torrance 1982). The formulas of
/// `model::fresnel_dn` with the divisions shared; where it returns early the selects give the
/// same.
#[inline(always)]
pub(super) fn fresnel(n: f64, n2m1: f64, eh: f64) -> (f64, f64) {
    let cc = eh.clamp(0.0, 1.0);
    let gg = (n2m1 + cc * cc).max(0.0).sqrt();
    let gp = gg + cc;
    let ok_f = gp > 0.0;
    let gp = if ok_f { gp } else { 1.0 };
    let gm = gg - cc;
    let vv = cc * gm + 1.0;
    // 1/(g+c), 1/(c(g−c)+1) and 1/g from one division (g = 0 only at n = 1, c = 0).
    let ok_g = gg > 0.0;
    let g1 = if ok_g { gg } else { 1.0 };
    let inv = 1.0 / (gp * vv * g1);
    let igp = vv * g1 * inv;
    let iv = gp * g1 * inv;
    let qf = gm * igp;
    let a = qf * qf;
    let t = (cc * gp - 1.0) * iv;
    let b = t * t;
    let f = if ok_f { 0.5 * a * (1.0 + b) } else { 1.0 };
    // dA/dg = 4c(g−c)/(g+c)³, dB/dg = 4c(1−c²)u/v³, dg/dn = n/g.
    let da = 4.0 * cc * qf * igp * igp;
    let db = 4.0 * cc * (1.0 - cc * cc) * t * iv * iv;
    let dn_dg = if ok_g { n * gp * vv * inv } else { 0.0 };
    let df = if ok_f {
        0.5 * (da * (1.0 + b) + a * db) * dn_dg
    } else {
        0.0
    };
    (f, df)
}

/// Blinn's Torrance–Sparrow model with D3 at fixed parameters, for the lane kernels.
#[derive(Clone, Copy)]
pub(super) struct TsD3 {
    pub(super) n: f64,
    pub(super) n2m1: f64,
    pub(super) c: f64,
    pub(super) s: f64,
    pub(super) ps: f64,
}

impl TsD3 {
    pub(super) fn new(p: [f64; 4]) -> Self {
        let (n, c) = (p[0], p[1]);
        TsD3 {
            n,
            n2m1: n * n - 1.0,
            c,
            s: c * c,
            ps: p[2],
        }
    }

    /// D3 and dD3/dc3 at cos θh = `nh`, without branches (0 where
    /// [`crate::model::Distribution::eval_dc`] returns early).
    #[inline(always)]
    pub(super) fn d(&self, nh: f64) -> (f64, f64) {
        // D3 = (c²/den)², den = x(c²−1) + 1, x = (N·H)²; dD/dc = 4c³(1 − x)/den³.
        let x = nh * nh;
        let den = x * (self.s - 1.0) + 1.0;
        let ok_d = den > 0.0;
        let id = 1.0 / if ok_d { den } else { 1.0 };
        let q = self.s * id;
        let d = if ok_d { q * q } else { 0.0 };
        let dd = if ok_d {
            4.0 * self.c * self.s * (1.0 - x) * id * id * id
        } else {
            0.0
        };
        (d, dd)
    }

    /// a = D3 F G/(π N·E), the specular term per unit ps times cosθi (so f_r = pd/π + ps a/N·L),
    /// and its derivatives with respect to n and c3. The formulas of [`crate::model::fresnel_dn`]
    /// and D3 in [`crate::model::Distribution::eval_dc`], without branches (where those return
    /// early, the selects below give the same) and with the divisions shared.
    #[inline(always)]
    pub(super) fn eval(&self, nh: f64, eh: f64, g_ne: f64) -> (f64, [f64; 2]) {
        let (d, dd) = self.d(nh);
        let (f, df) = fresnel(self.n, self.n2m1, eh);
        let w = g_ne * std::f64::consts::FRAC_1_PI;
        (d * f * w, [d * df * w, dd * f * w])
    }
}

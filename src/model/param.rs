//! How a parameter is declared: its role, bounds, solver scale, initialisation grid and
//! random-start range ([`ParamSpec`]), the two declarations every model shares (ps, pd), and
//! the two several models share (the Fresnel index n, the cosine exponent c1).

use super::{Distribution, readable};

/// How the fitter maps a parameter θ to its free solver variable u.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    /// θ = u: the parameter enters the model linearly (ps, pd) and its bounds are handled by
    /// the bound-constrained solver, so a value at a bound can leave it.
    Linear,
    /// θ = offset + e^u: a positive shape parameter spanning decades (c1, c2, c3 with offset 0;
    /// n with offset 1, so n − 1 is fitted on a log scale). dθ/du = θ − offset never vanishes
    /// inside the box.
    Log {
        /// The value θ approaches as u → −∞.
        offset: f64,
    },
}

/// Where the global initialisation's grid of a parameter comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Grid {
    /// No grid: the parameter enters linearly and is solved for at each grid point.
    Linear,
    /// Lobe half-widths [`HALF_WIDTHS_DEG`] mapped by a distribution's c(β) (Blinn 1977).
    HalfWidth(Distribution),
    /// Fixed values.
    Values(&'static [f64]),
}

/// The lobe half-widths (degrees) the initialisation grid spans, from mirror-sharp (well below
/// a goniometer's 1° step) to nearly diffuse.
pub const HALF_WIDTHS_DEG: [f64; 19] = [
    0.05, 0.1, 0.18, 0.3, 0.5, 0.8, 1.2, 1.8, 2.7, 4.0, 6.0, 9.0, 13.0, 18.0, 25.0, 33.0, 43.0,
    55.0, 70.0,
];

/// What a parameter does in the model, for the code that must know (the fitter solves the
/// linear ones at each grid point; one incidence angle cannot separate an index from ps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A Fresnel index of refraction.
    Index,
    /// A lobe shape parameter (exponent, width, roughness).
    Shape,
    /// The specular coefficient: f_r is linear in it.
    Specular,
    /// The diffuse coefficient pd: f_r is linear in it, f_r ∋ pd/π.
    Diffuse,
}

/// Everything the fitter, the CLI and the reports need to know about one model parameter,
/// declared once ([`ModelKind::params`](super::ModelKind::params)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    /// Name as in `--set`, `--fix` and the JSON.
    pub name: &'static str,
    /// What it does in the model.
    pub role: Role,
    /// What it means, for help and reports.
    pub meaning: &'static str,
    /// Admissible range for fitting (natural units, inclusive).
    pub lo: f64,
    /// Upper end of the admissible range.
    pub hi: f64,
    /// Solver variable.
    pub scale: Scale,
    /// Global-initialisation grid.
    pub grid: Grid,
    /// Default start.
    pub start: f64,
    /// Range random starts are drawn from (log-uniform when both ends are positive).
    pub random: (f64, f64),
    /// A fitted value at or above this is not physically usable (e.g. n ≥ 1e6).
    pub absurd_above: f64,
    /// Slider of an exported BRDF Explorer shader: the low end, and the high end (fixed when
    /// the parameter's own bound `hi` is ≤ 1, else twice the larger of it and the value).
    pub slider: (f64, f64),
}

impl ParamSpec {
    /// A random value in the declared random-start range: log-uniform when the range is
    /// positive, else uniform.
    pub fn random_value(&self, rng: &mut impl rand::Rng) -> f64 {
        let (a, b) = self.random;
        if a > 0.0 {
            (a.ln() + rng.random::<f64>() * (b / a).ln()).exp()
        } else {
            a + rng.random::<f64>() * (b - a)
        }
    }

    /// Whether a value may be given to the model: finite, ≥ lo for a linear parameter, above
    /// the offset (≥ 1 for n, > 0 otherwise) for a log-scale one, and ≤ hi where hi is a
    /// natural limit (≤ 1, as for c3 and α; larger fitting bounds such as n ≤ 1e7 bound the
    /// search, not the model).
    pub fn admits(&self, v: f64) -> bool {
        let (low, strict) = self.floor();
        let above = if strict { v > low } else { v >= low };
        v.is_finite() && above && v <= self.natural_hi()
    }

    /// The lowest admissible value, and whether it is itself excluded: lo for a linear
    /// parameter, the offset for a log-scale one (excluded when it is 0).
    fn floor(&self) -> (f64, bool) {
        match self.scale {
            Scale::Linear => (self.lo, false),
            Scale::Log { offset } => (offset, offset <= 0.0),
        }
    }

    /// The upper limit a value may take: `hi` when it is a natural limit (≤ 1), else ∞.
    fn natural_hi(&self) -> f64 {
        if self.hi <= 1.0 {
            self.hi
        } else {
            f64::INFINITY
        }
    }

    /// Whether `v` lies in the fitter's box (the declared [lo, hi], `hi` also where it is not a
    /// natural limit, and a log-scale parameter strictly above its offset, as offset + e^u
    /// always is: never n = 1, where F ≡ 0 holds the lobe at zero): every value a fit can
    /// return. A fit file or scene holding another was edited.
    pub fn in_fit_box(&self, v: f64) -> bool {
        let (low, strict) = self.box_floor();
        self.admits(v) && (!strict || v > low) && v <= self.hi
    }

    /// The fitter's box's lower end and whether it is excluded: lo for a linear parameter,
    /// the offset (excluded) for a log-scale one.
    fn box_floor(&self) -> (f64, bool) {
        match self.scale {
            Scale::Linear => (self.lo, false),
            Scale::Log { offset } => (offset, true),
        }
    }

    /// The fitter's box as text, e.g. `1 < n ≤ 1e7` (see [`ParamSpec::in_fit_box`]).
    pub fn fit_box_text(&self) -> String {
        let (low, strict) = self.box_floor();
        let op = if strict { "<" } else { "≤" };
        if self.hi.is_finite() {
            format!(
                "{} {op} {} ≤ {}",
                readable(low),
                self.name,
                readable(self.hi)
            )
        } else {
            self.bounds_text()
        }
    }

    /// The admissible values as text, e.g. `0 < c3 ≤ 1` or `ps ≥ 0`.
    pub fn bounds_text(&self) -> String {
        let (low, strict) = self.floor();
        let op = if strict { "<" } else { "≤" };
        if self.natural_hi().is_finite() {
            format!(
                "{} {op} {} ≤ {}",
                readable(low),
                self.name,
                readable(self.hi)
            )
        } else {
            let op = if op == "≤" { "≥" } else { ">" };
            format!("{} {op} {}", self.name, readable(low))
        }
    }

    /// The grid values of the global initialisation (empty for linear parameters).
    pub fn grid_values(&self) -> Vec<f64> {
        match self.grid {
            Grid::Linear => vec![],
            Grid::Values(v) => v.to_vec(),
            Grid::HalfWidth(d) => HALF_WIDTHS_DEG
                .iter()
                .map(|b| d.param_from_beta(b.to_radians()).clamp(self.lo, self.hi))
                .collect(),
        }
    }
}

pub(crate) const PS: ParamSpec = ParamSpec {
    name: "ps",
    role: Role::Specular,
    meaning: "specular coefficient",
    lo: 0.0,
    hi: f64::INFINITY,
    scale: Scale::Linear,
    grid: Grid::Linear,
    start: 0.5,
    random: (1e-2, 1e3),
    absurd_above: f64::INFINITY,
    slider: (0.0, 1.0),
};

pub(crate) const PD: ParamSpec = ParamSpec {
    name: "pd",
    role: Role::Diffuse,
    meaning: "diffuse coefficient (albedo of the Lambertian part)",
    lo: 0.0,
    hi: f64::INFINITY,
    scale: Scale::Linear,
    grid: Grid::Linear,
    start: 0.5,
    random: (1e-3, 1.0),
    absurd_above: f64::INFINITY,
    slider: (0.0, 1.0),
};

/// The index of refraction of a Fresnel term (torrance-sparrow, ggx-smith, ggx-smith-2).
pub(crate) const N: ParamSpec = ParamSpec {
    name: "n",
    role: Role::Index,
    meaning: "index of refraction of the Fresnel term (Blinn 1977, eq. for F)",
    lo: 1.0 + 1e-4,
    hi: 1e7,
    scale: Scale::Log { offset: 1.0 },
    // n − 1 from 0.003 (F0 ≈ 2e-6) to 3000 (F0 ≈ 0.9987, a metal's effective index).
    grid: Grid::Values(&[
        1.003, 1.007, 1.015, 1.03, 1.06, 1.12, 1.25, 1.5, 2.0, 3.0, 5.0, 9.0, 17.0, 41.0, 101.0,
        401.0, 3001.0,
    ]),
    start: 1.5,
    random: (1.01, 101.0),
    absurd_above: 1e6,
    slider: (1.0, 10.0),
};

/// Exponent of a cosine lobe: Phong's and Blinn–Phong's c1, and torrance-sparrow D1's.
pub(crate) const C1: ParamSpec = ParamSpec {
    name: "c1",
    role: Role::Shape,
    meaning: "exponent of the cosine lobe (larger = sharper)",
    lo: 1e-3,
    hi: 1e8,
    scale: Scale::Log { offset: 0.0 },
    grid: Grid::HalfWidth(Distribution::D1),
    start: 10.0,
    random: (0.3, 3e4),
    absurd_above: f64::INFINITY,
    slider: (1.0, 100.0),
};

//! Which reflection model: the model kinds, their names, facet distributions and parameter
//! declarations, and the catalogue the comparisons run.

use super::{Distribution, ParamSpec, Role};
use super::{ggx_smith, ggx_smith_2, lambert, phong, tabulated_ndf, torrance_sparrow};
use std::fmt;

/// Which reflection model. Each family lives in a file of its own in `src/model/` and declares
/// its parameters ([`ParamSpec`]), its BRDF with the analytic gradient, and how it maps onto
/// other renderers' materials ([`Material`](super::Material)); everything else reads those
/// declarations.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// Lambertian diffuse: i = pd N·L.
    Lambert,
    /// Phong: i = pd N·L + ps max(0, R·E)^c1.
    Phong,
    /// Blinn's form of Phong: i = pd N·L + ps max(0, N·H)^c1.
    #[value(alias = "blinnphong")]
    BlinnPhong,
    /// Blinn's Torrance–Sparrow: i = pd N·L + ps D G F/(N·E).
    #[value(alias = "ts")]
    #[serde(alias = "ts")]
    TorranceSparrow,
    /// GGX–Smith (Walter et al. 2007): f_r = pd/π + ps F D G1 G1 / (4 N·L N·E).
    GgxSmith,
    /// Two GGX–Smith lobes sharing the Fresnel index: f_r = pd/π + Σₖ psₖ F Dₖ G1ₖ G1ₖ /
    /// (4 N·L N·E), alpha1 ≤ alpha2.
    #[value(name = "ggx-smith-2")]
    #[serde(rename = "ggx-smith-2")]
    GgxSmith2,
    /// A microfacet model with a tabulated normal distribution over θh and the Smith masking
    /// derived from it (Dupuy et al. 2015): f_r = pd/π + ps F D G1 G1 / (4 N·L N·E).
    TabulatedNdf,
}

impl ModelKind {
    /// All model kinds, simplest first.
    pub const ALL: &[ModelKind] = &[
        ModelKind::Lambert,
        ModelKind::Phong,
        ModelKind::BlinnPhong,
        ModelKind::TorranceSparrow,
        ModelKind::GgxSmith,
        ModelKind::GgxSmith2,
    ];

    /// Command-line name: `lambert`, `phong`, `blinn-phong`, `torrance-sparrow`, ….
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Lambert => "lambert",
            ModelKind::Phong => "phong",
            ModelKind::BlinnPhong => "blinn-phong",
            ModelKind::TorranceSparrow => "torrance-sparrow",
            ModelKind::GgxSmith => "ggx-smith",
            ModelKind::GgxSmith2 => "ggx-smith-2",
            ModelKind::TabulatedNdf => "tabulated-ndf",
        }
    }

    /// Parse a command-line name or alias, ignoring case.
    pub fn parse(s: &str) -> Option<Self> {
        use clap::ValueEnum;
        Self::from_str(s, true).ok()
    }

    /// The command-line names of every model, comma separated (for messages).
    pub fn names() -> String {
        Self::ALL
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The facet distributions the model takes (`[D3]`, a placeholder, for models without one).
    pub fn distributions(self) -> &'static [Distribution] {
        match self {
            ModelKind::TorranceSparrow => &[
                Distribution::D1,
                Distribution::D2,
                Distribution::D3,
                Distribution::Abc,
            ],
            _ => &[Distribution::D3],
        }
    }

    /// True when the model has a choice of facet distribution (`--distribution`).
    pub fn has_distribution(self) -> bool {
        self.distributions().len() > 1
    }

    /// Label of the model with its distribution, e.g. `torrance-sparrow (d3)` or `phong`.
    pub fn label(self, dist: Distribution) -> String {
        if self.has_distribution() {
            format!("{} ({})", self.name(), dist.name())
        } else {
            self.name().to_string()
        }
    }

    /// The parameters' declarations in their fixed order (see [`ParamSpec`]).
    pub fn params(self, dist: Distribution) -> &'static [ParamSpec] {
        match self {
            ModelKind::Lambert => lambert::params(dist),
            ModelKind::Phong | ModelKind::BlinnPhong => phong::params(dist),
            ModelKind::TorranceSparrow => torrance_sparrow::params(dist),
            ModelKind::GgxSmith => ggx_smith::params(dist),
            ModelKind::GgxSmith2 => ggx_smith_2::params(dist),
            ModelKind::TabulatedNdf => tabulated_ndf::params(dist),
        }
    }

    /// Parameter names in their fixed order; for torrance-sparrow the shape parameter is
    /// named after the distribution (`c3` for D3).
    pub fn param_names(self, dist: Distribution) -> Vec<&'static str> {
        self.params(dist).iter().map(|s| s.name).collect()
    }

    /// The position of the parameter with `role`, if the model has one.
    pub fn index_of(self, dist: Distribution, role: Role) -> Option<usize> {
        self.params(dist).iter().position(|s| s.role == role)
    }
}

/// Every (model, distribution) pair `--model all`, `choose` and the report compare, simplest
/// first (Torrance–Sparrow with each of its distributions, ABC included).
pub fn catalogue() -> Vec<(ModelKind, Distribution)> {
    ModelKind::ALL
        .iter()
        .flat_map(|&k| k.distributions().iter().map(move |&d| (k, d)))
        .collect()
}

impl fmt::Display for ModelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

//! Exports of a fitted model to other renderers and formats: a Mitsuba 3 BSDF snippet, a
//! pbrt-v4 material line, a Disney BRDF Explorer analytic `.brdf`, a MERL `.binary` table and a
//! brdfit CSV sampled on a grid.

use crate::data::{Dataset, Quantity, merl};
use crate::model::{Geometry, Model, ModelKind, f0_from_n, short};
use std::f64::consts::FRAC_PI_2;

/// Export formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// Mitsuba 3 BSDF XML snippet.
    Mitsuba,
    /// pbrt-v4 material line.
    Pbrt,
    /// Disney BRDF Explorer analytic `.brdf`.
    BrdfExplorer,
    /// MERL `.binary`.
    Merl,
    /// brdfit CSV on a grid.
    Csv,
}

impl ExportFormat {
    /// Parse a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "mitsuba" => Some(Self::Mitsuba),
            "pbrt" => Some(Self::Pbrt),
            "brdf-explorer" => Some(Self::BrdfExplorer),
            "merl" => Some(Self::Merl),
            "csv" => Some(Self::Csv),
            _ => None,
        }
    }
}

/// GGX α of a model: c3 for D3 (D3 = π c3² D_GGX); for cosine powers the Beckmann-matched
/// α = √(2/(c1 + 2)) (Walter et al. 2007), for the Gaussian D2 α = √2/c2 (its slope width).
pub fn ggx_alpha(m: &Model) -> Option<f64> {
    match m.kind {
        ModelKind::Lambert => None,
        ModelKind::Phong | ModelKind::BlinnPhong => Some((2.0 / (m.p[0] + 2.0)).sqrt()),
        ModelKind::TorranceSparrow => Some(match m.dist {
            crate::model::Distribution::D3 => m.p[1],
            crate::model::Distribution::D2 => std::f64::consts::SQRT_2 / m.p[1],
            crate::model::Distribution::D1 => (2.0 / (m.p[1] + 2.0)).sqrt(),
        }),
    }
}

fn pd_of(m: &Model) -> f64 {
    m.get("pd").unwrap_or(0.0)
}

/// True for a metal-like fit: Fresnel reflectance at normal incidence above 0.5.
fn metallic(m: &Model) -> bool {
    m.kind == ModelKind::TorranceSparrow && f0_from_n(m.p[0]) > 0.5
}

const DIFFERS: &str = "What differs from brdfit's model: Mitsuba and pbrt use Smith masking instead of Blinn's V-groove G, a normalised GGX instead of Blinn's D3 with peak 1 (D3 = pi c3^2 D_GGX), and energy from the Fresnel term instead of the free scale ps; pd maps to the diffuse reflectance directly.";

/// Mitsuba 3 BSDF XML snippet.
pub fn mitsuba(m: &Model, id: &str) -> String {
    let pd = pd_of(m);
    let mut s = format!("<!-- brdfit export of {m}\n     {DIFFERS} -->\n");
    match (m.kind, ggx_alpha(m)) {
        (ModelKind::Lambert, _) | (_, None) => {
            s += &format!(
                "<bsdf type=\"diffuse\" id=\"{id}\">\n    <rgb name=\"reflectance\" value=\"{0}, {0}, {0}\"/>\n</bsdf>\n",
                short(pd)
            );
        }
        (_, Some(alpha)) if metallic(m) => {
            s += &format!(
                "<!-- a metal: n = {} acts as an effective index (F0 = {}); the conductor below uses Mitsuba's aluminium table -->\n<bsdf type=\"roughconductor\" id=\"{id}\">\n    <string name=\"distribution\" value=\"ggx\"/>\n    <float name=\"alpha\" value=\"{}\"/>\n    <string name=\"material\" value=\"Al\"/>\n</bsdf>\n",
                short(m.p[0]),
                short(f0_from_n(m.p[0])),
                short(alpha)
            );
        }
        (_, Some(alpha)) => {
            let ior = if m.kind == ModelKind::TorranceSparrow {
                m.p[0]
            } else {
                1.5
            };
            s += &format!(
                "<bsdf type=\"roughplastic\" id=\"{id}\">\n    <string name=\"distribution\" value=\"ggx\"/>\n    <float name=\"alpha\" value=\"{}\"/>\n    <float name=\"int_ior\" value=\"{}\"/>\n    <float name=\"ext_ior\" value=\"1.0\"/>\n    <rgb name=\"diffuse_reflectance\" value=\"{2}, {2}, {2}\"/>\n    <boolean name=\"nonlinear\" value=\"false\"/>\n</bsdf>\n",
                short(alpha),
                short(ior),
                short(pd)
            );
        }
    }
    s
}

/// pbrt-v4 material line.
pub fn pbrt(m: &Model) -> String {
    let pd = pd_of(m);
    let head = format!("# brdfit export of {m}\n# {DIFFERS}\n");
    match ggx_alpha(m) {
        None => {
            head + &format!(
                "Material \"diffuse\" \"rgb reflectance\" [ {0} {0} {0} ]\n",
                short(pd)
            )
        }
        Some(a) if metallic(m) => {
            head + &format!(
                "Material \"conductor\" \"float roughness\" [ {} ] \"bool remaproughness\" false \"spectrum eta\" \"metal-Al-eta\" \"spectrum k\" \"metal-Al-k\"\n",
                short(a)
            )
        }
        Some(a) => {
            let eta = if m.kind == ModelKind::TorranceSparrow {
                m.p[0]
            } else {
                1.5
            };
            head + &format!(
                "Material \"coateddiffuse\" \"rgb reflectance\" [ {0} {0} {0} ] \"float roughness\" [ {1} ] \"bool remaproughness\" false \"float eta\" [ {2} ]\n",
                short(pd),
                short(a),
                short(eta)
            )
        }
    }
}

/// Disney BRDF Explorer analytic `.brdf` of the model, fitted values as parameter defaults.
pub fn brdf_explorer(m: &Model) -> String {
    let params: String = m
        .param_names()
        .iter()
        .zip(m.params())
        .map(|(n, v)| {
            let (lo, hi) = match *n {
                "n" => (1.0, v.max(10.0) * 2.0),
                "c3" => (0.001, 1.0),
                "c1" => (1.0, v.max(100.0) * 2.0),
                "c2" => (0.01, v.max(10.0) * 2.0),
                _ => (0.0, v.max(1.0) * 2.0),
            };
            format!("float {n} {} {} {}\n", short(lo), short(hi), short(*v))
        })
        .collect();
    let body = match m.kind {
        ModelKind::Lambert => "    return vec3(pd / PI);".to_string(),
        ModelKind::Phong => "    vec3 R = reflect(-L, N);\n    float s = pow(max(dot(R, V), 0.0), c1);\n    return vec3(pd / PI + ps * s / (PI * NdotL));".to_string(),
        ModelKind::BlinnPhong => "    vec3 H = normalize(L + V);\n    float s = pow(max(dot(N, H), 0.0), c1);\n    return vec3(pd / PI + ps * s / (PI * NdotL));".to_string(),
        ModelKind::TorranceSparrow => {
            let d = match m.dist {
                crate::model::Distribution::D1 => "pow(NdotH, c1)",
                crate::model::Distribution::D2 => "exp(-pow(acos(min(NdotH, 1.0)) * c2, 2.0))",
                crate::model::Distribution::D3 => "pow(c3 * c3 / (NdotH * NdotH * (c3 * c3 - 1.0) + 1.0), 2.0)",
            };
            format!(
                "    vec3 H = normalize(L + V);\n    float NdotH = dot(N, H);\n    float EdotH = dot(V, H);\n    float D = {d};\n    float G = min(1.0, min(2.0 * NdotH * NdotV / EdotH, 2.0 * NdotH * NdotL / EdotH));\n    float c = EdotH;\n    float g = sqrt(n * n + c * c - 1.0);\n    float F = 0.5 * pow((g - c) / (g + c), 2.0) * (1.0 + pow((c * (g + c) - 1.0) / (c * (g - c) + 1.0), 2.0));\n    return vec3(pd / PI + ps * D * G * F / (PI * NdotL * NdotV));"
            )
        }
    };
    format!(
        "analytic\n# brdfit export of {m}: Blinn 1977 with brdfit's conventions (f_r = i / (pi N.L), F with the factor 1/2)\n::begin parameters\n{params}::end parameters\n::begin shader\nconst float PI = 3.14159265358979323846;\nvec3 BRDF( vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y )\n{{\n    float NdotL = dot(N, L);\n    float NdotV = dot(N, V);\n    if (NdotL <= 0.0 || NdotV <= 0.0) return vec3(0.0);\n{body}\n}}\n::end shader\n"
    )
}

/// The model tabulated at the MERL cell centres (above the horizon), f_r in r, g, b.
pub fn merl_dataset(m: &Model) -> Dataset {
    let mut ds = Dataset::new(
        Quantity::Brdf,
        vec![("r".into(), None), ("g".into(), None), ("b".into(), None)],
    );
    for cell in 0..merl::CELLS {
        let a = merl::cell_center(cell);
        if a[0] < FRAC_PI_2 && a[2] < FRAC_PI_2 {
            let f = m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
            ds.push(a, &[f, f, f]);
        }
    }
    ds.meta.comments.push(format!("brdfit export of {m}"));
    ds
}

/// The model on a grid: θi, θo = 0…85° in 5° steps, φi = 0, φo = 0…345° in 15° steps.
pub fn grid_dataset(m: &Model) -> Dataset {
    let mut ds = Dataset::new(Quantity::Brdf, vec![(String::new(), None)]);
    for ti in 0..18 {
        for to in 0..18 {
            for po in 0..24 {
                let a = [
                    (5.0 * ti as f64).to_radians(),
                    0.0,
                    (5.0 * to as f64).to_radians(),
                    (15.0 * po as f64).to_radians(),
                ];
                ds.push(a, &[m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]))]);
            }
        }
    }
    ds.meta.comments.push(format!("brdfit export of {m}"));
    ds
}

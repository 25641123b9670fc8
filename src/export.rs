//! Exports of a fitted model to other renderers and formats: a Mitsuba 3 BSDF snippet, a
//! pbrt-v4 material line, a Disney BRDF Explorer analytic `.brdf`, a MERL `.binary` table and a
//! brdfit CSV sampled on a grid.

use crate::data::{Dataset, Quantity, merl};
use crate::model::{Geometry, Material, MaterialKind, Model, Role, f0_from_n, short};
use std::f64::consts::FRAC_PI_2;

/// Export formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
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
        <Self as clap::ValueEnum>::from_str(s, true).ok()
    }
}

/// The material line's comment: the model, and whether the target's model is the same.
fn heading(m: &Model, mat: &Material, exact: bool) -> String {
    if exact {
        format!("brdfit export of {m}\n     The target evaluates the same f_r (exact).")
    } else {
        format!("brdfit export of {m}\n     {}", mat.differs)
    }
}

/// Mitsuba 3 BSDF XML snippet.
pub fn mitsuba(m: &Model, id: &str) -> String {
    let mat = m.material();
    let mut s = format!("<!-- {} -->\n", heading(m, &mat, mat.exact));
    s += &match mat.kind {
        MaterialKind::Diffuse { reflectance } => format!(
            "<bsdf type=\"diffuse\" id=\"{id}\">\n    <rgb name=\"reflectance\" value=\"{0}, {0}, {0}\"/>\n</bsdf>\n",
            short(reflectance)
        ),
        MaterialKind::Aluminium { alpha } => {
            let n = m.role(Role::Index).unwrap_or(1.5);
            format!(
                "<!-- a metal: n = {} acts as an effective index (F0 = {}); the conductor below uses Mitsuba's aluminium table -->\n<bsdf type=\"roughconductor\" id=\"{id}\">\n    <string name=\"distribution\" value=\"ggx\"/>\n    <float name=\"alpha\" value=\"{}\"/>\n    <string name=\"material\" value=\"Al\"/>\n</bsdf>\n",
                short(n),
                short(f0_from_n(n)),
                short(alpha)
            )
        }
        MaterialKind::Plastic {
            alpha,
            ior,
            diffuse,
        } => format!(
            "<bsdf type=\"roughplastic\" id=\"{id}\">\n    <string name=\"distribution\" value=\"ggx\"/>\n    <float name=\"alpha\" value=\"{}\"/>\n    <float name=\"int_ior\" value=\"{}\"/>\n    <float name=\"ext_ior\" value=\"1.0\"/>\n    <rgb name=\"diffuse_reflectance\" value=\"{2}, {2}, {2}\"/>\n    <boolean name=\"nonlinear\" value=\"false\"/>\n</bsdf>\n",
            short(alpha),
            short(ior),
            short(diffuse)
        ),
        MaterialKind::DiffusePlusConductor {
            diffuse,
            alpha,
            eta,
            scale,
        } => format!(
            "<!-- f_r = pd/pi + ps F D G1 G1/(4 cos cos) as the mean of two BSDFs, each weighted 1/2: diffuse(2 pd) and roughconductor(ggx, alpha, eta = n, k = 0, specular_reflectance = 2 ps); a conductor with k = 0 has the unpolarised dielectric Fresnel reflectance -->\n<bsdf type=\"blendbsdf\" id=\"{id}\">\n    <float name=\"weight\" value=\"0.5\"/>\n    <bsdf type=\"diffuse\">\n        <rgb name=\"reflectance\" value=\"{0}, {0}, {0}\"/>\n    </bsdf>\n    <bsdf type=\"roughconductor\">\n        <string name=\"distribution\" value=\"ggx\"/>\n        <float name=\"alpha\" value=\"{1}\"/>\n        <boolean name=\"sample_visible\" value=\"true\"/>\n        <rgb name=\"eta\" value=\"{2}, {2}, {2}\"/>\n        <rgb name=\"k\" value=\"0, 0, 0\"/>\n        <rgb name=\"specular_reflectance\" value=\"{3}, {3}, {3}\"/>\n    </bsdf>\n</bsdf>\n",
            short(2.0 * diffuse),
            short(alpha),
            short(eta),
            short(2.0 * scale)
        ),
    };
    s
}

/// pbrt-v4 material line.
pub fn pbrt(m: &Model) -> String {
    let mat = m.material();
    // pbrt-v4 has no sum of a diffuse and a conductor lobe (see below).
    let exact = mat.exact && !matches!(mat.kind, MaterialKind::DiffusePlusConductor { .. });
    let head = format!("# {}\n", heading(m, &mat, exact).replace("\n     ", "\n# "));
    head + &match mat.kind {
        MaterialKind::Diffuse { reflectance } => format!(
            "Material \"diffuse\" \"rgb reflectance\" [ {0} {0} {0} ]\n",
            short(reflectance)
        ),
        MaterialKind::Aluminium { alpha } => format!(
            "Material \"conductor\" \"float roughness\" [ {} ] \"bool remaproughness\" false \"spectrum eta\" \"metal-Al-eta\" \"spectrum k\" \"metal-Al-k\"\n",
            short(alpha)
        ),
        MaterialKind::Plastic {
            alpha,
            ior,
            diffuse,
        } => format!(
            "Material \"coateddiffuse\" \"rgb reflectance\" [ {0} {0} {0} ] \"float roughness\" [ {1} ] \"bool remaproughness\" false \"float eta\" [ {2} ]\n",
            short(diffuse),
            short(alpha),
            short(ior)
        ),
        MaterialKind::DiffusePlusConductor {
            diffuse,
            alpha,
            eta,
            scale,
        } => format!(
            "# Not exact in pbrt-v4: its conductor uses the height-correlated Smith G = 1/(1 + L(o) + L(i)), not the separable G1 G1, has no scale for ps (ps = {3}: the lobe below has ps = 1), and \"mix\" picks one material per ray (its mean is the average of the two).\nMakeNamedMaterial \"brdfit-diffuse\" \"string type\" \"diffuse\" \"rgb reflectance\" [ {0} {0} {0} ]\nMakeNamedMaterial \"brdfit-lobe\" \"string type\" \"conductor\" \"float roughness\" [ {1} ] \"bool remaproughness\" false \"spectrum eta\" [ 400 {2} 700 {2} ] \"spectrum k\" [ 400 0 700 0 ]\nMaterial \"mix\" \"string materials\" [ \"brdfit-diffuse\" \"brdfit-lobe\" ] \"float amount\" [ 0.5 ]\n",
            short(2.0 * diffuse),
            short(alpha),
            short(eta),
            short(scale)
        ),
    }
}

/// Disney BRDF Explorer analytic `.brdf` of the model, fitted values as parameter defaults
/// and slider ranges from the parameters' declared ranges.
pub fn brdf_explorer(m: &Model) -> String {
    let params: String = m
        .specs()
        .iter()
        .zip(m.params())
        .map(|(spec, v)| {
            let (lo, hi) = spec.slider;
            let hi = if spec.hi <= 1.0 { hi } else { v.max(hi) * 2.0 };
            format!(
                "float {} {} {} {}\n",
                spec.name,
                short(lo),
                short(hi),
                short(*v)
            )
        })
        .collect();
    let body = m.glsl();
    format!(
        "analytic\n# brdfit export of {m}: brdfit's conventions (f_r = i / (pi N.L), F with the factor 1/2)\n::begin parameters\n{params}::end parameters\n::begin shader\nconst float PI = 3.14159265358979323846;\nvec3 BRDF( vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y )\n{{\n    float NdotL = dot(N, L);\n    float NdotV = dot(N, V);\n    if (NdotL <= 0.0 || NdotV <= 0.0) return vec3(0.0);\n{body}\n}}\n::end shader\n"
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

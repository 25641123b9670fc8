//! Exports of a fitted model to other renderers and formats: a Mitsuba 3 BSDF snippet, a
//! pbrt-v4 material line, a Disney BRDF Explorer analytic `.brdf`, a MERL `.binary` table and a
//! brdfit CSV sampled on a grid.

use crate::data::{Dataset, Quantity, merl};
use crate::fit::Colour;
use crate::model::{Geometry, Material, MaterialKind, Model, short};
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

/// A number at full precision: the shortest text that reads back as the same `f64`.
fn full(v: f64) -> String {
    format!("{v}")
}

/// The colour notes as comment lines (empty for a grey material).
fn colour_notes(c: &Colour, prefix: &str) -> String {
    c.notes.iter().map(|n| format!("{prefix}{n}\n")).collect()
}

/// A reflectance in Mitsuba 3's XML: a `<spectrum>` value when r = g = b (Mitsuba refuses an
/// `<rgb>` reflectance above 1, such as 2 ps of a bright lobe), else an unbounded sRGB
/// texture, both at full precision.
fn mitsuba_reflectance(name: &str, v: [f64; 3], indent: &str) -> String {
    if v[0] == v[1] && v[1] == v[2] {
        format!(
            "{indent}<spectrum name=\"{name}\" value=\"{}\"/>\n",
            full(v[0])
        )
    } else {
        format!(
            "{indent}<texture type=\"srgb\" name=\"{name}\">\n{indent}    <rgb name=\"color\" value=\"{}, {}, {}\"/>\n{indent}    <boolean name=\"unbounded\" value=\"true\"/>\n{indent}</texture>\n",
            full(v[0]),
            full(v[1]),
            full(v[2])
        )
    }
}

/// The 95th percentile of the refit's relative f_r error above which [`refit_as_ggx`]'s note
/// ends in a warning (10 %).
pub const REFIT_FAITHFUL_P95: f64 = 0.10;

/// The material for a renderer whose models are Lambert and GGX–Smith (Mitsuba 3): lambert
/// and ggx-smith as they are (exact); any other model refitted as brdfit's `ggx-smith`, which
/// Mitsuba evaluates exactly: the lobe (α, n) fitted by brdfit's own fitter (log loss) to
/// 20,000 noiseless samples of the model over the hemisphere (θ ≤ 88°), then each colour
/// channel's ps and pd with α and n held. Returns the material and a sentence with the refit's
/// error (relative f_r on those directions), or None when nothing was refitted.
pub fn refit_as_ggx(c: &Colour) -> Result<(Colour, Option<String>), String> {
    use crate::fit::{FitOptions, fit};
    use crate::model::ModelKind;
    use crate::simulate::{Grid, simulate};
    if matches!(
        c.model.kind,
        ModelKind::Lambert | ModelKind::GgxSmith | ModelKind::GgxSmith2
    ) {
        return Ok((c.clone(), None));
    }
    let dirs = Grid::Hemisphere(20_000).directions(1);
    let run = |m: &Model, fix: &[(String, f64)]| -> Result<Model, String> {
        let ds = simulate(m, &dirs, 0.0, 1);
        let mut o = FitOptions::new(ModelKind::GgxSmith);
        o.profile = false;
        o.fix = fix.to_vec();
        let r = fit(&ds, &o).map_err(|e| format!("the refit of {m} as ggx-smith failed: {e}"))?;
        Ok(r[0].model_for(0))
    };
    let lobe = run(&c.model, &[])?;
    let (alpha, n) = (lobe.p[0], lobe.p[1]);
    let held = [("alpha".to_string(), alpha), ("n".to_string(), n)];
    let mut out = Colour {
        model: lobe,
        pd: [0.0; 3],
        ps: [0.0; 3],
        ps2: [0.0; 3],
        notes: c.notes.clone(),
        exact: c.exact,
    };
    let mut errs: Vec<f64> = Vec::new();
    for k in 0..3 {
        let orig = c.channel_model(k);
        // A channel without a diffuse part (pd 0, as where a spectrum's negative sRGB
        // component was clamped) keeps none: a pd the log loss leaves above 0 was thousands
        // of times the lobe's tail away from the highlight.
        let mut hold = held.to_vec();
        if orig.pd() == 0.0 {
            hold.push(("pd".to_string(), 0.0));
        }
        let g = if k > 0 && c.is_grey() {
            out.channel_model(0)
        } else {
            run(&orig, &hold)?
        };
        out.pd[k] = g.pd();
        out.ps[k] = g.p[2];
        // Relative to f_r plus 0.1 % of the channel's scale (pd + ps)/π: a lobe's far tail,
        // 10⁻⁹ of the peak where a channel has no diffuse part, is not counted.
        let floor = 1e-3 * (orig.pd() + g.p[2]).abs() * std::f64::consts::FRAC_1_PI;
        for a in &dirs {
            let geo = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            let (f0, f1) = (orig.brdf(&geo), g.brdf(&geo));
            if f0 > 0.0 {
                errs.push((f1 - f0).abs() / (f0 + floor));
            }
        }
    }
    errs.sort_by(f64::total_cmp);
    let q = |p: f64| {
        errs.get(((errs.len() as f64 - 1.0) * p) as usize)
            .copied()
            .unwrap_or(0.0)
    };
    let note = format!(
        "refitted: Mitsuba has no {}; this is brdfit's ggx-smith (alpha {}, n {}) fitted to 20,000 samples of it over the hemisphere (theta <= 88 deg, log loss), which Mitsuba evaluates exactly. The refit's f_r differs from the fitted model's by a median {} %, 95th percentile {} %, largest {} % (relative to f_r + 0.1 % of (pd + ps)/pi).",
        c.model.kind.label(c.model.dist),
        short(alpha),
        short(n),
        crate::model::readable(100.0 * q(0.5)),
        crate::model::readable(100.0 * q(0.95)),
        crate::model::readable(100.0 * q(1.0))
    );
    let note = if q(0.95) > REFIT_FAITHFUL_P95 {
        note + " warning: the refit is more than 10 % off on over 5 % of the directions: Mitsuba's GGX-Smith does not take this model's shape; fix: render the fit in brdfit, or fit ggx-smith to the data itself (fit --model ggx-smith, Mitsuba then evaluates exactly what was fitted) and export that."
    } else {
        note
    };
    Ok((out, Some(note)))
}

/// Mitsuba 3 BSDF XML snippet of the material (values at full precision; reflectances above 1
/// written as `<spectrum>` or an unbounded sRGB texture, which Mitsuba loads): lambert as
/// `diffuse`, ggx-smith and ggx-smith-2 as the exact `blendbsdf`s below, any other model
/// refitted as ggx-smith
/// ([`refit_as_ggx`]), the refit's error written in the file.
pub fn mitsuba(c: &Colour, id: &str) -> Result<String, String> {
    let (c, refit) = refit_as_ggx(c)?;
    let m = c.model;
    let compromise = c.notes.iter().any(|n| n.starts_with("compromise"));
    let mut head = format!(
        "brdfit export of {}\n     {}\n",
        if c.is_grey() {
            format!("{m}")
        } else {
            m.kind.label(m.dist)
        },
        match (refit.is_some(), compromise) {
            (false, false) => "The target evaluates the same f_r (exact).",
            (true, _) =>
                "The target evaluates the refitted ggx-smith below exactly, the fitted model only approximately (the refit's error follows).",
            (false, true) =>
                "The target evaluates the f_r below exactly; the channels share one lobe, a compromise (the note follows).",
        }
    );
    if let Some(r) = &refit {
        head += &format!("     {r}\n");
    }
    head += &colour_notes(&c, "     ");
    let mut s = format!("<!-- {} -->\n", comment_safe(&head));
    s += &match m.material().kind {
        MaterialKind::DiffusePlusConductor { alpha, eta, .. } => format!(
            "<!-- f_r = pd/pi + ps F D G1 G1/(4 cos cos) as the mean of two BSDFs, each weighted 1/2: diffuse(2 pd) and roughconductor(ggx, alpha, eta = n, k = 0, specular_reflectance = 2 ps); a conductor with k = 0 has the unpolarised dielectric Fresnel reflectance -->\n<bsdf type=\"blendbsdf\" id=\"{id}\">\n    <float name=\"weight\" value=\"0.5\"/>\n    <bsdf type=\"diffuse\">\n{}    </bsdf>\n    <bsdf type=\"roughconductor\">\n        <string name=\"distribution\" value=\"ggx\"/>\n        <float name=\"alpha\" value=\"{}\"/>\n        <boolean name=\"sample_visible\" value=\"true\"/>\n        <spectrum name=\"eta\" value=\"{}\"/>\n        <spectrum name=\"k\" value=\"0\"/>\n{}    </bsdf>\n</bsdf>\n",
            mitsuba_reflectance("reflectance", c.pd.map(|v| 2.0 * v), "        "),
            full(alpha),
            full(eta),
            mitsuba_reflectance("specular_reflectance", c.ps.map(|v| 2.0 * v), "        "),
        ),
        MaterialKind::DiffusePlusTwoConductors {
            alpha1,
            alpha2,
            eta,
            ..
        } => {
            let lobe = |alpha: f64, ps: [f64; 3]| {
                format!(
                    "        <bsdf type=\"roughconductor\">\n            <string name=\"distribution\" value=\"ggx\"/>\n            <float name=\"alpha\" value=\"{}\"/>\n            <boolean name=\"sample_visible\" value=\"true\"/>\n            <spectrum name=\"eta\" value=\"{}\"/>\n            <spectrum name=\"k\" value=\"0\"/>\n{}        </bsdf>\n",
                    full(alpha),
                    full(eta),
                    mitsuba_reflectance(
                        "specular_reflectance",
                        ps.map(|v| 3.0 * v),
                        "            "
                    )
                )
            };
            format!(
                "<!-- f_r = pd/pi + (ps1 D1 G1 G1 + ps2 D2 G1 G1) F/(4 cos cos) as the mean of three BSDFs, each weighted 1/3: diffuse(3 pd) blended (weight 2/3) with the even blend of roughconductor(ggx, alpha1, eta = n, k = 0, specular_reflectance = 3 ps1) and roughconductor(ggx, alpha2, eta = n, k = 0, specular_reflectance = 3 ps2); a conductor with k = 0 has the unpolarised dielectric Fresnel reflectance -->\n<bsdf type=\"blendbsdf\" id=\"{id}\">\n    <float name=\"weight\" value=\"{}\"/>\n    <bsdf type=\"diffuse\">\n{}    </bsdf>\n    <bsdf type=\"blendbsdf\">\n        <float name=\"weight\" value=\"0.5\"/>\n{}{}    </bsdf>\n</bsdf>\n",
                full(2.0 / 3.0),
                mitsuba_reflectance("reflectance", c.pd.map(|v| 3.0 * v), "        "),
                lobe(alpha1, c.ps),
                lobe(alpha2, c.ps2),
            )
        }
        _ => format!(
            "<bsdf type=\"diffuse\" id=\"{id}\">\n{}</bsdf>\n",
            mitsuba_reflectance("reflectance", c.pd, "    ")
        ),
    };
    Ok(s)
}

/// `text` fit for an XML comment, which may not hold `--` (XML 1.0, §2.5; Python's parsers
/// refuse it): each `--` becomes `- -`, and a trailing `-` is followed by a space.
pub fn comment_safe(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for ch in text.chars() {
        if ch == '-' && out.ends_with('-') {
            out.push(' ');
        }
        out.push(ch);
    }
    if out.ends_with('-') {
        out.push(' ');
    }
    out
}

/// The material line's comment: the model, and whether the target's model is the same.
fn heading(m: &Model, mat: &Material, exact: bool) -> String {
    if exact {
        format!("brdfit export of {m}\n     The target evaluates the same f_r (exact).")
    } else {
        format!("brdfit export of {m}\n     {}", mat.differs)
    }
}

/// pbrt-v4 material line (values at full precision; r, g, b per channel for a colour). Only
/// lambert is exact: pbrt-v4's materials differ from brdfit's other models as the comment says.
pub fn pbrt(c: &Colour) -> String {
    let m = &c.model;
    let mat = m.material();
    // pbrt-v4 has no sum of a diffuse and a conductor lobe (see below).
    let exact = mat.exact
        && !matches!(
            mat.kind,
            MaterialKind::DiffusePlusConductor { .. }
                | MaterialKind::DiffusePlusTwoConductors { .. }
        );
    let head = format!("# {}\n", heading(m, &mat, exact).replace("\n     ", "\n# "));
    let head = head + &colour_notes(c, "# ");
    let rgb = |v: [f64; 3]| format!("{} {} {}", full(v[0]), full(v[1]), full(v[2]));
    head + &match mat.kind {
        MaterialKind::Diffuse { .. } => format!(
            "Material \"diffuse\" \"rgb reflectance\" [ {} ]\n",
            rgb(c.pd)
        ),
        MaterialKind::Aluminium { alpha } => format!(
            "# pbrt's aluminium table gives the colour; the channels' ps do not enter.\nMaterial \"conductor\" \"float roughness\" [ {} ] \"bool remaproughness\" false \"spectrum eta\" \"metal-Al-eta\" \"spectrum k\" \"metal-Al-k\"\n",
            full(alpha)
        ),
        MaterialKind::Plastic { alpha, ior, .. } => format!(
            "Material \"coateddiffuse\" \"rgb reflectance\" [ {} ] \"float roughness\" [ {} ] \"bool remaproughness\" false \"float eta\" [ {} ]\n",
            rgb(c.pd),
            full(alpha),
            full(ior)
        ),
        MaterialKind::DiffusePlusConductor { alpha, eta, .. } => format!(
            "# Not exact in pbrt-v4: its conductor uses the height-correlated Smith G = 1/(1 + L(o) + L(i)), not the separable G1 G1, has no scale for ps (ps = {3}: the lobe below has ps = 1), and \"mix\" picks one material per ray (its mean is the average of the two).\nMakeNamedMaterial \"brdfit-diffuse\" \"string type\" \"diffuse\" \"rgb reflectance\" [ {0} ]\nMakeNamedMaterial \"brdfit-lobe\" \"string type\" \"conductor\" \"float roughness\" [ {1} ] \"bool remaproughness\" false \"spectrum eta\" [ 400 {2} 700 {2} ] \"spectrum k\" [ 400 0 700 0 ]\nMaterial \"mix\" \"string materials\" [ \"brdfit-diffuse\" \"brdfit-lobe\" ] \"float amount\" [ 0.5 ]\n",
            rgb(c.pd.map(|v| 2.0 * v)),
            full(alpha),
            full(eta),
            rgb(c.ps)
        ),
        MaterialKind::DiffusePlusTwoConductors {
            alpha1,
            alpha2,
            eta,
            ..
        } => format!(
            "# Not exact in pbrt-v4: its conductor uses the height-correlated Smith G = 1/(1 + L(o) + L(i)), not the separable G1 G1, has no scale for ps (ps1 = {4}, ps2 = {5}: each lobe below has ps = 1), and \"mix\" picks one material per ray (its mean is the average of the three, each weighted 1/3).\nMakeNamedMaterial \"brdfit-diffuse\" \"string type\" \"diffuse\" \"rgb reflectance\" [ {0} ]\nMakeNamedMaterial \"brdfit-lobe1\" \"string type\" \"conductor\" \"float roughness\" [ {1} ] \"bool remaproughness\" false \"spectrum eta\" [ 400 {3} 700 {3} ] \"spectrum k\" [ 400 0 700 0 ]\nMakeNamedMaterial \"brdfit-lobe2\" \"string type\" \"conductor\" \"float roughness\" [ {2} ] \"bool remaproughness\" false \"spectrum eta\" [ 400 {3} 700 {3} ] \"spectrum k\" [ 400 0 700 0 ]\nMakeNamedMaterial \"brdfit-lobes\" \"string type\" \"mix\" \"string materials\" [ \"brdfit-lobe1\" \"brdfit-lobe2\" ] \"float amount\" [ 0.5 ]\nMaterial \"mix\" \"string materials\" [ \"brdfit-diffuse\" \"brdfit-lobes\" ] \"float amount\" [ {6} ]\n",
            rgb(c.pd.map(|v| 3.0 * v)),
            full(alpha1),
            full(alpha2),
            full(eta),
            rgb(c.ps),
            rgb(c.ps2),
            full(2.0 / 3.0)
        ),
    }
}

/// Disney BRDF Explorer analytic `.brdf` of the model (brdfit's own f_r in GLSL, exact), fitted
/// values at full precision as parameter defaults and slider ranges from the parameters'
/// declared ranges. One channel: a colour is refused with the fix.
pub fn brdf_explorer(c: &Colour) -> Result<String, String> {
    if !c.is_grey() {
        return Err("the BRDF Explorer export holds one channel's model, and these fits are colour\n  fix: export one channel with --channel NAME".into());
    }
    let m = &c.model;
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
                full(*v)
            )
        })
        .collect();
    let body = m.glsl();
    Ok(format!(
        "analytic\n# brdfit export of {m}: brdfit's conventions (f_r = i / (pi N.L), F with the factor 1/2)\n::begin parameters\n{params}::end parameters\n::begin shader\nconst float PI = 3.14159265358979323846;\nvec3 BRDF( vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y )\n{{\n    float NdotL = dot(N, L);\n    float NdotV = dot(N, V);\n    if (NdotL <= 0.0 || NdotV <= 0.0) return vec3(0.0);\n{body}\n}}\n::end shader\n"
    ))
}

/// The material tabulated at the MERL cell centres (above the horizon), f_r in r, g, b (each
/// colour channel's model).
pub fn merl_dataset(c: &Colour) -> Dataset {
    let mut ds = Dataset::new(
        Quantity::Brdf,
        vec![("r".into(), None), ("g".into(), None), ("b".into(), None)],
    );
    let ms = [0, 1, 2].map(|k| c.channel_model(k));
    for cell in 0..merl::CELLS {
        let a = merl::cell_center(cell);
        if a[0] < FRAC_PI_2 && a[2] < FRAC_PI_2 {
            let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
            ds.push(a, &ms.map(|m| m.brdf(&g)));
        }
    }
    ds.meta
        .comments
        .push(format!("brdfit export of {}", c.model));
    ds.meta.comments.extend(c.notes.iter().cloned());
    ds
}

/// The material on a grid: θi, θo = 0…85° in 5° steps, φi = 0, φo = 0…345° in 15° steps; one
/// column for a grey material, r, g, b for a colour.
pub fn grid_dataset(c: &Colour) -> Dataset {
    let ms: Vec<Model> = if c.is_grey() {
        vec![c.model]
    } else {
        (0..3).map(|k| c.channel_model(k)).collect()
    };
    let names: Vec<(String, Option<f64>)> = if ms.len() == 1 {
        vec![(String::new(), None)]
    } else {
        ["r", "g", "b"]
            .iter()
            .map(|n| (n.to_string(), None))
            .collect()
    };
    let mut ds = Dataset::new(Quantity::Brdf, names);
    for ti in 0..18 {
        for to in 0..18 {
            for po in 0..24 {
                let a = [
                    (5.0 * ti as f64).to_radians(),
                    0.0,
                    (5.0 * to as f64).to_radians(),
                    (15.0 * po as f64).to_radians(),
                ];
                let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
                let v: Vec<f64> = ms.iter().map(|m| m.brdf(&g)).collect();
                ds.push(a, &v);
            }
        }
    }
    ds.meta
        .comments
        .push(format!("brdfit export of {}", c.model));
    ds.meta.comments.extend(c.notes.iter().cloned());
    ds
}

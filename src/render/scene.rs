//! Scene files (TOML), the built-in Figure 7 scenes, and the OBJ reader.
//!
//! ```toml
//! max_depth = 4            # ray-tree depth (1 = primary rays only)
//! min_weight = 0.001       # rays weighing less are not traced
//! ambient = [0.02, 0.02, 0.02]   # uniform ambient radiance (a number is grey)
//! background = 0.0
//! [camera]
//! eye = [0, 2.2, 8]
//! target = [0, 0.8, 0]
//! up = [0, 1, 0]
//! fov = 35                  # horizontal, degrees
//! width = 512
//! height = 512
//! [antialias]
//! mode = "adaptive"         # adaptive | uniform | stratified | none
//! threshold = 0.02          # adaptive: difference of √(linear value) that subdivides
//! max_level = 3             # adaptive: at most 2^3 × 2^3 squares per pixel
//! block = 1                 # adaptive: first squares of 1, 2 or 4 pixels (>1: interpolate)
//! jitter = false            # adaptive: trace each corner at a fixed random point near it
//! samples = 4               # uniform / stratified: 4 × 4 per pixel (stratified: jittered)
//! [[lights]]
//! kind = "point"            # point (1/r² falloff) | directional
//! position = [1, 4, 9]      # point; directional lights give `direction` (toward the light)
//! color = [1, 1, 1]
//! intensity = 120           # radiant intensity (point) or irradiance (directional)
//! [materials.mgo]
//! model = "torrance-sparrow"   # or fit = "mgo.json" (relative to this file)
//! distribution = "d3"
//! params = { n = 1.8, c3 = 0.35, ps = 0.667, pd = 0.333 }
//! color = [1, 1, 1]         # diffuse colour; the highlight is white
//! ks = 0.0                  # Whitted mirror weight
//! kt = 0.0                  # Whitted transmission weight
//! ior = 1.5                 # index for the refracted ray
//! checker = { size = 1.0, color0 = [0.2, 0.2, 0.2], color1 = [0.8, 0.8, 0.8] }
//! roughness = { cmin = 0.2, frequency = 4.0 }   # Blinn's Figure 8 (torrance-sparrow d3)
//! [[objects]]
//! kind = "sphere"           # sphere | plane | mesh
//! center = [1.2, 1, 0]
//! radius = 1
//! material = "mgo"
//! ```
//! Planes take `point`, `normal` and an optional half-size `size`; meshes take `path` (an OBJ
//! file relative to the scene file).

use super::{
    AntiAlias, Camera, Checker, Light, Material, Mesh, Object, RoughnessTexture, Scene, Shape,
};
use crate::model::{Distribution, Model, ModelKind};
use anyhow::{Context, Result, anyhow, bail};
use glam::DVec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Deserialize)]
#[serde(untagged)]
enum ColorSpec {
    Grey(f64),
    Rgb([f64; 3]),
}

impl ColorSpec {
    fn rgb(&self) -> DVec3 {
        match self {
            ColorSpec::Grey(g) => DVec3::splat(*g),
            ColorSpec::Rgb(c) => DVec3::from_array(*c),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSpec {
    eye: [f64; 3],
    target: [f64; 3],
    up: Option<[f64; 3]>,
    fov: f64,
    width: u32,
    height: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AaSpec {
    mode: String,
    threshold: Option<f64>,
    max_level: Option<u32>,
    block: Option<u32>,
    jitter: Option<bool>,
    samples: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightSpec {
    kind: String,
    position: Option<[f64; 3]>,
    direction: Option<[f64; 3]>,
    color: Option<ColorSpec>,
    intensity: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckerSpec {
    size: f64,
    color0: ColorSpec,
    color1: ColorSpec,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RoughSpec {
    cmin: f64,
    frequency: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialSpec {
    model: Option<String>,
    distribution: Option<String>,
    params: Option<BTreeMap<String, f64>>,
    fit: Option<String>,
    /// With `fit`: the model to take from a file of several (`fit --model all`).
    fit_model: Option<String>,
    /// With `fit`: the channel to take (default: every channel, as colour).
    fit_channel: Option<String>,
    /// With `fit`: use a fit marked not usable.
    fit_allow_unusable: Option<bool>,
    color: Option<ColorSpec>,
    checker: Option<CheckerSpec>,
    ks: Option<f64>,
    kt: Option<f64>,
    ior: Option<f64>,
    roughness: Option<RoughSpec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectSpec {
    kind: String,
    material: String,
    center: Option<[f64; 3]>,
    radius: Option<f64>,
    point: Option<[f64; 3]>,
    normal: Option<[f64; 3]>,
    size: Option<f64>,
    path: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    camera: CameraSpec,
    max_depth: Option<u32>,
    min_weight: Option<f64>,
    ambient: Option<ColorSpec>,
    background: Option<ColorSpec>,
    antialias: Option<AaSpec>,
    #[serde(default)]
    lights: Vec<LightSpec>,
    #[serde(default)]
    materials: BTreeMap<String, MaterialSpec>,
    #[serde(default)]
    objects: Vec<ObjectSpec>,
}

fn finite3(v: [f64; 3], what: &str) -> Result<DVec3> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(DVec3::from_array(v))
    } else {
        bail!("{what} must be three finite numbers")
    }
}

/// Read a scene from TOML text; `dir` resolves relative paths (fit JSON, OBJ).
pub fn parse_scene(text: &str, dir: &Path) -> Result<Scene> {
    let f: SceneFile = toml::from_str(text).map_err(|e| anyhow!("{e}"))?;
    let cam = &f.camera;
    if cam.width == 0 || cam.height == 0 || cam.width > 16384 || cam.height > 16384 {
        bail!(
            "camera resolution {}×{} is invalid\n  fix: width and height must be between 1 and 16384",
            cam.width,
            cam.height
        );
    }
    if !(cam.fov > 0.0 && cam.fov < 180.0) {
        bail!(
            "camera fov {} is invalid\n  fix: give a horizontal field of view in (0, 180) degrees",
            cam.fov
        );
    }
    let eye = finite3(cam.eye, "camera.eye")?;
    let target = finite3(cam.target, "camera.target")?;
    let up = finite3(cam.up.unwrap_or([0.0, 1.0, 0.0]), "camera.up")?;
    if (target - eye).length() < 1e-12 || (target - eye).cross(up).length() < 1e-12 {
        bail!(
            "the camera looks along its up vector or at its own position\n  fix: give a target away from the eye and an up vector not parallel to the view"
        );
    }
    let camera = Camera {
        eye,
        target,
        up,
        fov_deg: cam.fov,
        width: cam.width,
        height: cam.height,
    };
    let mut names = Vec::new();
    let mut materials = Vec::new();
    for (name, m) in &f.materials {
        materials.push(material(name, m, dir)?);
        names.push(name.clone());
    }
    let mut objects = Vec::new();
    for (k, o) in f.objects.iter().enumerate() {
        let mi = names.iter().position(|n| *n == o.material).ok_or_else(|| {
            anyhow!("object {} uses material '{}', which is not defined\n  fix: add [materials.{}] or use one of: {}", k + 1, o.material, o.material, names.join(", "))
        })?;
        let need = |v: Option<[f64; 3]>, what: &str| -> Result<DVec3> {
            finite3(
                v.ok_or_else(|| anyhow!("object {} ({}) needs `{what}`", k + 1, o.kind))?,
                what,
            )
        };
        let shape = match o.kind.as_str() {
            "sphere" => {
                let radius = o.radius.unwrap_or(1.0);
                if !(radius > 0.0 && radius.is_finite()) {
                    bail!("object {}: sphere radius {radius} must be positive", k + 1);
                }
                Shape::Sphere {
                    center: need(o.center, "center")?,
                    radius,
                }
            }
            "plane" => {
                let normal = need(o.normal, "normal")?;
                if normal.length() < 1e-12 {
                    bail!("object {}: plane normal is zero", k + 1);
                }
                let normal = normal.normalize();
                let (u, v) = plane_axes(normal);
                Shape::Plane {
                    point: need(o.point, "point")?,
                    normal,
                    half: o.size,
                    u,
                    v,
                }
            }
            "mesh" => {
                let p = dir.join(
                    o.path
                        .as_deref()
                        .ok_or_else(|| anyhow!("object {} (mesh) needs `path`", k + 1))?,
                );
                Shape::Mesh(read_obj(&p)?)
            }
            other => bail!(
                "object {}: unknown kind '{other}'\n  fix: use sphere, plane or mesh",
                k + 1
            ),
        };
        objects.push(Object::new(shape, mi));
    }
    let mut lights = Vec::new();
    for (k, l) in f.lights.iter().enumerate() {
        let color = l.color.as_ref().map_or(DVec3::ONE, |c| c.rgb());
        if !(l.intensity.is_finite() && l.intensity >= 0.0) {
            bail!("light {}: intensity must be a finite number ≥ 0", k + 1);
        }
        lights.push(match l.kind.as_str() {
            "point" => Light::Point {
                position: finite3(
                    l.position
                        .ok_or_else(|| anyhow!("light {} (point) needs `position`", k + 1))?,
                    "position",
                )?,
                intensity: color * l.intensity,
            },
            "directional" => {
                let d = finite3(
                    l.direction.ok_or_else(|| {
                        anyhow!("light {} (directional) needs `direction`", k + 1)
                    })?,
                    "direction",
                )?;
                if d.length() < 1e-12 {
                    bail!("light {}: direction is zero", k + 1);
                }
                Light::Directional {
                    direction: d.normalize(),
                    irradiance: color * l.intensity,
                }
            }
            other => bail!(
                "light {}: unknown kind '{other}'\n  fix: use point or directional",
                k + 1
            ),
        });
    }
    let antialias = match &f.antialias {
        None => AntiAlias::Adaptive {
            threshold: 0.02,
            max_level: 3,
            block: 1,
            jitter: false,
        },
        Some(a) => match a.mode.as_str() {
            "none" => AntiAlias::None,
            "uniform" => AntiAlias::Uniform(a.samples.unwrap_or(4).clamp(1, 64)),
            "stratified" => AntiAlias::Stratified(a.samples.unwrap_or(4).clamp(1, 64)),
            "adaptive" => AntiAlias::Adaptive {
                threshold: a.threshold.unwrap_or(0.02).max(0.0),
                max_level: a.max_level.unwrap_or(3).min(8),
                block: match a.block.unwrap_or(1) {
                    b @ (1 | 2 | 4) => b,
                    b => bail!("antialias block = {b} is not supported\n  fix: use 1, 2 or 4"),
                },
                jitter: a.jitter.unwrap_or(false),
            },
            other => {
                bail!(
                    "antialias mode '{other}' is unknown\n  fix: use adaptive, uniform, stratified or none"
                )
            }
        },
    };
    Ok(Scene {
        camera,
        objects,
        materials,
        lights,
        ambient: f.ambient.as_ref().map_or(DVec3::ZERO, |c| c.rgb()),
        background: f.background.as_ref().map_or(DVec3::ZERO, |c| c.rgb()),
        max_depth: f.max_depth.unwrap_or(4).clamp(1, 64),
        min_weight: f.min_weight.unwrap_or(1e-3).max(0.0),
        antialias,
    })
}

fn material(name: &str, m: &MaterialSpec, dir: &Path) -> Result<Material> {
    // A colour fit: the lobe with ps = pd = 1, its channels' pd and ps as colours.
    let mut fit_colour = (DVec3::ONE, DVec3::ONE);
    let model = match (&m.fit, &m.model) {
        (Some(fit), _) => {
            let p = dir.join(fit);
            let (model, diffuse, specular) = fit_material(name, m, &p)?;
            fit_colour = (diffuse, specular);
            model
        }
        (None, Some(kind)) => {
            let kind = ModelKind::parse(kind).ok_or_else(|| {
                anyhow!(
                    "material {name}: unknown model '{kind}'\n  fix: use one of {}",
                    ModelKind::names()
                )
            })?;
            let dist = match &m.distribution {
                Some(d) => Distribution::parse(d)
                    .ok_or_else(|| anyhow!("material {name}: unknown distribution '{d}'"))?,
                None => Distribution::D3,
            };
            let set: Vec<(String, f64)> =
                m.params.clone().unwrap_or_default().into_iter().collect();
            Model::from_named(kind, dist, &set).map_err(|e| anyhow!("material {name}: {e}"))?
        }
        (None, None) => bail!(
            "material {name} has neither `model` nor `fit`\n  fix: add model = \"lambert\" and params = {{ pd = 0.5 }}, or fit = \"FILE.json\""
        ),
    };
    let ior = m.ior.unwrap_or(1.5);
    if !(ior > 0.0 && ior.is_finite()) {
        bail!("material {name}: ior {ior} must be positive");
    }
    Ok(Material {
        name: name.to_string(),
        model,
        color: m.color.as_ref().map_or(DVec3::ONE, |c| c.rgb()) * fit_colour.0,
        specular: fit_colour.1,
        checker: m.checker.as_ref().map(|c| Checker {
            size: c.size.abs().max(1e-9),
            color0: c.color0.rgb(),
            color1: c.color1.rgb(),
        }),
        ks: m.ks.unwrap_or(0.0).clamp(0.0, 1.0),
        kt: m.kt.unwrap_or(0.0).clamp(0.0, 1.0),
        ior,
        roughness: m.roughness.as_ref().map(|r| RoughnessTexture {
            cmin: r.cmin.clamp(1e-3, 1.0),
            frequency: r.frequency,
        }),
        measured: None,
    })
}

/// A material's fit: the file read strictly, the model and channel picked by `fit_model` and
/// `fit_channel` (see [`crate::fit::pick`]); several channels become colour (the shared lobe
/// with ps = pd = 1, and their pd and ps as diffuse and specular colours). What was picked
/// for the user and any colour compromise are said on stderr.
fn fit_material(name: &str, m: &MaterialSpec, p: &Path) -> Result<(Model, DVec3, DVec3)> {
    use crate::fit::{Want, pick, read_fit_file};
    let text = std::fs::read_to_string(p)
        .with_context(|| format!("material {name}: cannot read fit {}", p.display()))?;
    let at = |e: &dyn std::fmt::Display| anyhow!("material {name}: {}: {e}", p.display());
    let fits = read_fit_file(&text).map_err(|e| at(&e))?;
    let model = match &m.fit_model {
        None => None,
        Some(k) => Some(ModelKind::parse(k).ok_or_else(|| {
            anyhow!(
                "material {name}: fit_model: unknown model '{k}'\n  fix: use one of {}",
                ModelKind::names()
            )
        })?),
    };
    let want = Want {
        model,
        dist: m.distribution.as_deref().and_then(Distribution::parse),
        channel: m.fit_channel.clone(),
        allow_unusable: m.fit_allow_unusable.unwrap_or(false),
    };
    let picked = pick(&fits, &want).map_err(|e| {
        at(&e
            .to_string()
            .replace("--allow-unusable", "fit_allow_unusable = true")
            .replace("--model", "fit_model")
            .replace("--channel", "fit_channel"))
    })?;
    let colour = picked
        .colour()
        .map_err(|e| at(&e.to_string().replace("with --channel", "with fit_channel")))?;
    for n in picked.notes.iter().chain(&colour.notes) {
        eprintln!(
            "note: material {name}: {}: {}",
            p.display(),
            n.replace("--model", "fit_model")
                .replace("--channel", "fit_channel")
        );
    }
    if colour.is_grey() {
        return Ok((colour.model, DVec3::ONE, DVec3::ONE));
    }
    let lobe = colour.channel_model(0);
    let mut unit = lobe;
    for (i, spec) in lobe.kind.params(lobe.dist).iter().enumerate() {
        if matches!(
            spec.role,
            crate::model::Role::Diffuse | crate::model::Role::Specular
        ) {
            unit.p[i] = 1.0;
        }
    }
    Ok((
        unit,
        DVec3::from_array(colour.pd),
        DVec3::from_array(colour.ps),
    ))
}

/// Texture axes of a plane: u follows world x (z when the normal is along x), v follows world
/// y (z when the normal is along y), both projected into the plane, so a floor's checker runs
/// along x and z and a wall's along x and y.
pub fn plane_axes(n: DVec3) -> (DVec3, DVec3) {
    let proj = |a: DVec3| a - a.dot(n) * n;
    let u = if n.x.abs() > 0.9 {
        proj(DVec3::Z)
    } else {
        proj(DVec3::X)
    }
    .normalize();
    let v0 = if n.y.abs() > 0.9 {
        proj(DVec3::Z)
    } else {
        proj(DVec3::Y)
    };
    let v = (v0 - v0.dot(u) * u).normalize();
    (u, v)
}

/// Read a scene file.
pub fn load_scene(path: &Path) -> Result<Scene> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the scene", path.display()))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse_scene(&text, dir).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Read the `v` and `f` lines of an OBJ file (polygons fanned into triangles; negative
/// indices count from the end).
pub fn read_obj(path: &Path) -> Result<Mesh> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the OBJ file", path.display()))?;
    let mut verts: Vec<DVec3> = Vec::new();
    let mut tris = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let c: Vec<f64> = w
                    .take(3)
                    .map(|x| x.parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| {
                        anyhow!(
                            "{}:{}: a vertex needs three numbers",
                            path.display(),
                            ln + 1
                        )
                    })?;
                if c.len() != 3 || c.iter().any(|x| !x.is_finite()) {
                    bail!(
                        "{}:{}: a vertex needs three finite numbers",
                        path.display(),
                        ln + 1
                    );
                }
                verts.push(DVec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<usize> = w
                    .map(|t| {
                        let i: i64 = t.split('/').next().unwrap_or("").parse().map_err(|_| {
                            anyhow!("{}:{}: bad face index '{t}'", path.display(), ln + 1)
                        })?;
                        let k = if i < 0 { verts.len() as i64 + i } else { i - 1 };
                        if k < 0 || k as usize >= verts.len() {
                            bail!(
                                "{}:{}: face index {i} refers to no vertex",
                                path.display(),
                                ln + 1
                            );
                        }
                        Ok(k as usize)
                    })
                    .collect::<Result<_>>()?;
                for k in 1..idx.len().saturating_sub(1) {
                    tris.push([verts[idx[0]], verts[idx[k]], verts[idx[k + 1]]]);
                }
            }
            _ => {}
        }
    }
    Ok(Mesh::new(tris))
}

/// Lighting of the Figure 7 scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lighting {
    /// Light from beside the eye.
    Front,
    /// Light from behind the object at 150° to the view, so the highlight forms at grazing
    /// incidence near the silhouette (Blinn's "edge lit").
    Edge,
}

/// Blinn's Figure 7 scene: one unit sphere (the test object) with `model`, black background,
/// a small ambient term, one directional light of irradiance π (a white Lambertian surface
/// facing it has radiance pd).
pub fn fig7_scene(model: Model, lighting: Lighting, res: u32) -> Scene {
    let direction = match lighting {
        Lighting::Front => DVec3::new(-0.35, 0.45, 1.0).normalize(),
        Lighting::Edge => {
            DVec3::new(150f64.to_radians().sin(), 0.12, 150f64.to_radians().cos()).normalize()
        }
    };
    Scene {
        camera: Camera {
            eye: DVec3::new(0.0, 0.0, 4.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            fov_deg: 36.0,
            width: res,
            height: res,
        },
        objects: vec![Object::new(
            Shape::Sphere {
                center: DVec3::ZERO,
                radius: 1.0,
            },
            0,
        )],
        materials: vec![Material {
            name: "test object".into(),
            model,
            color: DVec3::ONE,
            specular: DVec3::ONE,
            checker: None,
            ks: 0.0,
            kt: 0.0,
            ior: 1.5,
            roughness: None,
            measured: None,
        }],
        lights: vec![Light::Directional {
            direction,
            irradiance: DVec3::splat(std::f64::consts::PI),
        }],
        ambient: DVec3::splat(0.03),
        background: DVec3::ZERO,
        max_depth: 1,
        min_weight: 1e-3,
        antialias: AntiAlias::Adaptive {
            threshold: 0.02,
            max_level: 3,
            block: 1,
            jitter: false,
        },
    }
}

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
use crate::model::{Distribution, Model, ModelKind, exact};
use anyhow::{Context, Result, anyhow, bail};
use glam::DVec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Largest |coordinate| of a position (eye, target, centre, point, light position).
pub const MAX_COORD: f64 = 1e6;
/// Largest sphere radius and plane half-size.
pub const MAX_SIZE: f64 = 1e6;
/// Largest ambient or background radiance, and largest light colour component.
pub const MAX_RADIANCE: f64 = 1e6;
/// Largest light intensity, and largest product of a light's colour and intensity.
pub const MAX_INTENSITY: f64 = 1e12;
/// Most triangles of an OBJ mesh (with its BVH, about 200 bytes each).
pub const MAX_TRIANGLES: usize = 4_000_000;
/// Largest roughness-texture frequency and checker square size.
pub const MAX_FREQUENCY: f64 = 1e6;
/// Largest directional albedo (at any θi, by the quadrature `fit` uses to mark fits not
/// usable) of a material given by `model` and `params`. Blinn's lobes may exceed 1 at grazing
/// incidence, so 1 is not the limit; a million is no material (ps = 1e300 used to overflow
/// the image, and the error named the output file).
pub const MAX_ALBEDO: f64 = 1e6;

#[derive(Deserialize)]
#[serde(untagged)]
enum ColorSpec {
    Grey(f64),
    Rgb([f64; 3]),
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
    params: Option<toml::Spanned<BTreeMap<String, toml::Spanned<f64>>>>,
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
    test_object: Option<String>,
    #[serde(default)]
    lights: Vec<LightSpec>,
    #[serde(default, deserialize_with = "in_file_order")]
    materials: Vec<(String, MaterialSpec)>,
    #[serde(default)]
    objects: Vec<ObjectSpec>,
}

/// The `[materials.*]` tables in the order the file gives them (the parser's table is sorted
/// by name; each key's position in the text restores the file's order).
fn in_file_order<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Vec<(String, MaterialSpec)>, D::Error> {
    struct Entries;
    impl<'de> serde::de::Visitor<'de> for Entries {
        type Value = Vec<(toml::Spanned<String>, MaterialSpec)>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a table of materials, [materials.NAME]")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(
            self,
            mut m: A,
        ) -> Result<Self::Value, A::Error> {
            let mut v = Vec::new();
            while let Some(e) = m.next_entry()? {
                v.push(e);
            }
            Ok(v)
        }
    }
    let mut v = d.deserialize_map(Entries)?;
    v.sort_by_key(|(k, _)| k.span().start);
    Ok(v.into_iter().map(|(k, m)| (k.into_inner(), m)).collect())
}

/// An error at a line of the scene file (1-based): [`load_scene`] shows it as
/// `FILE:LINE: message`, [`parse_scene`] as `line LINE: message`.
#[derive(Debug)]
struct AtLine {
    line: usize,
    msg: String,
}

impl std::fmt::Display for AtLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.msg)
    }
}

impl std::error::Error for AtLine {}

/// The 1-based line of byte `at` of `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.get(..at).unwrap_or(text).matches('\n').count() + 1
}

/// One step of a key's path in the scene file: a key of a table, or an element of an array.
#[derive(Clone, Copy)]
enum Seg<'a> {
    K(&'a str),
    I(usize),
}
use Seg::{I, K};

/// The lines of every key of a scene file (toml's spans, [`toml::de::DeTable`]), so that
/// every error names its FILE:LINE as well as its key.
struct Lines<'a> {
    text: &'a str,
    root: Option<toml::Spanned<toml::de::DeTable<'a>>>,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            text,
            root: toml::de::DeTable::parse(text).ok(),
        }
    }

    /// The 1-based line of the key at `path` (an array element: its `[[…]]` header), or of
    /// the deepest table on the path that exists (a missing key: the table that lacks it).
    fn line(&self, path: &[Seg]) -> usize {
        use toml::de::DeValue;
        let Some(root) = &self.root else { return 1 };
        let mut at = 0;
        let mut table = Some(root.get_ref());
        let mut array = None;
        for seg in path {
            let next = match seg {
                K(k) => table.and_then(|t| {
                    t.iter()
                        .find(|(key, _)| key.get_ref().as_ref() == *k)
                        .map(|(key, v)| (key.span().start, v))
                }),
                I(i) => {
                    array.and_then(|a: &toml::de::DeArray| a.get(*i).map(|v| (v.span().start, v)))
                }
            };
            let Some((start, v)) = next else { break };
            at = start;
            (table, array) = match v.get_ref() {
                DeValue::Table(t) => (Some(t), None),
                DeValue::Array(a) => (None, Some(a)),
                _ => (None, None),
            };
        }
        line_of(self.text, at)
    }

    /// An error at the line of `path`: [`AtLine`] (kept as it is when it already has one).
    fn at(&self, path: &[Seg]) -> impl FnOnce(anyhow::Error) -> anyhow::Error + use<> {
        let line = self.line(path);
        move |e| {
            if e.downcast_ref::<AtLine>().is_some() {
                e
            } else {
                AtLine {
                    line,
                    msg: format!("{e:#}"),
                }
                .into()
            }
        }
    }
}

/// `v` within [lo, hi] (and finite), or an error naming `key`.
fn closed(key: &str, v: f64, lo: f64, hi: f64) -> Result<f64> {
    if v >= lo && v <= hi {
        Ok(v)
    } else {
        bail!(
            "{key} = {} is out of range\n  fix: give a finite number from {} to {}",
            exact(v),
            exact(lo),
            exact(hi)
        )
    }
}

/// `v` within (0, hi] (and finite), or an error naming `key`.
fn positive(key: &str, v: f64, hi: f64) -> Result<f64> {
    if v > 0.0 && v <= hi {
        Ok(v)
    } else {
        bail!(
            "{key} = {} is out of range\n  fix: give a finite number greater than 0 and at most {}",
            exact(v),
            exact(hi)
        )
    }
}

/// An integer setting within [lo, hi].
fn count(key: &str, v: u32, lo: u32, hi: u32) -> Result<u32> {
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        bail!("{key} = {v} is out of range\n  fix: give a whole number from {lo} to {hi}")
    }
}

/// A colour (a number is grey) with every component in [0, hi].
fn color(key: &str, c: &ColorSpec, hi: f64) -> Result<DVec3> {
    let v = match c {
        ColorSpec::Grey(g) => [*g; 3],
        ColorSpec::Rgb(c) => *c,
    };
    if v.iter().all(|x| *x >= 0.0 && *x <= hi) {
        Ok(DVec3::from_array(v))
    } else {
        bail!(
            "{key} = {v:?} is out of range\n  fix: give a number or [r, g, b], each finite from 0 to {}",
            exact(hi)
        )
    }
}

/// A position: three finite coordinates of magnitude at most [`MAX_COORD`].
fn position(key: &str, v: [f64; 3]) -> Result<DVec3> {
    if v.iter().all(|x| x.abs() <= MAX_COORD) {
        Ok(DVec3::from_array(v))
    } else {
        bail!(
            "{key} = {v:?} is out of range\n  fix: give three finite coordinates of magnitude at most {}",
            exact(MAX_COORD)
        )
    }
}

/// A direction: finite, not zero; returned normalised.
fn direction(key: &str, v: [f64; 3]) -> Result<DVec3> {
    let d = DVec3::from_array(v);
    if v.iter().all(|x| x.abs() <= MAX_COORD) && d.length() > 1e-12 {
        Ok(d.normalize())
    } else {
        bail!(
            "{key} = {v:?} is not a direction\n  fix: give three finite numbers, not all zero, of magnitude at most {}",
            exact(MAX_COORD)
        )
    }
}

/// A required key of a kind of light or object.
fn need<T: Copy>(v: Option<T>, owner: &str, key: &str) -> Result<T> {
    v.ok_or_else(|| anyhow!("{owner} needs `{key}`\n  fix: add {key} = … to it"))
}

/// Refuse keys given that do not apply to this kind of light, object or mode.
fn not_for(owner: &str, keys: &[(&str, bool)], hint: &str) -> Result<()> {
    if let Some((k, _)) = keys.iter().find(|(_, given)| *given) {
        bail!("{owner}: `{k}` does not apply here\n  fix: remove it ({hint})");
    }
    Ok(())
}

/// Read a scene from TOML text; `dir` resolves relative paths (fit JSON, OBJ). Every value is
/// checked against its range (README, "Scene files"); unknown, missing and duplicate keys are
/// errors naming the key. `materials[0]` of the result is the test object of `brdfit choose`:
/// the material named by the top-level `test_object`, else the first in the file; the others
/// follow in file order.
pub fn parse_scene(text: &str, dir: &Path) -> Result<Scene> {
    parse_scene_noted(text, dir, &mut Vec::new())
}

/// [`parse_scene`], adding to `notes` what was chosen for the user (which fit of a fit file a
/// material uses), one sentence each, for the caller to show, and the warnings (a `params`
/// material with a directional albedo above 1), each `warning: line LINE: …`.
pub fn parse_scene_noted(text: &str, dir: &Path, notes: &mut Vec<String>) -> Result<Scene> {
    let f: SceneFile = toml::from_str(text).map_err(|e| {
        let fix = match (e.message(), e.span()) {
            ("duplicate key", Some(span)) => format!(
                "`{}` is given twice in one table: keep one",
                text.get(span).unwrap_or("?")
            ),
            _ => "correct the key or value named above (the scene format is in README.md, \"Scene files\")".into(),
        };
        match e.span() {
            // The line and its text (which names the key), then toml's message.
            Some(span) => {
                let line = line_of(text, span.start);
                let shown = text.lines().nth(line - 1).unwrap_or("").trim();
                AtLine {
                    line,
                    msg: format!("`{shown}`: {}\n  fix: {fix}", e.message().trim_end()),
                }
                .into()
            }
            None => anyhow!("{}\n  fix: {fix}", e.to_string().trim_end()),
        }
    })?;
    let lines = Lines::new(text);
    let cam = &f.camera;
    let at_cam = |k: &str| lines.at(&[K("camera"), K(k)]);
    count("`camera.width`", cam.width, 1, 16384).map_err(at_cam("width"))?;
    count("`camera.height`", cam.height, 1, 16384).map_err(at_cam("height"))?;
    if !(cam.fov > 0.0 && cam.fov < 180.0) {
        return Err(at_cam("fov")(anyhow!(
            "`camera.fov` = {} is out of range\n  fix: give a horizontal field of view in degrees, greater than 0 and less than 180",
            cam.fov
        )));
    }
    let eye = position("`camera.eye`", cam.eye).map_err(at_cam("eye"))?;
    let target = position("`camera.target`", cam.target).map_err(at_cam("target"))?;
    let up = direction("`camera.up`", cam.up.unwrap_or([0.0, 1.0, 0.0])).map_err(at_cam("up"))?;
    if (target - eye).length() < 1e-9 * eye.abs().max_element().max(1.0)
        || (target - eye).normalize().cross(up).length() < 1e-9
    {
        return Err(at_cam("target")(anyhow!(
            "`camera.target`: the camera looks along its up vector or at its own position\n  fix: give a target away from the eye and an up vector not parallel to the view"
        )));
    }
    let camera = Camera {
        eye,
        target,
        up,
        fov_deg: cam.fov,
        width: cam.width,
        height: cam.height,
    };
    // The test object first, then the others in file order.
    let mut specs: Vec<&(String, MaterialSpec)> = f.materials.iter().collect();
    if let Some(t) = &f.test_object {
        let k = specs.iter().position(|(n, _)| n == t).ok_or_else(|| {
            lines.at(&[K("test_object")])(anyhow!(
                "`test_object` = \"{t}\" names no material\n  fix: use one of: {}",
                names_of(&f.materials)
            ))
        })?;
        let first = specs.remove(k);
        specs.insert(0, first);
    }
    let mut names = Vec::new();
    let mut materials = Vec::new();
    for (name, m) in specs {
        materials.push(material(name, m, dir, &lines, notes)?);
        names.push(name.clone());
    }
    let mut objects = Vec::new();
    for (k, o) in f.objects.iter().enumerate() {
        let owner = format!("object {} ({})", k + 1, o.kind);
        let at = |key: &str| lines.at(&[K("objects"), I(k), K(key)]);
        let mi = names.iter().position(|n| *n == o.material).ok_or_else(|| {
            at("material")(anyhow!("{owner} uses material '{}', which is not defined\n  fix: add [materials.{}] or use one of: {}", o.material, o.material, names.join(", ")))
        })?;
        let shape = match o.kind.as_str() {
            "sphere" => {
                not_for(
                    &owner,
                    &[
                        ("point", o.point.is_some()),
                        ("normal", o.normal.is_some()),
                        ("size", o.size.is_some()),
                        ("path", o.path.is_some()),
                    ],
                    "a sphere takes center and radius",
                )
                .map_err(at(""))?;
                Shape::Sphere {
                    center: need(o.center, &owner, "center")
                        .and_then(|c| position(&format!("{owner}: `center`"), c))
                        .map_err(at("center"))?,
                    radius: positive(
                        &format!("{owner}: `radius`"),
                        o.radius.unwrap_or(1.0),
                        MAX_SIZE,
                    )
                    .map_err(at("radius"))?,
                }
            }
            "plane" => {
                not_for(
                    &owner,
                    &[
                        ("center", o.center.is_some()),
                        ("radius", o.radius.is_some()),
                        ("path", o.path.is_some()),
                    ],
                    "a plane takes point, normal and an optional half-size size",
                )
                .map_err(at(""))?;
                let normal = need(o.normal, &owner, "normal")
                    .and_then(|n| direction(&format!("{owner}: `normal`"), n))
                    .map_err(at("normal"))?;
                let (u, v) = plane_axes(normal);
                Shape::Plane {
                    point: need(o.point, &owner, "point")
                        .and_then(|p| position(&format!("{owner}: `point`"), p))
                        .map_err(at("point"))?,
                    normal,
                    half: o
                        .size
                        .map(|s| positive(&format!("{owner}: `size`"), s, MAX_SIZE))
                        .transpose()
                        .map_err(at("size"))?,
                    u,
                    v,
                }
            }
            "mesh" => {
                not_for(
                    &owner,
                    &[
                        ("center", o.center.is_some()),
                        ("radius", o.radius.is_some()),
                        ("point", o.point.is_some()),
                        ("normal", o.normal.is_some()),
                        ("size", o.size.is_some()),
                    ],
                    "a mesh takes path",
                )
                .map_err(at(""))?;
                let p = dir.join(need(o.path.as_deref(), &owner, "path").map_err(at("path"))?);
                let mesh =
                    read_obj(&p).map_err(|e| at("path")(e.context(format!("{owner}: `path`"))))?;
                if mesh.tris.is_empty() {
                    return Err(at("path")(anyhow!(
                        "{owner}: {} holds no triangle\n  fix: give an OBJ file with `v` and `f` lines",
                        p.display()
                    )));
                }
                Shape::Mesh(mesh)
            }
            other => {
                return Err(at("kind")(anyhow!(
                    "{owner}: unknown kind '{other}'\n  fix: use sphere, plane or mesh"
                )));
            }
        };
        objects.push(Object::new(shape, mi));
    }
    let mut lights = Vec::new();
    for (k, l) in f.lights.iter().enumerate() {
        let owner = format!("light {} ({})", k + 1, l.kind);
        let at = |key: &str| lines.at(&[K("lights"), I(k), K(key)]);
        let color = match &l.color {
            Some(c) => color(&format!("{owner}: `color`"), c, MAX_RADIANCE).map_err(at("color"))?,
            None => DVec3::ONE,
        };
        let intensity = closed(
            &format!("{owner}: `intensity`"),
            l.intensity,
            0.0,
            MAX_INTENSITY,
        )
        .map_err(at("intensity"))?;
        let power = color * intensity;
        if power.max_element() > MAX_INTENSITY {
            return Err(at("intensity")(anyhow!(
                "{owner}: color × intensity = {:?} is above {}\n  fix: lower the intensity or the colour",
                power.to_array(),
                exact(MAX_INTENSITY)
            )));
        }
        lights.push(match l.kind.as_str() {
            "point" => {
                not_for(
                    &owner,
                    &[("direction", l.direction.is_some())],
                    "a point light takes position",
                )
                .map_err(at("direction"))?;
                Light::Point {
                    position: need(l.position, &owner, "position")
                        .and_then(|p| position(&format!("{owner}: `position`"), p))
                        .map_err(at("position"))?,
                    intensity: power,
                }
            }
            "directional" => {
                not_for(
                    &owner,
                    &[("position", l.position.is_some())],
                    "a directional light takes direction, toward the light",
                )
                .map_err(at("position"))?;
                Light::Directional {
                    direction: need(l.direction, &owner, "direction")
                        .and_then(|d| direction(&format!("{owner}: `direction`"), d))
                        .map_err(at("direction"))?,
                    irradiance: power,
                }
            }
            other => {
                return Err(at("kind")(anyhow!(
                    "{owner}: unknown kind '{other}'\n  fix: use point or directional"
                )));
            }
        });
    }
    let at_aa = |k: &str| lines.at(&[K("antialias"), K(k)]);
    let antialias = match &f.antialias {
        None => AntiAlias::Adaptive {
            threshold: 0.02,
            max_level: 3,
            block: 1,
            jitter: false,
        },
        Some(a) => {
            let adaptive_keys = [
                ("threshold", a.threshold.is_some()),
                ("max_level", a.max_level.is_some()),
                ("block", a.block.is_some()),
                ("jitter", a.jitter.is_some()),
            ];
            let owner = format!("antialias mode \"{}\"", a.mode);
            match a.mode.as_str() {
                "none" => {
                    not_for(&owner, &adaptive_keys, "mode none takes no other key")
                        .map_err(at_aa("mode"))?;
                    not_for(
                        &owner,
                        &[("samples", a.samples.is_some())],
                        "mode none takes no other key",
                    )
                    .map_err(at_aa("samples"))?;
                    AntiAlias::None
                }
                "uniform" | "stratified" => {
                    not_for(&owner, &adaptive_keys, "this mode takes samples")
                        .map_err(at_aa("mode"))?;
                    let n = count("`antialias.samples`", a.samples.unwrap_or(4), 1, 64)
                        .map_err(at_aa("samples"))?;
                    if a.mode == "uniform" {
                        AntiAlias::Uniform(n)
                    } else {
                        AntiAlias::Stratified(n)
                    }
                }
                "adaptive" => {
                    not_for(
                        &owner,
                        &[("samples", a.samples.is_some())],
                        "adaptive takes threshold, max_level, block and jitter",
                    )
                    .map_err(at_aa("samples"))?;
                    AntiAlias::Adaptive {
                        threshold: closed(
                            "`antialias.threshold`",
                            a.threshold.unwrap_or(0.02),
                            0.0,
                            100.0,
                        )
                        .map_err(at_aa("threshold"))?,
                        max_level: count("`antialias.max_level`", a.max_level.unwrap_or(3), 0, 8)
                            .map_err(at_aa("max_level"))?,
                        block: match a.block.unwrap_or(1) {
                            b @ (1 | 2 | 4) => b,
                            b => {
                                return Err(at_aa("block")(anyhow!(
                                    "`antialias.block` = {b} is not supported\n  fix: use 1, 2 or 4"
                                )));
                            }
                        },
                        jitter: a.jitter.unwrap_or(false),
                    }
                }
                other => {
                    return Err(at_aa("mode")(anyhow!(
                        "`antialias.mode` '{other}' is unknown\n  fix: use adaptive, uniform, stratified or none"
                    )));
                }
            }
        }
    };
    let scene = Scene {
        camera,
        objects,
        materials,
        lights,
        ambient: match &f.ambient {
            Some(c) => color("`ambient`", c, MAX_RADIANCE).map_err(lines.at(&[K("ambient")]))?,
            None => DVec3::ZERO,
        },
        background: match &f.background {
            Some(c) => {
                color("`background`", c, MAX_RADIANCE).map_err(lines.at(&[K("background")]))?
            }
            None => DVec3::ZERO,
        },
        max_depth: count("`max_depth`", f.max_depth.unwrap_or(4), 1, 64)
            .map_err(lines.at(&[K("max_depth")]))?,
        min_weight: closed("`min_weight`", f.min_weight.unwrap_or(1e-3), 0.0, 1.0)
            .map_err(lines.at(&[K("min_weight")]))?,
        antialias,
    };
    scene.check_inputs().map_err(|e| anyhow!("{e}"))?;
    Ok(scene)
}

fn names_of(m: &[(String, MaterialSpec)]) -> String {
    m.iter()
        .map(|(n, _)| n.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Material `name`'s model from its `params` (spans into `text`), each value within the
/// bounds a fit file's are read with ([`crate::model::ParamSpec::in_fit_box`]) and the whole
/// within [`MAX_ALBEDO`]; errors name the line, the key and the fix ([`AtLine`]).
fn model_params(
    name: &str,
    kind: ModelKind,
    dist: Distribution,
    params: &toml::Spanned<BTreeMap<String, toml::Spanned<f64>>>,
    text: &str,
    notes: &mut Vec<String>,
) -> Result<Model> {
    let at = |span: std::ops::Range<usize>, what: String, fix: String| AtLine {
        line: line_of(text, span.start),
        msg: format!("material {name}: {what}\n  fix: {fix}"),
    };
    let label = kind.label(dist);
    let names = kind.param_names(dist).join(", ");
    let specs = kind.params(dist);
    for (k, v) in params.get_ref() {
        let Some(spec) = specs.iter().find(|s| s.name == k) else {
            return Err(at(
                v.span(),
                format!("`params.{k}`: {label} has no parameter {k}"),
                format!("remove {k}; {label} takes {names}"),
            )
            .into());
        };
        let x = *v.get_ref();
        if !spec.in_fit_box(x) {
            return Err(at(
                v.span(),
                format!(
                    "`params.{k}` = {} is outside the range a fit can return: {}",
                    exact(x),
                    spec.fit_box_text()
                ),
                format!("write a value with {}", spec.fit_box_text()),
            )
            .into());
        }
    }
    let set: Vec<(String, f64)> = params
        .get_ref()
        .iter()
        .map(|(k, v)| (k.clone(), *v.get_ref()))
        .collect();
    let model = Model::from_named(kind, dist, &set).map_err(|e| {
        let fix = match &e {
            crate::model::ModelError::Missing { name: p, .. } => {
                format!("add {p} to params ({label} takes {names})")
            }
            crate::model::ModelError::Order { fix, .. } => fix.clone(),
            _ => format!("give {names} within their bounds"),
        };
        at(params.span(), format!("`params`: {e}"), fix)
    })?;
    let (t, a) = crate::model::albedo::max_albedo(&model);
    if !(a <= MAX_ALBEDO) {
        return Err(at(
            params.span(),
            format!(
                "`params` give a directional albedo of {} at θi = {t}° (the material would reflect that many times the light it receives, and the image overflow)",
                crate::model::readable(a)
            ),
            format!(
                "lower ps or pd: the albedo may be at most {} (a physical material's is at most 1)",
                exact(MAX_ALBEDO)
            ),
        )
        .into());
    }
    // fit's physical rule (crate::fit::physical, rule 2): above 1 by more than the quadrature's
    // margin reflects more light than it receives; rendered as given, with a warning.
    if a > 1.0 + crate::fit::physical::ALBEDO_MARGIN {
        notes.push(format!(
            "warning: {}",
            at(
                params.span(),
                format!(
                    "`params` give a directional albedo of {} at θi = {t}°: the material reflects more light than it receives (rendered as given)",
                    crate::model::readable(a)
                ),
                "lower ps or pd until the albedo is at most 1, as a physical material's is".into(),
            )
        ));
    }
    Ok(model)
}

/// Material `name`'s `distribution` key, or an error naming the ones there are.
fn distribution(name: &str, d: &str) -> Result<Distribution> {
    Distribution::parse(d).ok_or_else(|| {
        anyhow!("material {name}: unknown distribution '{d}'\n  fix: use d1, d2, d3 or abc")
    })
}

fn material(
    name: &str,
    m: &MaterialSpec,
    dir: &Path,
    lines: &Lines,
    notes: &mut Vec<String>,
) -> Result<Material> {
    let key = |k: &str| format!("`materials.{name}.{k}`");
    // Each error at the line of its key (a key not given: the material's own line).
    let at = |k: &str| lines.at(&[K("materials"), K(name), K(k)]);
    // A colour fit: the lobe with ps = pd = 1, its channels' pd and ps as colours.
    let mut fit_colour = (DVec3::ONE, DVec3::ONE);
    let model = match (&m.fit, &m.model) {
        (Some(_), Some(_)) => {
            return Err(at("fit")(anyhow!(
                "material {name} has both `model` and `fit`\n  fix: keep one: the fit file gives the model and its parameters"
            )));
        }
        (Some(fit), None) => {
            not_for(
                &format!("material {name}"),
                &[("params", m.params.is_some())],
                "the fit file gives the parameters (`distribution` and `fit_model` pick one fit of several)",
            )
            .map_err(at("params"))?;
            let p = dir.join(fit);
            let (model, diffuse, specular) = fit_material(name, m, &p, notes).map_err(at("fit"))?;
            fit_colour = (diffuse, specular);
            model
        }
        (None, Some(kind)) => {
            not_for(
                &format!("material {name}"),
                &[
                    ("fit_model", m.fit_model.is_some()),
                    ("fit_channel", m.fit_channel.is_some()),
                    ("fit_allow_unusable", m.fit_allow_unusable.is_some()),
                ],
                "it picks from a fit file, and this material gives `model`",
            )
            .map_err(at("model"))?;
            let kind = ModelKind::parse(kind).ok_or_else(|| {
                at("model")(anyhow!(
                    "material {name}: unknown model '{kind}'\n  fix: use one of {}",
                    ModelKind::names()
                ))
            })?;
            let dist = match &m.distribution {
                Some(d) if kind != ModelKind::TorranceSparrow => {
                    return Err(at("distribution")(anyhow!(
                        "material {name}: `distribution` = \"{d}\" applies to torrance-sparrow only\n  fix: remove it"
                    )));
                }
                Some(d) => distribution(name, d).map_err(at("distribution"))?,
                None => Distribution::D3,
            };
            let Some(params) = &m.params else {
                return Err(at("params")(anyhow!(
                    "material {name} needs `params`\n  fix: add params = {{ … }} with {}",
                    kind.param_names(dist).join(", ")
                )));
            };
            model_params(name, kind, dist, params, lines.text, notes)?
        }
        (None, None) => {
            return Err(at("model")(anyhow!(
                "material {name} has neither `model` nor `fit`\n  fix: add model = \"lambert\" and params = {{ pd = 0.5 }}, or fit = \"FILE.json\""
            )));
        }
    };
    let roughness = match &m.roughness {
        None => None,
        Some(r) => {
            if (model.kind, model.dist) != (ModelKind::TorranceSparrow, Distribution::D3) {
                return Err(at("roughness")(anyhow!(
                    "material {name}: `roughness` modulates Blinn's D3 and applies to torrance-sparrow d3 only, this is {} {}\n  fix: remove it or use model = \"torrance-sparrow\"",
                    model.kind,
                    model.dist.name()
                )));
            }
            Some(RoughnessTexture {
                cmin: closed(&key("roughness.cmin"), r.cmin, 1e-3, 1.0).map_err(at("roughness"))?,
                frequency: closed(&key("roughness.frequency"), r.frequency, 0.0, MAX_FREQUENCY)
                    .map_err(at("roughness"))?,
            })
        }
    };
    Ok(Material {
        name: name.to_string(),
        model,
        color: match &m.color {
            Some(c) => color(&key("color"), c, 1.0).map_err(at("color"))?,
            None => DVec3::ONE,
        } * fit_colour.0,
        specular: fit_colour.1,
        checker: match &m.checker {
            None => None,
            Some(c) => Some(Checker {
                size: positive(&key("checker.size"), c.size, MAX_FREQUENCY)
                    .map_err(at("checker"))?,
                color0: color(&key("checker.color0"), &c.color0, 1.0).map_err(at("checker"))?,
                color1: color(&key("checker.color1"), &c.color1, 1.0).map_err(at("checker"))?,
            }),
        },
        ks: closed(&key("ks"), m.ks.unwrap_or(0.0), 0.0, 1.0).map_err(at("ks"))?,
        kt: closed(&key("kt"), m.kt.unwrap_or(0.0), 0.0, 1.0).map_err(at("kt"))?,
        ior: closed(&key("ior"), m.ior.unwrap_or(1.5), 0.01, 100.0).map_err(at("ior"))?,
        roughness,
        measured: None,
    })
}

/// A material's fit: the file read strictly, the model and channel picked by `fit_model` and
/// `fit_channel` (see [`crate::fit::pick`]); several channels become colour (the shared lobe
/// with ps = pd = 1, and their pd and ps as diffuse and specular colours). What was picked
/// for the user and any colour compromise are said on stderr.
fn fit_material(
    name: &str,
    m: &MaterialSpec,
    p: &Path,
    notes: &mut Vec<String>,
) -> Result<(Model, DVec3, DVec3)> {
    use crate::fit::{Want, pick, read_fit_file};
    let text = crate::input::read_to_string_limited(p, crate::input::Input::FitJson)
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
    let dist = match &m.distribution {
        None => None,
        Some(d) => Some(distribution(name, d)?),
    };
    let want = Want {
        model,
        dist,
        channel: m.fit_channel.clone(),
        allow_unusable: m.fit_allow_unusable.unwrap_or(false),
    };
    let picked = pick(&fits, &want).map_err(|e| {
        at(&e
            .to_string()
            .replace("add --allow-unusable", "set fit_allow_unusable = true")
            .replace("with --model", "with fit_model")
            .replace("(and --distribution)", "(and distribution)")
            .replace("with --channel", "with fit_channel"))
    })?;
    let colour = picked
        .colour()
        .map_err(|e| at(&e.to_string().replace("with --channel", "with fit_channel")))?;
    for n in picked.notes.iter().chain(&colour.notes) {
        notes.push(format!(
            "material {name}: {}: {}",
            p.display(),
            n.replace("--model", "fit_model")
                .replace("--channel", "fit_channel")
        ));
    }
    if colour.is_grey() {
        return Ok((colour.model, DVec3::ONE, DVec3::ONE));
    }
    let lobe = colour.channel_model(0);
    let mut unit = lobe;
    // A second lobe (ggx-smith-2's ps2) keeps its ratio to the first, ps2 : ps1 over r, g, b.
    let (s1, s2) = (
        colour.ps.iter().sum::<f64>(),
        colour.ps2.iter().sum::<f64>(),
    );
    let ratio = if s1 > 0.0 { s2 / s1 } else { 1.0 };
    if (0..3).any(|c| (colour.ps2[c] - ratio * colour.ps[c]).abs() > 1e-9 * s2.max(1e-300)) {
        eprintln!(
            "note: material {name}: {}: the two lobes' colours differ; rendered with ps2 = {} ps1 in every channel (their ratio over r + g + b)",
            p.display(),
            crate::model::readable(ratio)
        );
    }
    let mut lobe_no = 0;
    for (i, spec) in lobe.kind.params(lobe.dist).iter().enumerate() {
        match spec.role {
            crate::model::Role::Diffuse => unit.p[i] = 1.0,
            crate::model::Role::Specular => {
                unit.p[i] = if lobe_no == 0 { 1.0 } else { ratio };
                lobe_no += 1;
            }
            _ => {}
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
    load_scene_noted(path).map(|(s, _)| s)
}

/// [`load_scene`] with the notes of [`parse_scene_noted`] (what was chosen for the user);
/// its warnings come as `warning: FILE:LINE: …`, ready to show.
pub fn load_scene_noted(path: &Path) -> Result<(Scene, Vec<String>)> {
    let text = crate::input::read_to_string_limited(path, crate::input::Input::Scene)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut notes = Vec::new();
    let s = parse_scene_noted(&text, dir, &mut notes).map_err(|e| {
        match e.downcast_ref::<AtLine>() {
            Some(at) => anyhow!("{}:{}: {}", path.display(), at.line, at.msg),
            None => e.context(path.display().to_string()),
        }
    })?;
    let notes = notes
        .into_iter()
        .map(|n| match n.strip_prefix("warning: line ") {
            Some(rest) => format!("warning: {}:{rest}", path.display()),
            None => n,
        })
        .collect();
    Ok((s, notes))
}

/// Read the `v` and `f` lines of an OBJ file (polygons fanned into triangles; negative
/// indices count from the end), within the mesh size limit ([`crate::input`]) and at most
/// [`MAX_TRIANGLES`] triangles.
pub fn read_obj(path: &Path) -> Result<Mesh> {
    let text = crate::input::read_to_string_limited(path, crate::input::Input::Mesh)?;
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
                if tris.len() + idx.len().saturating_sub(2) > MAX_TRIANGLES {
                    bail!(
                        "{}:{}: the mesh has more than {MAX_TRIANGLES} triangles (about 200 bytes of memory each)\n  fix: simplify the mesh",
                        path.display(),
                        ln + 1
                    );
                }
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

//! Reading a scene file: the TOML parsed into the file's own types, then each part (camera,
//! materials, objects, lights, anti-aliasing) checked against its range and built, every
//! error at the line of its key.

use super::lines::{AtLine, I, K, Lines, line_of};
use super::material::material;
use super::spec::{AaSpec, CameraSpec, LightSpec, MaterialSpec, ObjectSpec, SceneFile};
use super::values::{closed, color, count, direction, need, not_for, position, positive};
use super::{MAX_INTENSITY, MAX_RADIANCE, MAX_SIZE, read_obj};
use crate::model::exact;
use crate::render::{AntiAlias, Camera, Light, Material, Object, Scene, Shape};
use anyhow::{Result, anyhow};
use glam::DVec3;
use std::path::Path;

/// Most objects a scene file may hold: 1,000 (each ray tests each; 10,000 spheres took over
/// 120 s at 256 × 256). A mesh counts as one.
pub const MAX_OBJECTS: usize = 1000;

/// Most lights a scene file may hold: 64 (a shadow ray toward each at every hit).
pub const MAX_LIGHTS: usize = 64;

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
    let f: SceneFile = toml::from_str(text).map_err(|e| file_error(text, e))?;
    let lines = Lines::new(text);
    let camera = camera(&f.camera, &lines)?;
    let (names, materials) = materials(&f, dir, &lines, notes)?;
    // Every ray tests every object (only a mesh's triangles are in a BVH), and every hit
    // sends a shadow ray toward each light: both counts are bounded.
    for (what, n, most, fix) in [
        (
            "objects",
            f.objects.len(),
            MAX_OBJECTS,
            "merge small shapes into one OBJ mesh (its triangles are searched through a BVH)",
        ),
        (
            "lights",
            f.lights.len(),
            MAX_LIGHTS,
            "merge nearby lights into one",
        ),
    ] {
        if n > most {
            return Err(anyhow!(
                "{n} {what}, above the limit of {most} (each ray tests every object and sends a shadow ray toward every light, so the time grows with both)\n  fix: {fix}"
            ))
            .map_err(lines.at(&[K(what), I(most)]));
        }
    }
    let mut objects = Vec::new();
    for (k, o) in f.objects.iter().enumerate() {
        objects.push(object(k, o, &names, dir, &lines)?);
    }
    let mut lights = Vec::new();
    for (k, l) in f.lights.iter().enumerate() {
        lights.push(light(k, l, &lines)?);
    }
    let antialias = antialias(&f.antialias, &lines)?;
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

/// The error of a file the TOML parser refuses: the line and its text (which names the key),
/// then the parser's message and the fix.
fn file_error(text: &str, e: toml::de::Error) -> anyhow::Error {
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
}

/// The `[camera]` table, checked.
fn camera(cam: &CameraSpec, lines: &Lines) -> Result<Camera> {
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
    Ok(Camera {
        eye,
        target,
        up,
        fov_deg: cam.fov,
        width: cam.width,
        height: cam.height,
    })
}

/// The materials in the order a scene holds them (the test object first, then the others in
/// file order), with their names.
fn materials(
    f: &SceneFile,
    dir: &Path,
    lines: &Lines,
    notes: &mut Vec<String>,
) -> Result<(Vec<String>, Vec<Material>)> {
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
        materials.push(material(name, m, dir, lines, notes)?);
        names.push(name.clone());
    }
    Ok((names, materials))
}

fn names_of(m: &[(String, MaterialSpec)]) -> String {
    m.iter()
        .map(|(n, _)| n.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Object `k` (from 0) of the file, its material looked up in `names`.
fn object(k: usize, o: &ObjectSpec, names: &[String], dir: &Path, lines: &Lines) -> Result<Object> {
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
    Ok(Object::new(shape, mi))
}

/// Light `k` (from 0) of the file.
fn light(k: usize, l: &LightSpec, lines: &Lines) -> Result<Light> {
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
    Ok(match l.kind.as_str() {
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
    })
}

/// The `[antialias]` table, or the default (adaptive, threshold 0.02, 3 levels, blocks of 1).
fn antialias(aa: &Option<AaSpec>, lines: &Lines) -> Result<AntiAlias> {
    let at_aa = |k: &str| lines.at(&[K("antialias"), K(k)]);
    Ok(match aa {
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
                        max_level: count("`antialias.max_level`", a.max_level.unwrap_or(3), 0, 6)
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
    })
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

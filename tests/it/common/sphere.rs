//! The sphere scene of the reference tests (a unit sphere, one directional light of irradiance π
//! at 15° (front lit) or 95° (edge lit) from the view, no ambient term, one ray per pixel),
//! its exact render of a Neural-BRDF network, and LDR-ꟻLIP over the sphere's pixels.

use brdfit::data::nbrdf::Nbrdf;
use brdfit::model::{Geometry, Model, ModelKind};
use brdfit::render::measured::Tabulated;
use brdfit::render::{Image, Scene};
use std::sync::Arc;

/// The sphere scene at `res`², the light `angle` degrees from the view.
pub fn scene(angle: f64, res: u32) -> Scene {
    let (s, c) = angle.to_radians().sin_cos();
    let text = format!(
        r#"
ambient = 0.0
background = 0.0
max_depth = 1
[camera]
eye = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
fov = 32.0
width = {res}
height = {res}
[antialias]
mode = "none"
[[lights]]
kind = "directional"
direction = [{s}, 0.0, {c}]
intensity = {pi}
[materials.test]
model = "lambert"
params = {{ pd = 0.5 }}
[[objects]]
kind = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "test"
"#,
        pi = std::f64::consts::PI
    );
    brdfit::scene::parse_scene(&text, std::path::Path::new(".")).unwrap()
}

/// Render `scene` with its sphere reflecting by `table`.
pub fn render(scene: &Scene, table: Tabulated) -> Image {
    let mut s = scene.clone();
    s.materials[0].measured = Some(Arc::new(table));
    s.render(&|| {})
}

/// Render `scene` with its sphere reflecting by `f` exactly (evaluated at every shading point).
pub fn render_exact(scene: &Scene, f: impl Fn(&Geometry) -> f64 + Send + Sync + 'static) -> Image {
    render(scene, Tabulated::exact(Arc::new(f), lambert()))
}

/// Render `scene` with its sphere reflecting by the model `m`.
pub fn render_model(scene: &Scene, m: Model) -> Image {
    let mut s = scene.clone();
    s.materials[0].model = m;
    s.materials[0].measured = None;
    s.render(&|| {})
}

/// The exact render: the symmetrised network's green channel at every shading point.
pub fn exact(scene: &Scene, net: &Nbrdf) -> Image {
    let net = net.clone();
    render_exact(scene, move |g: &Geometry| net.eval_symmetric(angles(g))[1])
}

/// The angles (θi, 0, θo, Δφ ∈ [0, π]) of a configuration, back from its cosines:
/// L·E = 2 N·L N·E − R·E.
pub fn angles(g: &Geometry) -> [f64; 4] {
    let (ti, to) = (g.nl.clamp(-1.0, 1.0).acos(), g.ne.clamp(-1.0, 1.0).acos());
    let le = 2.0 * g.nl * g.ne - g.re;
    let den = ti.sin() * to.sin();
    let dphi = if den > 1e-12 {
        ((le - g.nl * g.ne) / den).clamp(-1.0, 1.0).acos()
    } else {
        std::f64::consts::PI
    };
    [ti, 0.0, to, dphi]
}

/// A Lambert material (the exact tables' fill; it gives only the ambient term, 0 here).
pub fn lambert() -> Model {
    Model::new(ModelKind::Lambert, Default::default(), &[0.5]).unwrap()
}

/// ꟻLIP 99th percentile over the object's pixels (`mask`).
pub fn flip_p99(reference: &Image, test: &Image, mask: &[bool]) -> f64 {
    let map = brdfit::render::compare::flip(
        &brdfit::render::to_srgb8(reference),
        &brdfit::render::to_srgb8(test),
        reference.width,
        reference.height,
    );
    brdfit::render::compare::summarise(&map, mask, 0.05).p99
}

/// The lit pixels of the sphere.
pub fn mask(scene: &Scene) -> Vec<bool> {
    scene.lit_configurations(0).1
}

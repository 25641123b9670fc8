//! The shared geometry pass of `brdfit choose` ([`brdfit::render::Scene::corners`]): a render
//! reading it must be the render without it, pixel for pixel and ray for ray. The peer is the
//! renderer's own path that intersects and builds the geometry at every sample.

use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::render::{AntiAlias, Image, Scene};
use brdfit::render::{Lighting, fig7_scene};
use brdfit::scene::load_scene;
use std::path::Path;

fn bits(img: &Image) -> Vec<[u32; 3]> {
    img.pixels.iter().map(|p| p.map(f32::to_bits)).collect()
}

/// Render `s` with and without the corners of `from` and require the same bits and counts.
fn same_with_corners(s: &Scene, from: &Scene, what: &str) {
    let plain = s.render(&|| {});
    let corners = from.corners();
    let cached = s.render_with_corners(Some(&corners), &|| {});
    assert_eq!(plain.rays, cached.rays, "{what}: ray counts");
    assert!(bits(&plain) == bits(&cached), "{what}: pixels differ");
}

/// Figure 7's sphere, both lightings, with several reflection models swapped into the scene
/// the corners were made from (what `choose` does for each candidate), blocks of 1 and 4
/// pixels (a block's inner corners are sampled with a smaller footprint).
#[test]
fn figure_7_renders_the_same_with_the_shared_corners() {
    let models = [
        Model::new(ModelKind::Lambert, Distribution::D3, &[0.6]).unwrap(),
        Model::new(ModelKind::Phong, Distribution::D3, &[12.0, 0.4, 0.5]).unwrap(),
        Model::blinn_mgo(),
        Model::new(
            ModelKind::TorranceSparrow,
            Distribution::D1,
            &[1.5, 40.0, 0.8, 0.2],
        )
        .unwrap(),
    ];
    for lighting in [Lighting::Front, Lighting::Edge] {
        for block in [1, 4] {
            let mut base = fig7_scene(Model::blinn_mgo(), lighting, 72);
            base.antialias = AntiAlias::Adaptive {
                threshold: 0.02,
                max_level: 3,
                block,
                jitter: false,
            };
            for m in models {
                let mut s = base.clone();
                s.materials[0].model = m;
                same_with_corners(&s, &base, &format!("{lighting:?} block {block} {m:?}"));
            }
        }
    }
}

/// A scene with planes, a checker, mirror and glass objects and several lights (shadows,
/// secondary rays from cached corners); and corners made for another camera are ignored.
#[test]
fn bundled_scene_renders_the_same_with_the_shared_corners() {
    let mut s = load_scene(Path::new("data/scenes/showcase.toml")).unwrap();
    s.camera.width = 80;
    s.camera.height = 56;
    for (block, jitter) in [(1, false), (2, false), (1, true)] {
        s.antialias = AntiAlias::Adaptive {
            threshold: 0.02,
            max_level: 2,
            block,
            jitter,
        };
        same_with_corners(&s, &s, &format!("showcase block {block} jitter {jitter}"));
    }
    let mut other = s.clone();
    other.camera.eye.x += 0.5;
    same_with_corners(&s, &other, "corners of another camera");
}

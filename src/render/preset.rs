//! The built-in scenes: Blinn's Figure 7 (one sphere, front or edge lit).

use crate::model::Model;
use crate::render::{AntiAlias, Camera, Light, Material, Object, Scene, Shape};
use glam::DVec3;

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

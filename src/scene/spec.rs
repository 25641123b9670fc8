//! The scene file's own types, as the TOML parser reads them (every table refuses unknown
//! keys); [`parse`](super::parse) checks and builds the scene from them.

use serde::Deserialize;
use std::collections::BTreeMap;

#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum ColorSpec {
    Grey(f64),
    Rgb([f64; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraSpec {
    pub(super) eye: [f64; 3],
    pub(super) target: [f64; 3],
    pub(super) up: Option<[f64; 3]>,
    pub(super) fov: f64,
    pub(super) width: u32,
    pub(super) height: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AaSpec {
    pub(super) mode: String,
    pub(super) threshold: Option<f64>,
    pub(super) max_level: Option<u32>,
    pub(super) block: Option<u32>,
    pub(super) jitter: Option<bool>,
    pub(super) samples: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightSpec {
    pub(super) kind: String,
    pub(super) position: Option<[f64; 3]>,
    pub(super) direction: Option<[f64; 3]>,
    pub(super) color: Option<ColorSpec>,
    pub(super) intensity: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CheckerSpec {
    pub(super) size: f64,
    pub(super) color0: ColorSpec,
    pub(super) color1: ColorSpec,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RoughSpec {
    pub(super) cmin: f64,
    pub(super) frequency: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaterialSpec {
    pub(super) model: Option<String>,
    pub(super) distribution: Option<String>,
    pub(super) params: Option<toml::Spanned<BTreeMap<String, toml::Spanned<f64>>>>,
    pub(super) fit: Option<String>,
    /// With `fit`: the model to take from a file of several (`fit --model all`).
    pub(super) fit_model: Option<String>,
    /// With `fit`: the channel to take (default: every channel, as colour).
    pub(super) fit_channel: Option<String>,
    /// With `fit`: use a fit marked not usable.
    pub(super) fit_allow_unusable: Option<bool>,
    pub(super) color: Option<ColorSpec>,
    pub(super) checker: Option<CheckerSpec>,
    pub(super) ks: Option<f64>,
    pub(super) kt: Option<f64>,
    pub(super) ior: Option<f64>,
    pub(super) roughness: Option<RoughSpec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObjectSpec {
    pub(super) kind: String,
    pub(super) material: String,
    pub(super) center: Option<[f64; 3]>,
    pub(super) radius: Option<f64>,
    pub(super) point: Option<[f64; 3]>,
    pub(super) normal: Option<[f64; 3]>,
    pub(super) size: Option<f64>,
    pub(super) path: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneFile {
    pub(super) camera: CameraSpec,
    pub(super) max_depth: Option<u32>,
    pub(super) min_weight: Option<f64>,
    pub(super) ambient: Option<ColorSpec>,
    pub(super) background: Option<ColorSpec>,
    pub(super) antialias: Option<AaSpec>,
    pub(super) test_object: Option<String>,
    #[serde(default)]
    pub(super) lights: Vec<LightSpec>,
    #[serde(default, deserialize_with = "in_file_order")]
    pub(super) materials: Vec<(String, MaterialSpec)>,
    #[serde(default)]
    pub(super) objects: Vec<ObjectSpec>,
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

//! Helpers shared by the integration tests.
#![allow(dead_code)]

use brdfit::data::{self, Dataset, LoadOptions};
use std::path::{Path, PathBuf};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A data file of the repository, loaded with the default options.
pub fn load(f: &str) -> Dataset {
    data::load(&root().join(f), &LoadOptions::default()).unwrap()
}

/// Write `body` to `dir/name` and return the path.
pub fn write(dir: &Path, name: &str, body: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p
}

/// A fit object written by hand (the keys the README documents), for the fit-file tests.
pub fn fit_object(model: &str, dist: &str, channel: &str, params: &str, extra: &str) -> String {
    format!(
        r#"{{"model": "{model}", "distribution": "{dist}", "loss": "log", "method": "lm",
  "channel": "{channel}", "params": {params}, "cost": 1.0, "rmse": 0.01,
  "samples_used": 1000, "bic": -5000.0, "aic": -5010.0, "n_free": 4{extra}}}"#
    )
}
pub mod sphere;

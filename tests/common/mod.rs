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
pub mod sphere;

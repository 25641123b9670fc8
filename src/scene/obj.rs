//! The OBJ reader for mesh objects.

use super::MAX_TRIANGLES;
use crate::render::Mesh;
use anyhow::{Result, anyhow, bail};
use glam::DVec3;
use std::path::Path;

/// Read the `v` and `f` lines of an OBJ file (polygons fanned into triangles; negative
/// indices count from the end), within the mesh size limit ([`crate::support::input`]) and at most
/// [`MAX_TRIANGLES`] triangles.
pub fn read_obj(path: &Path) -> Result<Mesh> {
    let text =
        crate::support::input::read_to_string_limited(path, crate::support::input::Input::Mesh)?;
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

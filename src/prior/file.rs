//! Prior files, the bundled networks and the cache of the prior built from them.
//!
//! A prior file: the line `brdfit prior 1`, one line of JSON (`dims`, `components`,
//! `variance`, `materials`, `epsilon`), then little-endian f32 values: the per-cell median,
//! then each component over the cells.

use super::{BuildOptions, EPSILON, Prior, build};
use crate::data::DataError;
use crate::data::nbrdf;
use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &str = "brdfit prior 1\n";

/// The Neural-BRDF weights brdfit ships (`data/nbrdf_weights.json`: the 100 MERL materials,
/// 51 RGL materials and Nielsen et al.'s 8; Sztrajman et al. 2021, MIT licence).
pub fn bundled_weights() -> &'static str {
    include_str!("../../data/nbrdf_weights.json")
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Header {
    dims: [usize; 3],
    components: usize,
    variance: Vec<f64>,
    materials: Vec<String>,
    epsilon: f64,
    residual_variance: f64,
}

/// Write `prior` to `path` (atomically).
pub fn save(prior: &Prior, path: &Path) -> std::io::Result<()> {
    let header = Header {
        dims: prior.dims,
        components: prior.components(),
        variance: prior.variance.clone(),
        materials: prior.materials.clone(),
        epsilon: EPSILON,
        residual_variance: prior.residual_variance,
    };
    let json = serde_json::to_string(&header).map_err(std::io::Error::other)?;
    crate::support::output::write_atomic(path, |w| {
        let mut w = std::io::BufWriter::new(w);
        w.write_all(MAGIC.as_bytes())?;
        w.write_all(json.as_bytes())?;
        w.write_all(b"\n")?;
        for x in prior.median.iter().chain(&prior.basis) {
            w.write_all(&x.to_le_bytes())?;
        }
        w.flush()
    })
}

/// Read a prior file written by [`save`].
pub fn load(path: &Path) -> Result<Prior, DataError> {
    crate::support::input::check_regular(path, crate::support::input::Input::Data)?;
    let bytes = std::fs::read(path).map_err(|e| crate::data::io_error(path, &e))?;
    let bad = |line: Option<u64>, msg: String| {
        DataError::new(
            path,
            line,
            msg,
            "give a file written by `brdfit prior build`, or build it again",
        )
    };
    let rest = bytes.strip_prefix(MAGIC.as_bytes()).ok_or_else(|| {
        bad(
            Some(1),
            "not a brdfit prior (no `brdfit prior 1` line)".into(),
        )
    })?;
    let end = rest
        .iter()
        .position(|&b| b == b'\n')
        .ok_or_else(|| bad(Some(2), "the header line has no end".into()))?;
    let header: Header = serde_json::from_slice(&rest[..end])
        .map_err(|e| bad(Some(2), format!("the header is not valid: {e}")))?;
    let cells = header
        .dims
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d).filter(|_| d > 0));
    let want = cells
        .and_then(|c| c.checked_mul(header.components + 1))
        .and_then(|n| n.checked_mul(4));
    let body = &rest[end + 1..];
    match (cells, want) {
        (Some(_), Some(n)) if n == body.len() => {}
        _ => {
            return Err(bad(
                None,
                format!(
                    "{} bytes of values where the header ({:?} cells, {} components) needs {}",
                    body.len(),
                    header.dims,
                    header.components,
                    want.map_or("more than can be counted".into(), |n| n.to_string())
                ),
            ));
        }
    }
    if header.variance.len() != header.components
        || header.epsilon != EPSILON
        || header.variance.iter().any(|v| !(v.is_finite() && *v > 0.0))
        || !(header.residual_variance.is_finite() && header.residual_variance > 0.0)
    {
        return Err(bad(
            Some(2),
            "the header's variances or epsilon do not match its components".into(),
        ));
    }
    let values: Vec<f32> = body
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    if values.iter().any(|v| !v.is_finite()) {
        return Err(bad(None, "a value is not finite".into()));
    }
    let cells = cells.unwrap_or(0);
    Ok(Prior {
        dims: header.dims,
        median: values[..cells].to_vec(),
        basis: values[cells..].to_vec(),
        variance: header.variance,
        materials: header.materials,
        residual_variance: header.residual_variance,
    })
}

/// FNV-1a over bytes: the cache key of a prior's inputs.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The cache folder: `$BRDFIT_CACHE`, else `$XDG_CACHE_HOME/brdfit`, else
/// `$HOME/.cache/brdfit`.
pub fn cache_dir() -> Option<PathBuf> {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    var("BRDFIT_CACHE")
        .or_else(|| var("XDG_CACHE_HOME").map(|p| p.join("brdfit")))
        .or_else(|| var("HOME").map(|p| p.join(".cache").join("brdfit")))
}

/// The prior of the bundled MERL networks built with `opts`: read from the cache when it was
/// built before, else built (calling `progress(done, total)` per network) and cached. A cache
/// that cannot be written is not an error (the prior is rebuilt next time); the second value
/// is the cache file, when one was read or written.
pub fn bundled(
    opts: &BuildOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Prior, Option<PathBuf>), DataError> {
    let text = bundled_weights();
    let key = fnv(format!("{MAGIC}{opts:?}{}", text.len()).as_bytes()) ^ fnv(text.as_bytes());
    let file = cache_dir().map(|d| d.join(format!("prior-{key:016x}.bin")));
    if let Some(f) = &file {
        if let Ok(p) = load(f) {
            return Ok((p, file));
        }
    }
    let label = Path::new("data/nbrdf_weights.json");
    let nets = nbrdf::parse_all(label, text)?;
    let prior = build(&nets, opts, progress).ok_or_else(|| {
        DataError::new(
            label,
            None,
            "fewer than two networks left to build a prior from",
            "exclude fewer materials",
        )
    })?;
    let written = file.filter(|f| save(&prior, f).is_ok());
    Ok((prior, written))
}

//! Answers: `choose` (the choose.json structure), `render` (a float image) and `export`.

use crate::dataset::PyDataset;
use crate::fits::PyFitResult;
use crate::{choice, error};
use brdfit::choose::{ChooseOptions, Metric, Threshold};
use numpy::{PyArray3, ndarray::Array3};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// Which model a scene needs, as `brdfit choose`: the text of `choose.json`, and the files
/// written when `output` names a folder.
#[pyfunction]
#[pyo3(signature = (data, scene, metric, value, res, verify, allow_large_image, output))]
#[allow(clippy::too_many_arguments)]
pub fn choose(
    py: Python<'_>,
    data: PyRef<'_, PyDataset>,
    scene: &str,
    metric: &str,
    value: f64,
    res: u32,
    verify: usize,
    allow_large_image: bool,
    output: Option<PathBuf>,
) -> PyResult<(String, Vec<PathBuf>)> {
    let metric = Metric::from_key(metric.trim()).ok_or_else(|| {
        let keys: Vec<&str> = Metric::ALL.iter().map(|m| m.key()).collect();
        error(format!(
            "unknown metric '{}'\n  fix: use one of {}",
            metric.trim(),
            keys.join(", ")
        ))
    })?;
    if !(value.is_finite() && value >= 0.0) {
        return Err(error(format!(
            "'{value}' is not a value ≥ 0\n  fix: e.g. threshold=\"{}=0.05\"",
            metric.key()
        )));
    }
    if !(16..=4096).contains(&res) {
        return Err(error(format!(
            "res {res} is out of range\n  fix: give a resolution between 16 and 4096"
        )));
    }
    let ds = if data.ds.channels.len() > 1 {
        brdfit::data::representative_channel(&data.ds)
            .map_err(error)?
            .0
    } else {
        data.ds.clone()
    };
    let cases = if scene == "fig7" {
        brdfit::choose::fig7_cases(res)
    } else {
        let path = Path::new(scene);
        let s = brdfit::scene::load_scene(path).map_err(error)?;
        vec![brdfit::choose::scene_case(path, s, allow_large_image).map_err(error)?]
    };
    let opts = ChooseOptions {
        threshold: Threshold { metric, value },
        verify,
        ..Default::default()
    };
    py.allow_threads(|| {
        let (result, images) =
            brdfit::choose::choose(&ds, &cases, &opts, &|_| {}).map_err(error)?;
        let json = serde_json::to_string_pretty(&result).map_err(error)? + "\n";
        let written = match &output {
            Some(dir) => brdfit::choose::write(dir, &result, &images).map_err(error)?,
            None => Vec::new(),
        };
        Ok((json, written))
    })
}

/// Render a scene file with Whitted's ray tracer: linear RGB radiance, shape (height, width,
/// 3), float32, and the scene's notes.
#[pyfunction]
#[pyo3(signature = (scene, allow_large_image=false))]
pub fn render<'py>(
    py: Python<'py>,
    scene: PathBuf,
    allow_large_image: bool,
) -> PyResult<(Bound<'py, PyArray3<f32>>, Vec<String>)> {
    let (s, notes) = brdfit::scene::load_scene_noted(&scene).map_err(error)?;
    brdfit::render::check_image_size(s.camera.width, s.camera.height, allow_large_image)
        .map_err(|e| error(format!("{}: camera: {e}", scene.display())))?;
    let img = py.allow_threads(|| s.render(&|| {}));
    let (w, h) = (img.width as usize, img.height as usize);
    let flat: Vec<f32> = img.pixels.iter().flatten().copied().collect();
    let a = Array3::from_shape_vec((h, w, 3), flat).map_err(error)?;
    Ok((numpy::IntoPyArray::into_pyarray(a, py), notes))
}

/// A fitted material for another renderer, as `brdfit export` prints it: `mitsuba` (BSDF
/// XML), `pbrt` (pbrt-v4 material) or `brdf-explorer`; the fit picked as `--model`,
/// `--distribution` and `--channel` pick it from a fit file.
#[pyfunction]
#[pyo3(signature = (fits, to, model, distribution, channel, allow_unusable, id))]
#[allow(clippy::too_many_arguments)]
pub fn export(
    fits: Vec<PyRef<'_, PyFitResult>>,
    to: &str,
    model: Option<&str>,
    distribution: Option<&str>,
    channel: Option<String>,
    allow_unusable: bool,
    id: &str,
) -> PyResult<String> {
    use brdfit::export::{self, ExportFormat};
    let fmt: ExportFormat = choice("to", to)?;
    let fits: Vec<brdfit::FitResult> = fits.iter().map(|f| f.r.clone()).collect();
    let want = brdfit::fit::Want {
        model: model.map(|m| choice("model", m)).transpose()?,
        dist: distribution
            .map(|d| choice("distribution", d))
            .transpose()?,
        channel,
        allow_unusable,
    };
    let picked = brdfit::fit::pick(&fits, &want).map_err(error)?;
    let c = picked.colour().map_err(error)?;
    match fmt {
        ExportFormat::Mitsuba => export::mitsuba(&c, id).map_err(error),
        ExportFormat::Pbrt => Ok(export::pbrt(&c)),
        ExportFormat::BrdfExplorer => export::brdf_explorer(&c).map_err(error),
        ExportFormat::Merl | ExportFormat::Csv | ExportFormat::RglBsdf => Err(error(format!(
            "to=\"{to}\" writes a binary or tabular file\n  fix: use the command line: brdfit export FIT.json --to {to} -o OUT"
        ))),
    }
}

/// The network names of a Neural-BRDF weights file, in file order.
#[pyfunction]
pub fn nbrdf_materials(py: Python<'_>, path: PathBuf) -> PyResult<Vec<String>> {
    py.allow_threads(|| brdfit::data::nbrdf::material_names(&path))
        .map_err(error)
}

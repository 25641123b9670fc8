//! Fits: `fit` (one model or every model), the `FitResult` class, the fit JSON both ways, and
//! `eval`.

use crate::dataset::PyDataset;
use crate::{choice, error};
use brdfit::fit::{FitOptions, FitResult};
use brdfit::model::{Distribution, Geometry, Model, ModelKind};
use numpy::{PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The outcome of one fit (one channel, or several fitted jointly): parameters with standard
/// errors, correlations, confidence intervals, checks and information criteria. Its JSON is the
/// command line's fit JSON.
#[pyclass(frozen, module = "brdfit._brdfit", name = "FitResult")]
pub struct PyFitResult {
    /// The library's result.
    pub r: FitResult,
}

/// A dict of `pairs` in order.
fn dict<'py, T: IntoPyObject<'py> + Clone>(
    py: Python<'py>,
    pairs: impl IntoIterator<Item = (String, T)>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in pairs {
        d.set_item(k, v)?;
    }
    Ok(d)
}

#[pymethods]
impl PyFitResult {
    fn __repr__(&self) -> String {
        let p: Vec<String> = self
            .r
            .params
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        format!(
            "<brdfit.FitResult {} on {}: {}{}>",
            self.r.label(),
            self.r.channel,
            p.join(", "),
            if self.r.usable() { "" } else { " NOT USABLE" }
        )
    }

    /// The fit as the command line prints it.
    fn __str__(&self) -> String {
        brdfit::fit::format_fit(&self.r)
    }

    /// Model name, e.g. `torrance-sparrow`.
    #[getter]
    fn model(&self) -> String {
        self.r.model.to_string()
    }

    /// Facet distribution (`d3` for models that take none).
    #[getter]
    fn distribution(&self) -> &'static str {
        self.r.dist.name()
    }

    /// Model label, e.g. `torrance-sparrow (d3)`.
    #[getter]
    fn label(&self) -> String {
        self.r.label()
    }

    /// Channel name(s), comma-separated for a joint fit.
    #[getter]
    fn channel(&self) -> String {
        self.r.channel.clone()
    }

    /// Parameter name → value, in the model's order.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        dict(py, self.r.params.clone())
    }

    /// Parameter name → standard error (0 for a held parameter).
    #[getter]
    fn stderr<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let names = self.r.params.iter().map(|(k, _)| k.clone());
        dict(py, names.zip(self.r.stderr.iter().copied()))
    }

    /// Correlation matrix in `params` order, shape (P, P).
    #[getter]
    fn correlation<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        PyArray2::from_vec2(py, &self.r.correlation).map_err(error)
    }

    /// Parameter name → (low, high): the confidence interval at `interval_level` by profile
    /// likelihood (±inf where it is open on that side).
    #[getter]
    fn intervals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.ranges(py)
    }

    /// The confidence level of `intervals` (0.95; 0 for a fit file of an earlier version,
    /// whose `ranges` held the values within 1 % of the minimum cost).
    #[getter]
    fn interval_level(&self) -> f64 {
        self.r.interval_level
    }

    /// The same as `intervals` (the name of earlier versions).
    #[getter]
    fn ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        dict(
            py,
            self.r
                .ranges
                .iter()
                .map(|(k, lo, hi)| (k.clone(), (*lo, *hi))),
        )
    }

    /// Short flags: `unconverged`, `bound:NAME`, `weak:NAME`.
    #[getter]
    fn flags(&self) -> Vec<String> {
        self.r.flags()
    }

    /// True when no check marks the fit as not usable.
    #[getter]
    fn usable(&self) -> bool {
        self.r.usable()
    }

    /// Why the fit is not usable (empty when it is).
    #[getter]
    fn unusable(&self) -> Vec<String> {
        self.r.unusable.clone()
    }

    /// Warnings: weakly determined parameters with their range, limits reached.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.r.warnings.clone()
    }

    /// Bayesian information criterion m ln(2 cost/m) + k ln m.
    #[getter]
    fn bic(&self) -> f64 {
        self.r.bic
    }

    /// Akaike information criterion m ln(2 cost/m) + 2k.
    #[getter]
    fn aic(&self) -> f64 {
        self.r.aic
    }

    /// ½ Σ w r² in the fit's loss at the returned parameters.
    #[getter]
    fn cost(&self) -> f64 {
        self.r.cost
    }

    /// √(2 cost / samples_used).
    #[getter]
    fn rmse(&self) -> f64 {
        self.r.rmse
    }

    /// Rows used (samples × channels).
    #[getter]
    fn samples_used(&self) -> usize {
        self.r.samples_used
    }

    /// Number of free parameters.
    #[getter]
    fn n_free(&self) -> usize {
        self.r.n_free
    }

    /// Wall time of the fit in seconds (no file reading).
    #[getter]
    fn seconds(&self) -> f64 {
        self.r.seconds
    }

    /// The random-start certificate: True or False when `verify` starts ran, else None.
    #[getter]
    fn verified(&self) -> Option<bool> {
        self.r.verification.as_ref().map(|v| v.verified)
    }

    /// f_r of the fitted model of channel `channel` (0 for a single-channel fit) at
    /// directions (N, 4) in radians; shape (N,).
    #[pyo3(signature = (directions, channel=0))]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        directions: PyReadonlyArray2<'py, f64>,
        channel: usize,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        eval_model(py, &self.r.model_for(channel), directions)
    }

    /// The command line's fit JSON of this fit (`fit --json` of one fit): the same text,
    /// ending in a newline.
    fn to_json(&self) -> PyResult<String> {
        json_text(&self.r.to_json())
    }

    /// A fit read back from its JSON (the text of one fit's object).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<PyFitResult> {
        let mut fits = brdfit::fit::read_fit_file(text).map_err(error)?;
        if fits.len() != 1 {
            return Err(error(format!(
                "the JSON holds {} fits, not one\n  fix: read it with brdfit.read_fits",
                fits.len()
            )));
        }
        Ok(PyFitResult { r: fits.remove(0) })
    }
}

/// Pretty JSON ending in a newline, as the command line writes its files.
fn json_text(v: &serde_json::Value) -> PyResult<String> {
    Ok(serde_json::to_string_pretty(v).map_err(error)? + "\n")
}

/// Every fit of a fit JSON (one fit, or several under `fits`).
#[pyfunction]
pub fn read_fits(text: &str) -> PyResult<Vec<PyFitResult>> {
    let fits = brdfit::fit::read_fit_file(text).map_err(error)?;
    Ok(fits.into_iter().map(|r| PyFitResult { r }).collect())
}

/// The fit JSON of several fits as `fit --json` writes it (one fit as its object, several
/// under `fits`).
#[pyfunction]
pub fn fits_json(fits: Vec<PyRef<'_, PyFitResult>>) -> PyResult<String> {
    let refs: Vec<&FitResult> = fits.iter().map(|f| &f.r).collect();
    json_text(&brdfit::fit::fits_json(&refs))
}

/// Every model `fit --model all` fits, as (model, distribution) names.
#[pyfunction]
pub fn model_names() -> Vec<(String, &'static str)> {
    brdfit::fit::all_models()
        .into_iter()
        .map(|(k, d)| (k.to_string(), d.name()))
        .collect()
}

/// Fit one model, or every model (`model="all"`), to every channel of `data` (or jointly
/// with `shared`): a list per model of a list per channel.
#[pyfunction]
#[pyo3(signature = (data, model, distribution, loss, method, robust, max_theta, weights, fix, start, shared, local_only, resolution, verify, verify_seed, fast_pow))]
#[allow(clippy::too_many_arguments)]
pub fn fit(
    py: Python<'_>,
    data: PyRef<'_, PyDataset>,
    model: &str,
    distribution: &str,
    loss: &str,
    method: &str,
    robust: Option<&str>,
    max_theta: Option<f64>,
    weights: &str,
    fix: Vec<(String, f64)>,
    start: Vec<(String, f64)>,
    shared: Vec<String>,
    local_only: bool,
    resolution: f64,
    verify: usize,
    verify_seed: u64,
    fast_pow: Option<u32>,
) -> PyResult<Vec<Vec<PyFitResult>>> {
    let dist: Distribution = choice("distribution", distribution)?;
    let kinds: Vec<(ModelKind, Distribution)> = if model == "all" {
        brdfit::fit::all_models()
    } else {
        vec![(choice("model", model)?, dist)]
    };
    if !(0.0..=1.0).contains(&resolution) {
        return Err(error(format!(
            "resolution {resolution} is not a fraction from 0 to 1\n  fix: e.g. resolution=1e-6 (the default), or 0 to polish to the last digits"
        )));
    }
    let mut o = FitOptions::new(kinds[0].0);
    o.method = choice("method", method)?;
    o.loss = choice("loss", loss)?;
    o.robust = robust.map(|r| choice("robust", r)).transpose()?;
    o.max_theta_deg = max_theta;
    o.weights = choice("weights", weights)?;
    (o.fix, o.start, o.shared) = (fix, start, shared);
    o.local_only = local_only;
    o.resolution = resolution;
    o.fast_pow = fast_pow;
    o.verify = verify;
    o.seed = verify_seed;
    let opts = brdfit::fit::options_per_model(&o, &kinds);
    let ds = &data.ds;
    // One model: `fit`, as fit_models gives it but without its progress ticker (a thread
    // started per call, a tenth of a millisecond: a seventh of a 10,000-sample fit).
    let all = py
        .allow_threads(|| match &opts[..] {
            [one] => brdfit::fit::fit(ds, one).map(|f| vec![f]),
            _ => brdfit::fit::fit_models(ds, &opts, 1).map(|(all, _)| all),
        })
        .map_err(error)?;
    Ok(all
        .into_iter()
        .map(|fits| fits.into_iter().map(|r| PyFitResult { r }).collect())
        .collect())
}

/// f_r of `m` at each row (θi, φi, θo, φo) of `directions` (radians), read in place when the
/// array is C-contiguous.
fn eval_model<'py>(
    py: Python<'py>,
    m: &Model,
    directions: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    if directions.shape()[1] != 4 {
        return Err(error(format!(
            "directions have shape ({}, {}), not (N, 4)\n  fix: give one row (θi, φi, θo, φo) in radians per sample",
            directions.shape()[0],
            directions.shape()[1]
        )));
    }
    let f = |a: &[f64]| m.brdf(&Geometry::from_angles(a[0], a[1], a[2], a[3]));
    // `as_slice` takes a Fortran-ordered array too, whose rows are not the slice's quads.
    let flat = directions
        .is_c_contiguous()
        .then(|| directions.as_slice().ok())
        .flatten();
    let out: Vec<f64> = match flat {
        Some(flat) => py.allow_threads(|| flat.chunks_exact(4).map(f).collect()),
        None => directions
            .as_array()
            .rows()
            .into_iter()
            .map(|r| f(&[r[0], r[1], r[2], r[3]]))
            .collect(),
    };
    Ok(PyArray1::from_vec(py, out))
}

/// f_r of a model with parameters `params` at directions (N, 4) in radians; shape (N,).
#[pyfunction]
#[pyo3(signature = (model, params, directions, distribution=None))]
pub fn eval<'py>(
    py: Python<'py>,
    model: &str,
    params: Vec<(String, f64)>,
    directions: PyReadonlyArray2<'py, f64>,
    distribution: Option<&str>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let kind: ModelKind = choice("model", model)?;
    let dist: Distribution = choice("distribution", distribution.unwrap_or("d3"))?;
    let m = Model::from_named(kind, dist, &params).map_err(error)?;
    eval_model(py, &m, directions)
}

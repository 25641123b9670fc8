//! Data sets: `load`, `from_arrays`, `simulate` and the `Dataset` class (float64 arrays out).

use crate::{choice, error};
use brdfit::data::{self, ChannelSelect, Dataset, LoadOptions, NegativePolicy, Quantity, RowSink};
use brdfit::model::{Distribution, Model, ModelKind};
use brdfit::simulate::Grid;
use numpy::{PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// Reflectance samples: angles in radians, one column of values per channel, and the file's
/// metadata. Read-only; the arrays returned are copies.
#[pyclass(frozen, module = "brdfit._brdfit", name = "Dataset")]
pub struct PyDataset {
    /// The library's data set.
    pub ds: Dataset,
}

impl PyDataset {
    /// One column as a new numpy array.
    fn column<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, v)
    }
}

#[pymethods]
impl PyDataset {
    /// Number of samples.
    fn __len__(&self) -> usize {
        self.ds.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "<brdfit.Dataset: {} samples, channels [{}], {} from {:?}>",
            self.ds.len(),
            self.ds.channel_names(),
            self.ds.quantity.column(),
            self.ds.meta.source
        )
    }

    /// Incidence polar angle θi (radians), shape (N,).
    #[getter]
    fn theta_i<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Self::column(py, &self.ds.theta_i)
    }

    /// Incidence azimuth φi (radians), shape (N,).
    #[getter]
    fn phi_i<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Self::column(py, &self.ds.phi_i)
    }

    /// Outgoing polar angle θo (radians), shape (N,).
    #[getter]
    fn theta_o<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Self::column(py, &self.ds.theta_o)
    }

    /// Outgoing azimuth φo (radians), shape (N,).
    #[getter]
    fn phi_o<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Self::column(py, &self.ds.phi_o)
    }

    /// The four angles (θi, φi, θo, φo) in radians, shape (N, 4).
    #[getter]
    fn directions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let d = &self.ds;
        let flat: Vec<f64> = (0..d.len()).flat_map(|k| d.angles(k)).collect();
        let a = numpy::ndarray::Array2::from_shape_vec((d.len(), 4), flat)
            .expect("four angles per sample");
        numpy::IntoPyArray::into_pyarray(a, py)
    }

    /// The values, one column per channel, shape (N, C), in the data's quantity (see
    /// `quantity`); NaN marks a missing value.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let d = &self.ds;
        let c = d.channels.len();
        let mut flat = vec![0.0; d.len() * c];
        for (j, ch) in d.channels.iter().enumerate() {
            for (k, v) in ch.values.iter().enumerate() {
                flat[k * c + j] = *v;
            }
        }
        let a = numpy::ndarray::Array2::from_shape_vec((d.len(), c), flat)
            .expect("a value per sample and channel");
        numpy::IntoPyArray::into_pyarray(a, py)
    }

    /// Channel names, in column order of `values`.
    #[getter]
    fn channels(&self) -> Vec<String> {
        self.ds.channels.iter().map(|c| c.name.clone()).collect()
    }

    /// Wavelength of each channel in nm (None where not spectral).
    #[getter]
    fn wavelengths(&self) -> Vec<Option<f64>> {
        self.ds.channels.iter().map(|c| c.wavelength_nm).collect()
    }

    /// What the values measure: `brdf` (f_r, 1/sr), `brdf_cos` (f_r cos θi) or `rfactor`
    /// (π f_r).
    #[getter]
    fn quantity(&self) -> &'static str {
        self.ds.quantity.column()
    }

    /// Per-sample weights, shape (N,), or None.
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.ds.weights.as_deref().map(|w| Self::column(py, w))
    }

    /// The file read (empty for arrays and simulations).
    #[getter]
    fn source(&self) -> String {
        self.ds.meta.source.clone()
    }

    /// Format name (`csv`, `astm`, `cornell`, `merl`; empty for arrays and simulations).
    #[getter]
    fn format(&self) -> String {
        self.ds.meta.format.clone()
    }

    /// Material or sample name, if the file gives one.
    #[getter]
    fn material(&self) -> Option<String> {
        self.ds.meta.material.clone()
    }

    /// Comment and header lines kept from the file.
    #[getter]
    fn comments(&self) -> Vec<String> {
        self.ds.meta.comments.clone()
    }

    /// What looked wrong while loading but was not an error, each naming the fix.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.ds.meta.warnings.clone()
    }

    /// Negative values met while loading (masked or clamped by the negative policy).
    #[getter]
    fn negatives(&self) -> usize {
        self.ds.negatives
    }

    /// The data reduced to one channel: a name (`r`, `550nm`), an index, a wavelength
    /// (`555nm`, interpolated) or `cie-y`, as `--channel` takes it.
    fn select(&self, channel: &str) -> PyResult<PyDataset> {
        select(self.ds.clone(), channel, &self.ds.meta.source)
    }

    /// The one channel `choose`, the report and the studies use: CIE Y of spectral data,
    /// green of RGB, else the first.
    fn representative(&self) -> PyResult<PyDataset> {
        let (ds, _) = data::representative_channel(&self.ds).map_err(error)?;
        Ok(PyDataset { ds })
    }

    /// A short summary, as `brdfit info` prints it.
    fn summary(&self) -> String {
        data::summary(&self.ds)
    }
}

/// `ds` reduced to `channel`, the error as `--channel`'s for the file `source`.
fn select(ds: Dataset, channel: &str, source: &str) -> PyResult<PyDataset> {
    let ds = ds.select(&ChannelSelect::parse(channel)).map_err(|m| {
        error(format!(
            "{}: {m}\n  fix: pick a channel the file has",
            if source.is_empty() { "data" } else { source }
        ))
    })?;
    Ok(PyDataset { ds })
}

/// Read a data file (brdfit CSV, ASTM E1392, Cornell spectral text, MERL .binary).
#[pyfunction]
#[pyo3(signature = (path, channel=None, format=None, negative="mask"))]
pub fn load(
    py: Python<'_>,
    path: PathBuf,
    channel: Option<&str>,
    format: Option<&str>,
    negative: &str,
) -> PyResult<PyDataset> {
    let format = format.map(|f| choice("format", f)).transpose()?;
    let negative: NegativePolicy = choice("negative", negative)?;
    let ds = py
        .allow_threads(|| data::load(&path, &LoadOptions { format, negative }))
        .map_err(error)?;
    match channel {
        None => Ok(PyDataset { ds }),
        Some(c) => select(ds, c, &path.display().to_string()),
    }
}

/// A data set from arrays: directions (N, 4) in radians, values (N, C), validated as a file's
/// rows are (rows numbered from 1 in errors, named `arrays`).
#[pyfunction]
#[pyo3(signature = (directions, values, channels, quantity="brdf", weights=None, negative="mask"))]
pub fn from_arrays(
    directions: PyReadonlyArray2<'_, f64>,
    values: PyReadonlyArray2<'_, f64>,
    channels: Vec<String>,
    quantity: &str,
    weights: Option<numpy::PyReadonlyArray1<'_, f64>>,
    negative: &str,
) -> PyResult<PyDataset> {
    let negative: NegativePolicy = choice("negative", negative)?;
    let quantity = match quantity {
        "brdf" => Quantity::Brdf,
        "brdf_cos" => Quantity::BrdfCos,
        "rfactor" => Quantity::RFactor,
        q => {
            return Err(error(format!(
                "invalid value '{q}' for quantity\n  fix: use one of brdf, brdf_cos, rfactor"
            )));
        }
    };
    let (n, c) = (directions.shape()[0], values.shape()[1]);
    if directions.shape()[1] != 4 {
        return Err(error(format!(
            "directions have shape ({n}, {}), not (N, 4)\n  fix: give one row (θi, φi, θo, φo) in radians per sample",
            directions.shape()[1]
        )));
    }
    if values.shape()[0] != n || channels.len() != c || c == 0 {
        return Err(error(format!(
            "values have shape ({}, {c}) for {n} directions and {} channel name(s)\n  fix: give values of shape (N, C) with one name per column",
            values.shape()[0],
            channels.len()
        )));
    }
    let w = weights.as_ref().map(|w| w.as_array());
    if w.as_ref().is_some_and(|w| w.len() != n) {
        return Err(error(format!(
            "weights have {} entries for {n} samples\n  fix: give one weight per sample",
            w.as_ref().map_or(0, |w| w.len())
        )));
    }
    let (dirs, vals) = (directions.as_array(), values.as_array());
    let ds = Dataset::new(quantity, channels.into_iter().map(|n| (n, None)).collect());
    let path = Path::new("arrays");
    let mut sink = RowSink::new(path, negative, ds);
    if w.is_some() {
        sink.ds.weights = Some(Vec::with_capacity(n));
    }
    let mut row = vec![0.0; c];
    for k in 0..n {
        let a = [dirs[[k, 0]], dirs[[k, 1]], dirs[[k, 2]], dirs[[k, 3]]];
        for (j, r) in row.iter_mut().enumerate() {
            *r = vals[[k, j]];
        }
        sink.push(k as u64 + 1, a, &row, w.as_ref().map(|w| w[k]))
            .map_err(error)?;
    }
    Ok(PyDataset {
        ds: sink.finish().map_err(error)?,
    })
}

/// Synthetic samples: of a model (`model`, `params`) with multiplicative Gaussian noise, or of
/// a Neural-BRDF network (`nbrdf`, `material`), on a grid or at given directions.
#[pyfunction]
#[pyo3(signature = (model=None, params=Vec::new(), grid="hemisphere:10000", directions=None, distribution="d3", noise=0.0, seed=1, nbrdf=None, material=None, symmetric=false))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    model: Option<&str>,
    params: Vec<(String, f64)>,
    grid: &str,
    directions: Option<PyReadonlyArray2<'_, f64>>,
    distribution: &str,
    noise: f64,
    seed: u64,
    nbrdf: Option<PathBuf>,
    material: Option<&str>,
    symmetric: bool,
) -> PyResult<PyDataset> {
    let dirs: Cow<[[f64; 4]]> = match &directions {
        Some(d) => {
            if d.shape()[1] != 4 {
                return Err(error(format!(
                    "directions have shape ({}, {}), not (N, 4)\n  fix: give one row (θi, φi, θo, φo) in radians per sample",
                    d.shape()[0],
                    d.shape()[1]
                )));
            }
            // In place when C-contiguous (`as_slice` takes a Fortran-ordered array too).
            match d.is_c_contiguous().then(|| d.as_slice().ok()).flatten() {
                Some(flat) => Cow::Borrowed(flat.as_chunks::<4>().0),
                None => d
                    .as_array()
                    .rows()
                    .into_iter()
                    .map(|r| [r[0], r[1], r[2], r[3]])
                    .collect(),
            }
        }
        None => Grid::parse(grid)
            .map_err(|e| error(format!("grid {e}")))?
            .directions(seed)
            .into(),
    };
    if !(noise.is_finite() && noise >= 0.0) {
        return Err(error(format!(
            "noise {noise} must be a finite number ≥ 0\n  fix: e.g. noise=0.01 for 1 %"
        )));
    }
    let ds = match (nbrdf, model) {
        (Some(file), None) => {
            if noise != 0.0 {
                return Err(error(format!(
                    "noise {noise} with nbrdf: a network is sampled without noise\n  fix: drop noise"
                )));
            }
            let name = material.unwrap_or_default().to_string();
            py.allow_threads(|| {
                let net = brdfit::data::nbrdf::Nbrdf::load(&file, &name)?;
                Ok::<_, brdfit::data::DataError>(brdfit::simulate::simulate_nbrdf(
                    &net, &dirs, symmetric,
                ))
            })
            .map_err(error)?
        }
        (None, Some(kind)) => {
            let kind: ModelKind = choice("model", kind)?;
            let dist: Distribution = choice("distribution", distribution)?;
            let m = Model::from_named(kind, dist, &params).map_err(error)?;
            py.allow_threads(|| brdfit::simulate(&m, &dirs, noise, seed))
        }
        _ => {
            return Err(error(
                "give a model (with params) or a Neural-BRDF weights file (nbrdf with material)\n  fix: e.g. simulate(model=\"torrance-sparrow\", params=…) or simulate(nbrdf=\"weights.json\", material=\"steel\")",
            ));
        }
    };
    Ok(PyDataset { ds })
}

//! The Python module `brdfit._brdfit`: brdfit's library called from Python, with numpy arrays
//! in and out. Every function here converts its arguments, calls the library with the GIL
//! released where the work is long (loading, fitting, simulating, choosing, rendering) and
//! converts the answer; the logic stays in the library. The Python package `brdfit`
//! (python/brdfit) wraps these with defaults, dicts and warnings.

mod answers;
mod dataset;
mod fits;

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    _brdfit,
    BrdfitError,
    PyValueError,
    "An error brdfit reports (bad data, a fit that cannot be run, a bad scene): the message is \
     the command line's, naming the file, the line and the fix."
);

/// The Python exception of a library error, with the command line's message (`error: ` left
/// off): the chain of an `anyhow` error as the CLI prints it (`{:#}`).
pub(crate) fn error(e: impl std::fmt::Display) -> PyErr {
    BrdfitError::new_err(format!("{e:#}"))
}

/// A choice given by name (`model`, `loss`, …) as the command line parses it, or the error
/// with the valid names.
pub(crate) fn choice<T: clap::ValueEnum>(arg: &str, name: &str) -> PyResult<T> {
    T::from_str(name.trim(), false).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value())
            .map(|p| p.get_name().to_string())
            .collect();
        error(format!(
            "invalid value '{name}' for {arg}\n  fix: use one of {}",
            names.join(", ")
        ))
    })
}

/// Tell the C allocator to keep freed memory for reuse, as the `brdfit` program does at its
/// start ([`brdfit::keep_freed_memory`]): repeated fits then reuse pages already touched. It
/// changes the allocator of the whole Python process (freed memory is not handed back to the
/// system while it runs), so it is for processes that do mostly fitting, such as a Dask
/// worker's.
#[pyfunction]
fn keep_freed_memory() {
    brdfit::keep_freed_memory();
}

/// The module.
#[pymodule]
fn _brdfit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("BrdfitError", m.py().get_type::<BrdfitError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<dataset::PyDataset>()?;
    m.add_class::<fits::PyFitResult>()?;
    m.add_function(wrap_pyfunction!(dataset::load, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::from_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(fits::fit, m)?)?;
    m.add_function(wrap_pyfunction!(fits::eval, m)?)?;
    m.add_function(wrap_pyfunction!(fits::read_fits, m)?)?;
    m.add_function(wrap_pyfunction!(fits::fits_json, m)?)?;
    m.add_function(wrap_pyfunction!(fits::model_names, m)?)?;
    m.add_function(wrap_pyfunction!(answers::choose, m)?)?;
    m.add_function(wrap_pyfunction!(answers::render, m)?)?;
    m.add_function(wrap_pyfunction!(answers::export, m)?)?;
    m.add_function(wrap_pyfunction!(answers::nbrdf_materials, m)?)?;
    m.add_function(wrap_pyfunction!(keep_freed_memory, m)?)?;
    Ok(())
}

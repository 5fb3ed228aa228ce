//! `savme._savme`: the Rust half of the `savme` Python package (the Python half is
//! `python/savme/`, which re-exports this module's classes and adds pure-Python helpers).
//!
//! One module per concept: `space` (spaces and variables), `trial` (trials, records,
//! posteriors), `kernel` (the ask/tell kernel, plain or journaled), `estimation` (P(failure)
//! by importance sampling from a kernel's posteriors), `protocol`, `problem`,
//! `history` (the told records a kernel keeps), `campaign` (the campaign loop), `callables` (Python callables as its simulator), `result`
//! (what it returns), `sim` (the bundled driving simulator
//! and FMUs), `native` (those simulators built and run on an executor's nodes), `openscenario` (OpenSCENARIO parameter variations), `convert` (values
//! between Rust and Python) and `errors` (Rust errors as Python exceptions).

use pyo3::prelude::*;

mod callables;
mod campaign;
mod convert;
mod errors;
mod estimation;
mod executor;
mod history;
mod kernel;
mod native;
mod openscenario;
mod problem;
mod protocol;
mod result;
mod signals;
mod sim;
mod space;
mod trial;

/// The savme kernel (Rust) for Python.
#[pymodule]
fn _savme(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("TellError", py.get_type::<errors::TellError>())?;
    m.add("JournalError", py.get_type::<errors::JournalError>())?;
    m.add_class::<space::PyVariable>()?;
    m.add_class::<space::PySpace>()?;
    m.add_function(wrap_pyfunction!(space::discrete, m)?)?;
    m.add_function(wrap_pyfunction!(space::boolean, m)?)?;
    m.add_function(wrap_pyfunction!(space::continuous, m)?)?;
    m.add_class::<trial::PyTrial>()?;
    m.add_class::<trial::PyRecord>()?;
    m.add_class::<trial::PyPosterior>()?;
    m.add_class::<kernel::PyKernel>()?;
    m.add_class::<estimation::PyEstimation>()?;
    m.add("CampaignError", py.get_type::<errors::CampaignError>())?;
    m.add_class::<protocol::PyProtocol>()?;
    m.add("PROTOCOL_VALUES", protocol::protocol_values(py)?)?;
    m.add_class::<problem::PyProblem>()?;
    m.add_class::<campaign::PyCampaign>()?;
    m.add_class::<result::PyCampaignResult>()?;
    m.add_function(wrap_pyfunction!(campaign::load_campaign, m)?)?;
    m.add_class::<sim::PyDriving>()?;
    m.add_class::<sim::PyFmuSimulator>()?;
    m.add_class::<native::PyNativeSimulator>()?;
    m.add_class::<openscenario::PyParameterVariation>()?;
    m.add_function(wrap_pyfunction!(openscenario::read_openscenario, m)?)?;
    Ok(())
}

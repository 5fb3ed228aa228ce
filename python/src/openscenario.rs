//! `savme.openscenario`: an OpenSCENARIO `ParameterValueDistribution` file as a φ-space and
//! the nominal distribution `Kernel.estimation` takes (see `savme::openscenario`).

use crate::convert::json_to_py;
use crate::errors;
use crate::space::PySpace;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use savme::openscenario::{ParameterDistribution, Variation};
use std::path::PathBuf;

/// A parameter variation file, read and checked.
#[pyclass(name = "ParameterVariation", module = "savme.openscenario", frozen)]
pub struct PyParameterVariation {
    inner: ParameterDistribution,
}

#[pymethods]
impl PyParameterVariation {
    /// The file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.inner.path.clone()
    }

    /// `ScenarioFile filepath`: the scenario whose parameters vary, as written.
    #[getter]
    fn scenario_file(&self) -> Option<String> {
        self.inner.scenario_file.clone()
    }

    /// "deterministic" or "stochastic".
    #[getter]
    fn variation(&self) -> &'static str {
        match self.inner.variation {
            Variation::Deterministic => "deterministic",
            Variation::Stochastic { .. } => "stochastic",
        }
    }

    /// `numberOfTestRuns` of a stochastic variation (None if not given).
    #[getter]
    fn number_of_test_runs(&self) -> Option<u64> {
        match self.inner.variation {
            Variation::Stochastic { runs, .. } => runs,
            Variation::Deterministic => None,
        }
    }

    /// The varied parameters' names, in file order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inner
            .parameters
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// The φ-space: one variable per parameter, continuous ones in `bins` linear bins.
    #[pyo3(signature = (bins = 10))]
    fn space(&self, bins: i128) -> PyResult<PySpace> {
        Ok(PySpace {
            space: (self.inner)
                .space(crate::convert::whole("bins", bins)?)
                .map_err(errors::value)?,
        })
    }

    /// The nominal of every parameter that is not uniform, as `Kernel.estimation(nominal=
    /// {scenario: this})` takes it: `{variable: {"distribution": ...}}`.
    #[getter]
    fn nominal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.inner.nominal())
    }

    /// Where each parameter's distribution is: `{name: {"element": ..., "line": ...}}`.
    #[getter]
    fn declared_at<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let out = PyDict::new(py);
        for p in &self.inner.parameters {
            let at = PyDict::new(py);
            at.set_item("element", &p.element)?;
            at.set_item("line", p.line)?;
            out.set_item(&p.name, at)?;
        }
        Ok(out)
    }

    fn __repr__(&self) -> String {
        format!(
            "ParameterVariation({:?}, {} parameters, {})",
            self.inner.path.display().to_string(),
            self.inner.parameters.len(),
            self.variation()
        )
    }
}

/// Reads a `ParameterValueDistribution` file; ValueError naming the file, line and element
/// of what is wrong.
#[pyfunction]
pub fn read_openscenario(path: PathBuf) -> PyResult<PyParameterVariation> {
    Ok(PyParameterVariation {
        inner: ParameterDistribution::read(&path).map_err(errors::value)?,
    })
}

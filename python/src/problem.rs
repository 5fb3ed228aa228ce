//! `savme.Problem`: what a campaign searches — the fidelity space with θ_HF and each
//! scenario's φ-space.

use crate::convert;
use crate::space::PySpace;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use savme::campaign::Problem;
use std::collections::BTreeMap;

/// What a campaign searches: the fidelity space with θ_HF, and each scenario's φ-space.
#[pyclass(name = "Problem", module = "savme", frozen)]
#[derive(Clone)]
pub struct PyProblem {
    pub problem: Problem,
}

#[pymethods]
impl PyProblem {
    #[new]
    #[pyo3(signature = (*, fidelity, theta_hf, scenarios))]
    fn new(
        fidelity: PyRef<'_, PySpace>,
        theta_hf: &Bound<'_, PyDict>,
        scenarios: &Bound<'_, PyDict>,
    ) -> PyResult<Self> {
        let mut by_name = BTreeMap::new();
        for (k, v) in scenarios.iter() {
            let name: String = k.extract()?;
            let space = v.cast::<PySpace>().map_err(|_| {
                PyTypeError::new_err(format!("scenarios: scenario `{name}` needs a savme.Space"))
            })?;
            by_name.insert(name, space.get().space.clone());
        }
        let theta_hf = convert::assignment("theta_hf", theta_hf, &fidelity.space)?;
        fidelity
            .space
            .arms_of(&theta_hf)
            .map_err(|e| PyValueError::new_err(format!("high-fidelity settings θ_HF: {e}")))?;
        Ok(PyProblem {
            problem: Problem {
                fidelity: fidelity.space.clone(),
                theta_hf,
                scenarios: by_name,
            },
        })
    }

    /// The bundled driving simulator's problem: Table I with `bins` per continuous setting,
    /// θ_HF and the ten scenarios.
    #[staticmethod]
    #[pyo3(signature = (bins = 10))]
    fn driving(bins: i128) -> PyResult<Self> {
        Ok(PyProblem {
            problem: Problem::from(savme_sim::problem(crate::convert::whole("bins", bins)?)),
        })
    }

    /// The scenarios' names.
    #[getter]
    fn scenarios(&self) -> Vec<String> {
        self.problem.scenarios.keys().cloned().collect()
    }

    fn __repr__(&self) -> String {
        format!(
            "Problem(fidelity={} settings, scenarios={:?})",
            self.problem.fidelity.len(),
            self.scenarios()
        )
    }
}

//! What the kernel hands out and gives back: `Trial`, `Record`, `Posterior`.

use crate::convert;
use crate::errors;
use pyo3::exceptions::{PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString, PyType};
use savme_kernel::{Assignment, Posterior, Run, Trial, TrialRecord};
use std::sync::Arc;

/// The value of variable `name` of `a` (`what`: "phi" or "theta_lf") as a `kind` (bool, int,
/// float or str): an int is taken as a float, nothing else is converted.
fn typed<'py>(
    py: Python<'py>,
    a: &Assignment,
    what: &str,
    name: &str,
    kind: &Bound<'py, PyType>,
) -> PyResult<Bound<'py, PyAny>> {
    let value = a.get(name).ok_or_else(|| {
        let known: Vec<&str> = a.iter().map(|(n, _)| n).collect();
        PyKeyError::new_err(format!(
            "{what} has no variable `{name}` (it has: {})",
            known.join(", ")
        ))
    })?;
    let v = convert::to_py(py, value)?;
    let is_bool = v.is_instance_of::<PyBool>();
    let ok = if kind.is(py.get_type::<PyFloat>()) {
        if (v.is_instance_of::<PyInt>() || v.is_instance_of::<PyFloat>()) && !is_bool {
            return Ok(PyFloat::new(py, v.extract::<f64>()?).into_any());
        }
        false
    } else if kind.is(py.get_type::<PyInt>()) {
        v.is_instance_of::<PyInt>() && !is_bool
    } else if kind.is(py.get_type::<PyBool>()) {
        is_bool
    } else if kind.is(py.get_type::<PyString>()) {
        v.is_instance_of::<PyString>()
    } else {
        return Err(PyTypeError::new_err(format!(
            "{what}[{name:?}]: the kind must be bool, int, float or str, got {kind}"
        )));
    };
    if ok {
        Ok(v)
    } else {
        Err(PyTypeError::new_err(format!(
            "{what}[{name:?}] is {} {v}, not a {}",
            v.get_type().name()?,
            kind.name()?
        )))
    }
}

/// A suggested trial: run `scenario` with `phi` on the high-fidelity simulator and, unless
/// this is a baseline trial, on the learned-fidelity one with `theta_lf`.
#[pyclass(name = "Trial", module = "savme", frozen)]
pub struct PyTrial {
    pub trial: Trial,
}

#[pymethods]
impl PyTrial {
    /// Unique id, counting up from 0 in ask order.
    #[getter]
    fn id(&self) -> u64 {
        self.trial.id
    }

    /// The phase the trial was asked in: "train", "evaluate", "baseline" or "test".
    #[getter]
    fn phase(&self) -> String {
        self.trial.phase.to_string()
    }

    /// The scenario's name.
    #[getter]
    fn scenario(&self) -> &str {
        &self.trial.scenario
    }

    /// Scenario parameters φ, in space order.
    #[getter]
    fn phi<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        convert::dict(py, &self.trial.phi)
    }

    /// Learned-fidelity settings θ_LF in space order; None for a baseline trial.
    #[getter]
    fn theta_lf<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.trial
            .theta_lf
            .as_ref()
            .map(|a| convert::dict(py, a))
            .transpose()
    }

    /// True when the trial needs both runs: it has a θ_LF (every phase but baseline, unless
    /// the kernel's pairing left a learning trial HF only).
    #[getter]
    fn paired(&self) -> bool {
        self.trial.theta_lf.is_some()
    }

    /// The trial as a dict (the JSON of `savme serve`'s trials).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::json_to_py(py, &self.trial)
    }

    /// A trial from `to_dict()` output (or a trial of `savme serve`'s JSON); ValueError says
    /// which field is wrong. Telling it to a kernel still requires it to be that kernel's
    /// pending trial.
    #[staticmethod]
    fn from_dict(py: Python<'_>, d: &Bound<'_, PyAny>) -> PyResult<Self> {
        let text: String = py.import("json")?.call_method1("dumps", (d,))?.extract()?;
        let trial = serde_json::from_str(&text)
            .map_err(|e| PyValueError::new_err(format!("Trial.from_dict: {e}")))?;
        Ok(PyTrial { trial })
    }

    /// φ's variable `name` as a `kind` (bool, int, float or str), for code a type checker
    /// reads: `trial.phi_as("gap_m", float) < 15`. An int is given as a float; any other
    /// mismatch raises TypeError naming the variable, an unknown name KeyError.
    fn phi_as<'py>(
        &self,
        py: Python<'py>,
        name: &str,
        kind: &Bound<'py, PyType>,
    ) -> PyResult<Bound<'py, PyAny>> {
        typed(py, &self.trial.phi, "phi", name, kind)
    }

    /// θ_LF's setting `name` as a `kind`, as [`phi_as`](PyTrial::phi_as); a baseline trial
    /// (no θ_LF) raises ValueError.
    fn theta_as<'py>(
        &self,
        py: Python<'py>,
        name: &str,
        kind: &Bound<'py, PyType>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let theta = self.trial.theta_lf.as_ref().ok_or_else(|| {
            PyValueError::new_err(format!(
                "trial {} is a {} trial without theta_lf (only the HF run)",
                self.trial.id, self.trial.phase
            ))
        })?;
        typed(py, theta, "theta_lf", name, kind)
    }

    /// A trial from its JSON (pickling's state).
    #[staticmethod]
    fn _from_json(text: &str) -> PyResult<Self> {
        let trial =
            serde_json::from_str(text).map_err(|e| PyValueError::new_err(format!("Trial: {e}")))?;
        Ok(PyTrial { trial })
    }

    /// Pickling (`multiprocessing`, `copy.deepcopy`): the trial exactly, through its JSON.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let text = serde_json::to_string(&slf.get().trial).map_err(errors::value)?;
        Ok((slf.get_type().getattr("_from_json")?, (text,)))
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyTrial>()
            .is_ok_and(|o| o.get().trial == self.trial)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let t = &self.trial;
        let lf = match self.theta_lf(py)? {
            Some(d) => d.repr()?.to_string(),
            None => "None".to_string(),
        };
        Ok(format!(
            "Trial(id={}, phase='{}', scenario={}, phi={}, theta_lf={lf})",
            t.id,
            t.phase,
            PyString::new(py, &t.scenario).repr()?,
            self.phi(py)?.repr()?
        ))
    }
}

/// A told trial: the trial, the runs, the outcome, the cost ratio and what was credited.
#[pyclass(name = "Record", module = "savme", frozen)]
pub struct PyRecord {
    /// Shared with the kernel's history (`Kernel.trials()`), never changed.
    pub record: Arc<TrialRecord>,
}

fn run_tuple(r: &Run) -> (bool, f64) {
    (r.failure, r.runtime)
}

#[pymethods]
impl PyRecord {
    /// The trial as it was asked.
    #[getter]
    fn trial(&self) -> PyTrial {
        PyTrial {
            trial: self.record.trial.clone(),
        }
    }

    /// The trial's id.
    #[getter]
    fn id(&self) -> u64 {
        self.record.trial.id
    }

    /// "TP", "TN", "FP" or "FN" (HF failure vs LF failure); None for a baseline trial.
    #[getter]
    fn outcome(&self) -> Option<String> {
        self.record.outcome.map(|o| format!("{o:?}"))
    }

    /// t_LF / t_HF; None for a baseline trial.
    #[getter]
    fn cost_ratio(&self) -> Option<f64> {
        self.record.cost_ratio
    }

    /// What the bandits were credited: {"fidelity": bool | None, "scenario": bool | None}
    /// (None: not updated — evaluation and baseline trials).
    #[getter]
    fn credit<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("fidelity", self.record.credit.fidelity)?;
        d.set_item("scenario", self.record.credit.scenario)?;
        Ok(d)
    }

    /// The HF run as (failure, runtime).
    #[getter]
    fn hf(&self) -> (bool, f64) {
        run_tuple(self.record.observation.hf())
    }

    /// The LF run as (failure, runtime); None for a baseline trial.
    #[getter]
    fn lf(&self) -> Option<(bool, f64)> {
        self.record.observation.lf().map(run_tuple)
    }

    /// The HF run's robustness, if it was told one.
    #[getter]
    fn hf_robustness(&self) -> Option<f64> {
        self.record.observation.hf().robustness
    }

    /// The LF run's robustness, if it was told one (None for a baseline trial).
    #[getter]
    fn lf_robustness(&self) -> Option<f64> {
        self.record.observation.lf().and_then(|r| r.robustness)
    }

    /// The record as a dict (the JSON of `savme serve`'s records and of journal tell lines).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::json_to_py(py, &*self.record)
    }

    /// A record from its JSON (pickling's state).
    #[staticmethod]
    fn _from_json(text: &str) -> PyResult<Self> {
        let record = serde_json::from_str(text)
            .map_err(|e| PyValueError::new_err(format!("Record: {e}")))?;
        Ok(PyRecord {
            record: Arc::new(record),
        })
    }

    /// Pickling (`multiprocessing`, `copy.deepcopy`): the record exactly, through its JSON.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let text = serde_json::to_string(&*slf.get().record).map_err(errors::value)?;
        Ok((slf.get_type().getattr("_from_json")?, (text,)))
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyRecord>()
            .is_ok_and(|o| o.get().record == self.record)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let outcome = self.outcome().map_or("None".into(), |o| format!("'{o}'"));
        let ratio = self
            .record
            .cost_ratio
            .map_or("None".into(), |r| format!("{r:?}"));
        Ok(format!(
            "Record(id={}, outcome={outcome}, cost_ratio={ratio}, credit={})",
            self.record.trial.id,
            self.credit(py)?.repr()?
        ))
    }
}

/// Beta beliefs over the arms of a space (p_ω(θ_LF), or a scenario's p_ψ(φ | s)).
#[pyclass(name = "Posterior", module = "savme", frozen)]
pub struct PyPosterior {
    pub posterior: Posterior,
}

#[pymethods]
impl PyPosterior {
    /// The variables' names, in space order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.posterior.names().to_vec()
    }

    /// The (alpha, beta) of every arm of the variable `name`.
    fn arms(&self, name: &str) -> PyResult<Vec<(f64, f64)>> {
        let arms = self
            .posterior
            .variable(name)
            .ok_or_else(|| convert::unknown("variable", name, self.posterior.names()))?;
        Ok(arms.iter().map(|a| (a.alpha, a.beta)).collect())
    }

    /// The posterior mean of every arm of the variable `name`.
    fn means(&self, name: &str) -> PyResult<Vec<f64>> {
        let arms = self
            .posterior
            .variable(name)
            .ok_or_else(|| convert::unknown("variable", name, self.posterior.names()))?;
        Ok(arms.iter().map(|a| a.mean()).collect())
    }

    /// The base prior counts (successes, losses).
    #[getter]
    fn prior(&self) -> (f64, f64) {
        let p = self.posterior.prior();
        (p.successes, p.losses)
    }

    /// The posterior as JSON (to save it and carry it over to a meta-testing kernel).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.posterior).map_err(errors::value)
    }

    /// A posterior from `to_json()` output.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        Ok(PyPosterior {
            posterior: serde_json::from_str(text).map_err(errors::value)?,
        })
    }

    /// The posterior as a dict: {"prior": …, "names": […], "arms": [[{"alpha", "beta"}, …], …]}.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::json_to_py(py, &self.posterior)
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyPosterior>()
            .is_ok_and(|o| o.get().posterior == self.posterior)
    }

    fn __repr__(&self) -> String {
        format!("Posterior(names={:?})", self.posterior.names())
    }
}

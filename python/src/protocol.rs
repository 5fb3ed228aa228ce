//! `savme.Protocol` and `savme.PROTOCOL_VALUES`: the paper's protocol, each value read by the
//! name every front end shares (`savme::campaign::values`).

use crate::convert;
use crate::errors;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use savme::campaign::config::Overrides;
use savme::campaign::{Method, OnError, Protocol};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// What the campaign's protocol is: stages, iterations, budgets, seeds, scenarios.
#[pyclass(name = "Protocol", module = "savme", frozen)]
#[derive(Clone)]
pub struct PyProtocol {
    pub protocol: Protocol,
}

/// `savme.PROTOCOL_VALUES`: every protocol value as declared once (name — the keyword of
/// `Protocol`, the `[campaign]` key —, the `savme` flag, help text, the stages it changes).
pub fn protocol_values(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    let values: Vec<serde_json::Value> = savme::campaign::values::VALUES
        .iter()
        .map(|v| {
            serde_json::json!({
                "name": v.name,
                "flag": format!("--{}", v.flag),
                "help": v.help.trim(),
                "stages": v.stages,
                "in_protocol": v.in_protocol,
            })
        })
        .collect();
    convert::json_to_py(py, &values)
}

/// Protocol values given as keyword arguments, read by the names every front end shares
/// ([`savme::campaign::values`]); `None` means "not given".
pub fn overrides(values: Option<&Bound<'_, PyDict>>) -> PyResult<Overrides> {
    let Some(values) = values else {
        return Ok(Overrides::default());
    };
    let json = values.py().import("json")?;
    let mut entries = Vec::new();
    for (k, v) in values.iter() {
        if v.is_none() {
            continue;
        }
        let key: String = k.extract()?;
        let text: String = json
            .call_method1("dumps", (&v,))
            .and_then(|t| t.extract())
            .map_err(|e| PyTypeError::new_err(format!("{key}: {e}")))?;
        let value: serde_json::Value = serde_json::from_str(&text).map_err(errors::value)?;
        entries.push((key, value));
    }
    Overrides::from_entries(entries).map_err(|e| {
        if e.message.starts_with("not a protocol value") {
            PyTypeError::new_err(format!("unexpected keyword argument {e}"))
        } else {
            PyValueError::new_err(e.to_string())
        }
    })
}

fn on_error(name: &str) -> PyResult<OnError> {
    match name {
        "abort" => Ok(OnError::Abort),
        "skip" => Ok(OnError::Skip),
        other => Err(PyValueError::new_err(format!(
            "on_error must be \"abort\" or \"skip\", got {other:?}"
        ))),
    }
}

#[pymethods]
impl PyProtocol {
    /// The paper's protocol (or the quick preset) for the given scenarios, with any protocol
    /// value given by its name (`seed`, `budgets`, `train_iterations`, …: the names of
    /// `savme.PROTOCOL_VALUES`, the same as `savme run`'s flags and a campaign file's
    /// `[campaign]` keys); validated (a ValueError names the value).
    #[new]
    #[pyo3(signature = (train_scenarios, test_scenarios, *, preset = "paper", simulator = "python",
        weights = None, on_error = None, **values))]
    fn new(
        train_scenarios: Vec<String>,
        test_scenarios: Vec<String>,
        preset: &str,
        simulator: &str,
        weights: Option<BTreeMap<String, f64>>,
        on_error: Option<&str>,
        values: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mut p = match preset {
            "paper" => Protocol::paper(simulator, train_scenarios, test_scenarios),
            "quick" => Protocol::quick(simulator, train_scenarios, test_scenarios),
            other => {
                return Err(PyValueError::new_err(format!(
                    "preset must be \"paper\" or \"quick\", got {other:?}"
                )))
            }
        }
        // savme's tuned search unless `method="paper"` is given (the preset is the length).
        .with_method(Method::Tuned);
        let o = overrides(values)?;
        if o.repeat.is_some() {
            return Err(PyValueError::new_err(
                "repeat: not part of a protocol; give it to Campaign(..., repeat=N)",
            ));
        }
        let lookup = |k: &str| Some(k.to_string());
        o.apply(&mut p, &lookup, "").map_err(errors::value)?;
        if let Some(w) = weights {
            p.weights = w;
        }
        if let Some(e) = on_error {
            p.on_error = self::on_error(e)?;
        }
        p.validate().map_err(errors::value)?;
        Ok(PyProtocol { protocol: p })
    }

    /// The protocol as JSON (`protocol.json` of a campaign directory).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.protocol).map_err(errors::value)
    }

    /// The protocol as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::json_to_py(py, &self.protocol)
    }

    /// The protocol saved in a campaign directory (`protocol.json`).
    #[staticmethod]
    fn load(out: PathBuf) -> PyResult<Self> {
        let protocol = savme::campaign::load_protocol(&out).map_err(errors::campaign)?;
        Ok(PyProtocol { protocol })
    }

    /// How many trials the campaign runs in all; None when a stage runs by a cost budget
    /// (`search_budget`, `deploy_budget`): its number of trials is not known in advance.
    #[getter]
    fn total_trials(&self) -> Option<u64> {
        self.protocol.known_total_trials()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyProtocol>()
            .is_ok_and(|o| o.get().protocol == self.protocol)
    }

    fn __repr__(&self) -> String {
        let p = &self.protocol;
        format!(
            "Protocol(simulator={:?}, seed={}, budgets={:?}, trials={})",
            p.simulator,
            p.seed,
            p.budgets,
            p.known_total_trials()
                .map_or("by cost".to_string(), |n| n.to_string())
        )
    }
}

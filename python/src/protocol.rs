//! `savme.Protocol` and `savme.PROTOCOL_VALUES`: the paper's protocol, each value read by the
//! name every front end shares (`savme::campaign::values`).

use crate::convert;
use crate::errors;
use pyo3::exceptions::{PyKeyError, PyTypeError, PyValueError};
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
        entries.push((key.clone(), json_value(&json, &key, &v)?));
    }
    Overrides::from_entries(entries).map_err(|e| {
        if e.message.starts_with("not a protocol value") {
            PyTypeError::new_err(format!("unexpected keyword argument {e}"))
        } else {
            PyValueError::new_err(e.to_string())
        }
    })
}

/// The protocol value `key` = `v` as JSON (through Python's `json`, so that what
/// `json.dumps` takes is what a campaign file's TOML would give). NaN and infinities — which
/// JSON has no words for — and ints beyond 64 bits are refused naming the key and the value.
fn json_value(
    json: &Bound<'_, PyModule>,
    key: &str,
    v: &Bound<'_, PyAny>,
) -> PyResult<serde_json::Value> {
    let kwargs = PyDict::new(v.py());
    kwargs.set_item("allow_nan", false)?;
    let text: String = match json.call_method("dumps", (v,), Some(&kwargs)) {
        Ok(t) => t.extract()?,
        Err(e) if e.is_instance_of::<PyValueError>(v.py()) => {
            return Err(PyValueError::new_err(format!(
                "{key} = {}: not a finite number (NaN and infinity are refused)",
                v.repr()?
            )))
        }
        Err(e) => return Err(PyTypeError::new_err(format!("{key}: {e}"))),
    };
    if let Some(n) = too_large(v)? {
        let given = v.repr()?.to_string();
        let which = if given == n { "it" } else { n.as_str() };
        return Err(PyValueError::new_err(format!(
            "{key} = {given}: {which} does not fit in 64 bits"
        )));
    }
    serde_json::from_str(&text).map_err(|e| PyValueError::new_err(format!("{key} = {text}: {e}")))
}

/// The first int in `v` (itself, or an item of a list, tuple or dict) that does not fit in
/// 64 bits: JSON parsing would turn it into a float.
fn too_large(v: &Bound<'_, PyAny>) -> PyResult<Option<String>> {
    use pyo3::types::{PyBool, PyInt, PyList, PyTuple};
    if v.is_instance_of::<PyInt>() && !v.is_instance_of::<PyBool>() {
        let fits = v.extract::<i64>().is_ok() || v.extract::<u64>().is_ok();
        return Ok((!fits).then(|| v.to_string()));
    }
    let items = if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        v.try_iter()?.collect::<PyResult<Vec<_>>>()?
    } else if let Ok(d) = v.cast::<PyDict>() {
        d.values().iter().collect()
    } else {
        return Ok(None);
    };
    for item in items {
        if let Some(n) = too_large(&item)? {
            return Ok(Some(n));
        }
    }
    Ok(None)
}

/// A list of scenario names (`train_scenarios`, `test_scenarios`): a str is refused, not
/// split into its characters.
fn scenario_names(which: &str, names: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    if names.is_instance_of::<pyo3::types::PyString>() {
        return Err(PyTypeError::new_err(format!(
            "{which} must be a list of scenario names, got the str {}; give [{}] for one scenario",
            names.repr()?,
            names.repr()?
        )));
    }
    let items = names.try_iter().map_err(|_| {
        PyTypeError::new_err(format!(
            "{which} must be a list of scenario names, got {}",
            names
                .get_type()
                .name()
                .map_or_else(|_| "?".into(), |n| n.to_string())
        ))
    })?;
    items
        .enumerate()
        .map(|(i, name)| {
            let name = name?;
            name.extract::<String>().map_err(|_| {
                PyTypeError::new_err(format!(
                    "{which}[{i}]: a scenario name must be a str, got {}",
                    name.repr().map_or_else(|_| "?".into(), |r| r.to_string())
                ))
            })
        })
        .collect()
}

/// `weights=`: each key must be one of the protocol's scenarios (a misspelt one weighed
/// nothing, silently).
fn check_weights(p: &Protocol, weights: &BTreeMap<String, f64>) -> PyResult<()> {
    let known = || p.train_scenarios.iter().chain(&p.test_scenarios);
    match weights.keys().find(|k| !known().any(|s| s == *k)) {
        Some(unknown) => Err(PyKeyError::new_err(format!(
            "weights: unknown scenario `{unknown}` (the protocol's scenarios: {})",
            known().map(String::as_str).collect::<Vec<_>>().join(", ")
        ))),
        None => Ok(()),
    }
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
        train_scenarios: &Bound<'_, PyAny>,
        test_scenarios: &Bound<'_, PyAny>,
        preset: &str,
        simulator: &str,
        weights: Option<BTreeMap<String, f64>>,
        on_error: Option<&str>,
        values: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let train_scenarios = scenario_names("train_scenarios", train_scenarios)?;
        let test_scenarios = scenario_names("test_scenarios", test_scenarios)?;
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
            check_weights(&p, &w)?;
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

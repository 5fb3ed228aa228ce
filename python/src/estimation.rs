//! `savme.Estimation`: P(failure) under the nominal distribution by importance sampling from
//! a kernel's learned posteriors (`Kernel.estimation(...)`; the maths is
//! `savme_kernel::estimation`, the method docs/ESTIMATION.md).

use crate::convert;
use crate::errors;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use savme_kernel::estimation::{
    Control, Estimation, EstimationConfig, Fidelity, Joint, Nominal, Refine, Tilt, MAX_COMPONENTS,
};
use savme_kernel::Kernel;
use std::collections::BTreeMap;
use std::sync::Mutex;

/// An importance-sampling estimation: `ask()` a trial (φ drawn from the fixed proposal, or
/// None while a refinement round waits for its outcomes), run the HF simulator on it,
/// `tell(id, failure)`, and read `estimate()`.
#[pyclass(name = "Estimation", module = "savme", frozen)]
pub struct PyEstimation {
    estimation: Mutex<Estimation>,
}

/// `control_calibration=` and `control_extra=` as the kernel's control variates (the extra
/// runs alone are refused: they need the calibration).
fn control_of(given: (Option<u64>, Option<u32>)) -> PyResult<Option<Control>> {
    match given {
        (None, None) => Ok(None),
        (None, Some(k)) => Err(PyValueError::new_err(format!(
            "control_extra: {k} extra LF runs per pair need control_calibration (the control variates' calibration pairs) too"
        ))),
        (Some(calibration), extra) => Ok(Some(Control { calibration, extra })),
    }
}

/// The kernel's `estimation(...)` arguments as a configuration; errors name the argument.
// Python keyword arguments, one parameter each.
#[allow(clippy::too_many_arguments)]
pub fn config(
    py: Python<'_>,
    epsilon: f64,
    seed: u64,
    nominal: Option<&Bound<'_, PyAny>>,
    tilt: &str,
    refine: Option<(u32, u64)>,
    refine_reuse: u32,
    joint_components: Option<u32>,
    pilot_fidelity: &str,
    control: (Option<u64>, Option<u32>),
) -> PyResult<EstimationConfig> {
    let control = control_of(control)?;
    let pilot_fidelity = match pilot_fidelity {
        "hf" => Fidelity::Hf,
        "lf" if refine.is_none() => {
            return Err(PyValueError::new_err(
                "pilot_fidelity: \"lf\" runs the cross-entropy pilot rounds at the learned low fidelity: give refine=(rounds, runs) too",
            ))
        }
        "lf" if refine_reuse > 0 => {
            return Err(PyValueError::new_err(format!(
                "refine_reuse: {refine_reuse} pilot rounds to reuse, but the pilot runs at low fidelity (pilot_fidelity=\"lf\"): LF outcomes are not the HF failures the estimate is about; leave it at 0"
            )))
        }
        "lf" => Fidelity::Lf,
        other => {
            return Err(PyValueError::new_err(format!(
                "pilot_fidelity: expected \"hf\" or \"lf\", got {other:?}"
            )))
        }
    };
    if refine.is_none() && refine_reuse > 0 {
        return Err(PyValueError::new_err(format!(
            "refine_reuse: {refine_reuse} pilot rounds to reuse, but no refine=(rounds, runs)"
        )));
    }
    match (joint_components, refine) {
        (Some(k), _) if k == 0 || k > MAX_COMPONENTS => {
            return Err(PyValueError::new_err(format!(
                "joint_components: must lie in 1..={MAX_COMPONENTS}, got {k}"
            )))
        }
        (Some(_), None) => {
            return Err(PyValueError::new_err(
                "joint_components: the joint proposal is fitted by the cross-entropy pilot rounds: give refine=(rounds, runs) too",
            ))
        }
        _ => {}
    }
    // The kernel's own names for the tilts (its serde form), so there is one list of them.
    let tilt: Tilt =
        serde_json::from_value(serde_json::Value::String(tilt.into())).map_err(|_| {
            PyValueError::new_err(format!(
                "tilt: unknown tilt {tilt:?}: expected \"posterior\" or \"nominal-weighted\""
            ))
        })?;
    let nominal = match nominal {
        None => BTreeMap::new(),
        Some(n) => {
            if !n.is_instance_of::<PyDict>() {
                return Err(PyTypeError::new_err(format!(
                    "nominal: expected {{scenario: {{variable: {{\"distribution\": ...}}}}}}, got {}",
                    n.get_type().name()?
                )));
            }
            let text: String = py.import("json")?.call_method1("dumps", (n,))?.extract()?;
            serde_json::from_str::<BTreeMap<String, BTreeMap<String, Nominal>>>(&text).map_err(
                |e| {
                    PyValueError::new_err(format!(
                        "nominal: {e} (a variable's nominal is {{\"distribution\": \"uniform\"}}, {{\"distribution\": \"normal\", \"mean\": M, \"sd\": S}}, {{\"distribution\": \"lognormal\", \"mu\": M, \"sigma\": S}}, {{\"distribution\": \"histogram\", \"edges\": [...], \"weights\": [...]}} or {{\"distribution\": \"weights\", \"weights\": [...]}})"
                    ))
                },
            )?
        }
    };
    Ok(EstimationConfig {
        epsilon,
        seed,
        nominal,
        tilt,
        refine: refine.map(|(rounds, runs)| Refine {
            rounds,
            runs,
            reuse: refine_reuse,
        }),
        joint: joint_components.map(|components| Joint { components }),
        pilot_fidelity,
        control,
    })
}

impl PyEstimation {
    /// The estimation of `kernel`'s current posteriors with `config` (`ValueError` naming ε,
    /// the refinement, the scenario or the variable).
    pub fn of(kernel: &Kernel, config: &EstimationConfig) -> PyResult<Self> {
        let estimation = kernel.estimation(config).map_err(errors::value)?;
        Ok(PyEstimation {
            estimation: Mutex::new(estimation),
        })
    }

    fn with<T>(&self, f: impl FnOnce(&mut Estimation) -> PyResult<T>) -> PyResult<T> {
        let mut guard = self
            .estimation
            .lock()
            .map_err(|_| PyValueError::new_err("the estimation is poisoned by an earlier panic"))?;
        f(&mut guard)
    }
}

#[pymethods]
impl PyEstimation {
    /// The next trial as a dict — `id`, `scenario`, `phi`, `q`, `p`, `weight`, `round`
    /// (the refinement round, None for a trial of the estimate) and, for a pilot trial of a
    /// multi-fidelity estimation or an LF run of the control variates, `"fidelity": "lf"`
    /// (run it at θ_LF*; every other trial runs HF), and with control variates `control`
    /// (`"calibration"`, `"paired"`: a pair's HF and LF runs, consecutive trials with the
    /// same φ; `"extra"`: an LF-only run) — or None while a refinement round or the
    /// calibration has asked all its trials and waits for their outcomes.
    fn ask<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let trial = self.with(|e| Ok(e.ask()))?;
        trial.map(|t| convert::json_to_py(py, &t)).transpose()
    }

    /// Takes the outcome of trial `id` (HF; LF for a trial marked `"fidelity": "lf"`) (`savme.TellError` for a trial not pending), with
    /// the run's robustness if it has one (a joint proposal's pilot aims at near-misses),
    /// and its cost (finite, ≥ 0, any unit: the control variates' calibration compares the
    /// LF and HF runs' mean costs; without costs it takes them as equal).
    #[pyo3(signature = (id, failure, *, robustness = None, cost = None))]
    fn tell(
        &self,
        id: i128,
        failure: bool,
        robustness: Option<f64>,
        cost: Option<f64>,
    ) -> PyResult<()> {
        let id = convert::whole("id", id)?;
        self.with(|e| {
            e.tell_measured(id, failure, robustness, cost)
                .map_err(|e| errors::TellError::new_err(e.to_string()))
        })
    }

    /// The estimate so far as a dict: `total` (`mean`, `std_error`, `half_width`, `lo`, `hi`),
    /// `runs`, `failures` and per scenario the same with the effective sample sizes (and,
    /// with control variates, `control`: the calibration's `plan` — ρ, α, extra LF runs per
    /// pair, whether the LF is used — and the LF runs). Only the trials after the refinement
    /// (and the calibration) count.
    fn estimate<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let estimate = self.with(|e| Ok(e.estimate()))?;
        convert::json_to_py(py, &estimate)
    }

    /// Trials told so far, refinement and estimate together.
    #[getter]
    fn told(&self) -> PyResult<u64> {
        self.with(|e| Ok(e.told()))
    }

    /// The refinement round under way (None: no refinement, or it is over).
    #[getter]
    fn round(&self) -> PyResult<Option<u32>> {
        self.with(|e| Ok(e.round()))
    }

    fn __repr__(&self) -> PyResult<String> {
        self.with(|e| {
            let names: Vec<String> = e.scenarios().iter().map(|s| format!("'{s}'")).collect();
            Ok(format!(
                "Estimation(scenarios=[{}], told={})",
                names.join(", "),
                e.told()
            ))
        })
    }
}

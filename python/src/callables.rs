//! Python callables as a campaign's simulator (`PySimulator`): `hf`/`lf(scenario, phi,
//! theta)`, their results read (`sim_result`) and their exceptions kept for chaining.

use crate::convert;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator};
use std::sync::Arc;
use std::time::Instant;

/// Python callables as the campaign's simulator: `hf(scenario, phi, theta)` and
/// `lf(scenario, phi, theta)` (the same callable for both is fine). Each returns the failure
/// flag, `(failure, work_units)`, or `(failure, work_units or None, robustness)`; the wall time of the call is measured here. The GIL is
/// taken only around the call.
#[derive(Clone)]
pub struct PySimulator {
    pub(crate) hf: Arc<Py<PyAny>>,
    pub(crate) lf: Arc<Py<PyAny>>,
    /// The first exception a callable raised: the campaign's error is chained to it
    /// (`raise CampaignError(...) from exc`), so that its traceback is kept.
    pub(crate) raised: Raised,
}

/// The first exception a Python simulator raised, shared by its clones (one per worker).
pub type Raised = Arc<std::sync::Mutex<Option<PyErr>>>;

impl PySimulator {
    pub(crate) fn new(hf: Arc<Py<PyAny>>, lf: Arc<Py<PyAny>>) -> PySimulator {
        PySimulator {
            hf,
            lf,
            raised: Raised::default(),
        }
    }
}

/// Where `e` was raised: ` (at FILE:LINE, in FUNCTION)` of its innermost frame, or nothing.
fn raised_at(py: Python<'_>, e: &PyErr) -> String {
    let frame = (|| -> PyResult<String> {
        let tb = e
            .traceback(py)
            .ok_or_else(|| PyValueError::new_err("no traceback"))?;
        let frames = py.import("traceback")?.call_method1("extract_tb", (tb,))?;
        let last = frames.get_item(-1)?;
        let (file, line, name): (String, u32, String) = (
            last.getattr("filename")?.extract()?,
            last.getattr("lineno")?.extract()?,
            last.getattr("name")?.extract()?,
        );
        Ok(format!(" (at {file}:{line}, in {name})"))
    })();
    frame.unwrap_or_default()
}

pub fn sim_result(out: &Bound<'_, PyAny>, wall: f64) -> Result<SimResult, String> {
    // The flag alone, the first of (failure, work_units), or of (failure, work_units or None,
    // robustness).
    let tuple = out.cast::<PyTuple>().ok();
    let pair = tuple.and_then(|t| t.extract::<(Bound<'_, PyAny>, u64)>().ok());
    let triple = tuple.and_then(|t| t.extract::<(Bound<'_, PyAny>, Option<u64>, f64)>().ok());
    let (flag, work, robustness) = match (pair, triple) {
        (Some((flag, work)), _) => (flag, Some(work), None),
        (None, Some((flag, work, rho))) => (flag, work, Some(rho)),
        (None, None) => (out.clone(), None, None),
    };
    let kind = match crate::convert::failure_flag(&flag) {
        Ok(failure) => {
            let result = SimResult::new(failure, wall, work);
            return match robustness {
                Some(rho) if !rho.is_finite() => Err(format!(
                    "a simulator's robustness must be a finite number, got {rho}"
                )),
                Some(rho) => Ok(result.with_robustness(rho)),
                None => Ok(result),
            };
        }
        Err(kind) => kind,
    };
    Err(format!(
        "a simulator must return the failure flag (bool or numpy bool), (failure, work_units) or (failure, work_units or None, robustness), got {kind} {flag}"
    ))
}

impl Simulator for PySimulator {
    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        let (f, name) = match role {
            Role::High => (&self.hf, "hf"),
            Role::Learned => (&self.lf, "lf"),
        };
        Python::attach(|py| {
            let args = (
                scenario,
                convert::dict(py, phi).map_err(|e| SimError::Failed(e.to_string()))?,
                convert::dict(py, fidelity).map_err(|e| SimError::Failed(e.to_string()))?,
            );
            let start = Instant::now();
            let out = f.call1(py, args);
            let wall = start.elapsed().as_secs_f64();
            let out = out.map_err(|e| {
                let message = format!("the `{name}` simulator raised {e}{}", raised_at(py, &e));
                let mut first = self.raised.lock().unwrap_or_else(|p| p.into_inner());
                if first.is_none() {
                    *first = Some(e);
                }
                SimError::Failed(message)
            })?;
            sim_result(out.bind(py), wall)
                .map_err(|m| SimError::Failed(format!("the `{name}` simulator: {m}")))
        })
    }
}

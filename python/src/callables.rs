//! Python callables as a campaign's simulator (`PySimulator`): `hf`/`lf(scenario, phi,
//! theta)`, their results read (`sim_result`) and their exceptions kept for chaining.

use crate::convert;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use savme::campaign::Stop;
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
    /// A `KeyboardInterrupt`, `SystemExit` (any `BaseException` that is no `Exception`) a
    /// callable raised: the campaign stops between trials and `run` raises it as it was.
    pub(crate) interrupt: Raised,
    /// The campaign's stop, requested when a callable raises such an exception.
    pub(crate) stop: Stop,
}

/// The first exception a Python simulator raised, shared by its clones (one per worker).
pub type Raised = Arc<std::sync::Mutex<Option<PyErr>>>;

impl PySimulator {
    pub(crate) fn new(hf: Arc<Py<PyAny>>, lf: Arc<Py<PyAny>>) -> PySimulator {
        PySimulator {
            hf,
            lf,
            raised: Raised::default(),
            interrupt: Raised::default(),
            stop: Stop::new(),
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

/// What a Python simulator may return, for the messages.
const SHAPES: &str = "the failure flag (bool or numpy bool), (failure, work_units) or (failure, work_units or None, robustness)";

/// A simulator's result `out`, timed `wall` seconds: the failure flag alone,
/// `(failure, work_units)` or `(failure, work_units or None, robustness)`. A bad part is named
/// with its value and the whole result (the caller adds the simulator and the trial).
pub fn sim_result(out: &Bound<'_, PyAny>, wall: f64) -> Result<SimResult, String> {
    let shown = || {
        out.repr()
            .map_or_else(|_| "?".to_string(), |r| r.to_string())
    };
    let Ok(tuple) = out.cast::<PyTuple>() else {
        let failure = crate::convert::failure_flag(out)
            .map_err(|kind| format!("a simulator must return {SHAPES}, got {kind} {}", shown()))?;
        return Ok(SimResult::new(failure, wall, None));
    };
    if !(2..=3).contains(&tuple.len()) {
        return Err(format!(
            "a simulator must return {SHAPES}, got a tuple of {} items: {}",
            tuple.len(),
            shown()
        ));
    }
    let item = |i: usize| tuple.get_item(i).map_err(|e| e.to_string());
    let flag = item(0)?;
    let failure = crate::convert::failure_flag(&flag).map_err(|kind| {
        format!(
            "the failure flag (first of {}) must be a bool or a numpy bool, got {kind} {flag}",
            shown()
        )
    })?;
    let work = item(1)?;
    let work = if work.is_none() && tuple.len() == 3 {
        None
    } else {
        let whole = !work.is_instance_of::<pyo3::types::PyBool>();
        match work.extract::<u64>() {
            Ok(n) if whole => Some(n),
            _ => {
                let hint = if work.is_instance_of::<pyo3::types::PyFloat>() {
                    " (the second item counts work units, not seconds: savme times each call \
                     itself; a robustness goes third)"
                } else {
                    ""
                };
                return Err(format!(
                    "work_units (second of {}) must be a whole number ≥ 0 (an int{}), got {}{hint}",
                    shown(),
                    if tuple.len() == 3 { ", or None" } else { "" },
                    work.repr().map_or_else(|_| "?".into(), |r| r.to_string())
                ));
            }
        }
    };
    let result = SimResult::new(failure, wall, work);
    if tuple.len() == 2 {
        return Ok(result);
    }
    let rho = item(2)?;
    match rho.extract::<f64>() {
        Ok(r) if r.is_finite() && !rho.is_instance_of::<pyo3::types::PyBool>() => {
            Ok(result.with_robustness(r))
        }
        _ => Err(format!(
            "the robustness (third of {}) must be a finite number, got {}",
            shown(),
            rho.repr().map_or_else(|_| "?".into(), |r| r.to_string())
        )),
    }
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
        let interrupted = || {
            let slot = self.interrupt.lock().unwrap_or_else(|p| p.into_inner());
            slot.is_some()
        };
        if interrupted() {
            // A callable asked to stop (KeyboardInterrupt, SystemExit): the runs queued
            // behind it are not started.
            return Err(SimError::Failed(format!(
                "the `{name}` run was not started: a simulator raised KeyboardInterrupt or SystemExit"
            )));
        }
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
                let interrupt = !e.is_instance_of::<PyException>(py);
                let slot = if interrupt {
                    self.stop.request();
                    &self.interrupt
                } else {
                    &self.raised
                };
                let mut first = slot.lock().unwrap_or_else(|p| p.into_inner());
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

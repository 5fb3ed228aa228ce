//! `Campaign(..., executor=…)`: a campaign's HF and LF runs handed to a Python executor object
//! (`savme.RayExecutor`: Ray tasks or actors, on a cluster) instead of local worker threads.
//! The kernel, the store and the stage loop stay in this process; the executor is a
//! [`RemoteRunner`] to the campaign loop, so that the trials are the same as a local run's
//! (told in ask order, whatever order the runs finish in).
//!
//! An executor is any object with these methods (what `savme.RayExecutor` implements):
//! - `start(hf, lf)`: before the campaign, on the main thread — `hf` and `lf` are the
//!   simulator callables `(scenario, phi, theta) -> failure | (failure, work)` (for the bundled
//!   simulator and a campaign file's FMUs, `savme.executors.native`'s: an executor calls them
//!   like any other, or ships their files as `RayExecutor` does, see `native.rs`);
//! - `submit(trial, which, scenario, phi, theta)`: start a run (`which` is `"hf"` or `"lf"`);
//! - `poll(timeout_s)`: the runs finished since the last poll (waiting up to `timeout_s` for
//!   one), each `(trial, which, outcome)` with `outcome` one of `("ok", value, wall_seconds)`
//!   (the callable's return value), `("raised", "Type: message")` (the callable raised), or
//!   `("error", message)` (the run could not finish: timed out, its worker lost twice, …);
//! - `finish()`: after the campaign (also after an error or Ctrl-C): cancel what is left.

use crate::callables::sim_result;
use crate::convert;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use savme::campaign::executor::{Done, RemoteRunner, Runner, Task};
use savme::campaign::CampaignError;
use savme::kernel::Role;
use savme_kernel::SimError;
use std::collections::VecDeque;
use std::sync::Arc;

/// How long one `poll` waits for a finished run; between polls the GIL is free.
const POLL_SECONDS: f64 = 0.2;

/// The methods an executor object must have.
const METHODS: [&str; 4] = ["start", "submit", "poll", "finish"];

/// The executor of `Campaign(executor=…)`: None or `"local"` (threads here), `"ray"` (a
/// default `savme.RayExecutor()`), or an executor object.
pub fn executor_of(value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Arc<Py<PyAny>>>> {
    let Some(value) = value.filter(|v| !v.is_none()) else {
        return Ok(None);
    };
    if let Ok(name) = value.extract::<String>() {
        return match name.as_str() {
            "local" => Ok(None),
            "ray" => {
                let module = value.py().import("savme.executors")?;
                Ok(Some(Arc::new(module.getattr("RayExecutor")?.call0()?.unbind())))
            }
            other => Err(PyValueError::new_err(format!(
                "executor must be \"local\", \"ray\" or an executor object (savme.RayExecutor(...)), got {other:?}"
            ))),
        };
    }
    for method in METHODS {
        if !value.hasattr(method)? {
            let kind = value.get_type().name()?;
            return Err(PyTypeError::new_err(format!(
                "executor: a {kind} has no `{method}` method; give \"ray\", savme.RayExecutor(...) or an object with start, submit, poll and finish"
            )));
        }
    }
    Ok(Some(Arc::new(value.clone().unbind())))
}

/// The executor's name in error messages (its type).
fn name_of(py: Python<'_>, executor: &Py<PyAny>) -> String {
    executor
        .bind(py)
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "executor".into())
}

/// The campaign loop's [`Runner`] on an executor object.
pub struct ExecutorRunner {
    executor: Arc<Py<PyAny>>,
    /// Finished runs polled but not yet handed to the loop.
    ready: VecDeque<Done>,
}

impl ExecutorRunner {
    /// A runner on `executor` (already started).
    pub fn new(executor: Arc<Py<PyAny>>) -> Self {
        ExecutorRunner {
            executor,
            ready: VecDeque::new(),
        }
    }

    /// One `poll` of the executor: what it gives goes to `ready`.
    fn poll(&mut self) -> Result<(), CampaignError> {
        Python::attach(|py| -> Result<(), CampaignError> {
            let polled = self
                .executor
                .call_method1(py, "poll", (POLL_SECONDS,))
                .map_err(|e| self.error(py, "poll", e))?;
            let items = polled
                .bind(py)
                .try_iter()
                .map_err(|e| self.error(py, "poll() must give a list", e))?;
            for item in items {
                let item = item.map_err(|e| self.error(py, "poll", e))?;
                let done = Self::done(&item).map_err(|m| CampaignError::Executor {
                    executor: name_of(py, &self.executor),
                    message: m,
                })?;
                self.ready.push_back(done);
            }
            Ok(())
        })
    }

    fn error(&self, py: Python<'_>, what: &str, e: PyErr) -> CampaignError {
        CampaignError::Executor {
            executor: name_of(py, &self.executor),
            message: format!("{what}: {e}"),
        }
    }

    /// One polled item `(trial, which, outcome)` as a finished run.
    fn done(item: &Bound<'_, PyAny>) -> Result<Done, String> {
        let (trial, which, outcome): (u64, String, Bound<'_, PyTuple>) = item
            .extract()
            .map_err(|e| format!("poll() must give (trial, which, outcome) tuples: {e}"))?;
        let Some(which) = Role::from_key(&which) else {
            return Err(format!(
                "poll(): which must be \"hf\" or \"lf\", got {which:?}"
            ));
        };
        let kind: String = outcome
            .get_item(0)
            .and_then(|k| k.extract())
            .map_err(|e| format!("poll(): trial {trial}: the outcome's first item: {e}"))?;
        let item = |i: usize| {
            outcome
                .get_item(i)
                .map_err(|e| format!("poll(): trial {trial}: a {kind:?} outcome: {e}"))
        };
        let result = match kind.as_str() {
            "ok" => {
                let wall: f64 = item(2)?
                    .extract()
                    .map_err(|e| format!("poll(): trial {trial}: wall seconds: {e}"))?;
                sim_result(&item(1)?, wall).map_err(|m| {
                    SimError::Failed(format!("the `{}` simulator: {m}", which.key()))
                })
            }
            "raised" => Err(SimError::Failed(format!(
                "the `{}` simulator raised {}",
                which.key(),
                item(1)?
            ))),
            "error" => Err(SimError::Failed(item(1)?.to_string())),
            other => {
                return Err(format!(
                    "poll(): trial {trial}: outcome must start with \"ok\", \"raised\" or \"error\", got {other:?}"
                ))
            }
        };
        Ok(Done {
            trial,
            which,
            result,
        })
    }
}

impl Runner for ExecutorRunner {
    fn submit(&mut self, task: Task) -> Result<(), CampaignError> {
        Python::attach(|py| {
            let args = (
                task.trial,
                task.which.key(),
                &*task.scenario,
                convert::dict(py, &task.phi)?,
                convert::dict(py, &task.fidelity)?,
            );
            self.executor.call_method1(py, "submit", args).map(drop)
        })
        .map_err(|e| Python::attach(|py| self.error(py, "submit", e)))
    }

    fn next_done(&mut self) -> Result<Done, CampaignError> {
        loop {
            if let Some(done) = self.ready.pop_front() {
                return Ok(done);
            }
            self.poll()?;
        }
    }

    /// Polls until a run is finished or `stop` is requested (Ctrl-C): the runs still in
    /// flight are then left to the executor's `finish`, which cancels them — a stop waits at
    /// most one poll ([`POLL_SECONDS`]), not for a run that may take minutes.
    fn next_done_unless(
        &mut self,
        stop: &savme::campaign::Stop,
    ) -> Result<Option<Done>, CampaignError> {
        loop {
            if let Some(done) = self.ready.pop_front() {
                return Ok(Some(done));
            }
            if stop.is_requested() {
                return Ok(None);
            }
            self.poll()?;
        }
    }
}

impl RemoteRunner for ExecutorRunner {
    /// Nothing: the executor's `finish()` is called by the campaign's driver thread once the
    /// campaign has ended, however it ended.
    fn finish(self: Box<Self>) -> Result<(), CampaignError> {
        Ok(())
    }
}

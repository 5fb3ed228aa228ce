//! Native simulators on an executor (`savme.RayExecutor`): a campaign file's FMUs and the
//! bundled driving simulator, run where the executor runs
//! its runs instead of on this process's threads.
//!
//! The driver describes the simulator as a [`NativeSpec`] (JSON) plus the files it needs (an
//! FMU campaign's HF and LF FMUs, by role); `savme.executors` turns that into the `hf`/`lf`
//! callables an executor ships (the FMUs' bytes through Ray's object store, written once per
//! node). On the node, [`PyNativeSimulator`] builds the very simulator a local run builds — the
//! same `FmuBackend` from the same [`WorkerInit`] (its FMU paths replaced by the node's copies),
//! the same `DrivingSimulator` — and runs it, so a run gives there what it gives here.

use crate::convert;
use crate::errors;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use savme::adapter::AnySimulator;
use savme_fmu::worker::WorkerInit;
use savme_fmu::FmuBackend;
use savme_kernel::{Assignment, Role, SimResult};
use savme_sim::sim::{DrivingSimulator, PerceptionMode};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Duration;

/// What a node needs to build a native simulator (besides the files, named by role).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum NativeSpec {
    /// The bundled driving simulator: camera + lidar (`None`) or ideal perception with this
    /// noise (metres).
    Driving { ideal_noise_sd: Option<f64> },
    /// An FMU campaign: the worker initialisation a local run builds its back end from (its
    /// `hf`/`lf` paths replaced on the node by the files shipped under those names).
    Fmu {
        init: Box<WorkerInit>,
        isolate: bool,
        timeout_s: f64,
    },
}

impl NativeSpec {
    /// The spec of the bundled driving simulator `sim`.
    pub fn driving(sim: &DrivingSimulator) -> NativeSpec {
        NativeSpec::Driving {
            ideal_noise_sd: match sim.perception {
                PerceptionMode::Sensors => None,
                PerceptionMode::Ideal { noise_sd } => Some(noise_sd),
            },
        }
    }

    /// The spec of an FMU campaign file's simulator, with the FMUs to ship (by role).
    pub fn fmu(
        init: &WorkerInit,
        isolate: bool,
        timeout: Duration,
    ) -> (NativeSpec, BTreeMap<String, PathBuf>) {
        let files = BTreeMap::from([
            ("hf".to_string(), init.hf.clone()),
            ("lf".to_string(), init.lf.clone()),
        ]);
        let spec = NativeSpec::Fmu {
            init: Box::new(init.clone()),
            isolate,
            timeout_s: timeout.as_secs_f64(),
        };
        (spec, files)
    }

    /// The `(hf, lf)` callables for an executor: `savme.executors.native(spec, files)`.
    pub fn callables(
        &self,
        py: Python<'_>,
        files: &BTreeMap<String, PathBuf>,
    ) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let json = serde_json::to_string(self).map_err(errors::value)?;
        let pair = py
            .import("savme.executors")?
            .call_method1("native", (json, files.clone()))?;
        pair.extract()
    }

    /// The simulator this spec describes, its files at `files` (by role).
    fn build(self, files: &BTreeMap<String, PathBuf>) -> Result<AnySimulator, String> {
        match self {
            NativeSpec::Driving { ideal_noise_sd } => {
                let mut sim = DrivingSimulator::default();
                if let Some(noise_sd) = ideal_noise_sd {
                    sim.perception = PerceptionMode::Ideal { noise_sd };
                }
                Ok(AnySimulator::new(sim))
            }
            NativeSpec::Fmu {
                mut init,
                isolate,
                timeout_s,
            } => {
                for (role, path) in [("hf", &mut init.hf), ("lf", &mut init.lf)] {
                    *path = files
                        .get(role)
                        .cloned()
                        .ok_or_else(|| format!("the `{role}` FMU was not shipped"))?;
                }
                let worker = if isolate {
                    Some(crate::sim::worker_command()?)
                } else {
                    None
                };
                let timeout = Duration::try_from_secs_f64(timeout_s)
                    .map_err(|e| format!("timeout_s {timeout_s}: {e}"))?;
                let backend = FmuBackend::new(&init, worker, timeout)
                    .map_err(|e| format!("{}: {e}", init.hf.display()))?;
                Ok(AnySimulator::new(backend))
            }
        }
    }
}

/// A native simulator built on the node that runs it (`savme.executors` makes one per worker
/// process and keeps it): `run(which, scenario, phi, theta)` gives the run's outcome as an
/// executor reports it — `("ok", value, wall_seconds)` or `("error", message)`.
#[pyclass(name = "NativeSimulator", module = "savme._savme", frozen)]
pub struct PyNativeSimulator {
    sim: Mutex<AnySimulator>,
}

#[pymethods]
impl PyNativeSimulator {
    /// Builds the simulator of `spec` (JSON, see `savme.executors.native`), its files at the
    /// paths `files` gives by role.
    #[new]
    fn new(spec: &str, files: BTreeMap<String, PathBuf>) -> PyResult<Self> {
        let spec: NativeSpec = serde_json::from_str(spec)
            .map_err(|e| PyValueError::new_err(format!("a native simulator's spec: {e}")))?;
        let sim = spec.build(&files).map_err(PyRuntimeError::new_err)?;
        Ok(PyNativeSimulator {
            sim: Mutex::new(sim),
        })
    }

    /// One run (the GIL released while it runs): `("ok", value, wall_seconds)` — `value` in
    /// the shapes a Python simulator returns — or `("error", message)` with the simulator's
    /// own error, as a local run stores it.
    fn run<'py>(
        &self,
        py: Python<'py>,
        which: &str,
        scenario: &str,
        phi: &Bound<'py, PyDict>,
        theta: &Bound<'py, PyDict>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let role = Role::from_key(which).ok_or_else(|| {
            PyValueError::new_err(format!("which must be \"hf\" or \"lf\", got {which:?}"))
        })?;
        let (phi, theta) = (assignment(phi)?, assignment(theta)?);
        let result = py.detach(|| {
            let mut sim = self.sim.lock().unwrap_or_else(|p| p.into_inner());
            savme::campaign::executor::simulate(&mut *sim, role, scenario, &phi, &theta)
        });
        match result {
            Ok(r) => ("ok", value(py, &r)?, r.wall_seconds).into_pyobject(py),
            Err(e) => ("error", e.to_string()).into_pyobject(py),
        }
    }
}

/// A dict of φ or θ as the campaign sent it (`convert::dict`'s order and types) back as the
/// assignment a local run passes.
fn assignment(d: &Bound<'_, PyDict>) -> PyResult<Assignment> {
    let mut a = Assignment::new();
    for (k, v) in d.iter() {
        let name: String = k.extract()?;
        let value = convert::value(&name, &v)?;
        a.set(&name, value);
    }
    Ok(a)
}

/// A result in the shapes `sim_result` reads back: `failure`, `(failure, work)`,
/// `(failure, work, robustness)` or `(failure, None, robustness)`.
fn value<'py>(py: Python<'py>, r: &SimResult) -> PyResult<Bound<'py, PyAny>> {
    Ok(match (r.work, r.robustness) {
        (None, None) => r.failure.into_pyobject(py)?.to_owned().into_any(),
        (Some(w), None) => (r.failure, w).into_pyobject(py)?.into_any(),
        (w, Some(rho)) => (r.failure, w, rho).into_pyobject(py)?.into_any(),
    })
}

//! The bundled simulators for Python: `savme.sim.Driving` (the camera/lidar driving simulator
//! with the paper's ten scenarios and Table I) and `savme.fmu.Simulator` (the FMUs of a
//! campaign file).

use crate::convert;
use crate::errors;
use crate::space::PySpace;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use savme::adapter::{AnySimulator, FileSimulator};
use savme_fmu::campaign_file::FmuCampaignFile;
use savme_fmu::FmuBackend;
use savme_kernel::{Assignment, Role, SimResult, Simulator, Space};
use savme_sim::sim::DrivingSimulator;
use std::path::PathBuf;

/// A dict of values for `space` (θ or φ); `what` names it in errors.
fn assignment_for(
    what: &str,
    d: &Bound<'_, PyDict>,
    space: Option<&Space>,
) -> PyResult<Assignment> {
    match space {
        Some(space) => convert::assignment(what, d, space),
        None => {
            let mut a = Assignment::new();
            for (k, v) in d.iter() {
                let name: String = k.extract()?;
                let value = convert::value(&format!("{what}[{name:?}]"), &v)?;
                a.set(&name, value);
            }
            Ok(a)
        }
    }
}

/// A bundled scenario by name or number (KeyError listing the names otherwise).
fn find_scenario(scenario: &str) -> PyResult<&'static savme_sim::scenario::ScenarioInfo> {
    savme_sim::scenario::find(scenario).ok_or_else(|| {
        convert::unknown(
            "scenario",
            scenario,
            savme_sim::scenario::SCENARIOS.iter().map(|s| s.name),
        )
    })
}

/// A simulation's result as a dict.
fn result_dict<'py>(py: Python<'py>, r: &SimResult) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("failure", r.failure)?;
    d.set_item("wall_seconds", r.wall_seconds)?;
    d.set_item("work", r.work)?;
    // The run's robustness where the simulator reports one (an FMU campaign file's threshold
    // margin or `[failure] robustness` output).
    if let Some(rho) = r.robustness {
        d.set_item("robustness", rho)?;
    }
    Ok(d)
}

/// The bundled driving simulator.
#[pyclass(name = "Driving", module = "savme.sim", frozen)]
pub struct PyDriving {
    pub sim: DrivingSimulator,
}

#[pymethods]
impl PyDriving {
    /// `perception="sensors"` (camera + lidar: every fidelity setting acts) or `"ideal"`
    /// (ground truth + noise: fast, only the simulation rate acts).
    #[new]
    #[pyo3(signature = (perception = "sensors"))]
    fn new(perception: &str) -> PyResult<Self> {
        let sim = match perception {
            "sensors" => DrivingSimulator::default(),
            "ideal" => DrivingSimulator::ideal(),
            other => {
                return Err(PyValueError::new_err(format!(
                    "perception must be \"sensors\" or \"ideal\", got {other:?}"
                )))
            }
        };
        Ok(PyDriving { sim })
    }

    /// Runs scenario `scenario` (a name or its number 1–10) with parameters `phi` under the
    /// fidelity settings `theta` (default θ_HF); returns {"failure", "wall_seconds", "work",
    /// "min_distance", "collision_time"}. The GIL is released while it runs.
    #[pyo3(signature = (scenario, phi, theta = None))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        scenario: &str,
        phi: &Bound<'py, PyDict>,
        theta: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let info = find_scenario(scenario)?;
        let space = savme_sim::scenario::phi_space(info);
        let phi = assignment_for("phi", phi, Some(&space))?;
        let theta = match theta {
            Some(t) => assignment_for("theta", t, Some(&savme_sim::fidelity::space(10)))?,
            None => savme_sim::fidelity::theta_hf(),
        };
        let sim = self.sim;
        let r = py
            .detach(move || sim.run(info.name, &phi, &theta, false))
            .map_err(errors::value)?;
        let d = PyDict::new(py);
        d.set_item("failure", r.failure)?;
        d.set_item("wall_seconds", r.wall_seconds)?;
        d.set_item("work", r.work)?;
        d.set_item("min_distance", r.min_distance)?;
        d.set_item("collision_time", r.collision_time)?;
        Ok(d)
    }

    /// The ten scenarios: [{"id", "name", "description", "training"}].
    #[staticmethod]
    fn scenarios<'py>(py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        savme_sim::scenario::SCENARIOS
            .iter()
            .map(|s| {
                let d = PyDict::new(py);
                d.set_item("id", s.id)?;
                d.set_item("name", s.name)?;
                d.set_item("description", s.description)?;
                d.set_item("training", s.training())?;
                Ok(d)
            })
            .collect()
    }

    /// Scenario `scenario`'s φ-space.
    #[staticmethod]
    fn phi_space(scenario: &str) -> PyResult<PySpace> {
        let info = find_scenario(scenario)?;
        Ok(PySpace {
            space: savme_sim::scenario::phi_space(info),
        })
    }

    /// The paper's Table I: the 16 fidelity settings, continuous ones in `bins` log bins.
    #[staticmethod]
    #[pyo3(signature = (bins = 10))]
    fn fidelity_space(bins: i128) -> PyResult<PySpace> {
        Ok(PySpace {
            space: savme_sim::fidelity::space(convert::whole("bins", bins)?),
        })
    }

    /// θ_HF of Table I (the bold values).
    #[staticmethod]
    fn theta_hf<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        convert::dict(py, &savme_sim::fidelity::theta_hf())
    }

    fn __repr__(&self) -> String {
        format!("Driving(perception={:?})", self.sim.perception)
    }
}

/// The worker process of a simulator that isolates its runs (`[fmu] isolate = true`):
/// `$SAVME_FMU_WORKER`, else `savme-fmu-worker` on the PATH.
pub(crate) fn worker_command() -> Result<Vec<String>, String> {
    let command = std::env::var("SAVME_FMU_WORKER").unwrap_or_else(|_| "savme-fmu-worker".into());
    Ok(command.split_whitespace().map(String::from).collect())
}

/// The simulator of a checked campaign file (for FMUs: in this process, or in worker
/// processes, see [`worker_command`]).
pub fn file_simulator(file: &dyn FileSimulator) -> PyResult<AnySimulator> {
    file.simulator(&worker_command)
        .map_err(PyRuntimeError::new_err)
}

/// The FMU back end of a checked FMU campaign file.
pub fn fmu_backend(file: &FmuCampaignFile) -> PyResult<FmuBackend> {
    let worker = if file.isolate {
        Some(worker_command().map_err(PyRuntimeError::new_err)?)
    } else {
        None
    };
    FmuBackend::new(&file.init, worker, file.timeout)
        .map_err(|e| PyRuntimeError::new_err(format!("{}: {e}", file.common.path.display())))
}

/// The HF and LF FMUs of a campaign file (TOML, as `savme run --config` reads), with their
/// bindings checked.
#[pyclass(name = "Simulator", module = "savme.fmu", frozen)]
pub struct PyFmuSimulator {
    path: PathBuf,
    file: FmuCampaignFile,
}

impl PyFmuSimulator {
    pub fn backend(&self) -> PyResult<FmuBackend> {
        fmu_backend(&self.file)
    }

    /// Its spec and FMUs for an executor's nodes.
    pub fn native(
        &self,
    ) -> (
        crate::native::NativeSpec,
        std::collections::BTreeMap<String, PathBuf>,
    ) {
        crate::native::NativeSpec::fmu(&self.file.init, self.file.isolate, self.file.timeout)
    }
}

#[pymethods]
impl PyFmuSimulator {
    /// Reads and checks the campaign file at `path` (errors name its file, line and key).
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let c =
            savme::compose::campaign_file(&path, &Default::default()).map_err(errors::campaign)?;
        let Ok(file) = c.file.into_any().downcast::<FmuCampaignFile>() else {
            return Err(PyValueError::new_err(format!(
                "{}: not an FMU campaign file (no [fmu] section)",
                path.display()
            )));
        };
        Ok(PyFmuSimulator { path, file: *file })
    }

    /// Runs scenario `scenario` with `phi` under `theta` (default θ_HF) on the HF FMU, or the
    /// LF one with `role="lf"`; returns {"failure", "wall_seconds", "work"}, and "robustness"
    /// when the file's `[failure]` gives one (a threshold's margin, a `robustness` output).
    /// The GIL is released while it runs.
    #[pyo3(signature = (scenario, phi, theta = None, role = "hf"))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        scenario: &str,
        phi: &Bound<'py, PyDict>,
        theta: Option<&Bound<'py, PyDict>>,
        role: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let role = match role {
            "hf" => Role::High,
            "lf" => Role::Learned,
            other => {
                return Err(PyValueError::new_err(format!(
                    "role must be \"hf\" or \"lf\", got {other:?}"
                )))
            }
        };
        let space = self
            .file
            .common
            .scenarios
            .spaces
            .get(scenario)
            .ok_or_else(|| {
                convert::unknown(
                    "scenario",
                    scenario,
                    self.file.common.scenarios.spaces.keys(),
                )
            })?;
        let phi = assignment_for("phi", phi, Some(space))?;
        let theta = match theta {
            Some(t) => assignment_for("theta", t, Some(&self.file.common.fidelity.space))?,
            None => self.file.common.fidelity.theta_hf.clone(),
        };
        let mut backend = self.backend()?;
        let scenario = scenario.to_string();
        let r = py
            .detach(move || backend.simulate_as(role, &scenario, &phi, &theta))
            .map_err(errors::value)?;
        result_dict(py, &r)
    }

    /// The scenarios' names.
    #[getter]
    fn scenarios(&self) -> Vec<String> {
        self.file.common.scenarios.spaces.keys().cloned().collect()
    }

    /// Scenario `scenario`'s φ-space.
    fn phi_space(&self, scenario: &str) -> PyResult<PySpace> {
        let space = self
            .file
            .common
            .scenarios
            .spaces
            .get(scenario)
            .ok_or_else(|| {
                convert::unknown(
                    "scenario",
                    scenario,
                    self.file.common.scenarios.spaces.keys(),
                )
            })?;
        Ok(PySpace {
            space: space.clone(),
        })
    }

    /// The fidelity space.
    #[getter]
    fn fidelity(&self) -> PySpace {
        PySpace {
            space: self.file.common.fidelity.space.clone(),
        }
    }

    /// θ_HF.
    #[getter]
    fn theta_hf<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        convert::dict(py, &self.file.common.fidelity.theta_hf)
    }

    fn __repr__(&self) -> String {
        format!("Simulator({:?})", self.path.display().to_string())
    }
}

//! [`FmuBackend`]: a campaign's FMU simulator — in this process, or in worker processes.

use crate::worker::{IsolatedSimulator, WorkerInit};
use crate::{FmuError, FmuSimulator, Trace};
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator};
use std::time::Duration;

/// The simulator a campaign on FMUs runs: the FMUs loaded in this process, or (isolation) each
/// evaluation in a worker process, so that a crashing or hanging FMU costs one run.
#[derive(Debug, Clone)]
pub enum FmuBackend {
    /// In this process.
    InProcess(FmuSimulator),
    /// In worker child processes.
    Isolated(IsolatedSimulator),
}

impl FmuBackend {
    /// The backend for `init`: isolated when `worker` (the command that starts a worker, e.g.
    /// `["savme", "fmu-worker"]`) is given, each run limited to `timeout` — a first worker is
    /// started at once, loading and checking the FMUs in it (not in this process); else
    /// in-process —
    /// refused for an FMU that can be instantiated only once per process (a campaign runs
    /// several instances: one per thread and role).
    pub fn new(
        init: &WorkerInit,
        worker: Option<Vec<String>>,
        timeout: Duration,
    ) -> Result<FmuBackend, FmuError> {
        match worker {
            Some(command) => {
                let mut isolated = IsolatedSimulator::new(command, init, timeout)?;
                // Load and check the FMUs in a first worker, so that a library that cannot be
                // loaded (or crashes while loading) is reported before the campaign starts.
                isolated.start_now().map_err(|e| {
                    FmuError::Worker(match e {
                        SimError::Failed(m) => m,
                        other => other.to_string(),
                    })
                })?;
                Ok(FmuBackend::Isolated(isolated))
            }
            None => {
                for path in [&init.hf, &init.lf] {
                    if crate::FmuDescription::read(path)?.only_once_per_process() {
                        return Err(FmuError::OnlyOncePerProcess {
                            fmu: path.display().to_string(),
                        });
                    }
                }
                init.simulator().map(FmuBackend::InProcess)
            }
        }
    }
}

impl FmuBackend {
    /// One run that records the outputs `record` (each [`crate::simulator::recordable`]) at
    /// every communication point: what the viewer shows of an FMU trial.
    pub fn run_traced(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
        record: &[String],
    ) -> Result<(SimResult, Trace), SimError> {
        match self {
            FmuBackend::InProcess(s) => s
                .run_traced(role, scenario, phi, fidelity, record)
                .map_err(|e| SimError::Failed(e.to_string())),
            FmuBackend::Isolated(s) => s.run_traced(role, scenario, phi, fidelity, record),
        }
    }
}

impl Simulator for FmuBackend {
    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        match self {
            FmuBackend::InProcess(s) => s.simulate_as(role, scenario, phi, fidelity),
            FmuBackend::Isolated(s) => s.simulate_as(role, scenario, phi, fidelity),
        }
    }
}

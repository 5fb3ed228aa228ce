//! The estimate's run loop: the stored trials replayed on resume, then trials asked, run on
//! the executor's pool as HF runs, told in ask order and stored, until the stopping rule
//! (`stop_reason`) says so; progress reported after each tell.

use super::{
    EstimateError, EstimateLine, EstimateProgress, EstimateSettings, ProgressFn, StopReason,
};
use crate::executor::{Runner, Task};
use crate::log::RunLine;
use crate::store::{JsonlStore, TrialStore};
use crate::CampaignError;
use savme_kernel::estimation::{Estimation, EstimationTrial, Fidelity};
use savme_kernel::Role;
use std::collections::VecDeque;
use std::sync::Arc;

/// Replays the stored trials: each must be what the estimation asks again; its failure is
/// told. A torn last line (a killed process) was cut by the store.
pub(super) fn replay(
    store: &mut JsonlStore,
    estimation: &mut Estimation,
) -> Result<Vec<EstimateLine>, EstimateError> {
    let name = store.path().display().to_string();
    let loaded = store.load().map_err(CampaignError::from)?;
    let edited = loaded.edited.clone();
    let mut lines = Vec::with_capacity(loaded.lines.len());
    for stored in loaded.lines {
        let diverged = |message: String| EstimateError::Diverged {
            store: name.clone(),
            line: stored.line,
            message,
        };
        let line: EstimateLine =
            serde_json::from_value(stored.value.clone()).map_err(|e| diverged(e.to_string()))?;
        let asked = estimation
            .ask()
            .ok_or_else(|| diverged("the refinement round waits for outcomes here".into()))?;
        line.check(&asked).map_err(diverged)?;
        let run = line
            .run()
            .ok_or_else(|| diverged("a line holds exactly one run, `hf` or `lf`".into()))?;
        estimation.tell_measured(asked.id, run.failure, run.robustness, Some(run.runtime))?;
        lines.push(line);
    }
    // Checked after the lines (their check names the field that differs, if one does).
    if let Some(e) = edited {
        return Err(EstimateError::Diverged {
            store: name,
            line: e.line,
            message: e.message,
        });
    }
    Ok(lines)
}

/// Why the estimate is done, if it is.
pub(super) fn stop_reason(e: &Estimation, s: &EstimateSettings) -> Option<StopReason> {
    let est = e.estimate();
    let reached = s
        .target_width
        .is_some_and(|w| est.failures >= s.min_failures && est.total.relative_half_width() <= w);
    if reached {
        Some(StopReason::TargetWidth)
    } else if e.told() >= s.max_runs {
        Some(StopReason::MaxRuns)
    } else {
        None
    }
}

/// Calls the progress callback, if any.
pub(super) struct Reporter<'p> {
    pub(super) callback: Option<ProgressFn<'p>>,
    pub(super) started: std::time::Instant,
    pub(super) replayed: u64,
    pub(super) max_runs: u64,
    pub(super) rounds: u32,
}

impl Reporter<'_> {
    pub(super) fn call(&mut self, e: &Estimation) {
        let Some(callback) = &mut self.callback else {
            return;
        };
        let estimate = e.estimate();
        callback(&EstimateProgress {
            told: e.told(),
            replayed: self.replayed,
            max_runs: self.max_runs,
            round: e.round().map(|r| (r, self.rounds)),
            calibrating: e.calibrating(),
            estimate: &estimate,
            elapsed_seconds: self.started.elapsed().as_secs_f64(),
        });
    }
}

/// The run loop's state.
pub(super) struct Running<'a, 'p> {
    pub(super) estimation: &'a mut Estimation,
    pub(super) settings: &'a EstimateSettings,
    pub(super) store: &'a mut JsonlStore,
    pub(super) lines: &'a mut Vec<EstimateLine>,
    pub(super) cost: savme_kernel::CostMeasure,
    pub(super) theta_hf: &'a savme_kernel::Assignment,
    /// θ_LF*, for an LF pilot's runs (None: every run is HF).
    pub(super) theta_lf: Option<&'a savme_kernel::Assignment>,
    pub(super) report: &'a mut Reporter<'p>,
    pub(super) stop: &'a crate::Stop,
}

impl Running<'_, '_> {
    /// Keeps up to `window` HF runs in flight, tells them in ask order, stores each line,
    /// and stops at the first tell after which the stopping rule holds (runs still in flight
    /// then are dropped: they are not part of the estimate, whatever `jobs` is).
    pub(super) fn run(
        &mut self,
        pool: &mut impl Runner,
        window: usize,
    ) -> Result<StopReason, EstimateError> {
        let stage: Arc<str> = Arc::from("estimate");
        let mut flight: VecDeque<(EstimationTrial, Option<savme_kernel::SimResult>)> =
            VecDeque::new();
        let mut asked = self.lines.len() as u64;
        loop {
            while flight.len() < window
                && asked < self.settings.max_runs
                && !self.stop.is_requested()
            {
                // None: a refinement round waits for its outcomes before the refit.
                let Some(t) = self.estimation.ask() else {
                    break;
                };
                let (which, theta) = match (t.fidelity, self.theta_lf) {
                    (Fidelity::Lf, Some(theta_lf)) => (Role::Learned, theta_lf),
                    _ => (Role::High, self.theta_hf),
                };
                pool.submit(Task {
                    stage: stage.clone(),
                    trial: t.id,
                    which,
                    scenario: t.scenario.clone(),
                    phi: t.phi.clone(),
                    fidelity: theta.clone(),
                })?;
                flight.push_back((t, None));
                asked += 1;
            }
            while flight.front().is_some_and(|(_, r)| r.is_some()) {
                let Some((t, Some(r))) = flight.pop_front() else {
                    break;
                };
                self.tell(&t, &r)?;
                if let Some(reason) = stop_reason(self.estimation, self.settings) {
                    return Ok(reason);
                }
            }
            if flight.is_empty() {
                if self.stop.is_requested() {
                    return Err(EstimateError::Stopped {
                        told: self.estimation.told(),
                        store: self.store.path().to_path_buf(),
                    });
                }
                // Everything asked was told and the rule did not stop: ask more.
                continue;
            }
            let done = pool.next_done()?;
            let slot = flight.iter_mut().find(|(t, _)| t.id == done.trial);
            if let Some((t, slot)) = slot {
                match done.result {
                    Ok(r) => *slot = Some(r),
                    Err(e) => {
                        return Err(EstimateError::Simulation {
                            trial: t.id,
                            scenario: t.scenario.to_string(),
                            phi: t.phi.to_string(),
                            message: e.to_string(),
                        })
                    }
                }
            }
        }
    }

    fn tell(
        &mut self,
        t: &EstimationTrial,
        r: &savme_kernel::SimResult,
    ) -> Result<(), EstimateError> {
        let simulation = |message: String| EstimateError::Simulation {
            trial: t.id,
            scenario: t.scenario.to_string(),
            phi: t.phi.to_string(),
            message,
        };
        let run = r.run(self.cost).map_err(|e| simulation(e.to_string()))?;
        // Refused before the line is stored, so a resume does not meet it again.
        if let Some(x) = r.robustness.filter(|x| !x.is_finite()) {
            return Err(simulation(format!(
                "the {} run's robustness must be a finite number, got {x}",
                t.fidelity.key().to_uppercase()
            )));
        }
        let line = EstimateLine::new(t, RunLine::new(r, run.runtime));
        self.store.append(&line).map_err(CampaignError::from)?;
        self.estimation
            .tell_measured(t.id, r.failure, r.robustness, Some(run.runtime))?;
        self.lines.push(line);
        self.report.call(self.estimation);
        Ok(())
    }
}

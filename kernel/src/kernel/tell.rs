//! Telling the kernel a trial's outcome: the tell checked and worked out without changing
//! anything (classification per Table I, cost ratio, credit), then applied; the unconfirmed
//! tell of LF screening, a withdrawal, and the journal's two-step assess/commit.

use super::{Kernel, Phase, TellError, Trial, TrialRecord};
use crate::allocation::Ledger;
use crate::outcome::{Credit, Observation, Outcome, Run};
use crate::search::SearchModel;

impl Kernel {
    fn pending_index(&self, id: u64) -> Result<usize, TellError> {
        if id >= self.state.next_id {
            return Err(TellError::Unknown(id));
        }
        self.state
            .pending
            .binary_search_by_key(&id, |p| p.trial.id)
            .map_err(|_| TellError::AlreadyTold(id))
    }

    pub(crate) fn check_pending(&self, id: u64) -> Result<(), TellError> {
        self.pending_index(id).map(|_| ())
    }

    /// Checks a tell and works out its record without changing anything.
    fn assess(&self, id: u64, observation: &Observation) -> Result<(usize, Assessed), TellError> {
        let index = self.pending_index(id)?;
        let pending = &self.state.pending[index];
        let phase = pending.trial.phase;
        let check = |run: &Run, simulator: &'static str| {
            if run.runtime.is_finite() && run.runtime > 0.0 {
                Ok(())
            } else {
                Err(TellError::BadRuntime {
                    id,
                    simulator,
                    runtime: run.runtime,
                })
            }
        };
        match (pending.trial.theta_lf.is_some(), observation) {
            (true, Observation::HfOnly(_)) => return Err(TellError::ExpectedPaired { id, phase }),
            (false, Observation::Paired { .. }) => return Err(TellError::ExpectedHfOnly { id }),
            _ => {}
        }
        check(observation.hf(), "HF")?;
        check_robustness(id, observation.hf(), "HF")?;
        if let Some(lf) = observation.lf() {
            check(lf, "LF")?;
            check_robustness(id, lf, "LF")?;
        }
        let outcome = observation.outcome();
        let cost_ratio = observation.cost_ratio();
        if let (Some(r), Some(lf)) = (cost_ratio, observation.lf()) {
            if !r.is_finite() {
                return Err(TellError::BadCostRatio {
                    id,
                    hf: observation.hf().runtime,
                    lf: lf.runtime,
                });
            }
        }
        let credit = match (phase.learns(), outcome, cost_ratio) {
            (true, Some(o), Some(r)) => Credit {
                fidelity: Some(o.fidelity_success(r, self.state.config.budget)),
                scenario: Some(o.scenario_success()),
            },
            // An unpaired learning trial: the HF run credits the φ search alone.
            (true, None, None) => Credit {
                fidelity: None,
                scenario: Some(observation.hf().failure),
            },
            // A deployment that keeps learning: the HF run credits the φ search alone.
            (false, _, _) if phase == Phase::Evaluate && self.state.config.deployment.learn => {
                Credit {
                    fidelity: None,
                    scenario: Some(observation.hf().failure),
                }
            }
            _ => Credit::default(),
        };
        Ok((
            index,
            Assessed {
                outcome,
                cost_ratio,
                credit,
            },
        ))
    }

    /// Ingests the outcome of trial `id`: classifies it, credits the bandits per Table I (in
    /// the learning phases) and returns the record. On error nothing changes.
    pub fn tell(&mut self, id: u64, observation: Observation) -> Result<TrialRecord, TellError> {
        let (index, assessed) = self.assess(id, &observation)?;
        Ok(self.commit_tell(index, observation, assessed))
    }

    fn commit_tell(
        &mut self,
        index: usize,
        observation: Observation,
        assessed: Assessed,
    ) -> TrialRecord {
        let pending = self.state.pending.remove(index);
        let s = pending.trial.scenario_index;
        let (phi_arms, theta_arms) = pending.arms.split_at(self.state.scenarios[s].arms().len());
        let cost = observation.hf().runtime + observation.lf().map_or(0.0, |lf| lf.runtime);
        self.account(s, cost, observation.hf().failure);
        if let Some(ok) = assessed.credit.scenario {
            let phi = &pending.trial.phi;
            let hf_cost = matches!(&self.state.config.search,
                SearchModel::EliteMixture(m) if m.hf_cost);
            // A learning trial's LF run does not depend on φ: with `hf_cost` the archive
            // keeps what φ cost at HF (EliteMixture::hf_cost).
            let cost = if hf_cost && pending.trial.phase.learns() {
                observation.hf().runtime
            } else {
                cost
            };
            self.credit_scenario(s, phi, phi_arms, observation.hf(), ok, cost);
        }
        if let Some(ok) = assessed.credit.fidelity {
            self.state.fidelity.update(theta_arms, ok);
            if let (Some(e), Some(o), Some(r)) = (
                self.state.evidence.as_mut(),
                assessed.outcome,
                assessed.cost_ratio,
            ) {
                e.record(s, theta_arms, o, ok, r);
            }
        }
        self.state.stats.told += 1;
        TrialRecord {
            trial: pending.trial,
            observation,
            outcome: assessed.outcome,
            cost_ratio: assessed.cost_ratio,
            credit: assessed.credit,
        }
    }

    /// Tells an evaluation trial whose HF run was not made: LF screening passed it without an
    /// audit ([`crate::screening`]). Only trials of a phase that runs both simulators and
    /// learns nothing take it; on error nothing changes.
    ///
    /// ```
    /// use savme_kernel::{Kernel, Phase, Run, Space, Variable, Assignment, Scale};
    /// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
    /// let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 4, Scale::Linear)])?;
    /// let mut k = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
    ///     .scenario("s", phi, 1.0)
    ///     .build()?;
    /// let learning = k.ask();
    /// assert!(k.tell_unconfirmed(learning.id, Run::new(false, 0.2)).is_err());
    /// k.set_phase(Phase::Evaluate);
    /// let t = k.ask();
    /// assert_eq!(k.tell_unconfirmed(t.id, Run::new(false, 0.2))?.id, t.id);
    /// assert_eq!(k.stats().told, 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn tell_unconfirmed(&mut self, id: u64, lf: Run) -> Result<Trial, TellError> {
        // The screen called it a pass: a learning deployment learns it as one.
        self.tell_screened_alone(id, &lf, "LF", Run::new(false, lf.runtime))
    }

    /// Tells an evaluation trial whose LF run was not made: LF screening did not pay, so the
    /// harness ran HF directly ([`crate::screening::Economy`]). Only trials of a phase that
    /// runs both simulators and learns nothing take it; with [`crate::Deployment::learn`] the
    /// HF run credits the φ search. On error nothing changes.
    ///
    /// ```
    /// use savme_kernel::{Assignment, Kernel, Phase, Run, Scale, Space, Variable};
    /// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
    /// let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 4, Scale::Linear)])?;
    /// let mut k = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
    ///     .scenario("s", phi, 1.0)
    ///     .build()?;
    /// let learning = k.ask();
    /// assert!(k.tell_direct(learning.id, Run::new(true, 1.0)).is_err());
    /// k.set_phase(Phase::Evaluate);
    /// let t = k.ask();
    /// assert_eq!(k.tell_direct(t.id, Run::new(true, 1.0))?.id, t.id);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn tell_direct(&mut self, id: u64, hf: Run) -> Result<Trial, TellError> {
        self.tell_screened_alone(id, &hf, "HF", hf)
    }

    /// Tells a screened evaluation trial with one run (`simulator` names it); a learning
    /// deployment credits the φ search with `learned`.
    fn tell_screened_alone(
        &mut self,
        id: u64,
        run: &Run,
        simulator: &'static str,
        learned: Run,
    ) -> Result<Trial, TellError> {
        let index = self.pending_index(id)?;
        let phase = self.state.pending[index].trial.phase;
        if phase.learns() || !phase.is_paired() {
            return Err(TellError::NotScreened { id, phase });
        }
        if !(run.runtime.is_finite() && run.runtime > 0.0) {
            return Err(TellError::BadRuntime {
                id,
                simulator,
                runtime: run.runtime,
            });
        }
        check_robustness(id, run, simulator)?;
        self.state.stats.told += 1;
        let pending = self.state.pending.remove(index);
        let s = pending.trial.scenario_index;
        // Only an HF run (a direct trial) can find a failure; an LF pass found none.
        self.account(s, run.runtime, simulator == "HF" && run.failure);
        if self.state.config.deployment.learn {
            let phi_arms = &pending.arms[..self.state.scenarios[s].arms().len()];
            let phi = &pending.trial.phi;
            self.credit_scenario(s, phi, phi_arms, &learned, learned.failure, run.runtime);
        }
        Ok(pending.trial)
    }

    /// Credits scenario `s`'s φ search with a result: its bins by `found` (an HF failure), the
    /// elite archive (if any) by the run and what the trial cost (every run told).
    fn credit_scenario(
        &mut self,
        s: usize,
        phi: &crate::Assignment,
        phi_arms: &[u16],
        hf: &Run,
        found: bool,
        cost: f64,
    ) {
        self.state.scenarios[s].update(phi_arms, found);
        if let (Some(archive), SearchModel::EliteMixture(m)) =
            (self.state.search.get_mut(s), &self.state.config.search)
        {
            let space = &self.state.config.scenarios[s].space;
            archive.record(space, phi, phi_arms, hf, cost);
            archive.truncate(m.archive);
        }
    }

    /// Adds a told trial of scenario `s` to its ledger (kept by the cost-rate allocation only).
    fn account(&mut self, s: usize, cost: f64, failure: bool) {
        if let Some(l) = self.state.ledgers.get_mut(s) {
            l.add(cost, failure);
        }
        if let crate::Allocation::CostRate(crate::CostRate {
            half_life: Some(h), ..
        }) = self.state.config.allocation
        {
            Ledger::forget(&mut self.state.ledgers, h);
            if let Some(l) = self.state.ledgers.get_mut(s) {
                l.add_recent(cost, failure);
            }
        }
    }

    /// Withdraws a pending trial (e.g. its simulation crashed); it will never be told.
    pub fn cancel(&mut self, id: u64) -> Result<Trial, TellError> {
        let index = self.pending_index(id)?;
        self.state.stats.cancelled += 1;
        Ok(self.state.pending.remove(index).trial)
    }

    pub(crate) fn assess_tell(
        &self,
        id: u64,
        observation: Observation,
    ) -> Result<AssessedTell, TellError> {
        let (index, assessed) = self.assess(id, &observation)?;
        let pending = &self.state.pending[index];
        Ok(AssessedTell {
            index,
            record: TrialRecord {
                trial: pending.trial.clone(),
                observation,
                outcome: assessed.outcome,
                cost_ratio: assessed.cost_ratio,
                credit: assessed.credit,
            },
            assessed,
        })
    }

    pub(crate) fn commit_assessed(&mut self, a: AssessedTell) -> TrialRecord {
        let record = a.record;
        let committed = self.commit_tell(a.index, record.observation, a.assessed);
        debug_assert_eq!(committed, record);
        committed
    }
}

#[derive(Debug, Clone, Copy)]
struct Assessed {
    outcome: Option<Outcome>,
    cost_ratio: Option<f64>,
    credit: Credit,
}

/// A tell checked and worked out, not yet applied.
pub(crate) struct AssessedTell {
    index: usize,
    assessed: Assessed,
    pub(crate) record: TrialRecord,
}

/// Checks a finite robustness, if any.
fn check_robustness(id: u64, run: &Run, simulator: &'static str) -> Result<(), TellError> {
    match run.robustness {
        Some(r) if !r.is_finite() => Err(TellError::BadRobustness {
            id,
            simulator,
            robustness: r,
        }),
        _ => Ok(()),
    }
}

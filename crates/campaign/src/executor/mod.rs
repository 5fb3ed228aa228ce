//! Runs a stage's trials: up to `window` trials in flight, every HF and LF run a separate
//! [`Task`] (so the two runs of a trial execute concurrently), trials told strictly in ask
//! order — which makes a campaign independent of the number and the kind of workers. Where the
//! runs execute is a [`Runner`]: [`local`] threads, or a [`RemoteRunner`] (e.g. `savme worker`
//! processes through PostgreSQL, crate `savme-postgres`).

pub mod local;
mod tell;

pub use local::{with_pool, Pool};

use tell::{add_screened, check_direct, check_logged, simulation_error, tell};

use super::log::LogLine;
use super::protocol::{OnError, Stage};
use super::store::{EditedLine, StoreError, TrialStore};
use super::CampaignError;
use savme_kernel::screening::{Economy, Step};
use savme_kernel::{Assignment, CostMeasure, Kernel, Role, SimError, SimResult, Simulator, Trial};
use std::collections::VecDeque;
use std::panic::AssertUnwindSafe;
use std::sync::Arc;

/// One simulator run a stage wants.
#[derive(Debug, Clone)]
pub struct Task {
    /// The stage's label.
    pub stage: Arc<str>,
    /// The kernel's trial id.
    pub trial: u64,
    /// HF or LF.
    pub which: Role,
    /// The scenario.
    pub scenario: Arc<str>,
    /// Its parameters φ.
    pub phi: Assignment,
    /// The fidelity settings θ of the run.
    pub fidelity: Assignment,
}

/// A finished run.
#[derive(Debug)]
pub struct Done {
    /// The kernel's trial id.
    pub trial: u64,
    /// HF or LF.
    pub which: Role,
    /// The simulator's result or error.
    pub result: Result<SimResult, SimError>,
}

/// Where a stage's runs execute: [`local`] worker threads, or a [`RemoteRunner`] (`savme
/// worker` processes through the database). The stage loop ([`run_stage`]) is the same for both, so
/// both give the same trials.
pub trait Runner {
    /// Starts a run (returns at once).
    fn submit(&mut self, task: Task) -> Result<(), CampaignError>;
    /// Waits for the next finished run (any of those submitted, each returned once).
    fn next_done(&mut self) -> Result<Done, CampaignError>;
    /// [`Runner::next_done`], or `None` once `stop` is requested while it waits: for a runner
    /// that can leave its runs in flight (a cluster that cancels them), so that a stop does not
    /// wait for a run that may take minutes. The default waits for the run.
    fn next_done_unless(&mut self, _stop: &crate::Stop) -> Result<Option<Done>, CampaignError> {
        self.next_done().map(Some)
    }
}

/// A [`Runner`] whose runs execute outside this process (e.g. `savme worker` processes
/// through a database's work queue): told once when the campaign is done, so that its idle
/// workers can leave.
pub trait RemoteRunner: Runner {
    /// The campaign is done: no more runs will be submitted.
    fn finish(self: Box<Self>) -> Result<(), CampaignError>;
}

/// Runs `sim` under `role` on a task's scenario, φ and θ, a panic reported as the run's error.
pub fn simulate<S: Simulator>(
    sim: &mut S,
    role: Role,
    scenario: &str,
    phi: &Assignment,
    fidelity: &Assignment,
) -> Result<SimResult, SimError> {
    std::panic::catch_unwind(AssertUnwindSafe(|| {
        sim.simulate_as(role, scenario, phi, fidelity)
    }))
    .unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        Err(SimError::Failed(format!("the simulator panicked: {what}")))
    })
}

/// A trial in flight.
struct Slot {
    trial: Trial,
    index: u64,
    hf: Option<SimResult>,
    lf: Option<SimResult>,
    /// The stored line of this trial (resume) with its line number.
    logged: Option<(u64, LogLine)>,
    error: Option<String>,
    /// In a screening stage: whether the trial belongs to the audit sample.
    audit: Option<bool>,
    /// In a screening stage: the LF runs of the ladder's levels below the stage's budget,
    /// cheapest first (none without a ladder); the stage's own level's run is `lf`.
    rungs: Vec<Option<SimResult>>,
    /// In a screening stage: which levels of the ladder the trial runs
    /// ([`savme_kernel::screening::plan`]), the stage's own last.
    plan: Vec<bool>,
    /// In a screening stage: the run the trial waits for next.
    awaiting: Step,
}

impl Slot {
    fn ready(&self) -> bool {
        if self.logged.is_some() || self.error.is_some() {
            return true;
        }
        match (self.audit, self.awaiting) {
            // Screening: down the ladder's levels (one without a ladder), then HF only to
            // confirm a failure or for the audit (or directly, where no level pays).
            (Some(_), Step::Stop) => true,
            (Some(_), Step::Hf) => self.hf.is_some(),
            (Some(_), Step::Level(_)) => false,
            (None, _) => self.hf.is_some() && (self.lf.is_some() || self.trial.theta_lf.is_none()),
        }
    }

    /// Files a screened trial's LF run at the level it waits for and moves on to the next
    /// step; the step, or None if the trial waited for no LF run.
    fn screened(&mut self, r: SimResult, audit: bool) -> Option<Step> {
        let Step::Level(level) = self.awaiting else {
            return None;
        };
        let failed = r.failure;
        match self.rungs.get_mut(level) {
            Some(rung) => *rung = Some(r),
            None => self.lf = Some(r),
        }
        self.awaiting = savme_kernel::screening::next(&self.plan, Some((level, failed)), audit);
        Some(self.awaiting)
    }
}

/// A screening stage's audit: its seed and fraction α ([`savme_kernel::screening::audited`]),
/// the fidelity ladder it screens down, and where LF screening is decided by what it pays.
#[derive(Debug, Clone)]
pub struct Audit {
    /// Seed of the audit draws.
    pub seed: u64,
    /// Fraction of LF passes run on HF.
    pub fraction: f64,
    /// The ladder's levels below the stage's budget, cheapest first: each one's budget and
    /// θ_LF* (empty: the two-level screening, the stage's θ_LF* alone).
    pub rungs: Vec<(f64, Assignment)>,
    /// Per scenario (kernel order), per level of the ladder (cheapest first, the stage's own
    /// last), what its runs have cost so far, when each trial runs only the levels that pay
    /// ([`savme_kernel::screening::plan`]); None: every trial runs every level (the paper's).
    pub economy: Option<Vec<Vec<Economy>>>,
}

/// What a stage needs besides the kernel.
pub struct StageContext<'a> {
    /// The stage.
    pub stage: &'a Stage,
    /// Lines of this stage already in `trials.jsonl` (replayed, not run).
    pub logged: &'a [LogLine],
    /// Their line numbers in the store.
    pub logged_lines: &'a [u64],
    /// Trials in flight at once.
    pub window: usize,
    /// How run costs are measured.
    pub cost: CostMeasure,
    /// The trial store.
    pub store: &'a mut dyn TrialStore,
    /// What a failed simulation does.
    pub on_error: OnError,
    /// Some for an LF screening stage.
    pub screen: Option<Audit>,
    /// Checked before each wait for a finished run.
    pub stop: &'a crate::Stop,
    /// The first stored line changed after it was written (its checksum fails), if any: it
    /// is refused when it is replayed, after the checks that can name the changed field.
    pub edited: Option<&'a EditedLine>,
}

/// Runs (or replays) one stage on `kernel` until it has told `stage.iterations` trials; calls
/// `progress` after each told or screened trial (with the kernel that learnt from it) and
/// returns the stage's lines (withdrawn trials included).
pub fn run_stage(
    pool: &mut dyn Runner,
    kernel: &mut Kernel,
    cx: StageContext<'_>,
    mut progress: impl FnMut(&LogLine, &Kernel),
) -> Result<Vec<LogLine>, CampaignError> {
    kernel.set_phase(cx.stage.phase());
    let economy = cx.screen.as_ref().and_then(|a| a.economy.clone());
    let mut run = StageRun {
        label: cx.stage.label(),
        stage: cx.stage.label().into(),
        theta_hf: kernel.theta_hf().clone(),
        pool,
        kernel,
        cx,
        lines: Vec::new(),
        queue: VecDeque::new(),
        asked: 0,
        failed: 0,
        spent: 0.0,
        told: 0,
        economy,
    };
    while run.queue.len() < run.cx.window && run.ask()? {}
    while !run.queue.is_empty() {
        run.tell_ready(&mut progress)?;
        if run.queue.is_empty() {
            break;
        }
        if run.cx.stop.is_requested() {
            return Err(run.stopped());
        }
        let Some(done) = run.pool.next_done_unless(run.cx.stop)? else {
            return Err(run.stopped());
        };
        run.receive(done)?;
    }
    Ok(run.lines)
}

/// A stage in progress: trials in flight in ask order, the lines told so far.
struct StageRun<'p, 'k, 'c> {
    pool: &'p mut dyn Runner,
    kernel: &'k mut Kernel,
    cx: StageContext<'c>,
    label: String,
    stage: Arc<str>,
    theta_hf: Assignment,
    lines: Vec<LogLine>,
    queue: VecDeque<Slot>,
    /// Trials asked (withdrawn ones included) and withdrawn.
    asked: u64,
    failed: u64,
    /// What the told trials cost, and how many were told (a stage with a cost budget).
    spent: f64,
    told: u64,
    /// A screening stage's economy per scenario and level, updated as its trials are told.
    economy: Option<Vec<Vec<Economy>>>,
}

impl StageRun<'_, '_, '_> {
    /// Asks the next trial and sends its runs to the workers (or takes its logged line on
    /// resume); false when the stage has asked enough (withdrawn trials are replaced).
    fn ask(&mut self) -> Result<bool, CampaignError> {
        if self.asked - self.failed >= self.cx.stage.iterations || self.spent_enough() {
            return Ok(false);
        }
        let trial = self.kernel.ask();
        let index = self.asked;
        self.asked += 1;
        let logged = self.cx.logged.get(index as usize).map(|l| {
            let number = self.cx.logged_lines.get(index as usize).copied();
            (number.unwrap_or(index + 1), l.clone())
        });
        let audit = self
            .cx
            .screen
            .as_ref()
            .map(|a| savme_kernel::screening::audited(a.seed, index, a.fraction));
        // Screening: the ladder's levels (one without a ladder) that pay for this scenario.
        let rungs = self.cx.screen.as_ref().map_or(0, |a| a.rungs.len());
        let plan = match self.economy.as_ref().map(|e| e.get(trial.scenario_index)) {
            Some(Some(levels)) => savme_kernel::screening::plan(levels),
            _ => vec![audit.is_some(); rungs + 1],
        };
        // HF directly, without an LF run: no level pays.
        let direct = audit.is_some() && !plan.contains(&true);
        let awaiting = savme_kernel::screening::next(&plan, None, audit == Some(true));
        match &logged {
            Some((number, l)) => {
                let at = (self.cx.store.location(), *number);
                check_logged(l, &trial, self.cx.stage.id(), index, at.clone())?;
                check_direct(l, direct, at)?;
            }
            None if audit.is_some() => self.send_step(&trial, awaiting)?,
            None => {
                let theta_hf = self.theta_hf.clone();
                self.send(&trial, Role::High, &theta_hf)?;
                if let Some(theta) = trial.theta_lf.as_ref() {
                    self.send(&trial, Role::Learned, theta)?;
                }
            }
        }
        self.queue.push_back(Slot {
            trial,
            index,
            hf: None,
            lf: None,
            logged,
            error: None,
            audit,
            rungs: vec![None; rungs],
            plan,
            awaiting,
        });
        Ok(true)
    }

    /// Sends a screened trial's next run: the LF run of a level of the ladder (at the level's
    /// θ_LF*; the stage's own level at the trial's), or the HF run.
    fn send_step(&mut self, trial: &Trial, step: Step) -> Result<(), CampaignError> {
        let theta = match step {
            Step::Stop => return Ok(()),
            Step::Hf => self.theta_hf.clone(),
            Step::Level(i) => {
                let rung = self.cx.screen.as_ref().and_then(|a| a.rungs.get(i));
                match (rung, &trial.theta_lf) {
                    (Some((_, theta)), _) | (None, Some(theta)) => theta.clone(),
                    (None, None) => {
                        return Err(CampaignError::Diverged {
                            stage: self.label.clone(),
                            index: self.asked,
                            message: format!("screening trial {} has no θ_LF", trial.id),
                        })
                    }
                }
            }
        };
        let role = match step {
            Step::Hf => Role::High,
            _ => Role::Learned,
        };
        self.send(trial, role, &theta)
    }

    /// Whether a stage with a cost budget has spent it: what its told trials cost, plus its
    /// trials in flight at their mean cost so far (so a window does not overshoot by much).
    /// Depends on told trials only, so a resumed stage asks exactly what it asked before.
    fn spent_enough(&self) -> bool {
        let Some(budget) = self.cx.stage.spend else {
            return false;
        };
        let mean = if self.told > 0 {
            self.spent / self.told as f64
        } else {
            0.0
        };
        self.spent + self.queue.len() as f64 * mean >= budget
    }

    fn send(
        &mut self,
        trial: &Trial,
        which: Role,
        fidelity: &Assignment,
    ) -> Result<(), CampaignError> {
        let task = Task {
            stage: self.stage.clone(),
            trial: trial.id,
            which,
            scenario: trial.scenario.clone(),
            phi: trial.phi.clone(),
            fidelity: fidelity.clone(),
        };
        self.pool.submit(task)
    }

    /// Tells every trial at the front of the queue whose runs are in, in ask order, asking a
    /// new trial after each.
    fn tell_ready(
        &mut self,
        progress: &mut impl FnMut(&LogLine, &Kernel),
    ) -> Result<(), CampaignError> {
        while self.queue.front().is_some_and(Slot::ready) {
            let Some(slot) = self.queue.pop_front() else {
                break;
            };
            let number = slot.logged.as_ref().map(|(n, _)| *n);
            let scenario = slot.trial.scenario_index;
            let plan = slot.plan.clone();
            let rungs = self.cx.screen.as_ref().map_or(&[][..], |a| &a.rungs[..]);
            let line = tell(
                self.kernel,
                slot,
                &self.label,
                self.cx.stage,
                self.cx.cost,
                rungs,
                self.cx.store,
            )?;
            if let Some(e) = self.cx.edited.filter(|e| Some(e.line) == number) {
                return Err(StoreError::BadLine {
                    store: self.cx.store.location(),
                    line: e.line,
                    message: e.message.clone(),
                }
                .into());
            }
            if let (LogLine::Screen(s), Some(economy)) = (&line, self.economy.as_mut()) {
                if let Some(levels) = economy.get_mut(scenario) {
                    add_screened(levels, s, &plan);
                }
            }
            self.spent += line.cost();
            match &line {
                LogLine::Trial(_) | LogLine::Screen(_) => {
                    self.told += 1;
                    progress(&line, self.kernel)
                }
                LogLine::Failed(f) => {
                    self.failed += 1;
                    if self.failed > self.cx.stage.iterations {
                        return Err(CampaignError::TooManyFailures {
                            stage: self.label.clone(),
                            failures: self.failed,
                            last: f.error.clone(),
                        });
                    }
                }
            }
            self.lines.push(line);
            self.ask()?;
        }
        Ok(())
    }

    /// The error of a stage stopped by [`Stop`](crate::Stop).
    fn stopped(&self) -> CampaignError {
        let told = self
            .lines
            .iter()
            .filter(|l| !matches!(l, LogLine::Failed(_)))
            .count();
        CampaignError::Stopped {
            stage: self.label.clone(),
            told: told as u64,
            planned: self.cx.stage.planned(),
        }
    }

    /// Files a finished run with its trial (a failed one per `on_error`).
    fn receive(&mut self, done: Done) -> Result<(), CampaignError> {
        let Some(slot) = self.queue.iter_mut().find(|s| s.trial.id == done.trial) else {
            return Ok(());
        };
        match done.result {
            Ok(r) => match done.which {
                Role::High => slot.hf = Some(r),
                Role::Learned => match slot.audit {
                    // Screening: an LF failure is confirmed at the next level up (HF after
                    // the last), an audited pass checked on HF.
                    Some(audit) => {
                        if let Some(step) = slot.screened(r, audit) {
                            let trial = slot.trial.clone();
                            self.send_step(&trial, step)?;
                        }
                    }
                    None => slot.lf = Some(r),
                },
            },
            Err(source) if self.cx.on_error == OnError::Skip => {
                slot.error
                    .get_or_insert(format!("{} run: {source}", done.which.name()));
            }
            Err(source) => {
                return Err(simulation_error(
                    &self.label,
                    &slot.trial,
                    done.which.name(),
                    source,
                ))
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::config::{self, Overrides, NULL};
    use crate::toy::NullSimulator;
    use crate::{Campaign, CampaignError, Cost};

    #[test]
    fn a_result_the_kernel_refuses_is_named_as_the_simulators_not_as_a_diverged_store() {
        // The null simulator's runs take no time: under wall-clock cost the kernel refuses
        // their runtime of 0. The trial store is new, so it cannot be what is wrong.
        let over = Overrides {
            cost: Some(Cost::Wall),
            ..Overrides::default()
        };
        let (protocol, problem) = config::toy(NULL, &over).expect("toy protocol");
        let out = std::env::temp_dir().join(format!("savme-untellable-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let e = Campaign::new(protocol, problem)
            .out(&out)
            .jobs(1)
            .run(&NullSimulator)
            .expect_err("a runtime of 0 was told");
        let _ = std::fs::remove_dir_all(&out);
        assert!(
            matches!(&e, CampaignError::Untellable { stage, index: 0, .. } if stage == "baseline-train"),
            "{e:?}"
        );
        let text = e.to_string();
        assert!(
            text.contains("the simulator's result cannot be told") && text.contains("runtime"),
            "{text}"
        );
    }
}

//! Runs a stage's trials: up to `window` trials in flight, every HF and LF run a separate
//! [`Task`] (so the two runs of a trial execute concurrently), trials told strictly in ask
//! order — which makes a campaign independent of the number and the kind of workers. Where the
//! runs execute is a [`Runner`]: [`local`] threads, or a [`RemoteRunner`] (e.g. `savme worker`
//! processes through PostgreSQL, crate `savme-postgres`).

pub mod local;

pub use local::{with_pool, Pool};

use super::log::{FailedLine, LogLine, RunLine, ScreenLine, TrialLine};
use super::protocol::{OnError, Stage, StageId};
use super::store::{EditedLine, StoreError, TrialStore};
use super::CampaignError;
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
}

impl Slot {
    fn ready(&self) -> bool {
        if self.logged.is_some() || self.error.is_some() {
            return true;
        }
        match (self.audit, &self.lf) {
            // Screening: the LF run, then HF only to confirm a failure or for the audit.
            (Some(audit), Some(lf)) => self.hf.is_some() || !(lf.failure || audit),
            (Some(_), None) => false,
            (None, _) => self.hf.is_some() && (self.lf.is_some() || self.trial.theta_lf.is_none()),
        }
    }
}

/// A screening stage's audit: its seed and fraction α ([`savme_kernel::screening::audited`]).
#[derive(Debug, Clone, Copy)]
pub struct Audit {
    /// Seed of the audit draws.
    pub seed: u64,
    /// Fraction of LF passes run on HF.
    pub fraction: f64,
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
        let done = run.pool.next_done()?;
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
}

impl StageRun<'_, '_, '_> {
    /// Asks the next trial and sends its runs to the workers (or takes its logged line on
    /// resume); false when the stage has asked enough (withdrawn trials are replaced).
    fn ask(&mut self) -> Result<bool, CampaignError> {
        if self.asked - self.failed >= self.cx.stage.iterations {
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
            .map(|a| savme_kernel::screening::audited(a.seed, index, a.fraction));
        match &logged {
            Some((number, l)) => {
                let at = (self.cx.store.location(), *number);
                check_logged(l, &trial, self.cx.stage.id(), index, at)?
            }
            None => {
                if audit.is_none() {
                    let theta_hf = self.theta_hf.clone();
                    self.send(&trial, Role::High, &theta_hf)?;
                }
                if let Some(theta) = &trial.theta_lf {
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
        });
        Ok(true)
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
            let line = tell(
                self.kernel,
                slot,
                &self.label,
                self.cx.stage,
                self.cx.cost,
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
            match &line {
                LogLine::Trial(_) | LogLine::Screen(_) => progress(&line, self.kernel),
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
            iterations: self.cx.stage.iterations,
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
                Role::Learned => {
                    // Screening: an LF failure is confirmed on HF, an audited pass checked.
                    let confirm = slot.audit.is_some_and(|audit| r.failure || audit);
                    slot.lf = Some(r);
                    if confirm {
                        let (trial, theta_hf) = (slot.trial.clone(), self.theta_hf.clone());
                        self.send(&trial, Role::High, &theta_hf)?;
                    }
                }
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

fn simulation_error(
    label: &str,
    trial: &Trial,
    run: &'static str,
    source: SimError,
) -> CampaignError {
    CampaignError::Simulation(Box::new(super::error::SimulationError {
        stage: label.into(),
        trial: trial.id,
        scenario: trial.scenario.to_string(),
        phi: trial.phi.to_string(),
        run,
        source,
    }))
}

/// A logged trial must be the one the protocol asks for now; the error names the store, the
/// line `at` and the first field that differs (a φ or θ by its variable).
fn check_logged(
    l: &LogLine,
    t: &Trial,
    expected: StageId,
    index: u64,
    at: (String, u64),
) -> Result<(), CampaignError> {
    let (stage, i, id, scenario, phi, theta) = match l {
        LogLine::Trial(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
        LogLine::Failed(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
        LogLine::Screen(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
    };
    let show = |v: &dyn std::fmt::Display| v.to_string();
    let differs: Option<(String, String, String)> = if *stage != expected {
        Some(("stage".into(), show(stage), show(&expected)))
    } else if i != index {
        Some(("index".into(), show(&i), show(&index)))
    } else if id != t.id {
        Some(("id".into(), show(&id), show(&t.id)))
    } else if **scenario != *t.scenario {
        Some(("scenario".into(), show(scenario), t.scenario.to_string()))
    } else if *phi != t.phi {
        Some(assignment_difference("phi", phi, &t.phi))
    } else if *theta != t.theta_lf {
        Some(match (theta, &t.theta_lf) {
            (Some(a), Some(b)) => assignment_difference("theta_lf", a, b),
            (a, b) => ("theta_lf".into(), format!("{a:?}"), format!("{b:?}")),
        })
    } else {
        None
    };
    match differs {
        None => Ok(()),
        Some((field, logged, asked)) => Err(CampaignError::Log {
            store: at.0,
            line: at.1 as usize,
            message: format!(
                "field `{field}` is {logged}, but the protocol asks {asked} here ({expected} trial {index}): the line was edited, or written by another campaign"
            ),
        }),
    }
}

/// The first variable in which two assignments differ: (`field.variable`, logged, asked).
fn assignment_difference(
    field: &str,
    logged: &Assignment,
    asked: &Assignment,
) -> (String, String, String) {
    let none = || "(none)".to_string();
    let names: std::collections::BTreeSet<&str> = logged
        .iter()
        .chain(asked.iter())
        .map(|(name, _)| name)
        .collect();
    for name in names {
        let (a, b) = (logged.get(name), asked.get(name));
        if a != b {
            let a = a.map_or_else(none, |v| v.to_string());
            let b = b.map_or_else(none, |v| v.to_string());
            return (format!("{field}.{name}"), a, b);
        }
    }
    (field.into(), logged.to_string(), asked.to_string())
}

/// Tells the kernel a trial whose runs are in: its logged line on resume (checked against
/// what the kernel credits), a withdrawal if a run failed, else its runs — storing the line
/// (with the kernel's outcome and credit) before the next trial is told.
fn tell(
    kernel: &mut Kernel,
    mut slot: Slot,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
    store: &mut dyn TrialStore,
) -> Result<LogLine, CampaignError> {
    let cx = TellCx {
        label,
        stage,
        cost,
        index: slot.index,
        id: slot.trial.id,
    };
    match slot.logged.take() {
        Some((number, logged)) => cx.replay(kernel, &slot, number, logged, store),
        None => cx.tell_ran(kernel, slot, store),
    }
}

/// What telling one trial of a stage needs to know.
struct TellCx<'a> {
    label: &'a str,
    stage: &'a Stage,
    cost: CostMeasure,
    index: u64,
    id: u64,
}

impl TellCx<'_> {
    fn diverged(&self, message: String) -> CampaignError {
        CampaignError::Diverged {
            stage: self.label.into(),
            index: self.index,
            message,
        }
    }

    fn untellable(&self, e: savme_kernel::TellError) -> CampaignError {
        CampaignError::Untellable {
            stage: self.label.into(),
            index: self.index,
            message: e.to_string(),
        }
    }

    fn withdraw(&self, kernel: &mut Kernel) -> Result<(), CampaignError> {
        kernel
            .cancel(self.id)
            .map(|_| ())
            .map_err(|e| self.diverged(format!("the failed trial cannot be withdrawn: {e}")))
    }

    /// A stored line replayed on resume: told as logged, and refused (naming the store line
    /// and field) where replaying the trial gives something else.
    fn replay(
        &self,
        kernel: &mut Kernel,
        slot: &Slot,
        number: u64,
        logged: LogLine,
        store: &mut dyn TrialStore,
    ) -> Result<LogLine, CampaignError> {
        let tampered = |field: &str, logged: String, computed: String| {
            CampaignError::Log {
            store: store.location(),
            line: number as usize,
            message: format!(
                "field `{field}` is {logged} but replaying the trial gives {computed}: the line was edited, or written by another campaign"
            ),
        }
        };
        let cannot_tell = |e| self.diverged(format!("the logged outcome cannot be told: {e}"));
        match logged {
            LogLine::Failed(f) => {
                self.withdraw(kernel)?;
                Ok(LogLine::Failed(f))
            }
            LogLine::Screen(l) => {
                let expected =
                    savme_kernel::screening::decide(l.lf.failure, slot.audit == Some(true));
                let hf_expected = expected != savme_kernel::screening::Screen::Pass;
                if slot.audit.is_none() || l.screen != expected || l.hf.is_some() != hf_expected {
                    return Err(tampered(
                        "screen",
                        format!("{:?} (HF run: {})", l.screen, l.hf.is_some()),
                        format!("{expected:?}"),
                    ));
                }
                tell_screened(kernel, self.id, &l.lf, l.hf.as_ref()).map_err(cannot_tell)?;
                Ok(LogLine::Screen(l))
            }
            LogLine::Trial(l) => {
                check_costs(&l, self.cost, &tampered)?;
                let record = kernel.tell(self.id, l.observation()).map_err(cannot_tell)?;
                let show = |v: &dyn std::fmt::Debug| format!("{v:?}");
                let checks = [
                    ("phase", show(&l.phase), show(&slot.trial.phase)),
                    ("budget", show(&l.budget), show(&self.stage.budget)),
                    ("outcome", show(&l.outcome), show(&record.outcome)),
                    ("cost_ratio", show(&l.cost_ratio), show(&record.cost_ratio)),
                    ("credit", show(&l.credit), show(&record.credit)),
                ];
                match checks.into_iter().find(|(_, a, b)| a != b) {
                    Some((field, logged, computed)) => Err(tampered(field, logged, computed)),
                    None => Ok(LogLine::Trial(l)),
                }
            }
        }
    }

    /// A trial this process ran: withdrawn if a run failed, else told; its line stored.
    fn tell_ran(
        &self,
        kernel: &mut Kernel,
        slot: Slot,
        store: &mut dyn TrialStore,
    ) -> Result<LogLine, CampaignError> {
        let (label, stage, cost) = (self.label, self.stage, self.cost);
        let line = if let Some(error) = slot.error {
            self.withdraw(kernel)?;
            LogLine::Failed(FailedLine {
                stage: stage.id(),
                index: slot.index,
                id: slot.trial.id,
                scenario: slot.trial.scenario.to_string(),
                phi: slot.trial.phi.clone(),
                theta_lf: slot.trial.theta_lf.clone(),
                error,
            })
        } else if let Some(audit) = slot.audit {
            let l = screen_line(&slot, audit, label, stage, cost)?;
            tell_screened(kernel, self.id, &l.lf, l.hf.as_ref()).map_err(|e| self.untellable(e))?;
            LogLine::Screen(l)
        } else {
            let mut line = trial_line(&slot, label, stage, cost)?;
            let record = kernel
                .tell(self.id, line.observation())
                .map_err(|e| self.untellable(e))?;
            line.cost_ratio = record.cost_ratio;
            line.outcome = record.outcome;
            line.credit = record.credit;
            LogLine::Trial(line)
        };
        store.append(&line)?;
        Ok(line)
    }
}

/// The line of a run of `slot`'s trial, with the protocol's cost.
fn run_line(
    r: &SimResult,
    which: &'static str,
    slot: &Slot,
    label: &str,
    cost: CostMeasure,
) -> Result<RunLine, CampaignError> {
    let run = r
        .run(cost)
        .map_err(|source| simulation_error(label, &slot.trial, which, source))?;
    Ok(RunLine::new(r, run.runtime))
}

/// Tells the kernel a screened trial: paired when HF ran, LF alone otherwise.
fn tell_screened(
    kernel: &mut Kernel,
    id: u64,
    lf: &RunLine,
    hf: Option<&RunLine>,
) -> Result<(), savme_kernel::TellError> {
    match hf {
        Some(hf) => kernel
            .tell(
                id,
                savme_kernel::Observation::Paired {
                    hf: hf.run(),
                    lf: lf.run(),
                },
            )
            .map(|_| ()),
        None => kernel.tell_unconfirmed(id, lf.run()).map(|_| ()),
    }
}

/// The line of a screened trial whose runs are in.
fn screen_line(
    slot: &Slot,
    audit: bool,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
) -> Result<ScreenLine, CampaignError> {
    let run_line = |r: &SimResult, which| run_line(r, which, slot, label, cost);
    let lf = run_line(slot.lf.as_ref().ok_or(CampaignError::WorkersGone)?, "LF")?;
    let hf = match &slot.hf {
        Some(r) => Some(run_line(r, "HF")?),
        None => None,
    };
    let outcome = hf.map(|h| savme_kernel::Outcome::classify(h.failure, lf.failure));
    Ok(ScreenLine {
        stage: stage.id(),
        index: slot.index,
        id: slot.trial.id,
        budget: stage.budget,
        scenario: slot.trial.scenario.to_string(),
        phi: slot.trial.phi.clone(),
        theta_lf: slot.trial.theta_lf.clone(),
        screen: savme_kernel::screening::decide(lf.failure, audit),
        lf,
        hf,
        outcome,
    })
}

/// A stored trial's costs must be what the protocol's cost measure gives: its work units, or
/// its measured wall-clock seconds.
fn check_costs(
    l: &TrialLine,
    cost: CostMeasure,
    tampered: &dyn Fn(&str, String, String) -> CampaignError,
) -> Result<(), CampaignError> {
    for (name, run) in [("hf", Some(&l.hf)), ("lf", l.lf.as_ref())] {
        let Some(run) = run else { continue };
        let expected = match cost {
            CostMeasure::Work => run.work.map(|w| w as f64),
            CostMeasure::Wall => Some(run.wall_seconds),
        };
        if expected != Some(run.runtime) {
            return Err(tampered(
                &format!("{name}.runtime"),
                run.runtime.to_string(),
                expected.map_or("no cost".into(), |e| e.to_string()),
            ));
        }
    }
    Ok(())
}

/// The line of a trial whose runs are in (before the kernel's assessment).
fn trial_line(
    slot: &Slot,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
) -> Result<TrialLine, CampaignError> {
    let run_line = |r: &SimResult, which| run_line(r, which, slot, label, cost);
    let hf = run_line(slot.hf.as_ref().ok_or(CampaignError::WorkersGone)?, "HF")?;
    let lf = match &slot.lf {
        Some(r) => Some(run_line(r, "LF")?),
        None => None,
    };
    Ok(TrialLine {
        stage: stage.id(),
        index: slot.index,
        id: slot.trial.id,
        phase: slot.trial.phase,
        budget: stage.budget,
        scenario: slot.trial.scenario.to_string(),
        phi: slot.trial.phi.clone(),
        theta_lf: slot.trial.theta_lf.clone(),
        hf,
        lf,
        cost_ratio: None,
        outcome: None,
        credit: Default::default(),
    })
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

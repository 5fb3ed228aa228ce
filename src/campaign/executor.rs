//! Runs a stage's trials on a pool of worker threads: up to `window` trials in flight, every
//! HF and LF run a separate task (so the two runs of a trial execute concurrently), trials told
//! strictly in ask order — which makes a campaign independent of the number of workers.

use super::log::{FailedLine, LogLine, RunLine, TrialLine};
use super::protocol::{OnError, Stage};
use super::store::TrialStore;
use super::CampaignError;
use crossbeam_channel::{Receiver, Sender};
use savme_kernel::{Assignment, CostMeasure, Kernel, Role, SimError, SimResult, Simulator, Trial};
use std::collections::VecDeque;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Which of a trial's two runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Which {
    Hf,
    Lf,
}

struct Task {
    trial: u64,
    which: Which,
    scenario: Arc<str>,
    phi: Assignment,
    fidelity: Assignment,
}

struct Done {
    trial: u64,
    which: Which,
    result: Result<SimResult, SimError>,
}

/// Worker threads, each with its own simulator.
pub struct Pool {
    tasks: Sender<Task>,
    done: Receiver<Done>,
}

/// Starts `jobs` workers, each with a clone of `sim`, runs `f` with the pool, and stops the
/// workers (dropping queued tasks) when `f` returns.
pub fn with_pool<S, R>(sim: &S, jobs: usize, f: impl FnOnce(&mut Pool) -> R) -> R
where
    S: Simulator + Clone + Send,
{
    let (task_tx, task_rx) = crossbeam_channel::unbounded::<Task>();
    let (done_tx, done_rx) = crossbeam_channel::unbounded::<Done>();
    let stop = Arc::new(AtomicBool::new(false));
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            let (rx, tx, stop) = (task_rx.clone(), done_tx.clone(), stop.clone());
            let mut sim = sim.clone();
            scope.spawn(move || {
                for t in rx {
                    if stop.load(Ordering::Relaxed) {
                        break;
                    }
                    let role = match t.which {
                        Which::Hf => Role::High,
                        Which::Lf => Role::Learned,
                    };
                    let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
                        sim.simulate_as(role, &t.scenario, &t.phi, &t.fidelity)
                    }))
                    .unwrap_or_else(|panic| {
                        let what = panic
                            .downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| panic.downcast_ref::<String>().cloned())
                            .unwrap_or_else(|| "unknown panic".into());
                        Err(SimError::Failed(format!("the simulator panicked: {what}")))
                    });
                    let done = Done {
                        trial: t.trial,
                        which: t.which,
                        result,
                    };
                    if tx.send(done).is_err() {
                        break;
                    }
                }
            });
        }
        drop(done_tx);
        drop(task_rx);
        let mut pool = Pool {
            tasks: task_tx,
            done: done_rx,
        };
        let r = f(&mut pool);
        stop.store(true, Ordering::Relaxed);
        drop(pool);
        r
    })
}

/// A trial in flight.
struct Slot {
    trial: Trial,
    index: u64,
    hf: Option<SimResult>,
    lf: Option<SimResult>,
    logged: Option<LogLine>,
    error: Option<String>,
}

impl Slot {
    fn ready(&self) -> bool {
        self.logged.is_some()
            || self.error.is_some()
            || (self.hf.is_some() && (self.lf.is_some() || self.trial.theta_lf.is_none()))
    }
}

/// What a stage needs besides the kernel.
pub struct StageContext<'a> {
    /// The stage.
    pub stage: &'a Stage,
    /// Lines of this stage already in `trials.jsonl` (replayed, not run).
    pub logged: &'a [LogLine],
    /// Trials in flight at once.
    pub window: usize,
    /// How run costs are measured.
    pub cost: CostMeasure,
    /// The trial store.
    pub store: &'a mut dyn TrialStore,
    /// What a failed simulation does.
    pub on_error: OnError,
}

fn which_name(w: Which) -> &'static str {
    match w {
        Which::Hf => "HF",
        Which::Lf => "LF",
    }
}

/// Runs (or replays) one stage on `kernel` until it has told `stage.iterations` trials; calls
/// `progress` after each told trial (with the kernel that learnt from it) and returns the
/// stage's lines (withdrawn trials included).
pub fn run_stage(
    pool: &mut Pool,
    kernel: &mut Kernel,
    cx: StageContext<'_>,
    mut progress: impl FnMut(&TrialLine, &Kernel),
) -> Result<Vec<LogLine>, CampaignError> {
    let stage = cx.stage;
    let label = stage.label();
    kernel.set_phase(stage.phase());
    let theta_hf = kernel.theta_hf().clone();
    let mut lines = Vec::with_capacity(stage.iterations as usize);
    let mut queue: VecDeque<Slot> = VecDeque::new();
    let mut asked = 0u64;
    let failed = std::cell::Cell::new(0u64);
    // Asks the next trial (false when enough trials are asked: withdrawn ones are replaced).
    let mut ask =
        |kernel: &mut Kernel, queue: &mut VecDeque<Slot>| -> Result<bool, CampaignError> {
            if asked - failed.get() >= stage.iterations {
                return Ok(false);
            }
            let trial = kernel.ask();
            let index = asked;
            asked += 1;
            let logged = cx.logged.get(index as usize).cloned();
            if let Some(l) = &logged {
                check_logged(l, &trial, &label, index)?;
            } else {
                let task = |which, fidelity: &Assignment| Task {
                    trial: trial.id,
                    which,
                    scenario: trial.scenario.clone(),
                    phi: trial.phi.clone(),
                    fidelity: fidelity.clone(),
                };
                let send = |t| pool.tasks.send(t).map_err(|_| CampaignError::WorkersGone);
                send(task(Which::Hf, &theta_hf))?;
                if let Some(theta) = &trial.theta_lf {
                    send(task(Which::Lf, theta))?;
                }
            }
            queue.push_back(Slot {
                trial,
                index,
                hf: None,
                lf: None,
                logged,
                error: None,
            });
            Ok(true)
        };
    while queue.len() < cx.window && ask(kernel, &mut queue)? {}
    while !queue.is_empty() {
        while queue.front().is_some_and(Slot::ready) {
            let Some(slot) = queue.pop_front() else { break };
            let line = tell(kernel, slot, &label, stage, cx.cost, cx.store)?;
            match &line {
                LogLine::Trial(t) => progress(t, kernel),
                LogLine::Failed(f) => {
                    failed.set(failed.get() + 1);
                    if failed.get() > stage.iterations {
                        return Err(CampaignError::TooManyFailures {
                            stage: label,
                            failures: failed.get(),
                            last: f.error.clone(),
                        });
                    }
                }
            }
            lines.push(line);
            ask(kernel, &mut queue)?;
        }
        if queue.is_empty() {
            break;
        }
        let done = pool.done.recv().map_err(|_| CampaignError::WorkersGone)?;
        let Some(slot) = queue.iter_mut().find(|s| s.trial.id == done.trial) else {
            continue;
        };
        match done.result {
            Ok(r) => match done.which {
                Which::Hf => slot.hf = Some(r),
                Which::Lf => slot.lf = Some(r),
            },
            Err(source) if cx.on_error == OnError::Skip => {
                slot.error
                    .get_or_insert(format!("{} run: {source}", which_name(done.which)));
            }
            Err(source) => {
                return Err(CampaignError::Simulation(Box::new(
                    super::error::SimulationError {
                        stage: label,
                        trial: slot.trial.id,
                        scenario: slot.trial.scenario.to_string(),
                        phi: slot.trial.phi.to_string(),
                        run: which_name(done.which),
                        source,
                    },
                )))
            }
        }
    }
    Ok(lines)
}

/// A logged trial must be the one the protocol asks for now.
fn check_logged(l: &LogLine, t: &Trial, label: &str, index: u64) -> Result<(), CampaignError> {
    let (stage, i, id, scenario, phi, theta) = match l {
        LogLine::Trial(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
        LogLine::Failed(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
    };
    let same = stage == label
        && i == index
        && id == t.id
        && *scenario == *t.scenario
        && *phi == t.phi
        && *theta == t.theta_lf;
    if same {
        Ok(())
    } else {
        Err(CampaignError::Diverged {
            stage: label.into(),
            index,
            message: format!(
                "the log has trial {id} ({stage} {scenario}, {phi}) where the protocol asks trial {} ({} {})",
                t.id, t.scenario, t.phi
            ),
        })
    }
}

fn tell(
    kernel: &mut Kernel,
    slot: Slot,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
    store: &mut dyn TrialStore,
) -> Result<LogLine, CampaignError> {
    let diverged = |message: String| CampaignError::Diverged {
        stage: label.into(),
        index: slot.index,
        message,
    };
    let withdraw = |kernel: &mut Kernel| {
        kernel
            .cancel(slot.trial.id)
            .map(|_| ())
            .map_err(|e| diverged(format!("the failed trial cannot be withdrawn: {e}")))
    };
    match slot.logged {
        Some(LogLine::Failed(f)) => {
            withdraw(kernel)?;
            return Ok(LogLine::Failed(f));
        }
        Some(LogLine::Trial(l)) => {
            let record = kernel
                .tell(slot.trial.id, l.observation())
                .map_err(|e| diverged(format!("the logged outcome cannot be told: {e}")))?;
            if record.credit != l.credit {
                return Err(diverged(format!(
                    "the kernel credits {:?} where the log says {:?}",
                    record.credit, l.credit
                )));
            }
            return Ok(LogLine::Trial(l));
        }
        None => {}
    }
    if let Some(error) = slot.error {
        withdraw(kernel)?;
        let line = LogLine::Failed(FailedLine {
            stage: label.into(),
            index: slot.index,
            id: slot.trial.id,
            scenario: slot.trial.scenario.to_string(),
            phi: slot.trial.phi.clone(),
            theta_lf: slot.trial.theta_lf.clone(),
            error,
        });
        store.append(&line.to_value())?;
        return Ok(line);
    }
    let run_line = |r: &SimResult, which: &'static str| -> Result<RunLine, CampaignError> {
        let run = r.run(cost).map_err(|source| {
            CampaignError::Simulation(Box::new(super::error::SimulationError {
                stage: label.into(),
                trial: slot.trial.id,
                scenario: slot.trial.scenario.to_string(),
                phi: slot.trial.phi.to_string(),
                run: which,
                source,
            }))
        })?;
        Ok(RunLine::new(r, run.runtime))
    };
    let hf = run_line(slot.hf.as_ref().ok_or(CampaignError::WorkersGone)?, "HF")?;
    let lf = match &slot.lf {
        Some(r) => Some(run_line(r, "LF")?),
        None => None,
    };
    let mut line = TrialLine {
        stage: label.into(),
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
    };
    let record = kernel
        .tell(slot.trial.id, line.observation())
        .map_err(|e| diverged(format!("the outcome cannot be told: {e}")))?;
    line.cost_ratio = record.cost_ratio;
    line.outcome = record.outcome;
    line.credit = record.credit;
    let line = LogLine::Trial(line);
    store.append(&line.to_value())?;
    Ok(line)
}

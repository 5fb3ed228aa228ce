//! [`Campaign`]: the one loop every front end runs — `savme reproduce`, `savme run`, and
//! whatever embeds the library.

use super::executor::{self, RemoteRunner, Runner, StageContext};
use super::kernels::StageKernels;
use super::log::{self, LogLine, TrialLine};
use super::outputs::{self, Outputs};
use super::protocol::{StageId, StageKind};
use super::store::{EditedLine, JsonlStore, Loaded, StoreError, TrialStore};
use super::ScreenLf;
use super::{CampaignError, CampaignOutcome, Observer, Problem, Protocol, Report, Stop};
use savme_kernel::screening::Economy;
use savme_kernel::{Kernel, Simulator};
use std::path::PathBuf;
use std::time::Instant;

/// Stored lines with their line numbers in the store.
/// The stored lines with their line numbers, and the first edited one ([`Loaded::edited`]).
type NumberedLines = (Vec<(u64, LogLine)>, Option<EditedLine>);

/// A campaign to run: the protocol (what runs), the problem (what is searched), where results
/// go, how many workers, which trial store, and who watches.
///
/// ```no_run
/// use savme_campaign::{Campaign, Problem, ProgressBars, Protocol};
/// use savme_sim::sim::DrivingSimulator;
///
/// let (train, test) = savme_sim::scenario::train_test_names();
/// let protocol = Protocol::quick("savme-sim/sensors", train, test);
/// let outcome = Campaign::new(protocol.clone(), Problem::from(savme_sim::problem(protocol.fidelity_bins)))
///     .out("results")
///     .jobs(2)
///     .observer(ProgressBars::new())
///     .run(&DrivingSimulator::default())?;
/// println!("{}", outcome.report.table_md());
/// # Ok::<(), savme_campaign::CampaignError>(())
/// ```
pub struct Campaign<'o> {
    protocol: Protocol,
    problem: Problem,
    out: PathBuf,
    resume: bool,
    jobs: usize,
    store: Option<Box<dyn TrialStore>>,
    remote: Option<Box<dyn RemoteRunner>>,
    observers: Vec<Box<dyn Observer + 'o>>,
    stop: Stop,
}

impl<'o> Campaign<'o> {
    /// A new campaign into `savme-results/`, one worker per core, the JSON-lines store in the
    /// output directory, no observers.
    pub fn new(protocol: Protocol, problem: Problem) -> Self {
        Campaign {
            protocol,
            problem,
            out: PathBuf::from("savme-results"),
            resume: false,
            jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
            store: None,
            remote: None,
            observers: Vec::new(),
            stop: Stop::new(),
        }
    }

    /// The output directory (created if missing; a new campaign needs one without a campaign).
    pub fn out(mut self, dir: impl Into<PathBuf>) -> Self {
        self.out = dir.into();
        self
    }

    /// Continue the campaign in the output directory instead of starting one: its
    /// `protocol.json` must equal this protocol, and its stored trials are replayed.
    pub fn resume(mut self, resume: bool) -> Self {
        self.resume = resume;
        self
    }

    /// Worker threads (at least 1; the results do not depend on it).
    pub fn jobs(mut self, jobs: usize) -> Self {
        self.jobs = jobs.max(1);
        self
    }

    /// The trial store (default: `trials.jsonl` in the output directory, a [`JsonlStore`]).
    pub fn store(mut self, store: Box<dyn TrialStore>) -> Self {
        self.store = Some(store);
        self
    }

    /// Runs the HF and LF runs through `remote` (e.g. a database's work queue, served by
    /// `savme worker` processes on any host) instead of local threads (the trials are the
    /// same; `jobs` is unused).
    pub fn remote(mut self, remote: impl RemoteRunner + 'static) -> Self {
        self.remote = Some(Box::new(remote));
        self
    }

    /// Adds an observer; all are told, in the order added.
    pub fn observer(mut self, observer: impl Observer + 'o) -> Self {
        self.observers.push(Box::new(observer));
        self
    }

    /// Stops the campaign between trials when `stop` is requested: [`run`](Self::run) then
    /// returns [`CampaignError::Stopped`] with every told trial stored (see [`Stop`]).
    pub fn stop_on(mut self, stop: Stop) -> Self {
        self.stop = stop;
        self
    }

    /// Adds a boxed observer.
    pub fn boxed_observer(mut self, observer: Box<dyn Observer + 'o>) -> Self {
        self.observers.push(observer);
        self
    }

    /// Runs (or resumes) the campaign on `sim` and writes every output. Every error — bad
    /// protocol, unknown scenario, unwritable directory, a store held by another process, a
    /// corrupt trial line — comes before any simulation runs, except failures of the
    /// simulations themselves. The observers are finished whatever happens.
    pub fn run<S>(mut self, sim: &S) -> Result<CampaignOutcome, CampaignError>
    where
        S: Simulator + Clone + Send,
    {
        let mut observers = std::mem::take(&mut self.observers);
        let result = self.run_observed(sim, &mut observers);
        let mut finished = Ok(());
        for o in &mut observers {
            let r = o.finish();
            if finished.is_ok() {
                finished = r;
            }
        }
        let outcome = result?;
        finished.map(|()| outcome)
    }

    fn run_observed<S>(
        mut self,
        sim: &S,
        observers: &mut [Box<dyn Observer + 'o>],
    ) -> Result<CampaignOutcome, CampaignError>
    where
        S: Simulator + Clone + Send,
    {
        let clock = Instant::now();
        let custom_store = self.store.take();
        let p = &self.protocol;
        p.validate()?;
        let problem = self.problem.binned_for(p)?;
        let mut kernels = StageKernels::new(p, &problem)?;
        let files = Outputs::in_dir(&self.out);
        let (mut store, (logged, edited)) = self.open_store(&files, custom_store)?;
        let numbers: Vec<u64> = logged.iter().map(|(n, _)| *n).collect();
        let logged: Vec<LogLine> = logged.into_iter().map(|(_, l)| l).collect();
        let location = store.location();
        let by_stage = log::split_by_stage(p, &logged, &numbers, &location)?;

        for o in observers.iter_mut() {
            o.start(p);
        }
        let mut stages = Stages {
            protocol: p,
            by_stage: &by_stage,
            numbers: &numbers,
            kernels: &mut kernels,
            store: store.as_mut(),
            observers,
            stop: &self.stop,
            edited: edited.as_ref(),
        };
        let all_lines = match self.remote.take() {
            None => executor::with_pool(sim, self.jobs, |pool| stages.run(pool))?,
            Some(mut remote) => {
                let lines = stages.run(remote.as_mut())?;
                remote.finish()?;
                lines
            }
        };
        // Every stored line was replayed, the edited one refused there; this is a safety net.
        if let Some(e) = &edited {
            return Err(StoreError::BadLine {
                store: location,
                line: e.line,
                message: e.message.clone(),
            }
            .into());
        }
        drop(store);
        self.write_outcome(files, &problem, &logged, &all_lines, clock)
    }

    /// The report and the output files of a campaign whose stages are done: `logged` were
    /// replayed, `all_lines` are every stage's lines; `problem` binned as the campaign ran it.
    fn write_outcome(
        &self,
        files: Outputs,
        problem: &Problem,
        logged: &[LogLine],
        all_lines: &[LogLine],
        clock: Instant,
    ) -> Result<CampaignOutcome, CampaignError> {
        let p = &self.protocol;
        let count = |l: &[LogLine]| l.iter().filter(|x| x.is_told()).count() as u64;
        let replayed = count(logged);
        let trials: Vec<TrialLine> = all_lines
            .iter()
            .filter_map(|l| l.trial().cloned())
            .collect();
        let screened: Vec<_> = all_lines
            .iter()
            .filter_map(|l| l.screened().cloned())
            .collect();
        let failed = all_lines.iter().filter(|l| !l.is_told()).count();
        let mut report = Report::from_trials(p, &trials);
        report.add_screening(&screened, &trials);
        report.add_fidelity(problem, &trials);
        let elapsed = clock.elapsed().as_secs_f64();
        outputs::write(&report, &trials, failed, &files, problem, elapsed)?;
        Ok(CampaignOutcome {
            ran: count(all_lines) - replayed,
            report,
            outputs: files,
            replayed,
            elapsed_seconds: clock.elapsed().as_secs_f64(),
            trials,
            withdrawn: failed as u64,
        })
    }

    /// Prepares the output directory and opens (and locks) the store: a new campaign writes
    /// `protocol.json` and needs an empty store; a resumed one checks `protocol.json` and reads
    /// the stored lines (with their line numbers).
    fn open_store(
        &self,
        files: &Outputs,
        custom: Option<Box<dyn TrialStore>>,
    ) -> Result<(Box<dyn TrialStore>, NumberedLines), CampaignError> {
        outputs::usable_dir(&self.out)?;
        let mut custom = custom;
        let keeps = custom
            .as_mut()
            .is_some_and(|s| s.protocol_keeper().is_some());
        match custom {
            Some(store) if keeps => self.open_keeping_store(store),
            custom => self.open_beside_protocol_file(files, custom),
        }
    }

    /// Opens a store that keeps the protocol itself (a database): a new campaign saves it
    /// there and needs an empty store; a resumed one checks it. The output directory only
    /// receives the results.
    fn open_keeping_store(
        &self,
        mut store: Box<dyn TrialStore>,
    ) -> Result<(Box<dyn TrialStore>, NumberedLines), CampaignError> {
        std::fs::create_dir_all(&self.out).map_err(|e| CampaignError::io(&self.out, e))?;
        let location = store.location();
        let saved = match store.protocol_keeper() {
            Some(keeper) => keeper.load_protocol()?,
            None => None,
        };
        let loaded = store.load()?;
        match (self.resume, saved) {
            (true, None) => return Err(CampaignError::NothingToResumeIn { store: location }),
            (true, Some(saved)) => {
                let saved: Protocol =
                    serde_json::from_value(saved).map_err(|e| CampaignError::Log {
                        store: format!("{location}, protocol"),
                        line: e.line(),
                        message: e.to_string(),
                    })?;
                if saved != self.protocol {
                    return Err(CampaignError::Protocol {
                        field: "protocol".into(),
                        message: format!(
                            "{location} holds a different protocol than the one given to resume"
                        ),
                    });
                }
            }
            (false, saved) if saved.is_some() || !loaded.lines.is_empty() => {
                return Err(CampaignError::CampaignExists { store: location })
            }
            (false, _) => {
                let value =
                    serde_json::to_value(&self.protocol).map_err(|e| CampaignError::Protocol {
                        field: "protocol".into(),
                        message: e.to_string(),
                    })?;
                if let Some(keeper) = store.protocol_keeper() {
                    keeper.save_protocol(&value)?;
                }
            }
        }
        let lines = numbered(&loaded, &location)?;
        Ok((store, lines))
    }

    /// Opens a store that does not keep the protocol itself (the JSON-lines default, or a
    /// custom one): a new campaign appends the protocol as the store's first record and
    /// writes `protocol.json`, a copy for people; a resumed one checks the store's first
    /// record — or, in a store written before the protocol was kept there, `protocol.json`.
    fn open_beside_protocol_file(
        &self,
        files: &Outputs,
        custom: Option<Box<dyn TrialStore>>,
    ) -> Result<(Box<dyn TrialStore>, NumberedLines), CampaignError> {
        if self.resume && custom.is_none() {
            // Before the store is opened (and created): a directory without a campaign.
            self.check_saved(outputs::load_protocol(&self.out)?, "trials.jsonl")?;
        }
        if !self.resume {
            std::fs::create_dir_all(&self.out).map_err(|e| CampaignError::io(&self.out, e))?;
        }
        let default_store_exists = files.protocol.exists() || files.trials.exists();
        if !self.resume && custom.is_none() && default_store_exists {
            // Not a new campaign's directory: say so — or, when a process is running the
            // campaign there, name it (opening the store fails with its pid).
            drop(JsonlStore::open(&files.trials)?);
            return Err(CampaignError::OutputExists {
                path: self.out.clone(),
            });
        }
        let mut store: Box<dyn TrialStore> = match custom {
            Some(s) => s,
            None => Box::new(JsonlStore::open(&files.trials)?),
        };
        let loaded = store.load()?;
        let location = store.location();
        let (saved, lines) = log::read_stored(&loaded.lines, &location)?;
        if self.resume {
            let saved = match saved {
                Some(p) => p,
                None => outputs::load_protocol_file(&self.out)?,
            };
            self.check_saved(saved, &location)?;
        } else {
            if files.protocol.exists() || !loaded.lines.is_empty() {
                return Err(CampaignError::OutputExists {
                    path: self.out.clone(),
                });
            }
            store.append(&log::ProtocolLine {
                protocol: self.protocol.clone(),
            })?;
            outputs::save_protocol(&self.protocol, files)?;
        }
        Ok((store, (lines, loaded.edited.clone())))
    }

    /// Refuses to resume a campaign whose stored protocol (`saved`, kept in `store`) is not
    /// the one given.
    fn check_saved(&self, saved: Protocol, store: &str) -> Result<(), CampaignError> {
        if saved.same_campaign(&self.protocol) {
            return Ok(());
        }
        Err(CampaignError::Protocol {
            field: store.into(),
            message: format!(
                "differs from the protocol given to resume: {}",
                protocol_differences(&saved, &self.protocol)
            ),
        })
    }
}

/// The stored lines as trial lines with their line numbers (a database keeps the protocol
/// apart: none of its lines is a protocol record).
fn numbered(loaded: &Loaded, location: &str) -> Result<NumberedLines, CampaignError> {
    let (_, lines) = log::read_stored(&loaded.lines, location)?;
    Ok((lines, loaded.edited.clone()))
}

/// The top-level fields in which `saved` and `given` differ, each with both values
/// (`` `seed` is 1 there, 2 here ``).
fn protocol_differences(saved: &Protocol, given: &Protocol) -> String {
    let (Ok(serde_json::Value::Object(a)), Ok(serde_json::Value::Object(b))) =
        (serde_json::to_value(saved), serde_json::to_value(given))
    else {
        return "(its fields could not be compared)".into();
    };
    let null = serde_json::Value::Null;
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    let diffs: Vec<String> = keys
        .into_iter()
        .filter_map(|k| {
            let (x, y) = (a.get(k).unwrap_or(&null), b.get(k).unwrap_or(&null));
            (x != y).then(|| format!("`{k}` is {x} there, {y} here"))
        })
        .collect();
    diffs.join("; ")
}

/// Each scenario's screening economy at the start of the screening stage at `budget`, one per
/// level of its ladder (`levels`; one without a ladder): the HF passes of the search at that
/// budget (what a screened pass saves; the last level's is what counts).
fn economy(
    kernel: &Kernel,
    lines: &[LogLine],
    budget: Option<f64>,
    levels: usize,
) -> Vec<Vec<Economy>> {
    let names: Vec<&str> = kernel.config().scenarios.iter().map(|s| &*s.name).collect();
    let mut economy = vec![Economy::default(); names.len()];
    let search = StageId {
        kind: StageKind::Train,
        budget,
        strength: None,
    };
    for l in lines {
        if let LogLine::Trial(t) = l {
            let s = names.iter().position(|n| *n == t.scenario);
            if let (true, Some(s)) = (t.stage == search, s) {
                economy[s].saw_hf(&t.hf.run());
            }
        }
    }
    economy.into_iter().map(|e| vec![e; levels]).collect()
}

/// The stages of a campaign run one after the other on one runner, with what they share.
struct Stages<'a, 'o> {
    protocol: &'a Protocol,
    /// Each stage's stored lines (replayed, not run), in stage order.
    by_stage: &'a [&'a [LogLine]],
    /// The stored lines' numbers in the store, in the same order.
    numbers: &'a [u64],
    kernels: &'a mut StageKernels<'a>,
    store: &'a mut dyn TrialStore,
    observers: &'a mut [Box<dyn Observer + 'o>],
    stop: &'a Stop,
    edited: Option<&'a EditedLine>,
}

impl Stages<'_, '_> {
    /// Runs (or replays) every stage on `runner`; returns every stage's lines.
    fn run(&mut self, runner: &mut dyn Runner) -> Result<Vec<LogLine>, CampaignError> {
        let p = self.protocol;
        let mut all_lines = Vec::new();
        let mut first = 0;
        for (stage, logged) in p.stages().iter().zip(self.by_stage) {
            let logged_lines = &self.numbers[first..first + logged.len()];
            first += logged.len();
            let replayed = logged.iter().filter(|l| l.is_told()).count() as u64;
            for o in self.observers.iter_mut() {
                o.stage(stage);
                if replayed > 0 {
                    o.replaying(stage, replayed);
                }
            }
            let rungs = self.kernels.rungs(stage, &all_lines);
            let kernel = self.kernels.for_stage(stage, &all_lines)?;
            let cx = StageContext {
                stage,
                logged,
                logged_lines,
                window: p.window,
                cost: p.cost.measure(),
                store: &mut *self.store,
                on_error: p.on_error,
                stop: self.stop,
                edited: self.edited,
                screen: (stage.kind == super::StageKind::Screen).then(|| executor::Audit {
                    seed: p.kernel_seed(&format!("audit:{}", stage.label())),
                    fraction: p.audit_fraction,
                    economy: (p.screen_lf == ScreenLf::WhereItPays)
                        .then(|| economy(kernel, &all_lines, stage.budget, rungs.len() + 1)),
                    rungs,
                }),
            };
            let observers = &mut *self.observers;
            let lines = executor::run_stage(runner, kernel, cx, |line, kernel| {
                for o in observers.iter_mut() {
                    match line {
                        LogLine::Trial(t) => o.trial(stage, t, kernel),
                        LogLine::Screen(s) => o.screened(stage, s, kernel),
                        LogLine::Failed(_) => {}
                    }
                }
            })?;
            all_lines.extend(lines);
        }
        Ok(all_lines)
    }
}

//! `savme.Campaign` and `savme.campaign.load`: the paper's protocol run by the one
//! Rust campaign loop (`savme::campaign::Campaign`), on Python callables or the bundled and
//! FMU simulators — the same outputs, store and resume as `savme run`.

use crate::callables::{PySimulator, Raised};
use crate::convert;
use crate::errors;
use crate::executor::{executor_of, ExecutorRunner};
use crate::native::NativeSpec;
use crate::problem::PyProblem;
use crate::protocol::PyProtocol;
use crate::result::{Finished, PyCampaignResult};
use crate::signals;
use crate::sim::{PyDriving, PyFmuSimulator};
use crossbeam_channel::RecvTimeoutError;
use pyo3::exceptions::{
    PyKeyboardInterrupt, PyRuntimeError, PySystemExit, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use savme::campaign::config::{check_repeat, Overrides};
use savme::campaign::estimate::EstimateSettings;
use savme::campaign::store::{ProtocolKeeper, StoreError, TrialStore};
use savme::campaign::{Campaign, Problem, ProgressLines, Protocol, Repeated, Stop};
use savme::compose;
use savme::postgres::{check_name, Database, PostgresStore};
use savme_fmu::campaign_file::FmuCampaignFile;
use savme_kernel::Simulator;
use savme_sim::sim::DrivingSimulator;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// How often a running campaign looks for Ctrl-C (Python's signal handlers run only on the
/// main thread, when it holds the GIL).
const SIGNAL_CHECK: Duration = Duration::from_millis(50);

/// The database of `storage=` with the campaign's name (both or neither).
fn storage_of(
    storage: Option<&str>,
    campaign: Option<String>,
) -> PyResult<Option<(Database, String)>> {
    match (storage, campaign) {
        (None, None) => Ok(None),
        (None, Some(_)) => Err(PyValueError::new_err(
            "campaign= names a campaign in a database: give storage=\"postgresql://…\" too",
        )),
        (Some(_), None) => Err(PyValueError::new_err(
            "storage= needs campaign=NAME (the campaign's name in the database)",
        )),
        (Some(url), Some(name)) => {
            let db = Database::parse(url).map_err(|e| PyValueError::new_err(e.to_string()))?;
            check_name(&name).map_err(|e| PyValueError::new_err(e.to_string()))?;
            Ok(Some((db, name)))
        }
    }
}

/// `jobs=`: worker threads (None: one per core).
fn jobs_of(jobs: Option<i128>) -> PyResult<Option<usize>> {
    jobs.map(|n| convert::whole("jobs", n)).transpose()
}

/// The protocol the database keeps for campaign `name` (resume with protocol=None).
fn stored_protocol(db: &Database, name: &str) -> PyResult<Protocol> {
    let store_error = |e: StoreError| errors::campaign(e.into());
    let mut store = PostgresStore::open(db, name).map_err(store_error)?;
    let location = store.location();
    let value = store.load_protocol().map_err(store_error)?.ok_or_else(|| {
        errors::campaign(savme::campaign::CampaignError::NothingToResumeIn {
            store: location.clone(),
        })
    })?;
    serde_json::from_value(value)
        .map_err(|e| errors::campaign_message(format!("{location}, protocol: {e}")))
}

/// The simulator bound to a campaign loaded from a campaign file.
enum BoundSim {
    None,
    /// The campaign file (its path) as its adapter read and checked it; its simulator is made
    /// for each run.
    File(PathBuf, Box<dyn savme::adapter::FileSimulator>),
}

/// A native simulator as an executor runs it: its spec, the files to ship (by role), and the
/// same simulator built here (the campaign's local simulator: an `[estimate]` stage runs on it).
struct Native<S> {
    spec: NativeSpec,
    files: BTreeMap<String, PathBuf>,
    local: S,
}

/// A campaign: a protocol, a problem, an output directory.
#[pyclass(name = "Campaign", module = "savme", frozen)]
pub struct PyCampaign {
    /// What `run` runs (cloned onto the campaign thread).
    plan: Plan,
    /// Where the runs of Python simulators execute (None: local threads).
    executor: Option<Arc<Py<PyAny>>>,
    bound: BoundSim,
}

impl PyCampaign {
    /// Runs the campaign with its runs on `executor`: started here (on the main thread) with
    /// the simulator callables, finished here however the campaign ends.
    fn run_executed(
        &self,
        py: Python<'_>,
        sim: PySimulator,
        executor: &Arc<Py<PyAny>>,
    ) -> PyResult<PyCampaignResult> {
        let (hf, lf) = (sim.hf.clone_ref(py), sim.lf.clone_ref(py));
        executed(py, executor, hf, lf, || {
            self.run_python(py, sim, Some(executor))
        })
    }

    /// Runs the campaign with the runs of a native simulator (a campaign file's FMUs, the
    /// bundled simulator) on `executor`: `savme.executors.native` makes its `hf`/`lf`
    /// callables, which build the same simulator where the executor runs them.
    fn run_native<S: Simulator + Clone + Send + 'static>(
        &self,
        py: Python<'_>,
        native: Native<S>,
        executor: &Arc<Py<PyAny>>,
    ) -> PyResult<PyCampaignResult> {
        let (hf, lf) = native.spec.callables(py, &native.files)?;
        executed(py, executor, hf, lf, || {
            self.run_thread(py, native.local, Stop::new(), Some(executor))
        })
    }

    /// [`PyCampaign::run_native`] on `sim=` (the bundled simulator, an FMU campaign's
    /// `savme.fmu.Simulator`) or on the simulator of the campaign file this campaign was
    /// loaded from.
    fn run_native_on(
        &self,
        py: Python<'_>,
        sim: Option<&Bound<'_, PyAny>>,
        executor: &Arc<Py<PyAny>>,
    ) -> PyResult<PyCampaignResult> {
        if let Some(s) = sim {
            if let Ok(d) = s.cast::<PyDriving>() {
                let local: DrivingSimulator = d.get().sim;
                let spec = NativeSpec::driving(&local);
                let files = BTreeMap::new();
                return self.run_native(py, Native { spec, files, local }, executor);
            }
            if let Ok(f) = s.cast::<PyFmuSimulator>() {
                let f = f.get();
                let (spec, files) = f.native();
                let local = f.backend()?;
                return self.run_native(py, Native { spec, files, local }, executor);
            }
            return Err(PyTypeError::new_err(
                "sim= takes savme.sim.Driving or savme.fmu.Simulator",
            ));
        }
        let BoundSim::File(path, file) = &self.bound else {
            return Err(PyTypeError::new_err(
                "give the simulator: run(simulate), run(hf=..., lf=...) or run(sim=...)",
            ));
        };
        let (spec, files) = native_of_file(path, file.as_ref())?;
        let local = crate::sim::file_simulator(file.as_ref())?;
        self.run_native(py, Native { spec, files, local }, executor)
    }

    /// Runs the Rust campaign loop on `sim` on a thread of its own, with the GIL released
    /// (Python simulators take it back around each call). Meanwhile this (main) thread looks
    /// for signals every [`SIGNAL_CHECK`]: on Ctrl-C (or SIGTERM) it asks the campaign to stop
    /// between trials, waits for the runs in flight, and raises (see [`PyCampaign::stopped`])
    /// — every told trial is stored, so `resume=True` continues from there.
    fn run_on<S: Simulator + Clone + Send + 'static>(
        &self,
        py: Python<'_>,
        sim: S,
    ) -> PyResult<PyCampaignResult> {
        self.run_thread(py, sim, Stop::new(), None)
    }

    /// [`PyCampaign::run_on`] a Python simulator: a campaign that failed on an exception it
    /// raised is chained to that exception (its `__cause__`, with the traceback); a
    /// `KeyboardInterrupt` or `SystemExit` it raised stops the campaign and is raised itself.
    fn run_python(
        &self,
        py: Python<'_>,
        sim: PySimulator,
        executor: Option<&Arc<Py<PyAny>>>,
    ) -> PyResult<PyCampaignResult> {
        let (raised, interrupt) = (sim.raised.clone(), sim.interrupt.clone());
        let stop = sim.stop.clone();
        let outcome = self.run_thread(py, sim, stop, executor);
        let take = |slot: &Raised| slot.lock().unwrap_or_else(|p| p.into_inner()).take();
        if let Some(exc) = take(&interrupt) {
            let told = outcome.as_ref().err().map(|e| e.value(py).to_string());
            add_note(
                py,
                &exc,
                &self.stopped_note(told.as_deref(), executor.is_some()),
            );
            return Err(exc);
        }
        if let (Err(e), Some(cause)) = (&outcome, take(&raised)) {
            if e.to_string().contains("simulator raised") {
                e.set_cause(py, Some(cause));
            }
        }
        outcome
    }

    fn run_thread<S: Simulator + Clone + Send + 'static>(
        &self,
        py: Python<'_>,
        sim: S,
        stop: Stop,
        executor: Option<&Arc<Py<PyAny>>>,
    ) -> PyResult<PyCampaignResult> {
        let _sigterm = signals::SigtermStops::install(py)?;
        let mut plan = self.plan.clone();
        plan.executor = executor.cloned();
        let stop_campaign = stop.clone();
        let (tx, rx) = crossbeam_channel::bounded(1);
        let campaign = std::thread::Builder::new()
            .name("savme-campaign".into())
            .spawn(move || {
                let _ = tx.send(plan.run(&sim, stop_campaign));
            })
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the campaign: {e}")))?;
        let outcome = loop {
            match py.detach(|| rx.recv_timeout(SIGNAL_CHECK)) {
                Ok(outcome) => break outcome,
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => {
                    let _ = campaign.join();
                    return Err(PyRuntimeError::new_err("the campaign thread stopped"));
                }
            }
            if let Err(signal) = py.check_signals() {
                stop.request();
                let _ = py.detach(|| campaign.join());
                let told = match rx.try_recv() {
                    Ok(Err(e)) => Some(e.value(py).to_string()),
                    _ => None,
                };
                return Err(self.stopped(py, signal, told.as_deref(), executor.is_some()));
            }
        };
        let _ = py.detach(|| campaign.join());
        outcome
    }

    /// The error `run` raises when a signal stopped the campaign (`told`: what the campaign
    /// said when it stopped): SIGINT's `KeyboardInterrupt` again, its message saying where the
    /// campaign stopped and how to resume it; SIGTERM a `SystemExit(143)` (exit status 128 + 15,
    /// as `savme run`), the same said on stderr; what a handler of the caller's raised, with
    /// that as a note. `executed`: the runs went to an executor (the resume call names it).
    fn stopped(&self, py: Python<'_>, signal: PyErr, told: Option<&str>, executed: bool) -> PyErr {
        let note = self.stopped_note(told, executed);
        if signal.is_instance_of::<PyKeyboardInterrupt>(py) {
            return PyKeyboardInterrupt::new_err(note);
        }
        if signals::is_terminated(py, &signal) {
            let said = format!("savme: SIGTERM: {note}\n");
            let _ = py
                .import("sys")
                .and_then(|sys| sys.getattr("stderr"))
                .and_then(|err| err.call_method1("write", (said,)));
            let e = PySystemExit::new_err(128 + 15);
            add_note(py, &e, &note);
            return e;
        }
        add_note(py, &signal, &note);
        signal
    }

    /// Where a stopped campaign stopped (`told`: the campaign's own words, if it said) and
    /// the call that resumes it.
    fn stopped_note(&self, told: Option<&str>, executed: bool) -> String {
        let told = match told {
            Some(t) if t.contains("stopped") => t.to_string(),
            _ => "the campaign stopped between trials (every told trial is stored)".to_string(),
        };
        format!("{told}; resume it with {}", self.resume_call(executed))
    }

    /// The Python call that resumes this campaign where it stopped (on an executor again when
    /// `executed`).
    fn resume_call(&self, executed: bool) -> String {
        let plan = &self.plan;
        let mut args = vec![format!("out={:?}", plan.out.display().to_string())];
        if let Some((_, name)) = &plan.storage {
            args.push(format!("storage=\"postgresql://…\", campaign={name:?}"));
        }
        if let Some(n) = plan.repeat {
            args.push(format!("repeat={n}"));
        }
        args.push("resume=True".into());
        let args = args.join(", ");
        let on = if executed { "executor=..." } else { "" };
        match &self.bound {
            BoundSim::File(path, _) => format!(
                "savme.campaign.load({:?}, {args}).run({on})",
                path.display().to_string()
            ),
            BoundSim::None if executed => {
                format!("savme.Campaign(None, problem, {args}).run(..., {on})")
            }
            BoundSim::None => format!("savme.Campaign(None, problem, {args}).run(...)"),
        }
    }
}

/// `executor.start(hf, lf)`, then `campaign()`, then `executor.finish()` however the campaign
/// ended (an error of the campaign's is raised before one of `finish`).
fn executed(
    py: Python<'_>,
    executor: &Arc<Py<PyAny>>,
    hf: Py<PyAny>,
    lf: Py<PyAny>,
    campaign: impl FnOnce() -> PyResult<PyCampaignResult>,
) -> PyResult<PyCampaignResult> {
    executor.call_method1(py, "start", (hf, lf))?;
    let result = campaign();
    let finished = executor.call_method0(py, "finish");
    let result = result?;
    finished?;
    Ok(result)
}

/// An executor's campaign runs one seed with the executor's workers: refuses `repeat` (a
/// protocol's or a campaign file's) and `jobs=`.
fn check_executor(repeat: Option<u32>, jobs: Option<usize>) -> PyResult<()> {
    if repeat.is_some() {
        return Err(PyValueError::new_err(
            "repeat runs its seeds on local threads: not with executor=",
        ));
    }
    if jobs.is_some() {
        return Err(PyValueError::new_err(
            "jobs= sets local worker threads; with executor= the executor decides how many runs go at once (e.g. savme.RayExecutor(workers=N))",
        ));
    }
    Ok(())
}

/// Adds `note` to `e` (`BaseException.add_note`, Python ≥ 3.11: shown under its traceback);
/// nothing on older Pythons.
fn add_note(py: Python<'_>, e: &PyErr, note: &str) {
    let value = e.value(py);
    if value.hasattr("add_note").unwrap_or(false) {
        let _ = value.call_method1("add_note", (note,));
    }
}

/// What a campaign runs, on the campaign thread: the campaign (or one per seed), then the
/// `[estimate]` stage — the plan `savme run --config` runs (through the same parts).
#[derive(Clone)]
struct Plan {
    protocol: Protocol,
    problem: Problem,
    out: PathBuf,
    resume: bool,
    jobs: Option<usize>,
    progress: bool,
    /// The PostgreSQL database and the campaign's name in it, instead of the directory's store.
    storage: Option<(Database, String)>,
    /// Seeds to run the protocol with (None: one campaign).
    repeat: Option<u32>,
    /// A campaign file's `[estimate]` stage, run after the campaign.
    estimate: Option<EstimateSettings>,
    /// The executor the runs go to instead of local threads (started by `run`).
    executor: Option<Arc<Py<PyAny>>>,
}

impl Plan {
    fn run<S: Simulator + Clone + Send>(self, sim: &S, stop: Stop) -> PyResult<PyCampaignResult> {
        let jobs = self
            .jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
        let finished = match self.repeat {
            Some(n) => Finished::Seeds(
                Repeated::new(self.protocol, self.problem.clone(), n)
                    .out(&self.out)
                    .resume(self.resume)
                    .jobs(jobs)
                    .stop_on(stop.clone())
                    .run(sim)
                    .map_err(errors::campaign)?,
            ),
            None => {
                let mut c = Campaign::new(self.protocol, self.problem.clone())
                    .out(&self.out)
                    .resume(self.resume)
                    .stop_on(stop.clone())
                    .jobs(jobs);
                if self.progress {
                    c = c.observer(ProgressLines::new(std::io::stderr()));
                }
                if let Some((db, name)) = &self.storage {
                    let store =
                        PostgresStore::open(db, name).map_err(|e| errors::campaign(e.into()))?;
                    c = c.store(Box::new(store));
                }
                if let Some(executor) = &self.executor {
                    c = c.remote(ExecutorRunner::new(executor.clone()));
                }
                Finished::One(c.run(sim).map_err(errors::campaign)?)
            }
        };
        let place = match &self.storage {
            Some((db, name)) => compose::Place::Database(Box::new(db.clone()), name.clone()),
            None => compose::Place::Dir(self.out.clone()),
        };
        let estimate = match self.estimate {
            Some(settings) => {
                let progress = compose::estimate_progress_lines(!self.progress);
                Some(
                    compose::EstimateStage {
                        campaign: place,
                        out: self.out.clone(),
                        problem: self.problem,
                        settings,
                        jobs,
                        stop,
                    }
                    .run(progress, sim)
                    .map_err(|e| errors::campaign_message(e.to_string()))?,
                )
            }
            None => None,
        };
        Ok(PyCampaignResult { finished, estimate })
    }
}

#[pymethods]
impl PyCampaign {
    /// A campaign of `protocol` on `problem` into `out`. `resume=True` continues the campaign
    /// in `out` (its `protocol.json` must equal `protocol`; give protocol=None to take it
    /// from there). `jobs`: worker threads (default: one per core); `progress`: one line per
    /// finished stage on stderr. `storage="postgresql://USER@HOST/DB"` with `campaign=NAME`
    /// keeps the protocol and the trials in that database instead (as `savme run --storage`;
    /// the password comes from the URL, PGPASSWORD or ~/.pgpass and is never shown); the
    /// tables and figures are still written into `out`.
    #[new]
    #[pyo3(signature = (protocol, problem, *, out = None, resume = false,
        jobs = None, progress = false, storage = None, campaign = None, repeat = None,
        executor = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        protocol: Option<PyRef<'_, PyProtocol>>,
        problem: PyRef<'_, PyProblem>,
        out: Option<PathBuf>,
        resume: bool,
        jobs: Option<i128>,
        progress: bool,
        storage: Option<&str>,
        campaign: Option<String>,
        repeat: Option<i128>,
        executor: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let jobs = jobs_of(jobs)?;
        let repeat = repeat.map(|n| convert::whole("repeat", n)).transpose()?;
        let out = out.unwrap_or_else(|| PathBuf::from("savme-results"));
        let executor = executor_of(executor)?;
        if executor.is_some() {
            check_executor(repeat, jobs)?;
        }
        let storage = storage_of(storage, campaign)?;
        let repeat = check_repeat(repeat).map_err(errors::value)?;
        if repeat.is_some() && storage.is_some() {
            return Err(PyValueError::new_err(
                "repeat runs each seed in its own directory with the default trial store: not with storage=",
            ));
        }
        let protocol = match (protocol, &storage) {
            (Some(p), _) => p.protocol.clone(),
            (None, Some((db, name))) if resume => stored_protocol(db, name)?,
            (None, None) if resume => {
                savme::campaign::load_protocol(&out).map_err(errors::campaign)?
            }
            (None, _) => {
                return Err(PyValueError::new_err(
                    "give a protocol (protocol=None only with resume=True)",
                ))
            }
        };
        Ok(PyCampaign {
            plan: Plan {
                protocol,
                problem: problem.problem.clone(),
                out,
                resume,
                jobs,
                progress,
                storage,
                repeat,
                estimate: None,
                executor: executor.clone(),
            },
            executor,
            bound: BoundSim::None,
        })
    }

    /// Runs (or resumes) the campaign and writes `table.md`, `fidelity.md`, `summary.json`,
    /// `trials.jsonl` and the plots into `out`, like `savme run`.
    ///
    /// Give `hf` and `lf` callables `(scenario, phi, theta) -> failure | (failure, work)`, or
    /// one `simulate` callable for both, or `sim=savme.sim.Driving()` /
    /// `sim=savme.fmu.Simulator(...)`; a campaign from `savme.campaign.load` has its FMUs
    /// and refuses another simulator (its protocol names the file's).
    /// Ctrl-C stops the campaign between trials and raises `KeyboardInterrupt`, SIGTERM
    /// `SystemExit(143)`, each saying the call that resumes it (the told trials are stored:
    /// `resume=True` continues).
    ///
    /// `executor=` (`"ray"`, `savme.RayExecutor(...)`, …) runs this call's runs there instead
    /// of where the campaign was made to run them.
    #[pyo3(signature = (simulate = None, *, hf = None, lf = None, sim = None, executor = None))]
    fn run(
        &self,
        py: Python<'_>,
        simulate: Option<Py<PyAny>>,
        hf: Option<Py<PyAny>>,
        lf: Option<Py<PyAny>>,
        sim: Option<&Bound<'_, PyAny>>,
        executor: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyCampaignResult> {
        let executor = match executor_of(executor)? {
            Some(e) => {
                check_executor(self.plan.repeat, self.plan.jobs)?;
                Some(e)
            }
            None => self.executor.clone(),
        };
        let given = [
            simulate.is_some(),
            hf.is_some() || lf.is_some(),
            sim.is_some(),
        ];
        if let (BoundSim::File(path, _), true) = (&self.bound, given.contains(&true)) {
            return Err(PyTypeError::new_err(format!(
                "this campaign was loaded from {} and runs the simulator that file names ({}): \
                 call run() without a simulator. Its protocol, outputs and stored trials are \
                 labelled with that simulator, so another one is not run in its place; to run a \
                 Python simulator, make savme.Campaign(savme.Protocol(train, test, \
                 simulator=\"my-simulator\", ...), savme.Problem(...), out=...) and call \
                 run(simulate) on it",
                path.display(),
                self.plan.protocol.simulator
            )));
        }
        if given.iter().filter(|g| **g).count() > 1 {
            return Err(PyTypeError::new_err(
                "give one of: simulate, hf= and lf=, or sim=",
            ));
        }
        let callables = match (simulate, hf, lf) {
            (Some(f), _, _) => {
                let f = Arc::new(f);
                Some(PySimulator::new(f.clone(), f))
            }
            (None, Some(hf), Some(lf)) => Some(PySimulator::new(Arc::new(hf), Arc::new(lf))),
            (None, None, None) => None,
            _ => {
                return Err(PyTypeError::new_err(
                    "give both hf= and lf= (or one simulate callable)",
                ))
            }
        };
        if let Some(sim) = callables {
            return match &executor {
                Some(executor) => self.run_executed(py, sim, executor),
                None => self.run_python(py, sim, None),
            };
        }
        if let Some(executor) = &executor {
            return self.run_native_on(py, sim, executor);
        }
        if let Some(s) = sim {
            if let Ok(d) = s.cast::<PyDriving>() {
                let sim: DrivingSimulator = d.get().sim;
                return self.run_on(py, sim);
            }
            if let Ok(f) = s.cast::<PyFmuSimulator>() {
                return self.run_on(py, f.get().backend()?);
            }
            return Err(PyTypeError::new_err(
                "sim= takes savme.sim.Driving or savme.fmu.Simulator",
            ));
        }
        match &self.bound {
            BoundSim::File(_, file) => self.run_on(py, crate::sim::file_simulator(file.as_ref())?),
            BoundSim::None => Err(PyTypeError::new_err(
                "give the simulator: run(simulate), run(hf=..., lf=...) or run(sim=...)",
            )),
        }
    }

    /// The protocol.
    #[getter]
    fn protocol(&self) -> PyProtocol {
        PyProtocol {
            protocol: self.plan.protocol.clone(),
        }
    }

    /// The output directory.
    #[getter]
    fn out(&self) -> PathBuf {
        self.plan.out.clone()
    }

    /// The number of seeds the protocol runs with (None: one campaign).
    #[getter]
    fn repeat(&self) -> Option<u32> {
        self.plan.repeat
    }

    fn __repr__(&self) -> String {
        format!(
            "Campaign(simulator={:?}, out={:?}, resume={})",
            self.plan.protocol.simulator,
            self.plan.out.display().to_string(),
            self.plan.resume
        )
    }
}

/// `savme.campaign.load(path)`: a campaign file (TOML, as `savme run --config` reads) as a
/// campaign with its FMU simulator bound; `out` defaults to the file's `campaign.out`;
/// `storage` and `campaign` as for `Campaign`.
#[pyfunction]
#[pyo3(signature = (path, *, out = None, resume = false, jobs = None, progress = false,
    storage = None, campaign = None, executor = None))]
#[allow(clippy::too_many_arguments)]
pub fn load_campaign(
    path: PathBuf,
    out: Option<PathBuf>,
    resume: bool,
    jobs: Option<i128>,
    progress: bool,
    storage: Option<&str>,
    campaign: Option<String>,
    executor: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyCampaign> {
    let jobs = jobs_of(jobs)?;
    let executor = executor_of(executor)?;
    let storage = storage_of(storage, campaign)?;
    let c = compose::campaign_file(&path, &Overrides::default()).map_err(errors::campaign)?;
    // Build the simulator now (for FMUs: open them), so that a campaign that cannot run fails
    // here.
    crate::sim::file_simulator(c.file.as_ref())?;
    let out = out
        .or(c.file.common().campaign.out.clone())
        .unwrap_or_else(|| PathBuf::from("savme-fmu-results"));
    let estimate = c.estimate_settings().map_err(errors::campaign_message)?;
    if executor.is_some() {
        check_executor(c.repeat, jobs)?;
        native_of_file(&path, c.file.as_ref())?;
    }
    Ok(PyCampaign {
        plan: Plan {
            protocol: c.protocol,
            problem: c.problem,
            out,
            resume,
            jobs,
            progress,
            storage,
            repeat: c.repeat,
            estimate,
            executor: executor.clone(),
        },
        executor,
        bound: BoundSim::File(path, c.file),
    })
}

/// The native spec of a campaign file's simulator: its FMUs, shipped to the executor's nodes.
fn native_of_file(
    path: &std::path::Path,
    file: &dyn savme::adapter::FileSimulator,
) -> PyResult<(NativeSpec, BTreeMap<String, PathBuf>)> {
    match file.as_any().downcast_ref::<FmuCampaignFile>() {
        Some(fmu) => Ok(NativeSpec::fmu(&fmu.init, fmu.isolate, fmu.timeout)),
        None => Err(PyTypeError::new_err(format!(
            "{}: its simulator ({}) cannot run on an executor (FMU campaigns can)",
            path.display(),
            file.label()
        ))),
    }
}

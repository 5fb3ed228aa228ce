//! `savme.Protocol`, `savme.Problem` and `savme.Campaign`: the paper's protocol run by the one
//! Rust campaign loop (`savme::campaign::Campaign`), on Python callables or the bundled and
//! FMU simulators — the same outputs, store and resume as `savme run`.

use crate::convert;
use crate::errors;
use crate::executor::{executor_of, ExecutorRunner};
use crate::sim::{PyDriving, PyFmuSimulator};
use crate::space::PySpace;
use crossbeam_channel::RecvTimeoutError;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use savme::campaign::config::{check_repeat, Overrides};
use savme::campaign::estimate::{EstimateOutcome, EstimateSettings};
use savme::campaign::store::{ProtocolKeeper, StoreError, TrialStore};
use savme::campaign::{
    Campaign, CampaignOutcome, OnError, Problem, ProgressLines, Protocol, Repeated,
    RepeatedOutcome, Stop,
};
use savme::compose;
use savme::postgres::{check_name, Database, PostgresStore};
use savme_fmu::campaign_file::FmuCampaignFile;
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator};
use savme_sim::sim::DrivingSimulator;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How often a running campaign looks for Ctrl-C (Python's signal handlers run only on the
/// main thread, when it holds the GIL).
const SIGNAL_CHECK: Duration = Duration::from_millis(50);

/// What the campaign's protocol is: stages, iterations, budgets, seeds, scenarios.
#[pyclass(name = "Protocol", module = "savme", frozen)]
#[derive(Clone)]
pub struct PyProtocol {
    pub protocol: Protocol,
}

/// `savme.PROTOCOL_VALUES`: every protocol value as declared once (name — the keyword of
/// `Protocol`, the `[campaign]` key —, the `savme` flag, help text, the stages it changes).
pub fn protocol_values(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    let values: Vec<serde_json::Value> = savme::campaign::values::VALUES
        .iter()
        .map(|v| {
            serde_json::json!({
                "name": v.name,
                "flag": format!("--{}", v.flag),
                "help": v.help.trim(),
                "stages": v.stages,
                "in_protocol": v.in_protocol,
            })
        })
        .collect();
    convert::json_to_py(py, &values)
}

/// Protocol values given as keyword arguments, read by the names every front end shares
/// ([`savme::campaign::values`]); `None` means "not given".
pub fn overrides(values: Option<&Bound<'_, PyDict>>) -> PyResult<Overrides> {
    let Some(values) = values else {
        return Ok(Overrides::default());
    };
    let json = values.py().import("json")?;
    let mut entries = Vec::new();
    for (k, v) in values.iter() {
        if v.is_none() {
            continue;
        }
        let key: String = k.extract()?;
        let text: String = json
            .call_method1("dumps", (&v,))
            .and_then(|t| t.extract())
            .map_err(|e| PyTypeError::new_err(format!("{key}: {e}")))?;
        let value: serde_json::Value = serde_json::from_str(&text).map_err(errors::value)?;
        entries.push((key, value));
    }
    Overrides::from_entries(entries).map_err(|e| {
        if e.message.starts_with("not a protocol value") {
            PyTypeError::new_err(format!("unexpected keyword argument {e}"))
        } else {
            PyValueError::new_err(e.to_string())
        }
    })
}

fn on_error(name: &str) -> PyResult<OnError> {
    match name {
        "abort" => Ok(OnError::Abort),
        "skip" => Ok(OnError::Skip),
        other => Err(PyValueError::new_err(format!(
            "on_error must be \"abort\" or \"skip\", got {other:?}"
        ))),
    }
}

#[pymethods]
impl PyProtocol {
    /// The paper's protocol (or the quick preset) for the given scenarios, with any protocol
    /// value given by its name (`seed`, `budgets`, `train_iterations`, …: the names of
    /// `savme.PROTOCOL_VALUES`, the same as `savme run`'s flags and a campaign file's
    /// `[campaign]` keys); validated (a ValueError names the value).
    #[new]
    #[pyo3(signature = (train_scenarios, test_scenarios, *, preset = "paper", simulator = "python",
        weights = None, on_error = None, **values))]
    fn new(
        train_scenarios: Vec<String>,
        test_scenarios: Vec<String>,
        preset: &str,
        simulator: &str,
        weights: Option<BTreeMap<String, f64>>,
        on_error: Option<&str>,
        values: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mut p = match preset {
            "paper" => Protocol::paper(simulator, train_scenarios, test_scenarios),
            "quick" => Protocol::quick(simulator, train_scenarios, test_scenarios),
            other => {
                return Err(PyValueError::new_err(format!(
                    "preset must be \"paper\" or \"quick\", got {other:?}"
                )))
            }
        };
        let o = overrides(values)?;
        if o.repeat.is_some() {
            return Err(PyValueError::new_err(
                "repeat: not part of a protocol; give it to Campaign(..., repeat=N)",
            ));
        }
        let lookup = |k: &str| Some(k.to_string());
        o.apply(&mut p, &lookup, "").map_err(errors::value)?;
        if let Some(w) = weights {
            p.weights = w;
        }
        if let Some(e) = on_error {
            p.on_error = self::on_error(e)?;
        }
        p.validate().map_err(errors::value)?;
        Ok(PyProtocol { protocol: p })
    }

    /// The protocol as JSON (`protocol.json` of a campaign directory).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.protocol).map_err(errors::value)
    }

    /// The protocol as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::json_to_py(py, &self.protocol)
    }

    /// The protocol saved in a campaign directory (`protocol.json`).
    #[staticmethod]
    fn load(out: PathBuf) -> PyResult<Self> {
        let protocol = savme::campaign::load_protocol(&out).map_err(errors::campaign)?;
        Ok(PyProtocol { protocol })
    }

    /// How many trials the campaign runs in all.
    #[getter]
    fn total_trials(&self) -> u64 {
        self.protocol.total_trials()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyProtocol>()
            .is_ok_and(|o| o.get().protocol == self.protocol)
    }

    fn __repr__(&self) -> String {
        let p = &self.protocol;
        format!(
            "Protocol(simulator={:?}, seed={}, budgets={:?}, trials={})",
            p.simulator,
            p.seed,
            p.budgets,
            p.total_trials()
        )
    }
}

/// What a campaign searches: the fidelity space with θ_HF, and each scenario's φ-space.
#[pyclass(name = "Problem", module = "savme", frozen)]
#[derive(Clone)]
pub struct PyProblem {
    pub problem: Problem,
}

#[pymethods]
impl PyProblem {
    #[new]
    #[pyo3(signature = (*, fidelity, theta_hf, scenarios))]
    fn new(
        fidelity: PyRef<'_, PySpace>,
        theta_hf: &Bound<'_, PyDict>,
        scenarios: &Bound<'_, PyDict>,
    ) -> PyResult<Self> {
        let mut by_name = BTreeMap::new();
        for (k, v) in scenarios.iter() {
            let name: String = k.extract()?;
            let space = v.cast::<PySpace>().map_err(|_| {
                PyTypeError::new_err(format!("scenarios: scenario `{name}` needs a savme.Space"))
            })?;
            by_name.insert(name, space.get().space.clone());
        }
        let theta_hf = convert::assignment("theta_hf", theta_hf, &fidelity.space)?;
        fidelity
            .space
            .arms_of(&theta_hf)
            .map_err(|e| PyValueError::new_err(format!("high-fidelity settings θ_HF: {e}")))?;
        Ok(PyProblem {
            problem: Problem {
                fidelity: fidelity.space.clone(),
                theta_hf,
                scenarios: by_name,
            },
        })
    }

    /// The bundled driving simulator's problem: Table I with `bins` per continuous setting,
    /// θ_HF and the ten scenarios.
    #[staticmethod]
    #[pyo3(signature = (bins = 10))]
    fn driving(bins: u32) -> Self {
        PyProblem {
            problem: Problem::from(savme_sim::problem(bins)),
        }
    }

    /// The scenarios' names.
    #[getter]
    fn scenarios(&self) -> Vec<String> {
        self.problem.scenarios.keys().cloned().collect()
    }

    fn __repr__(&self) -> String {
        format!(
            "Problem(fidelity={} settings, scenarios={:?})",
            self.problem.fidelity.len(),
            self.scenarios()
        )
    }
}

/// Python callables as the campaign's simulator: `hf(scenario, phi, theta)` and
/// `lf(scenario, phi, theta)` (the same callable for both is fine). Each returns the failure
/// flag, `(failure, work_units)`, or `(failure, work_units or None, robustness)`; the wall time of the call is measured here. The GIL is
/// taken only around the call.
#[derive(Clone)]
pub struct PySimulator {
    hf: Arc<Py<PyAny>>,
    lf: Arc<Py<PyAny>>,
    /// The first exception a callable raised: the campaign's error is chained to it
    /// (`raise CampaignError(...) from exc`), so that its traceback is kept.
    raised: Raised,
}

/// The first exception a Python simulator raised, shared by its clones (one per worker).
pub type Raised = Arc<std::sync::Mutex<Option<PyErr>>>;

impl PySimulator {
    fn new(hf: Arc<Py<PyAny>>, lf: Arc<Py<PyAny>>) -> PySimulator {
        PySimulator {
            hf,
            lf,
            raised: Raised::default(),
        }
    }
}

/// Where `e` was raised: ` (at FILE:LINE, in FUNCTION)` of its innermost frame, or nothing.
fn raised_at(py: Python<'_>, e: &PyErr) -> String {
    let frame = (|| -> PyResult<String> {
        let tb = e
            .traceback(py)
            .ok_or_else(|| PyValueError::new_err("no traceback"))?;
        let frames = py.import("traceback")?.call_method1("extract_tb", (tb,))?;
        let last = frames.get_item(-1)?;
        let (file, line, name): (String, u32, String) = (
            last.getattr("filename")?.extract()?,
            last.getattr("lineno")?.extract()?,
            last.getattr("name")?.extract()?,
        );
        Ok(format!(" (at {file}:{line}, in {name})"))
    })();
    frame.unwrap_or_default()
}

pub fn sim_result(out: &Bound<'_, PyAny>, wall: f64) -> Result<SimResult, String> {
    // The flag alone, the first of (failure, work_units), or of (failure, work_units or None,
    // robustness).
    let tuple = out.cast::<PyTuple>().ok();
    let pair = tuple.and_then(|t| t.extract::<(Bound<'_, PyAny>, u64)>().ok());
    let triple = tuple.and_then(|t| t.extract::<(Bound<'_, PyAny>, Option<u64>, f64)>().ok());
    let (flag, work, robustness) = match (pair, triple) {
        (Some((flag, work)), _) => (flag, Some(work), None),
        (None, Some((flag, work, rho))) => (flag, work, Some(rho)),
        (None, None) => (out.clone(), None, None),
    };
    let kind = match crate::convert::failure_flag(&flag) {
        Ok(failure) => {
            let result = SimResult::new(failure, wall, work);
            return match robustness {
                Some(rho) if !rho.is_finite() => Err(format!(
                    "a simulator's robustness must be a finite number, got {rho}"
                )),
                Some(rho) => Ok(result.with_robustness(rho)),
                None => Ok(result),
            };
        }
        Err(kind) => kind,
    };
    Err(format!(
        "a simulator must return the failure flag (bool or numpy bool), (failure, work_units) or (failure, work_units or None, robustness), got {kind} {flag}"
    ))
}

impl Simulator for PySimulator {
    fn simulate(
        &mut self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        self.simulate_as(Role::High, scenario, phi, fidelity)
    }

    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        let (f, name) = match role {
            Role::High => (&self.hf, "hf"),
            Role::Learned => (&self.lf, "lf"),
        };
        Python::attach(|py| {
            let args = (
                scenario,
                convert::dict(py, phi).map_err(|e| SimError::Failed(e.to_string()))?,
                convert::dict(py, fidelity).map_err(|e| SimError::Failed(e.to_string()))?,
            );
            let start = Instant::now();
            let out = f.call1(py, args);
            let wall = start.elapsed().as_secs_f64();
            let out = out.map_err(|e| {
                let message = format!("the `{name}` simulator raised {e}{}", raised_at(py, &e));
                let mut first = self.raised.lock().unwrap_or_else(|p| p.into_inner());
                if first.is_none() {
                    *first = Some(e);
                }
                SimError::Failed(message)
            })?;
            sim_result(out.bind(py), wall)
                .map_err(|m| SimError::Failed(format!("the `{name}` simulator: {m}")))
        })
    }
}

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
    /// The checked campaign file; its FMU back end is made for each run.
    Fmu(Box<FmuCampaignFile>),
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

/// What the campaign thread finished: one campaign, or one per seed.
enum Finished {
    One(CampaignOutcome),
    Seeds(RepeatedOutcome),
}

/// What a finished campaign returns.
#[pyclass(name = "CampaignResult", module = "savme", frozen)]
pub struct PyCampaignResult {
    finished: Finished,
    estimate: Option<EstimateOutcome>,
}

impl PyCampaignResult {
    /// Each seed's campaign (one without `repeat`).
    fn outcomes(&self) -> Vec<&CampaignOutcome> {
        match &self.finished {
            Finished::One(o) => vec![o],
            Finished::Seeds(r) => r.runs.iter().collect(),
        }
    }
}

#[pymethods]
impl PyCampaignResult {
    /// The campaign directory.
    #[getter]
    fn out(&self) -> PathBuf {
        match &self.finished {
            Finished::One(o) => o
                .outputs
                .protocol
                .parent()
                .map(PathBuf::from)
                .unwrap_or_default(),
            Finished::Seeds(r) => r.out.clone(),
        }
    }

    /// The report as a dict (what `summary.json` holds under "report").
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.finished {
            Finished::One(o) => convert::json_to_py(py, &o.report),
            Finished::Seeds(r) => convert::json_to_py(py, &r.report),
        }
    }

    /// Table III as Markdown (`table.md`; over the seeds with `repeat`).
    #[getter]
    fn table_md(&self) -> String {
        match &self.finished {
            Finished::One(o) => o.report.table_md(),
            Finished::Seeds(r) => r.report.table_md(),
        }
    }

    /// Each seed's result, in seed order (`repeat`; one result without it).
    #[getter]
    fn runs(&self) -> Vec<PyCampaignResult> {
        self.outcomes()
            .into_iter()
            .map(|o| PyCampaignResult {
                finished: Finished::One(o.clone()),
                estimate: None,
            })
            .collect()
    }

    /// The `[estimate]` stage's result (a campaign file with one): its summary as a dict
    /// (`summary.json`), None otherwise.
    #[getter]
    fn estimate<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.estimate
            .as_ref()
            .map(|e| convert::json_to_py(py, e))
            .transpose()
    }

    /// The files written: protocol, trials, table, fidelity, summary, breakeven, meta_testing.
    #[getter]
    fn files<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let Finished::One(one) = &self.finished else {
            let out = self.out();
            for (k, f) in [
                ("table", "table.md"),
                ("summary", "summary.json"),
                ("breakeven", "breakeven.png"),
                ("meta_testing", "meta_testing.png"),
            ] {
                d.set_item(k, out.join(f))?;
            }
            return Ok(d);
        };
        let o = &one.outputs;
        for (k, v) in [
            ("protocol", &o.protocol),
            ("trials", &o.trials),
            ("table", &o.table),
            ("fidelity", &o.fidelity),
            ("summary", &o.summary),
            ("breakeven", &o.breakeven),
            ("meta_testing", &o.meta_testing),
        ] {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Trials replayed from `trials.jsonl` (a resumed campaign).
    #[getter]
    fn replayed(&self) -> u64 {
        self.outcomes().iter().map(|o| o.replayed).sum()
    }

    /// Trials run by this call.
    #[getter]
    fn ran(&self) -> u64 {
        self.outcomes().iter().map(|o| o.ran).sum()
    }

    /// Wall-clock seconds this call took.
    #[getter]
    fn elapsed_seconds(&self) -> f64 {
        match &self.finished {
            Finished::One(o) => o.elapsed_seconds,
            Finished::Seeds(r) => r.elapsed_seconds,
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "CampaignResult(out={:?}, ran={}, replayed={}, elapsed_seconds={:.1})",
            self.out().display().to_string(),
            self.ran(),
            self.replayed(),
            self.elapsed_seconds()
        )
    }
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
        executor.call_method1(py, "start", (sim.hf.clone_ref(py), sim.lf.clone_ref(py)))?;
        let result = self.run_python(py, sim);
        let finished = executor.call_method0(py, "finish");
        let result = result?;
        finished?;
        Ok(result)
    }

    /// Runs the Rust campaign loop on `sim` on a thread of its own, with the GIL released
    /// (Python simulators take it back around each call). Meanwhile this (main) thread looks
    /// for signals every [`SIGNAL_CHECK`]: on Ctrl-C it asks the campaign to stop between
    /// trials, waits for the runs in flight, and raises the `KeyboardInterrupt` — every told
    /// trial is stored, so `resume=True` continues from there.
    fn run_on<S: Simulator + Clone + Send + 'static>(
        &self,
        py: Python<'_>,
        sim: S,
    ) -> PyResult<PyCampaignResult> {
        self.run_raising(py, sim, None)
    }

    /// [`PyCampaign::run_on`] a Python simulator: a campaign that failed on an exception it
    /// raised is chained to that exception (its `__cause__`, with the traceback).
    fn run_python(&self, py: Python<'_>, sim: PySimulator) -> PyResult<PyCampaignResult> {
        let raised = sim.raised.clone();
        self.run_raising(py, sim, Some(raised))
    }

    fn run_raising<S: Simulator + Clone + Send + 'static>(
        &self,
        py: Python<'_>,
        sim: S,
        raised: Option<Raised>,
    ) -> PyResult<PyCampaignResult> {
        let outcome = self.run_thread(py, sim);
        let (Err(e), Some(raised)) = (&outcome, raised) else {
            return outcome;
        };
        let cause = raised.lock().unwrap_or_else(|p| p.into_inner()).take();
        if let Some(cause) = cause {
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
    ) -> PyResult<PyCampaignResult> {
        let plan = self.plan.clone();
        let stop = Stop::new();
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
            if let Err(interrupt) = py.check_signals() {
                stop.request();
                let _ = py.detach(|| campaign.join());
                return Err(interrupt);
            }
        };
        let _ = py.detach(|| campaign.join());
        outcome
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
        jobs: Option<usize>,
        progress: bool,
        storage: Option<&str>,
        campaign: Option<String>,
        repeat: Option<u32>,
        executor: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let out = out.unwrap_or_else(|| PathBuf::from("savme-results"));
        let executor = executor_of(executor)?;
        if executor.is_some() && repeat.is_some() {
            return Err(PyValueError::new_err(
                "repeat runs its seeds on local threads: not with executor=",
            ));
        }
        if executor.is_some() && jobs.is_some() {
            return Err(PyValueError::new_err(
                "jobs= sets local worker threads; with executor= the executor decides how many runs go at once (e.g. savme.RayExecutor(workers=N))",
            ));
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
    /// `sim=savme.fmu.Simulator(...)`; a campaign from `savme.campaign.load` has its FMUs.
    /// Ctrl-C stops the campaign between trials and raises `KeyboardInterrupt` (the told
    /// trials are stored: `resume=True` continues).
    #[pyo3(signature = (simulate = None, *, hf = None, lf = None, sim = None))]
    fn run(
        &self,
        py: Python<'_>,
        simulate: Option<Py<PyAny>>,
        hf: Option<Py<PyAny>>,
        lf: Option<Py<PyAny>>,
        sim: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyCampaignResult> {
        let given = [
            simulate.is_some(),
            hf.is_some() || lf.is_some(),
            sim.is_some(),
        ];
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
            return match &self.executor {
                Some(executor) => self.run_executed(py, sim, executor),
                None => self.run_python(py, sim),
            };
        }
        if self.executor.is_some() {
            return Err(PyTypeError::new_err(
                "executor= runs Python simulator callables: give run(simulate) or run(hf=..., lf=...) (sim= and campaign files' FMUs run on local threads)",
            ));
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
            BoundSim::Fmu(file) => self.run_on(py, crate::sim::fmu_backend(file)?),
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
    storage = None, campaign = None))]
pub fn load_campaign(
    path: PathBuf,
    out: Option<PathBuf>,
    resume: bool,
    jobs: Option<usize>,
    progress: bool,
    storage: Option<&str>,
    campaign: Option<String>,
) -> PyResult<PyCampaign> {
    let storage = storage_of(storage, campaign)?;
    let c = compose::fmu_file(&path, &Overrides::default()).map_err(errors::campaign)?;
    // Open the FMUs now, so that a campaign that cannot run fails here.
    crate::sim::fmu_backend(&c.file)?;
    let out = out
        .or(c.file.common.campaign.out.clone())
        .unwrap_or_else(|| PathBuf::from("savme-fmu-results"));
    let estimate = c.estimate_settings().map_err(errors::campaign_message)?;
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
            executor: None,
        },
        executor: None,
        bound: BoundSim::Fmu(Box::new(c.file)),
    })
}

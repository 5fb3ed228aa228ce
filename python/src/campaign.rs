//! `savme.Protocol`, `savme.Problem` and `savme.Campaign`: the paper's protocol run by the one
//! Rust campaign loop (`savme::campaign::Campaign`), on Python callables or the bundled and
//! FMU simulators — the same outputs, store and resume as `savme run`.

use crate::convert;
use crate::errors;
use crate::sim::{PyDriving, PyFmuSimulator};
use crate::space::PySpace;
use crossbeam_channel::RecvTimeoutError;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use savme::campaign::config::{self, Overrides};
use savme::campaign::store::postgres::{check_name, Database, PostgresStore};
use savme::campaign::store::{StoreError, TrialStore};
use savme::campaign::{
    Campaign, CampaignOutcome, Cost, OnError, Problem, ProgressLines, Protocol, Stop,
};
use savme_fmu::campaign_file::CampaignFile;
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

fn cost(name: &str) -> PyResult<Cost> {
    match name {
        "wall" => Ok(Cost::Wall),
        "work" => Ok(Cost::Work),
        other => Err(PyValueError::new_err(format!(
            "cost must be \"wall\" or \"work\", got {other:?}"
        ))),
    }
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
    /// The paper's protocol (or the quick preset) for the given scenarios, with any field
    /// overridden; validated (a ValueError names the field).
    #[new]
    #[pyo3(signature = (train_scenarios, test_scenarios, *, preset = "paper", simulator = "python",
        seed = None, budgets = None, train_iterations = None, eval_iterations = None,
        test_iterations = None, baseline_train_iterations = None, baseline_test_iterations = None,
        cost = None, fidelity_bins = None, prior_strength = None, window = None, weights = None,
        on_error = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        train_scenarios: Vec<String>,
        test_scenarios: Vec<String>,
        preset: &str,
        simulator: &str,
        seed: Option<u64>,
        budgets: Option<Vec<f64>>,
        train_iterations: Option<u64>,
        eval_iterations: Option<u64>,
        test_iterations: Option<u64>,
        baseline_train_iterations: Option<u64>,
        baseline_test_iterations: Option<u64>,
        cost: Option<&str>,
        fidelity_bins: Option<u32>,
        prior_strength: Option<f64>,
        window: Option<usize>,
        weights: Option<BTreeMap<String, f64>>,
        on_error: Option<&str>,
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
        let o = Overrides {
            seed,
            cost: cost.map(self::cost).transpose()?,
            budgets,
            train_iterations,
            eval_iterations,
            test_iterations,
            baseline_train_iterations,
            baseline_test_iterations,
            fidelity_bins,
            prior_strength,
            window,
            train_scenarios: None,
            test_scenarios: None,
            ..Overrides::default()
        };
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
            problem: Problem::driving(bins),
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
/// flag, or `(failure, work_units)`; the wall time of the call is measured here. The GIL is
/// taken only around the call.
#[derive(Clone)]
pub struct PySimulator {
    hf: Arc<Py<PyAny>>,
    lf: Arc<Py<PyAny>>,
}

fn sim_result(out: &Bound<'_, PyAny>, wall: f64) -> Result<SimResult, String> {
    // The flag alone, or the first of (failure, work_units).
    let pair = out
        .cast::<PyTuple>()
        .ok()
        .and_then(|t| t.extract::<(Bound<'_, PyAny>, u64)>().ok());
    let (flag, work) = match pair {
        Some((flag, work)) => (flag, Some(work)),
        None => (out.clone(), None),
    };
    let kind = match crate::convert::failure_flag(&flag) {
        Ok(failure) => return Ok(SimResult::new(failure, wall, work)),
        Err(kind) => kind,
    };
    Err(format!(
        "a simulator must return the failure flag (bool or numpy bool) or (failure, work_units), got {kind} {flag}"
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
            let out =
                out.map_err(|e| SimError::Failed(format!("the `{name}` simulator raised {e}")))?;
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
    Fmu(Box<CampaignFile>),
}

/// A campaign: a protocol, a problem, an output directory.
#[pyclass(name = "Campaign", module = "savme", frozen)]
pub struct PyCampaign {
    protocol: Protocol,
    problem: Problem,
    out: PathBuf,
    resume: bool,
    jobs: Option<usize>,
    progress: bool,
    /// The PostgreSQL database and the campaign's name in it, instead of the directory's store.
    storage: Option<(Database, String)>,
    bound: BoundSim,
}

/// What a finished campaign returns.
#[pyclass(name = "CampaignResult", module = "savme", frozen)]
pub struct PyCampaignResult {
    outcome: CampaignOutcome,
}

#[pymethods]
impl PyCampaignResult {
    /// The campaign directory.
    #[getter]
    fn out(&self) -> PathBuf {
        self.outcome
            .outputs
            .protocol
            .parent()
            .map(PathBuf::from)
            .unwrap_or_default()
    }

    /// The report as a dict (what `summary.json` holds under "report").
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::json_to_py(py, &self.outcome.report)
    }

    /// Table III as Markdown (`table.md`).
    #[getter]
    fn table_md(&self) -> String {
        self.outcome.report.table_md()
    }

    /// The files written: protocol, trials, table, fidelity, summary, breakeven, meta_testing.
    #[getter]
    fn files<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let o = &self.outcome.outputs;
        let d = PyDict::new(py);
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
        self.outcome.replayed
    }

    /// Trials run by this call.
    #[getter]
    fn ran(&self) -> u64 {
        self.outcome.ran
    }

    /// Wall-clock seconds this call took.
    #[getter]
    fn elapsed_seconds(&self) -> f64 {
        self.outcome.elapsed_seconds
    }

    fn __repr__(&self) -> String {
        format!(
            "CampaignResult(out={:?}, ran={}, replayed={}, elapsed_seconds={:.1})",
            self.out().display().to_string(),
            self.outcome.ran,
            self.outcome.replayed,
            self.outcome.elapsed_seconds
        )
    }
}

impl PyCampaign {
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
        let (protocol, problem) = (self.protocol.clone(), self.problem.clone());
        let (out, resume, jobs, progress) =
            (self.out.clone(), self.resume, self.jobs, self.progress);
        let storage = self.storage.clone();
        let stop = Stop::new();
        let stop_campaign = stop.clone();
        let (tx, rx) = crossbeam_channel::bounded(1);
        let campaign = std::thread::Builder::new()
            .name("savme-campaign".into())
            .spawn(move || {
                let mut c = Campaign::new(protocol, problem)
                    .out(out)
                    .resume(resume)
                    .stop_on(stop_campaign);
                if let Some(j) = jobs {
                    c = c.jobs(j);
                }
                if progress {
                    c = c.observer(ProgressLines::new(std::io::stderr()));
                }
                if let Some((db, name)) = storage {
                    match PostgresStore::open(&db, &name) {
                        Ok(store) => c = c.store(Box::new(store)),
                        Err(e) => {
                            let _ = tx.send(Err(e.into()));
                            return;
                        }
                    }
                }
                let _ = tx.send(c.run(&sim));
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
        Ok(PyCampaignResult {
            outcome: outcome.map_err(errors::campaign)?,
        })
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
        jobs = None, progress = false, storage = None, campaign = None))]
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
    ) -> PyResult<Self> {
        let out = out.unwrap_or_else(|| PathBuf::from("savme-results"));
        let storage = storage_of(storage, campaign)?;
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
            protocol,
            problem: problem.problem.clone(),
            out,
            resume,
            jobs,
            progress,
            storage,
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
        if let Some(f) = simulate {
            let f = Arc::new(f);
            return self.run_on(
                py,
                PySimulator {
                    hf: f.clone(),
                    lf: f,
                },
            );
        }
        match (hf, lf) {
            (Some(hf), Some(lf)) => {
                return self.run_on(
                    py,
                    PySimulator {
                        hf: Arc::new(hf),
                        lf: Arc::new(lf),
                    },
                )
            }
            (None, None) => {}
            _ => {
                return Err(PyTypeError::new_err(
                    "give both hf= and lf= (or one simulate callable)",
                ))
            }
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
            protocol: self.protocol.clone(),
        }
    }

    /// The output directory.
    #[getter]
    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Campaign(simulator={:?}, out={:?}, resume={})",
            self.protocol.simulator,
            self.out.display().to_string(),
            self.resume
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
    let c = config::fmu_file(&path, &Overrides::default()).map_err(errors::campaign)?;
    // Open the FMUs now, so that a campaign that cannot run fails here.
    crate::sim::fmu_backend(&c.file)?;
    let out = out
        .or(c.file.campaign.out.clone())
        .unwrap_or_else(|| PathBuf::from("savme-fmu-results"));
    Ok(PyCampaign {
        protocol: c.protocol,
        problem: c.problem,
        out,
        resume,
        jobs,
        progress,
        storage,
        bound: BoundSim::Fmu(Box::new(c.file)),
    })
}

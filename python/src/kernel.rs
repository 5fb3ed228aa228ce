//! `savme.Kernel`: the ask/tell kernel, plain or journaled to the same store as
//! `savme serve --journal`.
//!
//! One file of ~700 lines because a PyO3 class has one `#[pymethods]` block (several need
//! PyO3's `multiple-pymethods` feature and the `inventory` crate): every Python method of
//! `Kernel` is here; what they convert or build lives in `convert`, `trial`, `space` and
//! `estimation`.

use crate::convert;
use crate::errors;
use crate::estimation::{self, PyEstimation};
use crate::history::{self, History};
use crate::space::PySpace;
use crate::trial::{PyPosterior, PyRecord, PyTrial};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use savme::campaign::store::{journal, JsonlStore};
use savme::serve::Session;
use savme_kernel::{
    Allocation, CostRate, Deployment, EliteMixture, Estimator, FidelityPrior, Kernel, KernelConfig,
    Observation, Pairing, Phase, PriorCounts, Run, Scenario, ScenarioPrior, SearchModel, Space,
    TrialRecord,
};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

/// The ask/tell kernel.
#[pyclass(name = "Kernel", module = "savme", frozen)]
pub struct PyKernel {
    /// None once closed.
    session: Mutex<Option<Session>>,
    journal: Option<PathBuf>,
    /// The records of the trials told, in tell order (`trials()`): a resumed journal's first;
    /// all of them, the last N or none (`history=`).
    history: Mutex<History>,
}

pub fn parse_phase(phase: &str) -> PyResult<Phase> {
    Ok(match phase {
        "train" => Phase::Train,
        "evaluate" => Phase::Evaluate,
        "baseline" => Phase::Baseline,
        "test" => Phase::Test,
        other => {
            return Err(PyValueError::new_err(format!(
            "unknown phase {other:?}: expected \"train\", \"evaluate\", \"baseline\" or \"test\""
        )))
        }
    })
}

fn parse_estimator(estimator: &str) -> PyResult<Estimator> {
    match estimator {
        "map" => Ok(Estimator::Map),
        "mean" => Ok(Estimator::Mean),
        "evidence" => Ok(Estimator::Evidence),
        other => Err(PyValueError::new_err(format!(
            "unknown estimator {other:?}: expected \"map\", \"mean\" or \"evidence\""
        ))),
    }
}

/// `scenarios=`: a dict {name: Space} (weight 1 each) or a list of (name, Space) or
/// (name, Space, weight) tuples.
fn scenarios(arg: &Bound<'_, PyAny>) -> PyResult<Vec<Scenario>> {
    let one = |name: &Bound<'_, PyAny>, space: &Bound<'_, PyAny>, weight: f64| {
        let name: String = name.extract().map_err(|_| {
            PyTypeError::new_err(format!("scenarios: a name must be a str, got {name}"))
        })?;
        let space = space.cast::<PySpace>().map_err(|_| {
            PyTypeError::new_err(format!("scenarios: scenario `{name}` needs a savme.Space"))
        })?;
        Ok(Scenario {
            name: name.as_str().into(),
            space: space.get().space.clone(),
            weight,
        })
    };
    if let Ok(d) = arg.cast::<PyDict>() {
        return d.iter().map(|(k, v)| one(&k, &v, 1.0)).collect();
    }
    let bad = || {
        PyTypeError::new_err(
            "scenarios: give a dict {name: Space} or a list of (name, Space[, weight]) tuples",
        )
    };
    arg.try_iter()
        .map_err(|_| bad())?
        .map(|item| {
            let item = item?;
            let t = item.cast::<PyTuple>().map_err(|_| bad())?;
            match t.len() {
                2 => one(&t.get_item(0)?, &t.get_item(1)?, 1.0),
                3 => one(&t.get_item(0)?, &t.get_item(1)?, t.get_item(2)?.extract()?),
                _ => Err(bad()),
            }
        })
        .collect()
}

/// `scenario_priors=`: a list of {"scenario": name, "posterior": Posterior} dicts, the shape of
/// a configuration's `scenario_priors` (`KernelConfig::scenario_priors`); the kernel checks
/// each names one of its scenarios once and fits its φ-space.
fn scenario_priors(arg: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<ScenarioPrior>> {
    let Some(arg) = arg else {
        return Ok(Vec::new());
    };
    let bad = |at: String| {
        PyTypeError::new_err(format!(
            "scenario_priors{at}: give a list of {{\"scenario\": name, \"posterior\": savme.Posterior}} dicts"
        ))
    };
    if arg.is_instance_of::<PyDict>() || arg.extract::<String>().is_ok() {
        return Err(bad(String::new()));
    }
    arg.try_iter()
        .map_err(|_| bad(String::new()))?
        .enumerate()
        .map(|(i, item)| {
            let item = item?;
            let d = item.cast::<PyDict>().map_err(|_| bad(format!("[{i}]")))?;
            if let Some(key) = d
                .keys()
                .iter()
                .filter_map(|k| k.extract::<String>().ok())
                .find(|k| k != "scenario" && k != "posterior")
            {
                return Err(PyValueError::new_err(format!(
                    "scenario_priors[{i}]: unknown key {key:?} (the keys are \"scenario\" and \"posterior\")"
                )));
            }
            let missing = |key: &str| {
                PyValueError::new_err(format!("scenario_priors[{i}]: no {key:?} key"))
            };
            let scenario: String = d
                .get_item("scenario")?
                .ok_or_else(|| missing("scenario"))?
                .extract()
                .map_err(|_| bad(format!("[{i}][\"scenario\"]")))?;
            let posterior = d.get_item("posterior")?.ok_or_else(|| missing("posterior"))?;
            let posterior = posterior
                .cast::<PyPosterior>()
                .map_err(|_| bad(format!("[{i}][\"posterior\"]")))?;
            Ok(ScenarioPrior {
                scenario: scenario.as_str().into(),
                posterior: posterior.get().posterior.clone(),
            })
        })
        .collect()
}

/// `search=`: "bins" (the paper's), "elite", or a dict of [`EliteMixture`] parameters (the
/// elite mixture with those, the others at their defaults).
/// The `deployment` keyword: "frozen" (the paper's), "exploit", "learn" or "adaptive".
fn deployment(name: &str) -> PyResult<Deployment> {
    match name {
        "frozen" => Ok(Deployment::FROZEN),
        "exploit" => Ok(Deployment {
            learn: false,
            exploit: true,
        }),
        "learn" => Ok(Deployment {
            learn: true,
            exploit: false,
        }),
        "adaptive" => Ok(Deployment::ADAPTIVE),
        other => Err(PyValueError::new_err(format!(
            "deployment = {other:?}: give \"frozen\", \"exploit\", \"learn\" or \"adaptive\""
        ))),
    }
}

fn search_model(arg: Option<&Bound<'_, PyAny>>) -> PyResult<SearchModel> {
    let Some(arg) = arg else {
        return Ok(SearchModel::IndependentBins);
    };
    if let Ok(name) = arg.extract::<String>() {
        return match name.as_str() {
            "bins" => Ok(SearchModel::IndependentBins),
            "elite" => Ok(SearchModel::EliteMixture(EliteMixture::default())),
            other => Err(PyValueError::new_err(format!(
                "search = {other:?}: give \"bins\", \"elite\" or a dict of elite-mixture parameters"
            ))),
        };
    }
    let params = arg
        .extract::<std::collections::BTreeMap<String, f64>>()
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "search: give \"bins\", \"elite\" or a dict {{parameter: number}} of the elite mixture, got {arg}"
            ))
        })?;
    let given: serde_json::Map<String, serde_json::Value> = params
        .into_iter()
        .map(|(k, v)| {
            // Integer parameters (tries, archive, near_miss_until, rho_start, parzen_points) take whole numbers.
            let n = if v.fract() == 0.0 && (0.0..9e15).contains(&v) {
                serde_json::Value::from(v as u64)
            } else {
                serde_json::Value::from(v)
            };
            (k, n)
        })
        .collect();
    // The defaults with the given parameters in their place (the switches left out stay on).
    let m = EliteMixture::with(given).map_err(|e| PyValueError::new_err(format!("search: {e}")))?;
    m.validate()
        .map_err(|e| PyValueError::new_err(format!("search: {e}")))?;
    Ok(SearchModel::EliteMixture(m))
}

/// `hf=` / `lf=`: a (failure, runtime) pair, or a (failure, runtime, robustness) triple;
/// `robustness` (the keyword, if given) is the run's robustness instead.
fn run(which: &str, id: u64, arg: &Bound<'_, PyAny>, robustness: Option<f64>) -> PyResult<Run> {
    let bad = || {
        PyTypeError::new_err(format!(
            "tell(trial {id}, {which}=…): expected a (failure: bool, runtime: float) pair or a (failure, runtime, robustness: float) triple, got {arg}"
        ))
    };
    let (failure, runtime, third): (Bound<'_, PyAny>, f64, Option<f64>) =
        match arg.extract::<(Bound<'_, PyAny>, f64)>() {
            Ok((f, r)) => (f, r, None),
            Err(_) => {
                let (f, r, rho) = arg
                    .extract::<(Bound<'_, PyAny>, f64, f64)>()
                    .map_err(|_| bad())?;
                (f, r, Some(rho))
            }
        };
    if let (Some(a), Some(b)) = (third, robustness) {
        return Err(PyValueError::new_err(format!(
            "tell(trial {id}): the {which} robustness is given twice ({a} in the triple, {b} as a keyword); give it once"
        )));
    }
    let failure = crate::convert::failure_flag(&failure).map_err(|kind| {
        PyTypeError::new_err(format!(
            "tell(trial {id}, {which}=…): the failure flag (first of the pair) must be a bool or a numpy bool, got {kind} {failure}"
        ))
    })?;
    let run = Run::new(failure, runtime);
    Ok(match third.or(robustness) {
        Some(rho) => run.with_robustness(rho),
        None => run,
    })
}

impl PyKernel {
    fn lock(&self) -> PyResult<MutexGuard<'_, Option<Session>>> {
        self.session.lock().map_err(|_| errors::poisoned())
    }

    /// Runs `f` on the open session.
    fn with<T>(&self, f: impl FnOnce(&mut Session) -> PyResult<T>) -> PyResult<T> {
        let mut guard = self.lock()?;
        let session = guard.as_mut().ok_or_else(|| {
            PyValueError::new_err("the kernel is closed (its journal was released by close())")
        })?;
        f(session)
    }

    fn open(
        py: Python<'_>,
        config: Option<KernelConfig>,
        path: Option<PathBuf>,
        limit: Option<usize>,
    ) -> PyResult<Self> {
        let mut history = Vec::new();
        let session = match &path {
            None => {
                let config = config.ok_or_else(|| PyValueError::new_err("no configuration"))?;
                Session::Plain(Kernel::new(config).map_err(errors::value)?)
            }
            Some(p) => {
                let store = JsonlStore::open(p).map_err(errors::store)?;
                let opened = journal::open(Box::new(store), config).map_err(errors::open)?;
                if let Some(tail) = &opened.torn {
                    let msg = format!(
                        "{}: line {} was cut off mid-write ({} bytes); dropped it",
                        p.display(),
                        tail.line,
                        tail.bytes
                    );
                    let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
                    PyErr::warn(py, &category, &std::ffi::CString::new(msg)?, 1)?;
                }
                history = opened.records;
                Session::Journaled(opened.kernel)
            }
        };
        Ok(PyKernel {
            session: Mutex::new(Some(session)),
            journal: path,
            history: Mutex::new(History::new(history, limit)),
        })
    }

    /// A plain (not journaled) kernel from a snapshot, with its history.
    fn plain(kernel: Kernel, history: History) -> Self {
        PyKernel {
            session: Mutex::new(Some(Session::Plain(kernel))),
            journal: None,
            history: Mutex::new(history),
        }
    }

    fn history(&self) -> PyResult<MutexGuard<'_, History>> {
        self.history.lock().map_err(|_| errors::poisoned())
    }

    /// The id of `trial` (a Trial or an id). A Trial that is not this kernel's pending trial
    /// of that id (another `Kernel` asked it) is refused: it would credit this kernel's trial.
    fn trial_id(&self, trial: &Bound<'_, PyAny>) -> PyResult<u64> {
        if let Ok(t) = trial.cast::<PyTrial>() {
            let t = &t.get().trial;
            let other = self.with(|s| Ok(s.kernel().pending().any(|p| p.id == t.id && p != t)))?;
            if other {
                return Err(PyValueError::new_err(format!(
                    "trial {} was asked by another Kernel (this kernel's trial {} differs): tell or cancel it on the kernel that asked it",
                    t.id, t.id
                )));
            }
            return Ok(t.id);
        }
        trial.extract::<u64>().map_err(|_| {
            PyTypeError::new_err(format!(
                "expected a Trial or a trial id (a non-negative int), got {trial}"
            ))
        })
    }
}

#[pymethods]
impl PyKernel {
    #[new]
    #[pyo3(signature = (*, fidelity, theta_hf, scenarios, budget = 0.3, seed = 0, estimator = None,
        prior = None, fidelity_prior = None, prior_strength = 1.0, journal = None, search = None,
        pair_fraction = 1.0, pair_settle = 30, deployment = None, allocation = None,
        method = "tuned", history = None, scenario_priors = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        fidelity: PyRef<'_, PySpace>,
        theta_hf: &Bound<'_, PyDict>,
        scenarios: &Bound<'_, PyAny>,
        budget: f64,
        seed: i128,
        estimator: Option<&str>,
        prior: Option<(f64, f64)>,
        fidelity_prior: Option<PyRef<'_, PyPosterior>>,
        prior_strength: f64,
        journal: Option<PathBuf>,
        search: Option<&Bound<'_, PyAny>>,
        pair_fraction: f64,
        pair_settle: i128,
        deployment: Option<&str>,
        allocation: Option<&str>,
        method: &str,
        history: Option<&Bound<'_, PyAny>>,
        scenario_priors: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let limit = history::limit_of(history)?;
        let method = match method {
            "tuned" => savme::campaign::Method::Tuned,
            "paper" => savme::campaign::Method::Paper,
            other => {
                return Err(PyValueError::new_err(format!(
                    "method = {other:?}: give \"tuned\" (savme's search by cost) or \"paper\" (the paper's SAVME)"
                )))
            }
        };
        // The method's kernel settings (`Preset`, as `savme example-config` and the C ABI's
        // builder take them), each overridden by its keyword.
        let preset = method.preset();
        let search = match search {
            Some(s) => search_model(Some(s))?,
            None => preset.search(),
        };
        let deployment = deployment.map_or(Ok(preset.deployment()), self::deployment)?;
        let allocation = match allocation {
            None => preset.allocation(),
            Some("weights") => Allocation::Weights,
            Some("cost-rate") => Allocation::CostRate(CostRate {
                half_life: None,
                ..CostRate::default()
            }),
            Some("cost-rate-recent") => Allocation::CostRate(CostRate::default()),
            Some("cost-rate-scout") => Allocation::CostRate(CostRate {
                scout: true,
                ..CostRate::default()
            }),
            Some(other) => {
                return Err(PyValueError::new_err(format!(
                    "allocation = {other:?}: give \"weights\" (scenarios from p(s), the paper's), \"cost-rate\" (by HF failures per unit cost), \"cost-rate-recent\" (the same, recent evidence weighed more) or \"cost-rate-scout\" (the same, and a scenario without a failure yet kept at its share and run HF only)"
                )))
            }
        };
        let seed: u64 = convert::whole("seed", seed)?;
        let pairing = Pairing {
            fraction: pair_fraction,
            settle: convert::whole("pair_settle", pair_settle)?,
        };
        pairing.validate().map_err(|e| {
            PyValueError::new_err(format!(
                "pair_fraction = {pair_fraction} is outside {}",
                e.range
            ))
        })?;
        if fidelity_prior.is_none() && prior_strength != 1.0 {
            return Err(PyValueError::new_err(format!(
                "prior_strength = {prior_strength} without fidelity_prior: it weighs a transferred \
                 fidelity prior; give fidelity_prior=… too, or leave prior_strength out"
            )));
        }
        let fidelity: Space = fidelity.space.clone();
        let config = KernelConfig {
            scenarios: self::scenarios(scenarios)?,
            theta_hf: convert::assignment("theta_hf", theta_hf, &fidelity)?,
            fidelity,
            budget,
            seed,
            prior: prior.map_or(PriorCounts::UNIFORM, |(successes, losses)| PriorCounts {
                successes,
                losses,
            }),
            // The method's θ_LF* choice, as a campaign and `savme example-config` make it.
            estimator: match estimator {
                Some(e) => parse_estimator(e)?,
                None => preset.estimator(),
            },
            fidelity_prior: fidelity_prior.map(|p| FidelityPrior {
                posterior: p.posterior.clone(),
                strength: prior_strength,
            }),
            search,
            pairing,
            deployment,
            allocation,
            scenario_priors: self::scenario_priors(scenario_priors)?,
        };
        Kernel::new(config.clone()).map_err(errors::value)?;
        PyKernel::open(py, Some(config), journal, limit)
    }

    /// A kernel from a configuration in JSON (what `savme serve --config` reads and
    /// `savme example-config` prints), optionally journaled.
    #[staticmethod]
    #[pyo3(signature = (config, journal = None, *, history = None))]
    fn from_config(
        py: Python<'_>,
        config: &str,
        journal: Option<PathBuf>,
        history: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let limit = history::limit_of(history)?;
        // The one reader of a configuration's JSON (`savme serve --config`, the C ABI).
        let config = savme::serve::parse_config(config).map_err(errors::value)?;
        PyKernel::open(py, Some(config), journal, limit)
    }

    /// Reopens an existing journal (written by Python or by `savme serve --journal`); its
    /// told records are `trials()` (as many as `history` keeps).
    #[staticmethod]
    #[pyo3(signature = (journal, *, history = None))]
    fn resume(
        py: Python<'_>,
        journal: PathBuf,
        history: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let limit = history::limit_of(history)?;
        if !journal.is_file() {
            return Err(errors::JournalError::new_err(format!(
                "{}: no journal to resume (start one with savme.Kernel(..., journal=...))",
                journal.display()
            )));
        }
        PyKernel::open(py, None, Some(journal), limit)
    }

    /// A kernel restored from `to_json()` output (not journaled; its `trials()` history
    /// starts empty — a pickled kernel keeps it).
    #[staticmethod]
    #[pyo3(signature = (snapshot, *, history = None))]
    fn from_json(snapshot: &str, history: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let limit = history::limit_of(history)?;
        let kernel = Kernel::from_json(snapshot).map_err(errors::value)?;
        Ok(PyKernel::plain(kernel, History::new(Vec::new(), limit)))
    }

    /// A kernel from `__reduce__`'s state: its snapshot, its history (JSON) and how many
    /// records the history keeps (None: all).
    #[staticmethod]
    #[pyo3(signature = (snapshot, history, limit = None))]
    fn _restore(snapshot: &str, history: &str, limit: Option<usize>) -> PyResult<Self> {
        let kernel = Kernel::from_json(snapshot).map_err(errors::value)?;
        let records = serde_json::from_str(history).map_err(errors::value)?;
        Ok(PyKernel::plain(kernel, History::new(records, limit)))
    }

    /// Pickling (and `copy.deepcopy`): a plain kernel is restored exactly, with its history
    /// (through `to_json`). A journaled kernel is refused: its journal has one writer;
    /// `Kernel.resume(path)` reopens it in another process.
    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (String, String, Option<usize>))> {
        let me = slf.get();
        if let Some(path) = &me.journal {
            return Err(PyTypeError::new_err(format!(
                "a Kernel journaled to {} cannot be pickled (its journal has one writer): \
                 close() it and Kernel.resume({:?}) in the other process, or pickle \
                 Kernel.from_json(kernel.to_json()) for an unjournaled copy",
                path.display(),
                path.display().to_string()
            )));
        }
        let snapshot = me.to_json()?;
        let (records, limit) = {
            let history = me.history()?;
            let records: Vec<&TrialRecord> = history.records().map(|r| &**r).collect();
            (
                serde_json::to_string(&records).map_err(errors::value)?,
                history.limit(),
            )
        };
        Ok((
            slf.get_type().getattr("_restore")?,
            (snapshot, records, limit),
        ))
    }

    /// The told trials in tell order, each a `Record` (φ, θ_LF, the runs with their
    /// failures and runtimes, the outcome): a list with `.to_pandas()` (a DataFrame, one row
    /// per trial) when pandas is installed. A resumed journal's trials come first. Only the
    /// last N with `history=N`, none with `history=False`.
    fn trials<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let records = self
            .history()?
            .records()
            .map(|record| {
                Bound::new(
                    py,
                    PyRecord {
                        record: Arc::clone(record),
                    },
                )
            })
            .collect::<PyResult<Vec<_>>>()?;
        py.import("savme.history")?
            .getattr("Trials")?
            .call1((PyList::new(py, records)?,))
    }

    /// Asks, runs and tells `n_trials` trials (fewer if `timeout` seconds pass first; None:
    /// no limit), as Optuna's `study.optimize`: `objective(trial)` returns `(hf, lf)` — each
    /// a `(failure, runtime)` pair, `lf` None for a baseline trial. An exception of a type in
    /// `catch` (an exception class or a tuple of them) cancels the trial and goes on; any
    /// other cancels it and is raised. Each of `callbacks` (a list) is called as
    /// `callback(kernel, record)` after each tell. Returns the records told (as many as the
    /// kernel's `history` keeps).
    #[pyo3(signature = (objective, n_trials = None, *, timeout = None, callbacks = None, catch = None))]
    fn optimize<'py>(
        slf: &Bound<'py, Self>,
        objective: &Bound<'py, PyAny>,
        n_trials: Option<&Bound<'py, PyAny>>,
        timeout: Option<f64>,
        callbacks: Option<&Bound<'py, PyAny>>,
        catch: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        py.import("savme.history")?
            .getattr("optimize")?
            .call1((slf, objective, n_trials, timeout, callbacks, catch))
    }

    /// The complete state as JSON (`Kernel.from_json` restores it exactly).
    fn to_json(&self) -> PyResult<String> {
        self.with(|s| Ok(s.kernel().to_json()))
    }

    /// The configuration as JSON (the format `savme serve --config` reads).
    fn config_json(&self) -> PyResult<String> {
        self.with(|s| serde_json::to_string_pretty(s.kernel().config()).map_err(errors::value))
    }

    /// Suggests the next trial, or a list of `n` trials (all or none).
    #[pyo3(signature = (n = None))]
    fn ask(&self, py: Python<'_>, n: Option<i128>) -> PyResult<Py<PyAny>> {
        // Any int is taken, so that a negative or huge one is named as `n`, not an
        // OverflowError.
        let n = n
            .map(|n| {
                usize::try_from(n).map_err(|_| {
                    PyValueError::new_err(format!(
                        "n must be between 1 and {}, got {n}",
                        savme::serve::MAX_BATCH
                    ))
                })
            })
            .transpose()?;
        let trials = self.with(|s| s.ask(n.unwrap_or(1)).map_err(errors::session))?;
        let mut trials = trials.into_iter().map(|trial| PyTrial { trial });
        match (n, trials.next()) {
            (None, Some(t)) => Ok(Bound::new(py, t)?.into_any().unbind()),
            (_, first) => {
                let all = first
                    .into_iter()
                    .chain(trials)
                    .map(|t| Bound::new(py, t))
                    .collect::<PyResult<Vec<_>>>()?;
                Ok(PyList::new(py, all)?.into_any().unbind())
            }
        }
    }

    /// Ingests trial `trial`'s runs: `hf=(failure, runtime)` and, unless it is a baseline
    /// trial, `lf=(failure, runtime)`. Each run may carry its robustness (how close it came
    /// to failing: `≤ 0` failed, smaller = closer) as a third element, or as the keywords
    /// `robustness=` (HF) and `lf_robustness=` (LF). Returns the record; a refused tell
    /// raises `savme.TellError` and changes nothing.
    #[pyo3(signature = (trial, hf, lf = None, *, robustness = None, lf_robustness = None))]
    fn tell(
        &self,
        trial: &Bound<'_, PyAny>,
        hf: &Bound<'_, PyAny>,
        lf: Option<&Bound<'_, PyAny>>,
        robustness: Option<f64>,
        lf_robustness: Option<f64>,
    ) -> PyResult<PyRecord> {
        let id = self.trial_id(trial)?;
        let hf = run("hf", id, hf, robustness)?;
        let observation = match lf {
            Some(lf) => Observation::Paired {
                hf,
                lf: run("lf", id, lf, lf_robustness)?,
            },
            None if lf_robustness.is_some() => {
                return Err(PyValueError::new_err(format!(
                    "tell(trial {id}): lf_robustness without an lf run"
                )))
            }
            None => Observation::HfOnly(hf),
        };
        let record = Arc::new(self.with(|s| s.tell(id, observation).map_err(errors::session))?);
        self.history()?.push(&record);
        Ok(PyRecord { record })
    }

    /// Withdraws a pending trial (its simulation crashed); it will never be told.
    fn cancel(&self, trial: &Bound<'_, PyAny>) -> PyResult<PyTrial> {
        let id = self.trial_id(trial)?;
        let trial = self.with(|s| s.cancel(id).map_err(errors::session))?;
        Ok(PyTrial { trial })
    }

    /// Switches the phase of future asks: "train", "evaluate", "baseline" or "test".
    fn set_phase(&self, phase: &str) -> PyResult<()> {
        let phase = parse_phase(phase)?;
        self.with(|s| s.set_phase(phase).map_err(errors::session))
    }

    /// The phase new asks are drawn in.
    #[getter]
    fn phase(&self) -> PyResult<String> {
        self.with(|s| Ok(s.kernel().phase().to_string()))
    }

    /// θ_LF*: the greedy fidelity settings ("evidence", "map" — the paper's — or "mean";
    /// default: the kernel's estimator), continuous settings at their bin's expected value.
    #[pyo3(signature = (estimator = None))]
    fn estimate<'py>(
        &self,
        py: Python<'py>,
        estimator: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let est = estimator.map(parse_estimator).transpose()?;
        let theta = self.with(|s| {
            let k = s.kernel();
            Ok(k.fidelity_estimate(est.unwrap_or(k.config().estimator)))
        })?;
        convert::dict(py, &theta)
    }

    /// What stands behind θ_LF* under `estimator` (default: the kernel's): per fidelity
    /// setting its arm, the learning trials' tally of that arm (`tried`, `successes`, `tp`,
    /// `tn`, `fp`, `fn`, `cost`) and its false-alarm and miss rates — `savme serve`'s
    /// `estimate` answer's `settings`. None unless the kernel's estimator is "evidence" (the
    /// only one that keeps the tallies).
    #[pyo3(signature = (estimator = None))]
    fn estimate_evidence<'py>(
        &self,
        py: Python<'py>,
        estimator: Option<&str>,
    ) -> PyResult<Option<Bound<'py, PyAny>>> {
        let est = estimator.map(parse_estimator).transpose()?;
        let settings = self.with(|s| {
            let k = s.kernel();
            Ok(savme::serve::chosen_settings(
                k,
                est.unwrap_or(k.config().estimator),
            ))
        })?;
        settings.map(|v| convert::json_to_py(py, &v)).transpose()
    }

    /// An importance-sampling estimation of P(failure) under the nominal distribution from
    /// the current φ posteriors (typically after meta-training): `epsilon` is the nominal's
    /// share of the proposal, `nominal` maps scenario → variable → `{"distribution":
    /// "normal", "mean": M, "sd": S}` (or `"uniform"`, or `"weights"` with `"weights": [...]`)
    /// for the variables that are not uniform, `tilt` is "posterior" or "nominal-weighted",
    /// `refine=(rounds, runs)` adds cross-entropy pilot rounds, `refine_reuse=k` counts
    /// the last k of them in the estimate too, and `joint_components=K` makes the pilot fit a
    /// joint proposal (a mixture of at most K components over the whole of φ) instead of
    /// refitting each variable's bins, and `pilot_fidelity="lf"` (with `refine`) marks the
    /// pilot rounds' trials `"fidelity": "lf"`: run them at the learned θ_LF* (the
    /// multi-fidelity estimator; the estimate's trials stay HF), and `control_calibration=N`
    /// adds LF runs as control variates for the HF estimate: N calibration pairs choose α and
    /// `control_extra` (extra LF runs per pair; given: forced), or HF only when the LF does
    /// not pay (tell each run's `cost`). The kernel is not changed.
    #[pyo3(signature = (*, epsilon = 0.1, seed = 0, nominal = None, tilt = "posterior", refine = None, refine_reuse = 0, joint_components = None, pilot_fidelity = "hf", control_calibration = None, control_extra = None))]
    // Python keyword arguments, one parameter each.
    #[allow(clippy::too_many_arguments)]
    fn estimation(
        &self,
        py: Python<'_>,
        epsilon: f64,
        seed: i128,
        nominal: Option<&Bound<'_, PyAny>>,
        tilt: &str,
        refine: Option<(i128, i128)>,
        refine_reuse: i128,
        joint_components: Option<i128>,
        pilot_fidelity: &str,
        control_calibration: Option<i128>,
        control_extra: Option<i128>,
    ) -> PyResult<PyEstimation> {
        let refine = refine
            .map(|(rounds, runs)| {
                Ok::<_, PyErr>((
                    convert::whole("refine's rounds", rounds)?,
                    convert::whole("refine's runs", runs)?,
                ))
            })
            .transpose()?;
        let config = estimation::config(
            py,
            epsilon,
            convert::whole("seed", seed)?,
            nominal,
            tilt,
            refine,
            convert::whole("refine_reuse", refine_reuse)?,
            joint_components
                .map(|k| convert::whole("joint_components", k))
                .transpose()?,
            pilot_fidelity,
            (
                control_calibration
                    .map(|n| convert::whole("control_calibration", n))
                    .transpose()?,
                control_extra
                    .map(|k| convert::whole("control_extra", k))
                    .transpose()?,
            ),
        )?;
        self.with(|s| PyEstimation::of(s.kernel(), &config))
    }

    /// The fidelity posterior p_ω(θ_LF).
    fn fidelity_posterior(&self) -> PyResult<PyPosterior> {
        self.with(|s| {
            Ok(PyPosterior {
                posterior: s.kernel().fidelity_posterior().clone(),
            })
        })
    }

    /// The φ posterior p_ψ(φ | s) of the scenario `name` (KeyError if there is none).
    fn scenario_posterior(&self, name: &str) -> PyResult<PyPosterior> {
        self.with(|s| {
            let k = s.kernel();
            let posterior = k.scenario_posterior(name).ok_or_else(|| {
                convert::unknown(
                    "scenario",
                    name,
                    k.config().scenarios.iter().map(|s| &*s.name),
                )
            })?;
            Ok(PyPosterior {
                posterior: posterior.clone(),
            })
        })
    }

    /// {"fidelity": Posterior, "scenarios": {name: Posterior}}.
    fn posterior<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (fidelity, scenarios) = self.with(|s| {
            let k = s.kernel();
            let scenarios: Vec<_> = k
                .config()
                .scenarios
                .iter()
                .filter_map(|sc| {
                    Some((sc.name.to_string(), k.scenario_posterior(&sc.name)?.clone()))
                })
                .collect();
            Ok((k.fidelity_posterior().clone(), scenarios))
        })?;
        let by_name = PyDict::new(py);
        for (name, posterior) in scenarios {
            by_name.set_item(name, PyPosterior { posterior })?;
        }
        let d = PyDict::new(py);
        d.set_item(
            "fidelity",
            PyPosterior {
                posterior: fidelity,
            },
        )?;
        d.set_item("scenarios", by_name)?;
        Ok(d)
    }

    /// Trials asked and not yet told or cancelled, in id order (after a restart: the trials
    /// to run again).
    fn pending(&self) -> PyResult<Vec<PyTrial>> {
        self.with(|s| {
            Ok(s.kernel()
                .pending()
                .map(|t| PyTrial { trial: t.clone() })
                .collect())
        })
    }

    /// Counters: {"asked", "told", "cancelled"}.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let st = self.with(|s| Ok(s.kernel().stats()))?;
        let d = PyDict::new(py);
        d.set_item("asked", st.asked)?;
        d.set_item("told", st.told)?;
        d.set_item("cancelled", st.cancelled)?;
        Ok(d)
    }

    /// θ_HF, in space order.
    #[getter]
    fn theta_hf<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let theta = self.with(|s| Ok(s.kernel().theta_hf().clone()))?;
        convert::dict(py, &theta)
    }

    /// C_budget.
    #[getter]
    fn budget(&self) -> PyResult<f64> {
        self.with(|s| Ok(s.kernel().budget()))
    }

    /// The fidelity space.
    #[getter]
    fn fidelity(&self) -> PyResult<PySpace> {
        self.with(|s| {
            Ok(PySpace {
                space: s.kernel().config().fidelity.clone(),
            })
        })
    }

    /// The scenarios' names, in order.
    #[getter]
    fn scenarios(&self) -> PyResult<Vec<String>> {
        self.with(|s| {
            Ok(s.kernel()
                .config()
                .scenarios
                .iter()
                .map(|s| s.name.to_string())
                .collect())
        })
    }

    /// How many told records `trials()` keeps: None for all of them, else the last N (0:
    /// none) — the `history=` the kernel was made with.
    #[getter]
    fn history_limit(&self) -> PyResult<Option<usize>> {
        Ok(self.history()?.limit())
    }

    /// The journal's path, or None.
    #[getter]
    fn journal(&self) -> Option<&Path> {
        self.journal.as_deref()
    }

    /// Releases the journal (and its lock); later calls raise ValueError.
    fn close(&self) -> PyResult<()> {
        self.lock()?.take();
        Ok(())
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_exc))]
    fn __exit__(&self, _exc: &Bound<'_, PyTuple>) -> PyResult<bool> {
        self.close()?;
        Ok(false)
    }

    fn __repr__(&self) -> PyResult<String> {
        let journal = self.journal.as_ref().map_or_else(String::new, |p| {
            format!(", journal={:?}", p.display().to_string())
        });
        let guard = self.lock()?;
        Ok(match guard.as_ref() {
            None => format!("Kernel(closed{journal})"),
            Some(s) => {
                let k = s.kernel();
                let st = k.stats();
                format!(
                    "Kernel(phase={:?}, budget={}, asked={}, told={}, cancelled={}{journal})",
                    k.phase().to_string(),
                    k.budget(),
                    st.asked,
                    st.told,
                    st.cancelled
                )
            }
        })
    }
}

//! # savme-serve
//!
//! The kernel served: a [`Session`] (plain, or journaled to a trial store so that it resumes
//! after a crash: [`Session::open`]), the kernel configuration read from JSON
//! ([`parse_config`]: the one parser of `savme serve --config`, the Python `Kernel` and the C ABI),
//! and `savme serve`'s protocol: the kernel behind JSON lines on standard input and output, so
//! that a harness in any language (Python, MATLAB, C++, a shell script) can drive it.
//!
//! One request per line, one response per line, in order:
//!
//! | request | response |
//! |---|---|
//! | `{"op":"ask"}` or `{"op":"ask","n":4}` | `{"ok":true,"trials":[…]}` |
//! | `{"op":"tell","id":3,"observation":{"paired":{"hf":{"failure":true,"runtime":1.2},"lf":{"failure":true,"runtime":0.3}}}}` | `{"ok":true,"record":{…}}` |
//! | `{"op":"tell","id":4,"observation":{"hf_only":{"failure":false,"runtime":1.1}}}` | (baseline trials) |
//! | a run may carry `"robustness":0.4` (how close it came to failing, `≤ 0` failed) next to `failure` | learned from by the elite search (the configuration's `"search":{"model":"elite_mixture",…}`), journaled with the tell |
//! | `{"op":"cancel","id":5}` | `{"ok":true,"trial":{…}}` |
//! | `{"op":"phase","phase":"evaluate"}` (train, evaluate, baseline, test) | `{"ok":true}` |
//! | `{"op":"estimate"}` or `{"op":"estimate","estimator":"mean"}` (`map`, `mean`, `evidence`; default the configuration's) | `{"ok":true,"theta_lf":{…},"estimator":"evidence","evidence":n,"learned":bool,"settings":[{"variable","arm","tried","fp","false_alarm_rate","miss_rate",…}]}` (`settings` when the configuration's estimator is `evidence`, which keeps the tallies) |
//! | `{"op":"posterior"}` | `{"ok":true,"fidelity":{…},"scenarios":{…}}` |
//! | `{"op":"stats"}` | `{"ok":true,"stats":{…},"pending":[ids]}` |
//! | `{"op":"pending"}` | `{"ok":true,"trials":[…]}`: every trial asked and not yet told (a client restarting after a crash needs them) |
//! | `{"op":"estimation","epsilon":0.1,"seed":7}` (also `nominal`, `tilt`, `refine` = `{"rounds","runs","reuse"}`, `joint`, `pilot_fidelity` = `"lf"`, `control` = `{"calibration","extra"}`: LF runs as control variates: [`EstimationConfig`]) | `{"ok":true,"scenarios":[…],"probabilities":[…]}`: starts an importance-sampling estimation of P(failure) from the current posteriors (docs/ESTIMATION.md), replacing any earlier one |
//! | `{"op":"estimation_ask"}` | `{"ok":true,"trial":{"id","scenario","phi","q","p","weight","round",…}}` (with `"fidelity":"lf"` on a multi-fidelity estimation's pilot trials: run them at θ_LF*), or `"trial":null` while a refinement round waits for its outcomes |
//! | `{"op":"estimation_tell","id":0,"failure":true}` (also `"robustness":0.4`: a joint proposal's pilot aims at the near-misses; `"cost":0.3`: the control variates' calibration compares LF and HF costs) | `{"ok":true}` |
//! | `{"op":"estimation_result"}` | `{"ok":true,"estimate":{"total":{"mean","lo","hi",…},…},"told":n,"round":r}` |
//! | `{"op":"ladder_plan","levels":[{economy},…]}` (each level's [`Economy`], cheapest first) | `{"ok":true,"plan":[true,false]}`: which levels of a fidelity ladder the next screened trial runs ([`savme_kernel::screening::plan`]; one level is the two-level screening) |
//! | `{"op":"ladder_next","plan":[true,true],"last":{"level":0,"failure":true},"audited":false}` (`last` absent before any run) | `{"ok":true,"next":{"level":1}}`, `"next":"hf"` or `"next":"stop"`: the screened trial's next run ([`savme_kernel::screening::next`]) |
//!
//! A bad request — not UTF-8, not JSON, an unknown key, a refused tell — gets
//! `{"ok":false,"error":"request line N: …"}` and changes nothing; the server goes on. An ask of
//! `n` trials is all or nothing. With a journal every change is logged before it is applied,
//! and a restarted server resumes from it. `estimate` says how much evidence stands behind it:
//! before any (`"learned":false`) it is only the prior's choice. An estimation lives in the
//! server's memory only (it is not journaled, and it never changes the kernel); its trials
//! depend only on its request and the outcomes told, so a client that restarts it with the
//! same request and tells the same outcomes in order gets the same trials again.
//!
//! A fidelity ladder is served as a kernel per level: one server per level's budget, each
//! learning its own θ_LF (`estimate` reads its θ_LF*); `ladder_plan` and `ladder_next` are the
//! campaign's screening decisions, stateless, for a harness that screens down the levels.

#![warn(missing_docs)]

use savme_kernel::estimation::{Estimation, EstimationConfig};
use savme_kernel::journal::{Journaled, JournaledTellError};
use savme_kernel::screening::Economy;
use savme_kernel::{ConfigError, KernelConfig};
use savme_kernel::{Estimator, Kernel, Observation, Phase, TellError, Trial, TrialRecord};
use savme_store::journal::JournalSink;
use savme_store::journal::{self, JournalError};
use savme_store::StoreError;
use savme_store::{TornTail, TrialStore};
use serde::Deserialize;
use serde_json::{json, Value};
use std::io::{BufRead, Write};

/// One request line.
#[derive(Debug, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
enum Request {
    Ask {
        #[serde(default = "one")]
        n: usize,
    },
    Tell {
        id: u64,
        observation: Observation,
    },
    Cancel {
        id: u64,
    },
    Phase {
        phase: Phase,
    },
    Estimate {
        #[serde(default)]
        estimator: Option<Estimator>,
    },
    Posterior {},
    Stats {},
    Pending {},
    Estimation(EstimationConfig),
    EstimationAsk {},
    EstimationTell {
        id: u64,
        failure: bool,
        #[serde(default)]
        robustness: Option<f64>,
        #[serde(default)]
        cost: Option<f64>,
    },
    EstimationResult {},
    LadderPlan {
        levels: Vec<Economy>,
    },
    LadderNext {
        plan: Vec<bool>,
        #[serde(default)]
        last: Option<LastRun>,
        #[serde(default)]
        audited: bool,
    },
}

/// The last LF run of a screened trial on a ladder (`ladder_next`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LastRun {
    level: usize,
    failure: bool,
}

fn one() -> usize {
    1
}

/// The most trials one ask request may hand out.
pub const MAX_BATCH: usize = 100_000;

/// A kernel, journaled or not, behind the protocol.
#[derive(Debug)]
pub enum Session {
    /// No journal: state lives in memory only.
    Plain(Kernel),
    /// Every change logged to the journal (a trial store) first.
    Journaled(Journaled<JournalSink>),
}

/// Why a session refused a call. Either way nothing changed.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The kernel refused the tell or cancel.
    #[error(transparent)]
    Refused(#[from] TellError),
    /// The journal could not record the change.
    #[error("journal: {0}")]
    Journal(#[from] StoreError),
    /// An ask of no trials, or of more than [`MAX_BATCH`].
    #[error("n must be between 1 and {MAX_BATCH}, got {0}")]
    BadBatch(usize),
    /// An estimation that cannot start, or a refused estimation tell.
    #[error("estimation: {0}")]
    Estimation(#[from] savme_kernel::estimation::EstimationError),
    /// An estimation request before any `estimation` started one.
    #[error("no estimation is running: start one with {{\"op\":\"estimation\",\"epsilon\":0.1,\"seed\":0}}")]
    NoEstimation,
    /// A `ladder_next` whose last level is not a level of its plan.
    #[error("last.level {level} is not a level of the plan ({levels} levels, numbered from 0)")]
    NoSuchLevel {
        /// The level given.
        level: usize,
        /// Levels in the plan.
        levels: usize,
    },
}

/// Why a kernel configuration (JSON, as `savme example-config` prints) was refused.
#[derive(Debug, thiserror::Error)]
pub enum ParseConfigError {
    /// Not JSON, or not a kernel configuration (the message names line and column).
    #[error("not a kernel configuration: {0}")]
    Json(#[from] serde_json::Error),
    /// A configuration the kernel refuses (the message names the variable or value).
    #[error(transparent)]
    Invalid(#[from] ConfigError),
}

/// Reads a kernel configuration from JSON text and validates it (a kernel is built from it and
/// dropped), so that the error comes before anything starts.
///
/// ```
/// let config = savme_serve::parse_config("{}");
/// assert!(config.unwrap_err().to_string().starts_with("not a kernel configuration: missing field"));
/// ```
pub fn parse_config(text: &str) -> Result<KernelConfig, ParseConfigError> {
    let config: KernelConfig = serde_json::from_str(text)?;
    Kernel::new(config.clone())?;
    Ok(config)
}

/// Why a session could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// No journal and no configuration.
    #[error("give a kernel configuration (or a journal to resume)")]
    NoConfig,
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The journal could not be opened or replayed (the message names the store and line).
    #[error(transparent)]
    Journal(#[from] JournalError),
}

/// A session as [`Session::open`] found it.
#[derive(Debug)]
pub struct Opened {
    /// The session.
    pub session: Session,
    /// Some when an existing journal was resumed: trials told and pending.
    pub resumed: Option<(u64, Vec<Trial>)>,
    /// An incomplete last journal line that was dropped (a process killed mid-write).
    pub torn: Option<TornTail>,
}

/// The running estimation, or the error saying none is.
fn running(e: &mut Option<Estimation>) -> Result<&mut Estimation, SessionError> {
    e.as_mut().ok_or(SessionError::NoEstimation)
}

impl From<JournaledTellError<StoreError>> for SessionError {
    fn from(e: JournaledTellError<StoreError>) -> Self {
        match e {
            JournaledTellError::Tell(e) => SessionError::Refused(e),
            JournaledTellError::Sink(e) => SessionError::Journal(e),
        }
    }
}

impl Session {
    /// Opens a session: with a journal, started with `config` if the journal is new, else
    /// replayed (`config`, if given, must be the journal's) — what `savme serve --journal` does;
    /// without one, a plain kernel from `config`.
    pub fn open(
        config: Option<KernelConfig>,
        journal: Option<Box<dyn TrialStore>>,
    ) -> Result<Opened, OpenError> {
        match journal {
            None => {
                let config = config.ok_or(OpenError::NoConfig)?;
                Ok(Opened {
                    session: Session::Plain(Kernel::new(config)?),
                    resumed: None,
                    torn: None,
                })
            }
            Some(store) => {
                let opened = journal::open(store, config)?;
                Ok(Opened {
                    session: Session::Journaled(opened.kernel),
                    resumed: opened.resumed,
                    torn: opened.torn,
                })
            }
        }
    }

    /// The kernel (read-only: changes go through the session, so that they are journaled).
    pub fn kernel(&self) -> &Kernel {
        match self {
            Session::Plain(k) => k,
            Session::Journaled(j) => j.kernel(),
        }
    }

    /// Asks `n` trials (1 to [`MAX_BATCH`]), all or none.
    pub fn ask(&mut self, n: usize) -> Result<Vec<Trial>, SessionError> {
        if n == 0 || n > MAX_BATCH {
            return Err(SessionError::BadBatch(n));
        }
        Ok(match self {
            Session::Plain(k) => (0..n).map(|_| k.ask()).collect(),
            Session::Journaled(j) if n == 1 => vec![j.ask()?],
            Session::Journaled(j) => j.ask_batch(n)?,
        })
    }

    /// Asks one trial (as `ask(1)`, without the vector: the C ABI's hot path).
    pub fn ask_one(&mut self) -> Result<Trial, SessionError> {
        Ok(match self {
            Session::Plain(k) => k.ask(),
            Session::Journaled(j) => j.ask()?,
        })
    }

    /// Tells trial `id`'s observation ([`Kernel::tell`]).
    pub fn tell(&mut self, id: u64, observation: Observation) -> Result<TrialRecord, SessionError> {
        Ok(match self {
            Session::Plain(k) => k.tell(id, observation)?,
            Session::Journaled(j) => j.tell(id, observation)?,
        })
    }

    /// Withdraws pending trial `id` ([`Kernel::cancel`]).
    pub fn cancel(&mut self, id: u64) -> Result<Trial, SessionError> {
        Ok(match self {
            Session::Plain(k) => k.cancel(id)?,
            Session::Journaled(j) => j.cancel(id)?,
        })
    }

    /// Switches the phase of future asks ([`Kernel::set_phase`]).
    pub fn set_phase(&mut self, phase: Phase) -> Result<(), SessionError> {
        match self {
            Session::Plain(k) => k.set_phase(phase),
            Session::Journaled(j) => j.set_phase(phase)?,
        }
        Ok(())
    }

    /// Handles one request line; returns the response object. Estimation requests need the
    /// server's state: use [`Session::handle_with`] (as [`Session::serve`] does).
    pub fn handle(&mut self, line: &str) -> Value {
        self.handle_with(line, &mut None)
    }

    /// Handles one request line with `estimation`, the estimation the server is running (the
    /// `estimation…` requests start, ask, tell and read it); returns the response object.
    pub fn handle_with(&mut self, line: &str, estimation: &mut Option<Estimation>) -> Value {
        match serde_json::from_str::<Request>(line) {
            Err(e) => error(not_a_request(line, &e)),
            Ok(r) => self
                .apply(r, estimation)
                .unwrap_or_else(|e| error(e.to_string())),
        }
    }

    fn apply(
        &mut self,
        request: Request,
        estimation: &mut Option<Estimation>,
    ) -> Result<Value, SessionError> {
        match request {
            Request::Ask { n } => Ok(json!({"ok": true, "trials": self.ask(n)?})),
            Request::Tell { id, observation } => {
                Ok(json!({"ok": true, "record": self.tell(id, observation)?}))
            }
            Request::Cancel { id } => Ok(json!({"ok": true, "trial": self.cancel(id)?})),
            Request::Phase { phase } => {
                self.set_phase(phase)?;
                Ok(json!({"ok": true}))
            }
            Request::Estimate { estimator } => Ok(estimate(self.kernel(), estimator)),
            Request::Posterior {} => Ok(posterior(self.kernel())),
            Request::Pending {} => {
                let trials: Vec<_> = self.kernel().pending().cloned().collect();
                Ok(json!({"ok": true, "trials": trials}))
            }
            Request::Estimation(config) => {
                let e = self
                    .kernel()
                    .estimation(&config)
                    .map_err(SessionError::Estimation)?;
                let answer = json!({
                    "ok": true,
                    "scenarios": e.scenarios(),
                    "probabilities": e.probabilities(),
                });
                *estimation = Some(e);
                Ok(answer)
            }
            Request::EstimationAsk {} => {
                let trial = running(estimation)?.ask();
                Ok(json!({"ok": true, "trial": trial}))
            }
            Request::EstimationTell {
                id,
                failure,
                robustness,
                cost,
            } => {
                running(estimation)?
                    .tell_measured(id, failure, robustness, cost)
                    .map_err(SessionError::Estimation)?;
                Ok(json!({"ok": true}))
            }
            Request::EstimationResult {} => {
                let e = running(estimation)?;
                Ok(json!({
                    "ok": true,
                    "estimate": e.estimate(),
                    "told": e.told(),
                    "round": e.round(),
                }))
            }
            Request::LadderPlan { levels } => {
                Ok(json!({"ok": true, "plan": savme_kernel::screening::plan(&levels)}))
            }
            Request::LadderNext {
                plan,
                last,
                audited,
            } => {
                let last = match last {
                    Some(LastRun { level, .. }) if level >= plan.len() => {
                        return Err(SessionError::NoSuchLevel {
                            level,
                            levels: plan.len(),
                        })
                    }
                    l => l.map(|l| (l.level, l.failure)),
                };
                let next = savme_kernel::screening::next(&plan, last, audited);
                Ok(json!({"ok": true, "next": next}))
            }
            Request::Stats {} => {
                let k = self.kernel();
                let pending: Vec<u64> = k.pending().map(|t| t.id).collect();
                Ok(json!({
                    "ok": true,
                    "stats": k.stats(),
                    "phase": k.phase(),
                    "pending": pending,
                }))
            }
        }
    }

    /// Serves requests from `input` until it ends, writing one response line each to `output`.
    /// Blank lines are skipped; a line that is not UTF-8 gets an error response like any bad
    /// request. Only an I/O error on `input` or `output` ends it early.
    pub fn serve<R: BufRead, O: Write>(
        &mut self,
        mut input: R,
        mut output: O,
    ) -> std::io::Result<()> {
        let mut buf = Vec::new();
        let mut number = 0usize;
        let mut estimation = None;
        loop {
            buf.clear();
            if input.read_until(b'\n', &mut buf)? == 0 {
                return Ok(());
            }
            number += 1;
            let mut response = match std::str::from_utf8(&buf) {
                Ok(line) if line.trim().is_empty() => continue,
                Ok(line) => self.handle_with(line, &mut estimation),
                Err(e) => error(format!(
                    "not UTF-8 text (byte {} of the line)",
                    e.valid_up_to() + 1
                )),
            };
            if let Some(msg) = response.get("error").and_then(Value::as_str) {
                response["error"] = Value::String(format!("request line {number}: {msg}"));
            }
            serde_json::to_writer(&mut output, &response)?;
            output.write_all(b"\n")?;
            output.flush()?;
        }
    }
}

/// The answer to `estimate`: θ_LF* with the evidence behind it — the estimator used and, when
/// the kernel keeps tallies (its configuration's estimator is `evidence`), per fidelity
/// setting the chosen arm, how often the learning trials tried it and its false-alarm and
/// miss rates on HF.
fn estimate(k: &Kernel, estimator: Option<Estimator>) -> Value {
    let est = estimator.unwrap_or(k.config().estimator);
    let evidence = evidence(k.fidelity_posterior());
    let mut answer = json!({
        "ok": true,
        "theta_lf": k.fidelity_estimate(est),
        "estimator": est,
        "evidence": evidence,
        "learned": evidence > 0.0,
    });
    if let Some(settings) = chosen_settings(k, est) {
        answer["settings"] = settings;
    }
    if evidence == 0.0 {
        answer["warning"] = json!(
                "nothing has been learned yet (no credited trial and no transferred prior): this is the untrained prior's choice"
            );
    }
    answer
}

/// Per fidelity setting, θ_LF*'s arm under `est` with its tally over every scenario's learning
/// trials (`tried`, `successes`, `tp`, `tn`, `fp`, `fn`, `cost`) and its false-alarm and miss
/// rates (null without an HF pass or failure); None when the kernel keeps no tallies. What
/// `estimate` answers as `settings` and Python's `Kernel.estimate_evidence()` returns.
pub fn chosen_settings(k: &Kernel, est: Estimator) -> Option<Value> {
    let totals = k.fidelity_evidence()?.totals();
    let arms = k.fidelity_arms(est);
    let settings = k
        .config()
        .fidelity
        .variables()
        .iter()
        .zip(&arms)
        .enumerate()
        .map(|(v, (var, &arm))| {
            let tally = totals
                .get(v)
                .and_then(|t| t.get(usize::from(arm)))
                .copied()
                .unwrap_or_default();
            let mut one = json!({"variable": var.name.to_string(), "arm": arm});
            if let (Value::Object(o), Ok(Value::Object(t))) =
                (&mut one, serde_json::to_value(tally))
            {
                o.extend(t);
            }
            one["false_alarm_rate"] = json!(tally.false_alarm_rate());
            one["miss_rate"] = json!(tally.miss_rate());
            one
        })
        .collect();
    Some(Value::Array(settings))
}

/// The answer to `posterior`: the fidelity posterior and every scenario's.
fn posterior(k: &Kernel) -> Value {
    let scenarios: serde_json::Map<String, Value> = k
        .config()
        .scenarios
        .iter()
        .map(|s| {
            let p = k.scenario_posterior(&s.name);
            (s.name.to_string(), json!(p))
        })
        .collect();
    json!({
        "ok": true,
        "fidelity": k.fidelity_posterior(),
        "scenarios": scenarios,
    })
}

/// How many observations stand behind the fidelity posterior (told or transferred): the
/// evidence on its first variable beyond the prior's pseudo-counts.
pub fn evidence(p: &savme_kernel::Posterior) -> f64 {
    let prior = p.prior();
    p.arms().first().map_or(0.0, |arms| {
        arms.iter()
            .map(|a| (a.alpha - prior.successes) + (a.beta - prior.losses))
            .sum::<f64>()
            .max(0.0)
    })
}

/// Why a line is not a request, said without serde's "line 1" (the request line is named by
/// the caller) and with a hint for the usual mistakes.
fn not_a_request(line: &str, e: &serde_json::Error) -> String {
    if let Some(mistake) = serde_json::from_str::<Value>(line)
        .ok()
        .and_then(|v| mistake(&v))
    {
        return format!("not a request: {mistake}");
    }
    let text = e.to_string();
    let message = match text.find(" at line ") {
        Some(i) => format!("{} (column {})", &text[..i], e.column()),
        None => text,
    };
    let hint = if line.starts_with('\u{feff}') {
        "; the line starts with a byte-order mark: send UTF-8 without one"
    } else if ["NaN", "Infinity"].iter().any(|t| line.contains(t)) {
        "; JSON has no NaN or Infinity: every number (a runtime, epsilon, a mean) must be finite"
    } else {
        ""
    };
    format!("not a request: {message}{hint}")
}

/// The usual mistake in a line that is JSON but not a request, said plainly (serde's message
/// speaks of variant identifiers and maps with a single key).
fn mistake(v: &Value) -> Option<String> {
    let Some(request) = v.as_object() else {
        let kind = match v {
            Value::Null => "null",
            Value::Bool(_) => "a boolean",
            Value::Number(_) => "a number",
            Value::String(_) => "a string",
            _ => "an array",
        };
        return Some(format!(
            "a request is a JSON object with an \"op\" key, e.g. {{\"op\":\"ask\"}}; got {kind}"
        ));
    };
    if let Some(n) = request.get("n").filter(|n| n.as_u64().is_none()) {
        return Some(format!(
            "`n` must be a whole number between 1 and {MAX_BATCH}, got {n}"
        ));
    }
    let observation = request.get("observation").and_then(Value::as_object);
    if observation.is_some_and(|o| o.contains_key("paired") && o.contains_key("hf_only")) {
        return Some(
            "an observation is exactly one of `paired` (HF and LF runs) or `hf_only` (a baseline trial), got both"
                .into(),
        );
    }
    None
}

fn error(message: String) -> Value {
    json!({"ok": false, "error": message})
}

#[cfg(test)]
mod tests {
    use super::*;

    fn session() -> Session {
        Session::Plain(
            savme_campaign::toy::kernel_builder()
                .seed(3)
                .build()
                .unwrap(),
        )
    }

    fn run(s: &mut Session, input: &str) -> Vec<Value> {
        let mut out = Vec::new();
        s.serve(input.as_bytes(), &mut out).unwrap();
        String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    }

    /// The ladder's decisions over the protocol: the plan from each level's economy (one level
    /// is the two-level screening's), the next run; a level outside the plan is refused.
    #[test]
    fn a_ladders_plan_and_next_step_are_served() {
        let mut s = session();
        let dear_top = json!({"screened": 20, "lf_failures": 20, "direct": 0, "direct_failures": 0,
            "lf_cost": 60.0, "hf_passes": 1, "hf_pass_cost": 10.0});
        let cheap = json!({"screened": 20, "lf_failures": 2, "direct": 0, "direct_failures": 0,
            "lf_cost": 2.0, "hf_passes": 0, "hf_pass_cost": 0.0});
        let input = format!(
            "{}\n{}\n{}\n{}\n{}\n{}\n",
            json!({"op": "ladder_plan", "levels": [cheap, dear_top]}),
            json!({"op": "ladder_plan", "levels": [dear_top]}),
            json!({"op": "ladder_next", "plan": [true, false]}),
            json!({"op": "ladder_next", "plan": [true, true], "last": {"level": 0, "failure": true}}),
            json!({"op": "ladder_next", "plan": [true, true], "last": {"level": 0, "failure": false}, "audited": true}),
            json!({"op": "ladder_next", "plan": [true], "last": {"level": 1, "failure": true}}),
        );
        let r = run(&mut s, &input);
        assert_eq!(r[0]["plan"], json!([true, false]));
        let e: Economy = serde_json::from_value(dear_top).unwrap();
        assert_eq!(r[1]["plan"], json!([e.screen_pays()]));
        assert_eq!(r[2]["next"], json!({"level": 0}));
        assert_eq!(r[3]["next"], json!({"level": 1}));
        assert_eq!(r[4]["next"], "hf");
        assert_eq!(r[5]["ok"], false);
        assert!(
            r[5]["error"]
                .as_str()
                .unwrap()
                .contains("request line 6: last.level 1 is not a level of the plan (1 levels"),
            "{}",
            r[5]
        );
    }

    #[test]
    fn a_session_asks_tells_and_reports() {
        let mut s = session();
        let r = run(&mut s, "{\"op\":\"ask\",\"n\":2}\n");
        let trials = r[0]["trials"].as_array().unwrap();
        assert_eq!(trials.len(), 2);
        let id = trials[1]["id"].as_u64().unwrap();
        let tell = format!(
            "{{\"op\":\"tell\",\"id\":{id},\"observation\":{{\"paired\":{{\"hf\":{{\"failure\":true,\"runtime\":2.0}},\"lf\":{{\"failure\":true,\"runtime\":0.4}}}}}}}}\n\
             {{\"op\":\"stats\"}}\n{{\"op\":\"phase\",\"phase\":\"evaluate\"}}\n{{\"op\":\"estimate\",\"estimator\":\"mean\"}}\n{{\"op\":\"posterior\"}}\n"
        );
        let r = run(&mut s, &tell);
        assert_eq!(r[0]["record"]["outcome"], "TP");
        assert_eq!(r[0]["record"]["credit"]["fidelity"], true); // agreed, 0.4 / 2.0 ≤ 0.3
        assert_eq!(r[1]["stats"]["told"], 1);
        assert_eq!(r[1]["pending"], json!([0]));
        assert_eq!(r[2]["ok"], true);
        assert!(r[3]["theta_lf"]["rate_hz"].is_number());
        assert!(r[4]["scenarios"]["braking_lead"].is_object());
    }

    /// A multi-fidelity estimation (`pilot_fidelity` = `lf`): its pilot trials say to run at
    /// LF, the estimate's do not (HF); without `refine` it is refused, naming the setting.
    #[test]
    fn a_multi_fidelity_estimation_marks_its_pilot_trials_lf() {
        let mut s = trained();
        let input = "{\"op\":\"estimation\",\"epsilon\":0.2,\"seed\":5,\"refine\":{\"rounds\":1,\"runs\":2},\"pilot_fidelity\":\"lf\"}\n\
                     {\"op\":\"estimation_ask\"}\n{\"op\":\"estimation_ask\"}\n\
                     {\"op\":\"estimation_tell\",\"id\":0,\"failure\":true}\n\
                     {\"op\":\"estimation_tell\",\"id\":1,\"failure\":false}\n\
                     {\"op\":\"estimation_ask\"}\n\
                     {\"op\":\"estimation\",\"epsilon\":0.2,\"seed\":5,\"pilot_fidelity\":\"lf\"}\n";
        let r = run(&mut s, input);
        assert_eq!(
            (&r[1]["trial"]["fidelity"], &r[2]["trial"]["round"]),
            (&json!("lf"), &json!(0))
        );
        assert_eq!(
            r[5]["trial"]["fidelity"],
            Value::Null,
            "the estimate runs HF"
        );
        assert!(
            r[6]["error"]
                .as_str()
                .unwrap()
                .contains("pilot_fidelity: `lf` runs the cross-entropy pilot rounds"),
            "{}",
            r[6]
        );
    }

    /// Control variates (`control`): calibration pairs say which run is LF, a cost is taken
    /// with the tell, and a bad calibration is refused naming the setting.
    #[test]
    fn an_estimation_with_control_variates_pairs_its_runs() {
        let mut s = trained();
        let input = "{\"op\":\"estimation\",\"epsilon\":0.2,\"seed\":5,\"control\":{\"calibration\":4,\"extra\":1}}\n\
                     {\"op\":\"estimation_ask\"}\n{\"op\":\"estimation_ask\"}\n\
                     {\"op\":\"estimation_tell\",\"id\":0,\"failure\":true,\"cost\":1.0}\n\
                     {\"op\":\"estimation_tell\",\"id\":1,\"failure\":true,\"cost\":-0.2}\n\
                     {\"op\":\"estimation\",\"epsilon\":0.2,\"seed\":5,\"control\":{\"calibration\":1}}\n";
        let r = run(&mut s, input);
        assert_eq!(
            (&r[1]["trial"]["control"], &r[2]["trial"]["control"]),
            (&json!("calibration"), &json!("calibration"))
        );
        assert_eq!(
            (&r[1]["trial"]["fidelity"], &r[2]["trial"]["fidelity"]),
            (&Value::Null, &json!("lf"))
        );
        assert_eq!(r[3]["ok"], true);
        assert!(
            r[4]["error"]
                .as_str()
                .unwrap()
                .contains("cost must be a finite number ≥ 0, got -0.2"),
            "{}",
            r[4]
        );
        assert!(
            r[5]["error"]
                .as_str()
                .unwrap()
                .contains("control: calibration must be at least 2 pairs per scenario (2 scenarios: at least 4), got 1"),
            "{}",
            r[5]
        );
    }

    /// Trains the toy session on 60 paired trials (the failure rule: trial id divisible by 3).
    fn trained() -> Session {
        let mut s = session();
        for _ in 0..60 {
            let t = s.ask(1).unwrap().remove(0);
            let run = savme_kernel::Run::new(t.id.is_multiple_of(3), 1.0);
            let observation = Observation::Paired { hf: run, lf: run };
            s.tell(t.id, observation).unwrap();
        }
        s
    }

    /// An estimation over the protocol: started from the posteriors (the kernel unchanged),
    /// asked and told (here failing every fourth trial), its result read; with refinement,
    /// `estimation_ask` answers `null` while the round waits. Trials are those of the kernel's
    /// own `Estimation` with the same configuration.
    #[test]
    fn an_estimation_runs_over_the_protocol() {
        let mut s = trained();
        let before = s.kernel().to_json();
        let mut input = String::from("{\"op\":\"estimation\",\"epsilon\":0.2,\"seed\":5,\"refine\":{\"rounds\":1,\"runs\":4}}\n");
        // The round's 4 asks, a fifth that must wait, then the round's outcomes.
        input += &"{\"op\":\"estimation_ask\"}\n".repeat(5);
        for id in 0..4 {
            input += &format!(
                "{{\"op\":\"estimation_tell\",\"id\":{id},\"failure\":{}}}\n",
                id % 2 == 0
            );
        }
        for id in 4..40 {
            input += &format!("{{\"op\":\"estimation_ask\"}}\n{{\"op\":\"estimation_tell\",\"id\":{id},\"failure\":{}}}\n", id % 4 == 0);
        }
        input += "{\"op\":\"estimation_result\"}\n";
        let r = run(&mut s, &input);
        assert_eq!(
            r[0]["scenarios"],
            json!(["stopped_obstacle", "braking_lead"])
        );
        assert_eq!(r[0]["probabilities"], json!([0.5, 0.5]));
        assert_eq!(r[1]["trial"]["round"], 0);
        assert_eq!(
            r[5]["trial"],
            Value::Null,
            "the round waits for its outcomes"
        );
        assert!(r[6..10].iter().all(|x| x["ok"] == true));
        assert_eq!(r[10]["trial"]["round"], Value::Null);
        let last = r.last().unwrap();
        assert_eq!(
            (last["told"].as_u64(), last["estimate"]["runs"].as_u64()),
            (Some(40), Some(36))
        );
        assert_eq!(last["estimate"]["failures"], 9);
        assert_eq!(s.kernel().to_json(), before);
        // The same trials as the kernel's own estimation with that configuration.
        let config = EstimationConfig {
            refine: Some(savme_kernel::estimation::Refine {
                rounds: 1,
                runs: 4,
                reuse: 0,
            }),
            ..EstimationConfig::new(0.2, 5)
        };
        let mut e = s.kernel().estimation(&config).unwrap();
        let first = e.ask().unwrap();
        assert_eq!(json!(first), r[1]["trial"]);
    }

    #[test]
    fn estimation_requests_are_refused_naming_what_is_wrong() {
        let mut s = trained();
        let input = "{\"op\":\"estimation_ask\"}\n\
                     {\"op\":\"estimation\",\"epsilon\":0,\"seed\":1}\n\
                     {\"op\":\"estimation\",\"epsilon\":0.1,\"seed\":1,\"nominal\":{\"braking_lead\":{\"nope\":{\"distribution\":\"uniform\"}}}}\n\
                     {\"op\":\"estimation\",\"epsilon\":0.1,\"seed\":1,\"bogus\":2}\n\
                     {\"op\":\"estimation\",\"epsilon\":0.1,\"seed\":1}\n\
                     {\"op\":\"estimation_tell\",\"id\":3,\"failure\":true}\n";
        let r = run(&mut s, input);
        let err = |i: usize| r[i]["error"].as_str().unwrap().to_string();
        assert!(
            err(0).starts_with("request line 1: no estimation is running"),
            "{}",
            err(0)
        );
        assert!(
            err(1).contains(
                "epsilon (the nominal's share of the proposal) must lie in (0, 1], got 0"
            ),
            "{}",
            err(1)
        );
        assert!(
            err(2).contains("unknown variable `nope` of scenario `braking_lead`"),
            "{}",
            err(2)
        );
        assert!(err(3).contains("bogus"), "{}", err(3));
        assert_eq!(r[4]["ok"], true);
        assert!(
            err(5).contains("estimation trial 3 is not pending"),
            "{}",
            err(5)
        );
        // A joint proposal: refused without pilot rounds; with them, a tell carries the
        // run's robustness (one JSON cannot hold as a finite number is refused).
        let input = "{\"op\":\"estimation\",\"epsilon\":0.1,\"seed\":1,\"joint\":{\"components\":2}}\n\
                     {\"op\":\"estimation\",\"epsilon\":0.1,\"seed\":1,\"refine\":{\"rounds\":1,\"runs\":4},\"joint\":{\"components\":2}}\n\
                     {\"op\":\"estimation_ask\"}\n\
                     {\"op\":\"estimation_tell\",\"id\":0,\"failure\":false,\"robustness\":1e999}\n\
                     {\"op\":\"estimation_tell\",\"id\":0,\"failure\":false,\"robustness\":0.5}\n";
        let r = run(&mut s, input);
        let err = |i: usize| r[i]["error"].as_str().unwrap_or("").to_string();
        assert!(
            err(0)
                .contains("joint: the joint proposal is fitted by the cross-entropy pilot rounds"),
            "{}",
            err(0)
        );
        assert_eq!(
            (r[1]["ok"].clone(), r[2]["trial"]["id"].clone()),
            (json!(true), json!(0))
        );
        assert!(!err(3).is_empty(), "{}", r[3]);
        assert_eq!(r[4]["ok"], true, "{}", r[4]);
    }

    #[test]
    fn bad_requests_are_answered_with_the_line_and_change_nothing() {
        let mut s = session();
        let before = s.kernel().to_json();
        let input = "not json\n\n{\"op\":\"fly\"}\n{\"op\":\"ask\",\"n\":0}\n\
                     {\"op\":\"tell\",\"id\":9,\"observation\":{\"hf_only\":{\"failure\":true,\"runtime\":1}}}\n\
                     {\"op\":\"cancel\",\"id\":1}\n{\"op\":\"ask\",\"bogus\":1}\n";
        let r = run(&mut s, input);
        assert_eq!(r.len(), 6);
        for (resp, line) in r.iter().zip([1, 3, 4, 5, 6, 7]) {
            assert_eq!(resp["ok"], false);
            let msg = resp["error"].as_str().unwrap();
            assert!(msg.starts_with(&format!("request line {line}:")), "{msg}");
        }
        assert!(r[4]["error"].as_str().unwrap().contains("never asked"));
        assert_eq!(s.kernel().to_json(), before);
    }

    fn errors(s: &mut Session, input: &[u8]) -> Vec<Value> {
        let mut out = Vec::new();
        s.serve(input, &mut out).unwrap();
        String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    }

    #[test]
    fn unknown_keys_bad_bytes_and_bad_numbers_are_named_and_the_server_goes_on() {
        let mut s = session();
        let mut input = b"{\"op\":\"stats\",\"x\":1}\n{\"op\":\"posterior\",\"y\":2}\n".to_vec();
        input.extend_from_slice(b"{\"op\":\"ask\",\"\xff\":1}\n");
        input.extend_from_slice(b"{\"op\":\"tell\",\"id\":0,\"observation\":{\"hf_only\":{\"failure\":true,\"runtime\":NaN}}}\n");
        input.extend_from_slice("\u{feff}{\"op\":\"stats\"}\n".as_bytes());
        input.extend_from_slice(b"{\"op\":\"ask\",\"n\":1,\"runtme\":5}\n{\"op\":\"stats\"}\n");
        let r = errors(&mut s, &input);
        assert_eq!(r.len(), 7);
        let msg = |i: usize| r[i]["error"].as_str().unwrap_or_default().to_string();
        assert!(
            msg(0).starts_with("request line 1:") && msg(0).contains("unknown field `x`"),
            "{}",
            msg(0)
        );
        assert!(msg(1).contains("unknown field `y`"), "{}", msg(1));
        assert!(
            msg(2).starts_with("request line 3: not UTF-8 text (byte 14"),
            "{}",
            msg(2)
        );
        assert!(
            msg(3).contains("no NaN or Infinity") && !msg(3).contains("line 1"),
            "{}",
            msg(3)
        );
        assert!(msg(4).contains("byte-order mark"), "{}", msg(4));
        assert!(msg(5).contains("unknown field `runtme`"), "{}", msg(5));
        assert_eq!(r[6]["ok"], true);
        assert_eq!(r[6]["stats"]["asked"], 0);
    }

    #[test]
    fn json_that_is_no_request_is_named_plainly_and_changes_nothing() {
        let mut s = session();
        let input =
            "{\"op\":\"ask\",\"n\":18446744073709551616}\n[1,2]\nnull\n{\"op\":\"ask\",\"n\":-1}\n\
             {\"op\":\"tell\",\"id\":0,\"observation\":{\"paired\":{},\"hf_only\":{}}}\n\
             {\"op\":\"estimation\",\"epsilon\":NaN,\"seed\":1}\n{\"op\":\"stats\"}\n";
        let r = errors(&mut s, input.as_bytes());
        let msg = |i: usize| r[i]["error"].as_str().unwrap_or_default().to_string();
        for (i, needle) in [
            (0, "`n` must be a whole number between 1 and 100000, got 1.8446744073709552e+19"),
            (1, "a request is a JSON object with an \"op\" key, e.g. {\"op\":\"ask\"}; got an array"),
            (2, "got null"),
            (3, "`n` must be a whole number between 1 and 100000, got -1"),
            (4, "exactly one of `paired` (HF and LF runs) or `hf_only` (a baseline trial), got both"),
            (5, "every number (a runtime, epsilon, a mean) must be finite"),
        ] {
            assert!(msg(i).contains(needle), "{i}: {}", msg(i));
        }
        assert_eq!(r[6]["stats"]["asked"], 0);
    }

    #[test]
    fn pending_lists_every_asked_untold_trial_and_estimate_says_when_nothing_was_learned() {
        let mut s = session();
        let r = run(
            &mut s,
            "{\"op\":\"estimate\"}\n{\"op\":\"ask\",\"n\":3}\n{\"op\":\"pending\"}\n",
        );
        assert_eq!(r[0]["learned"], false);
        assert_eq!(r[0]["evidence"], 0.0);
        assert!(r[0]["warning"]
            .as_str()
            .unwrap()
            .contains("nothing has been learned"));
        assert_eq!(r[2]["trials"], r[1]["trials"]);
        let id = r[1]["trials"][0]["id"].as_u64().unwrap();
        let tell = format!("{{\"op\":\"tell\",\"id\":{id},\"observation\":{{\"paired\":{{\"hf\":{{\"failure\":true,\"runtime\":2.0}},\"lf\":{{\"failure\":true,\"runtime\":0.4}}}}}}}}\n{{\"op\":\"estimate\"}}\n{{\"op\":\"pending\"}}\n");
        let r = run(&mut s, &tell);
        assert_eq!(r[1]["learned"], true);
        assert_eq!(r[1]["evidence"], 1.0);
        assert!(r[1].get("warning").is_none());
        assert_eq!(r[2]["trials"].as_array().unwrap().len(), 2);
    }

    /// A store that refuses any write once it holds `room` lines (a full disk).
    struct Full {
        lines: Vec<String>,
        room: usize,
    }

    impl savme_store::TrialStore for Full {
        fn location(&self) -> String {
            "full".into()
        }
        fn load(&mut self) -> Result<savme_store::Loaded, StoreError> {
            Ok(Default::default())
        }
        fn append_all(&mut self, records: &[&dyn savme_store::Record]) -> Result<(), StoreError> {
            if self.lines.len() + records.len() > self.room {
                return Err(StoreError::io(
                    "full",
                    std::io::Error::other("no space left"),
                ));
            }
            for r in records {
                let object = r
                    .object()
                    .map_err(|e| StoreError::io("full", std::io::Error::other(e)))?;
                self.lines
                    .push(String::from_utf8_lossy(&object).into_owned());
            }
            Ok(())
        }
    }

    #[test]
    fn a_batch_ask_that_cannot_be_journaled_asks_nothing() {
        let config = savme_campaign::toy::kernel_builder()
            .seed(3)
            .build()
            .unwrap()
            .config()
            .clone();
        let store = Full {
            lines: Vec::new(),
            room: 11,
        };
        let opened = savme_store::journal::open(Box::new(store), Some(config)).unwrap();
        let mut s = Session::Journaled(opened.kernel);
        let r = run(
            &mut s,
            "{\"op\":\"ask\",\"n\":30}\n{\"op\":\"ask\",\"n\":10}\n{\"op\":\"pending\"}\n",
        );
        assert_eq!(r[0]["ok"], false);
        assert!(
            r[0]["error"].as_str().unwrap().contains("no space left"),
            "{}",
            r[0]
        );
        assert_eq!(r[1]["trials"].as_array().unwrap().len(), 10);
        // The refused batch left nothing pending: ids continue from 0.
        assert_eq!(r[2]["trials"][0]["id"], 0);
        assert_eq!(r[2]["trials"].as_array().unwrap().len(), 10);
    }
}

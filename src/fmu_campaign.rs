//! `savme run --config campaign.toml`: the paper's protocol on FMUs the user names, and
//! `savme fmu pack`: the bundled simulator as an FMU.
//!
//! A campaign file names the HF and LF FMUs, how runs execute (stop time, step size, failure
//! signal, cost, isolation), the fidelity space with θ_HF and the scenarios with their
//! parameters — each bound to an FMU variable by name. Every error names the file, the line and
//! the key. See `examples/fmu/campaign.toml`.

use crate::campaign::config::Overrides;
use crate::campaign::{CampaignError, Cost, OnError, Problem, Protocol};
use savme_fmu::worker::{IsolatedSimulator, WorkerInit};
use savme_fmu::{
    Binding, CostSource, Crossing, Failure, Fixed, FmuError, FmuSimulator, RunSpec, ScenarioSpec,
    StepSize,
};
use savme_kernel::{
    Assignment, Role, Scale, SimError, SimResult, Simulator, Space, Value, Variable,
};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;
use toml::Spanned;

/// A problem with a campaign file: where it is and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{file}{}{}: {message}", line.map_or(String::new(), |l| format!(", line {l}")), key.as_ref().map_or(String::new(), |k| format!(", key `{k}`")))]
pub struct ConfigError {
    /// The campaign file.
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// The key, when known.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    fmu: FmuSection,
    failure: FailureSection,
    #[serde(default)]
    campaign: CampaignSection,
    fidelity: FidelitySection,
    #[serde(rename = "scenario")]
    scenarios: Vec<ScenarioSection>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FmuSection {
    hf: Spanned<String>,
    lf: Option<Spanned<String>>,
    stop_time: f64,
    step: Spanned<StepSection>,
    #[serde(default = "yes")]
    stop_on_failure: bool,
    #[serde(default)]
    cost: Option<Spanned<String>>,
    #[serde(default)]
    isolate: bool,
    #[serde(default = "default_timeout")]
    timeout_s: f64,
    #[serde(default)]
    on_error: OnError,
}

fn yes() -> bool {
    true
}

fn default_timeout() -> f64 {
    60.0
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum StepSection {
    Fixed(f64),
    Rate { rate_of: String },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FailureSection {
    boolean: Option<Spanned<String>>,
    threshold: Option<Spanned<String>>,
    above: Option<f64>,
    below: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CampaignSection {
    #[serde(default = "one")]
    seed: u64,
    #[serde(default)]
    budgets: Option<Vec<f64>>,
    train_iterations: Option<u64>,
    eval_iterations: Option<u64>,
    test_iterations: Option<u64>,
    baseline_train_iterations: Option<u64>,
    baseline_test_iterations: Option<u64>,
    #[serde(default = "ten")]
    fidelity_bins: u32,
    #[serde(default)]
    cost: Cost,
    window: Option<usize>,
    prior_strength: Option<f64>,
    out: Option<String>,
}

impl Default for CampaignSection {
    fn default() -> Self {
        CampaignSection {
            seed: 1,
            budgets: None,
            train_iterations: None,
            eval_iterations: None,
            test_iterations: None,
            baseline_train_iterations: None,
            baseline_test_iterations: None,
            fidelity_bins: 10,
            cost: Cost::Wall,
            window: None,
            prior_strength: None,
            out: None,
        }
    }
}

fn one() -> u64 {
    1
}

fn ten() -> u32 {
    10
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FidelitySection {
    /// The paper's Table I, each setting bound to the FMU variable of the same name.
    #[serde(default)]
    paper: bool,
    #[serde(default, rename = "variable")]
    variables: Vec<Spanned<VarSection>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct VarSection {
    name: String,
    fmu: Option<Spanned<String>>,
    values: Option<Vec<toml::Value>>,
    range: Option<[f64; 2]>,
    #[serde(default = "ten")]
    bins: u32,
    #[serde(default)]
    scale: ScaleSection,
    hf: Option<toml::Value>,
}

#[derive(Debug, Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum ScaleSection {
    #[default]
    Linear,
    Log,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioSection {
    name: String,
    #[serde(default = "unit")]
    weight: f64,
    role: Spanned<String>,
    #[serde(default)]
    fixed: BTreeMap<String, Spanned<toml::Value>>,
    #[serde(rename = "phi")]
    phi: Vec<Spanned<VarSection>>,
}

fn unit() -> f64 {
    1.0
}

/// A loaded campaign: protocol, problem, how to build its simulator, and where to write.
#[derive(Debug)]
pub struct Campaign {
    /// The protocol.
    pub protocol: Protocol,
    /// The spaces.
    pub problem: Problem,
    /// What the worker processes (or the in-process simulator) are built from.
    pub init: WorkerInit,
    /// Run each evaluation in a worker process.
    pub isolate: bool,
    /// Per-run timeout with isolation.
    pub timeout: Duration,
    /// The output directory named in the file (relative to it), if any.
    pub out: Option<PathBuf>,
}

fn toml_value(v: &toml::Value) -> Option<Value> {
    Some(match v {
        toml::Value::Boolean(b) => Value::Bool(*b),
        toml::Value::Integer(i) => Value::Int(*i),
        toml::Value::Float(f) => Value::Real(*f),
        toml::Value::String(s) => Value::from(s.as_str()),
        _ => return None,
    })
}

/// The 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

impl Campaign {
    /// [`Campaign::load`], then the command line's protocol values over the file's, validated.
    pub fn load_with(path: &Path, o: &Overrides) -> Result<Campaign, String> {
        let mut c = Campaign::load(path).map_err(|e| e.to_string())?;
        if o.any() {
            let known = c
                .problem
                .scenarios
                .keys()
                .cloned()
                .collect::<Vec<_>>()
                .join(", ");
            let scenarios = &c.problem.scenarios;
            let lookup = |k: &str| scenarios.contains_key(k).then(|| k.to_string());
            o.apply(&mut c.protocol, &lookup, &known)
                .and_then(|()| c.protocol.validate())
                .map_err(|e| e.to_string())?;
        }
        Ok(c)
    }

    /// Reads and checks `path`: the TOML, then the FMUs (opened, every binding and signal
    /// type-checked against both).
    pub fn load(path: &Path) -> Result<Campaign, ConfigError> {
        let file = path.display().to_string();
        let err = |line: Option<usize>, key: Option<&str>, message: String| ConfigError {
            file: file.clone(),
            line,
            key: key.map(String::from),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(None, None, e.to_string()))?;
        let at = |span: std::ops::Range<usize>| Some(line_of(&text, span.start));
        let f: File = toml::from_str(&text).map_err(|e| {
            let line = e.span().map(|s| line_of(&text, s.start));
            err(line, None, e.message().to_string())
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        let resolve = |p: &str| -> PathBuf {
            let p = Path::new(p);
            if p.is_absolute() {
                p.to_path_buf()
            } else {
                base.join(p)
            }
        };
        // Where each FMU variable name came from, to point at the line of a mapping error.
        let mut origins: Vec<(String, usize, String)> = Vec::new();
        // The FMU variable a savme variable binds to (its `fmu` key, else its own name),
        // remembered with its line and key.
        let fmu_name = |v: &VarSection,
                        line: Option<usize>,
                        key: &str,
                        origins: &mut Vec<(String, usize, String)>| {
            let name = v
                .fmu
                .as_ref()
                .map_or(v.name.clone(), |s| s.get_ref().clone());
            let at = v
                .fmu
                .as_ref()
                .map_or(line.unwrap_or(0), |s| line_of(&text, s.span().start));
            origins.push((name.clone(), at, key.to_string()));
            name
        };

        // Fidelity space and θ_HF.
        let (fidelity, theta_hf, fidelity_bindings) = if f.fidelity.paper {
            if !f.fidelity.variables.is_empty() {
                return Err(err(
                    None,
                    Some("fidelity.variable"),
                    "give either `paper = true` or variables, not both".into(),
                ));
            }
            let space = savme_sim::fidelity::space(f.campaign.fidelity_bins);
            let bindings = space
                .variables()
                .iter()
                .map(|v| Binding {
                    variable: v.name.to_string(),
                    fmu_variable: v.name.to_string(),
                    labels: savme_fmu::simulator::labels_of(&space, &v.name),
                })
                .collect();
            (space, savme_sim::fidelity::theta_hf(), bindings)
        } else {
            let mut vars = Vec::new();
            let mut hf = Assignment::new();
            let mut bindings = Vec::new();
            for (k, sv) in f.fidelity.variables.iter().enumerate() {
                let key = format!("fidelity.variable[{k}]");
                let line = at(sv.span());
                let v = sv.get_ref();
                let var = variable(v).map_err(|m| err(line, Some(&key), m))?;
                let hf_value = v.hf.as_ref().and_then(toml_value).ok_or_else(|| {
                    err(
                        line,
                        Some(&format!("{key}.hf")),
                        "θ_HF value missing or not a number/boolean/string".into(),
                    )
                })?;
                hf.set(&v.name, hf_value);
                let fmu = fmu_name(v, line, &format!("{key}.fmu"), &mut origins);
                bindings.push((v.name.clone(), fmu));
                vars.push(var);
            }
            let space = Space::new(vars).map_err(|e| err(None, Some("fidelity"), e.to_string()))?;
            space
                .arms_of(&hf)
                .map_err(|e| err(None, Some("fidelity.variable.hf"), format!("θ_HF: {e}")))?;
            let bindings = bindings
                .into_iter()
                .map(|(name, fmu)| Binding {
                    labels: savme_fmu::simulator::labels_of(&space, &name),
                    variable: name,
                    fmu_variable: fmu,
                })
                .collect();
            (space, hf, bindings)
        };

        // Scenarios.
        let mut scenarios = BTreeMap::new();
        let mut specs = Vec::new();
        let (mut train, mut test, mut weights) = (Vec::new(), Vec::new(), BTreeMap::new());
        for (k, s) in f.scenarios.iter().enumerate() {
            let key = format!("scenario[{k}]");
            if scenarios.contains_key(&s.name) {
                return Err(err(
                    None,
                    Some(&format!("{key}.name")),
                    format!("scenario `{}` is defined twice", s.name),
                ));
            }
            match s.role.get_ref().as_str() {
                "train" => train.push(s.name.clone()),
                "test" => test.push(s.name.clone()),
                other => {
                    return Err(err(
                        at(s.role.span()),
                        Some(&format!("{key}.role")),
                        format!("`{other}`: expected \"train\" or \"test\""),
                    ))
                }
            }
            if s.weight != 1.0 {
                weights.insert(s.name.clone(), s.weight);
            }
            let mut vars = Vec::new();
            let mut phi = Vec::new();
            for (j, sv) in s.phi.iter().enumerate() {
                let pkey = format!("{key}.phi[{j}]");
                let line = at(sv.span());
                let v = sv.get_ref();
                vars.push(variable(v).map_err(|m| err(line, Some(&pkey), m))?);
                let fmu = fmu_name(v, line, &format!("{pkey}.fmu"), &mut origins);
                phi.push(Binding {
                    variable: v.name.clone(),
                    fmu_variable: fmu,
                    labels: None,
                });
            }
            let space = Space::new(vars).map_err(|e| err(None, Some(&key), e.to_string()))?;
            let mut fixed = Vec::new();
            for (name, v) in &s.fixed {
                let value = toml_value(v.get_ref()).ok_or_else(|| {
                    err(
                        at(v.span()),
                        Some(&format!("{key}.fixed.{name}")),
                        "expected a number, boolean or string".into(),
                    )
                })?;
                origins.push((
                    name.clone(),
                    line_of(&text, v.span().start),
                    format!("{key}.fixed.{name}"),
                ));
                fixed.push(Fixed {
                    fmu_variable: name.clone(),
                    value,
                });
            }
            scenarios.insert(s.name.clone(), space);
            specs.push(ScenarioSpec {
                name: s.name.clone(),
                phi,
                fixed,
            });
        }

        // How runs execute.
        let step = match f.fmu.step.get_ref() {
            StepSection::Fixed(h) => StepSize::Fixed(*h),
            StepSection::Rate { rate_of } => {
                if fidelity.variable(rate_of).is_none() {
                    return Err(err(
                        at(f.fmu.step.span()),
                        Some("fmu.step.rate_of"),
                        format!("`{rate_of}` is not a fidelity variable"),
                    ));
                }
                StepSize::RateOf(rate_of.clone())
            }
        };
        let failure = match (&f.failure.boolean, &f.failure.threshold, f.failure.above, f.failure.below) {
            (Some(b), None, None, None) => {
                origins.push((b.get_ref().clone(), line_of(&text, b.span().start), "failure.boolean".into()));
                Failure::Boolean { variable: b.get_ref().clone() }
            }
            (None, Some(t), Some(v), None) | (None, Some(t), None, Some(v)) => {
                origins.push((t.get_ref().clone(), line_of(&text, t.span().start), "failure.threshold".into()));
                Failure::Threshold {
                    variable: t.get_ref().clone(),
                    when: if f.failure.above.is_some() { Crossing::Above } else { Crossing::Below },
                    value: v,
                }
            }
            _ => {
                return Err(err(
                    None,
                    Some("failure"),
                    "give `boolean = \"output\"`, or `threshold = \"output\"` with one of `above` / `below`".into(),
                ))
            }
        };
        let cost = match &f.fmu.cost {
            None => CostSource::Wall,
            Some(c) if c.get_ref() == "wall" => CostSource::Wall,
            Some(c) => {
                origins.push((
                    c.get_ref().clone(),
                    line_of(&text, c.span().start),
                    "fmu.cost".into(),
                ));
                CostSource::Output(c.get_ref().clone())
            }
        };
        let spec = RunSpec {
            stop_time: f.fmu.stop_time,
            step,
            failure,
            stop_on_failure: f.fmu.stop_on_failure,
            cost,
            fidelity: fidelity_bindings,
            scenarios: specs,
        };
        let hf_path = resolve(f.fmu.hf.get_ref());
        let lf_path = f
            .fmu
            .lf
            .as_ref()
            .map_or(hf_path.clone(), |l| resolve(l.get_ref()));
        let init = WorkerInit {
            hf: hf_path.clone(),
            lf: lf_path.clone(),
            spec,
            fidelity: Some(fidelity.clone()),
            phi: scenarios.clone(),
            theta_hf: Some(theta_hf.clone()),
        };
        // Open both FMUs and check every binding now, naming the line of a bad variable.
        init.simulator().map_err(|e| {
            let (line, key) = match &e {
                FmuError::UnknownVariable { variable, .. }
                | FmuError::WrongType { variable, .. }
                | FmuError::WrongCausality { variable, .. } => origins
                    .iter()
                    .find(|(n, _, _)| n == variable)
                    .map_or((None, None), |(_, l, k)| (Some(*l), Some(k.as_str()))),
                FmuError::Spec(_) => (None, Some("fmu")),
                _ => {
                    let span = if f
                        .fmu
                        .lf
                        .as_ref()
                        .is_some_and(|l| e.to_string().contains(l.get_ref().as_str()))
                    {
                        f.fmu.lf.as_ref().map(|l| l.span())
                    } else {
                        Some(f.fmu.hf.span())
                    };
                    (
                        span.map(|s| line_of(&text, s.start)),
                        Some("fmu.hf / fmu.lf"),
                    )
                }
            };
            err(line, key, e.to_string())
        })?;

        let c = &f.campaign;
        let label = format!("fmu:{}|{}", hf_path.display(), lf_path.display());
        let mut protocol = Protocol::paper(&label, train, test);
        protocol.seed = c.seed;
        if let Some(b) = &c.budgets {
            protocol.budgets = b.clone();
        }
        let set = |slot: &mut u64, v: Option<u64>| {
            if let Some(v) = v {
                *slot = v;
            }
        };
        set(&mut protocol.train_iterations, c.train_iterations);
        set(&mut protocol.eval_iterations, c.eval_iterations);
        set(&mut protocol.test_iterations, c.test_iterations);
        set(
            &mut protocol.baseline_train_iterations,
            c.baseline_train_iterations,
        );
        set(
            &mut protocol.baseline_test_iterations,
            c.baseline_test_iterations,
        );
        protocol.fidelity_bins = c.fidelity_bins;
        protocol.cost = c.cost;
        if let Some(w) = c.window {
            protocol.window = w;
        }
        if let Some(s) = c.prior_strength {
            protocol.prior_strength = s;
        }
        protocol.weights = weights;
        protocol.on_error = f.fmu.on_error;
        protocol.validate().map_err(|e| match e {
            CampaignError::Protocol { field, message } => {
                let key = match field.as_str() {
                    "train_scenarios" | "test_scenarios" => "scenario.role".to_string(),
                    "weights" => "scenario.weight".to_string(),
                    other => format!("campaign.{other}"),
                };
                err(None, Some(&key), message)
            }
            other => err(None, None, other.to_string()),
        })?;
        if !(f.fmu.timeout_s > 0.0 && f.fmu.timeout_s.is_finite()) {
            return Err(err(None, Some("fmu.timeout_s"), "must be positive".into()));
        }
        Ok(Campaign {
            protocol,
            problem: Problem {
                fidelity,
                theta_hf,
                scenarios,
            },
            init,
            isolate: f.fmu.isolate,
            timeout: Duration::from_secs_f64(f.fmu.timeout_s),
            out: c.out.as_ref().map(|o| resolve(o)),
        })
    }
}

/// A savme variable from its TOML section.
fn variable(v: &VarSection) -> Result<Variable, String> {
    match (&v.values, v.range) {
        (Some(values), None) => {
            let values: Option<Vec<Value>> = values.iter().map(toml_value).collect();
            let values = values.ok_or("`values` must be numbers, booleans or strings")?;
            if values.is_empty() {
                return Err("`values` is empty".into());
            }
            Ok(Variable::discrete(&v.name, values))
        }
        (None, Some([lo, hi])) => {
            if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
                return Err(format!("`range` = [{lo}, {hi}] is empty"));
            }
            if v.bins == 0 {
                return Err("`bins` must be at least 1".into());
            }
            let scale = match v.scale {
                ScaleSection::Linear => Scale::Linear,
                ScaleSection::Log if lo > 0.0 => Scale::Log,
                ScaleSection::Log => {
                    return Err(format!("a log scale needs 0 < lo (range [{lo}, {hi}])"))
                }
            };
            Ok(Variable::continuous(&v.name, lo, hi, v.bins, scale))
        }
        _ => Err("give either `values` (discrete) or `range` (continuous)".into()),
    }
}

/// The simulator a campaign runs on: in-process, or in worker processes.
#[derive(Debug, Clone)]
pub enum FmuBackend {
    /// In this process.
    InProcess(FmuSimulator),
    /// In `savme fmu-worker` child processes.
    Isolated(IsolatedSimulator),
}

impl Simulator for FmuBackend {
    fn simulate(
        &mut self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        match self {
            FmuBackend::InProcess(s) => s.simulate(scenario, phi, fidelity),
            FmuBackend::Isolated(s) => s.simulate(scenario, phi, fidelity),
        }
    }

    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        match self {
            FmuBackend::InProcess(s) => s.simulate_as(role, scenario, phi, fidelity),
            FmuBackend::Isolated(s) => s.simulate_as(role, scenario, phi, fidelity),
        }
    }
}

impl FmuBackend {
    /// The campaign's simulator: in this process, or (`isolate = true`) in `savme fmu-worker`
    /// child processes of this executable.
    pub fn new(c: &Campaign) -> Result<FmuBackend, String> {
        if c.isolate {
            let exe = std::env::current_exe()
                .map_err(|e| format!("cannot find the savme binary for the FMU workers: {e}"))?;
            let worker = vec![exe.display().to_string(), "fmu-worker".into()];
            IsolatedSimulator::new(worker, &c.init, c.timeout)
                .map(FmuBackend::Isolated)
                .map_err(|e| e.to_string())
        } else {
            c.init
                .simulator()
                .map(FmuBackend::InProcess)
                .map_err(|e| e.to_string())
        }
    }
}

//! The TOML campaign file of `savme run --config`: which FMUs, how runs execute, the fidelity
//! space with θ_HF and the scenarios — every savme variable bound to an FMU variable by name.
//!
//! [`CampaignFile::load`] reads and checks a file: the TOML (syntax, unknown keys, types), the
//! spaces, the run specification, then both FMUs (opened, every binding and signal type-checked
//! against both). Every error is a [`ConfigError`] naming the file and, where known, the line and
//! the key — also for an FMU variable that does not fit, by remembering where each FMU variable
//! name came from. The `[campaign]` section is protocol data: it comes back as written
//! ([`CampaignSection`], with the line of each key) for the caller to apply and validate.
//!
//! ```toml
//! [fmu]
//! hf = "hf.fmu"                  # paths relative to the campaign file
//! lf = "lf.fmu"                  # optional: the HF FMU with other settings
//! stop_time = 12.0
//! step = { rate_of = "rate" }    # or a fixed step: step = 0.1
//! stop_on_failure = true         # default true
//! cost = "wall"                  # or the name of an output counting work units
//! isolate = false                # run every evaluation in a worker process
//! timeout_s = 60.0               # per run, with isolation
//! on_error = "abort"             # or "skip"
//!
//! [failure]
//! boolean = "collision"          # or: threshold = "distance" with above = … / below = …
//!
//! [campaign]                     # optional; every key optional (see CampaignSection)
//! budgets = [0.3]
//!
//! [fidelity]                     # paper = true, or variables:
//! [[fidelity.variable]]
//! name = "rate"                  # bound to the FMU variable `rate` unless fmu = "…"
//! values = [2, 4, 10]            # or range = [lo, hi], bins = 10, scale = "linear" | "log"
//! hf = 10                        # θ_HF
//!
//! [[scenario]]
//! name = "cut_in"
//! role = "train"                 # or "test"
//! weight = 1.0                   # p(s) weight, default 1
//! fixed = { scenario = 5 }       # FMU parameters set for every run of this scenario
//! [[scenario.phi]]
//! name = "gap"
//! range = [2.0, 8.0]
//! ```

use crate::worker::WorkerInit;
use crate::{
    Binding, CostSource, Crossing, Failure, Fixed, FmuError, RunSpec, ScenarioSpec, StepSize,
};
use raw::{FmuSection, ScaleSection, StepSection, VarSection};
use savme_kernel::{Assignment, Scale, Space, Value, Variable};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Duration;
use toml::Spanned;

/// A problem with a campaign file: where it is and what is wrong. Displayed as
/// ``FILE, line N, key `K`: message`` (line and key when known).
///
/// ```
/// use savme_fmu::campaign_file::ConfigError;
/// let e = ConfigError {
///     file: "campaign.toml".into(),
///     line: Some(12),
///     key: Some("campaign.budgets".into()),
///     message: "1.3 is outside (0, 1]".into(),
/// };
/// assert_eq!(
///     e.to_string(),
///     "campaign.toml, line 12, key `campaign.budgets`: 1.3 is outside (0, 1]"
/// );
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
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

/// The cost measure `[campaign] cost` names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Cost {
    /// `"wall"`: measured wall-clock seconds.
    #[default]
    Wall,
    /// `"work"`: work units (the output `[fmu] cost` names, or the step count).
    Work,
}

/// The `[campaign]` section as written: the protocol's settings, every one optional (the caller
/// supplies the defaults and validates the values).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CampaignSection {
    /// `seed`.
    pub seed: Option<u64>,
    /// `budgets`.
    pub budgets: Option<Vec<f64>>,
    /// `train_iterations`.
    pub train_iterations: Option<u64>,
    /// `eval_iterations`.
    pub eval_iterations: Option<u64>,
    /// `test_iterations`.
    pub test_iterations: Option<u64>,
    /// `baseline_train_iterations`.
    pub baseline_train_iterations: Option<u64>,
    /// `baseline_test_iterations`.
    pub baseline_test_iterations: Option<u64>,
    /// `fidelity_bins` (for `[fidelity] paper = true` the parser has used it, default 10).
    pub fidelity_bins: Option<u32>,
    /// `cost`.
    pub cost: Option<Cost>,
    /// `window`.
    pub window: Option<usize>,
    /// `prior_strength`.
    pub prior_strength: Option<f64>,
    /// `out`, resolved relative to the campaign file.
    pub out: Option<PathBuf>,
    /// The 1-based line of each key given (`"budgets"` → 12), to name the line of an error
    /// found in a value later.
    pub lines: BTreeMap<String, usize>,
}

/// A campaign file, read and checked against its FMUs.
#[derive(Debug, Clone)]
pub struct CampaignFile {
    /// The file.
    pub path: PathBuf,
    /// What the simulator (in-process or in workers) is built from: the FMU paths (resolved
    /// relative to the file), the run specification, the spaces and θ_HF.
    pub init: WorkerInit,
    /// `[fmu] isolate`: run each evaluation in a worker process.
    pub isolate: bool,
    /// `[fmu] timeout_s`: per-run timeout with isolation (default 60 s).
    pub timeout: Duration,
    /// `[fmu] on_error = "skip"` (true) or `"abort"` (false, the default).
    pub skip_failed_runs: bool,
    /// The fidelity space.
    pub fidelity: Space,
    /// θ_HF.
    pub theta_hf: Assignment,
    /// Each scenario's φ-space.
    pub scenarios: BTreeMap<String, Space>,
    /// The meta-training scenarios (role `"train"`), in file order.
    pub train: Vec<String>,
    /// The meta-testing scenarios (role `"test"`), in file order.
    pub test: Vec<String>,
    /// Scenario weights other than 1.
    pub weights: BTreeMap<String, f64>,
    /// The `[campaign]` section.
    pub campaign: CampaignSection,
    /// `fmu:<hf path>|<lf path>`: which simulator ran the trials.
    pub label: String,
}

impl CampaignFile {
    /// Reads and checks `path`: the TOML, then the FMUs (opened, every binding and signal
    /// type-checked against both). `paper(bins)` gives the fidelity space and θ_HF of
    /// `[fidelity] paper = true` (called with `[campaign] fidelity_bins`, at least 1), each
    /// setting bound to the FMU variable of its name.
    ///
    /// ```no_run
    /// use savme_fmu::campaign_file::CampaignFile;
    /// use savme_kernel::{Assignment, Space, Variable};
    ///
    /// // The caller's "paper" fidelity table (savme passes the bundled simulator's Table I).
    /// let file = CampaignFile::load("campaign.toml".as_ref(), &|_bins| {
    ///     let space = Space::new(vec![Variable::discrete("rate_hz", [2, 10])]).expect("valid");
    ///     (space, Assignment::new().with("rate_hz", 10))
    /// })?;
    /// println!("{}: {} scenarios", file.label, file.scenarios.len());
    /// # Ok::<(), savme_fmu::campaign_file::ConfigError>(())
    /// ```
    pub fn load(
        path: &Path,
        paper: &dyn Fn(u32) -> (Space, Assignment),
    ) -> Result<CampaignFile, ConfigError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
            file: file.clone(),
            line: None,
            key: None,
            message: e.to_string(),
        })?;
        let src = Source { file, text: &text };
        let f = src.parse()?;
        let base = path.parent().unwrap_or(Path::new("."));
        let campaign = campaign_section(&src, f.campaign, base);
        let mut origins = Origins::default();
        let fidelity = fidelity(&src, &f.fidelity, &campaign, paper, &mut origins)?;
        let scenarios = scenarios(&src, &f.scenarios, &mut origins)?;
        let step = step(&src, &f.fmu.step, &fidelity.space)?;
        let failure = failure(&src, &f.failure, &mut origins)?;
        let cost = cost_source(&src, f.fmu.cost.as_ref(), &mut origins);
        let hf = resolve(base, f.fmu.hf.get_ref());
        let lf = f
            .fmu
            .lf
            .as_ref()
            .map_or(hf.clone(), |l| resolve(base, l.get_ref()));
        let init = WorkerInit {
            hf,
            lf,
            spec: RunSpec {
                stop_time: f.fmu.stop_time,
                step,
                failure,
                stop_on_failure: f.fmu.stop_on_failure,
                cost,
                fidelity: fidelity.bindings,
                scenarios: scenarios.specs,
            },
            fidelity: Some(fidelity.space.clone()),
            phi: scenarios.spaces.clone(),
            theta_hf: Some(fidelity.theta_hf.clone()),
        };
        check_fmus(&src, &init, &f.fmu, &origins)?;
        let timeout = timeout(&src, f.fmu.timeout_s.as_ref())?;
        Ok(CampaignFile {
            path: path.to_path_buf(),
            label: format!("fmu:{}|{}", init.hf.display(), init.lf.display()),
            init,
            isolate: f.fmu.isolate,
            timeout,
            skip_failed_runs: f.fmu.on_error == raw::OnError::Skip,
            fidelity: fidelity.space,
            theta_hf: fidelity.theta_hf,
            scenarios: scenarios.spaces,
            train: scenarios.train,
            test: scenarios.test,
            weights: scenarios.weights,
            campaign,
        })
    }
}

/// The file as serde reads it. Keep the type names: serde names some of them in its messages
/// (e.g. "untagged enum StepSection").
mod raw {
    use super::Cost;
    use serde::Deserialize;
    use std::collections::BTreeMap;
    use toml::Spanned;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct File {
        pub fmu: FmuSection,
        pub failure: FailureSection,
        #[serde(default)]
        pub campaign: CampaignSection,
        pub fidelity: FidelitySection,
        #[serde(rename = "scenario")]
        pub scenarios: Vec<ScenarioSection>,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct FmuSection {
        pub hf: Spanned<String>,
        pub lf: Option<Spanned<String>>,
        pub stop_time: f64,
        pub step: Spanned<StepSection>,
        #[serde(default = "yes")]
        pub stop_on_failure: bool,
        #[serde(default)]
        pub cost: Option<Spanned<String>>,
        #[serde(default)]
        pub isolate: bool,
        pub timeout_s: Option<Spanned<f64>>,
        #[serde(default)]
        pub on_error: OnError,
    }

    fn yes() -> bool {
        true
    }

    #[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq, Eq)]
    #[serde(rename_all = "lowercase")]
    pub enum OnError {
        #[default]
        Abort,
        Skip,
    }

    #[derive(Debug, Deserialize)]
    #[serde(untagged)]
    pub enum StepSection {
        Fixed(f64),
        Rate { rate_of: String },
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct FailureSection {
        pub boolean: Option<Spanned<String>>,
        pub threshold: Option<Spanned<String>>,
        pub above: Option<f64>,
        pub below: Option<f64>,
    }

    #[derive(Debug, Default, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct CampaignSection {
        pub seed: Option<Spanned<u64>>,
        pub budgets: Option<Spanned<Vec<f64>>>,
        pub train_iterations: Option<Spanned<u64>>,
        pub eval_iterations: Option<Spanned<u64>>,
        pub test_iterations: Option<Spanned<u64>>,
        pub baseline_train_iterations: Option<Spanned<u64>>,
        pub baseline_test_iterations: Option<Spanned<u64>>,
        pub fidelity_bins: Option<Spanned<u32>>,
        pub cost: Option<Spanned<Cost>>,
        pub window: Option<Spanned<usize>>,
        pub prior_strength: Option<Spanned<f64>>,
        pub out: Option<Spanned<String>>,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct FidelitySection {
        /// The paper's Table I, each setting bound to the FMU variable of the same name.
        #[serde(default)]
        pub paper: bool,
        #[serde(default, rename = "variable")]
        pub variables: Vec<Spanned<VarSection>>,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct VarSection {
        pub name: String,
        pub fmu: Option<Spanned<String>>,
        pub values: Option<Vec<toml::Value>>,
        pub range: Option<[f64; 2]>,
        #[serde(default = "ten")]
        pub bins: u32,
        #[serde(default)]
        pub scale: ScaleSection,
        pub hf: Option<toml::Value>,
    }

    fn ten() -> u32 {
        10
    }

    #[derive(Debug, Deserialize, Default, Clone, Copy)]
    #[serde(rename_all = "lowercase")]
    pub enum ScaleSection {
        #[default]
        Linear,
        Log,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct ScenarioSection {
        pub name: Spanned<String>,
        #[serde(default = "unit")]
        pub weight: f64,
        pub role: Spanned<String>,
        #[serde(default)]
        pub fixed: BTreeMap<String, Spanned<toml::Value>>,
        #[serde(rename = "phi")]
        pub phi: Vec<Spanned<VarSection>>,
    }

    fn unit() -> f64 {
        1.0
    }
}

/// The file's name and text: turns spans into lines and builds errors.
struct Source<'a> {
    file: String,
    text: &'a str,
}

impl Source<'_> {
    /// The 1-based line of a span's start.
    fn line(&self, span: Range<usize>) -> usize {
        line_of(self.text, span.start)
    }

    fn err(
        &self,
        line: Option<usize>,
        key: Option<&str>,
        message: impl Into<String>,
    ) -> ConfigError {
        ConfigError {
            file: self.file.clone(),
            line,
            key: key.map(String::from),
            message: message.into(),
        }
    }

    /// The TOML, deserialised; a syntax or type error names its line.
    fn parse(&self) -> Result<raw::File, ConfigError> {
        toml::from_str(self.text).map_err(|e| {
            let line = e.span().map(|s| self.line(s));
            self.err(line, None, e.message())
        })
    }
}

/// The 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// `p` relative to the campaign file's directory, unless absolute.
fn resolve(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// Where each FMU variable name came from: its line and key, to point at the line of a mapping
/// error the FMU check reports by variable name.
#[derive(Debug, Default)]
struct Origins(Vec<(String, usize, String)>);

impl Origins {
    fn add(&mut self, fmu_variable: &str, line: usize, key: impl Into<String>) {
        self.0.push((fmu_variable.to_string(), line, key.into()));
    }

    /// The line and key of the first binding of `fmu_variable`.
    fn of(&self, fmu_variable: &str) -> Option<(usize, &str)> {
        self.0
            .iter()
            .find(|(n, _, _)| n == fmu_variable)
            .map(|(_, l, k)| (*l, k.as_str()))
    }
}

/// The FMU variable a savme variable binds to (its `fmu` key, else its own name), remembered
/// with its line (the `fmu` key's, else the variable's) and key.
fn bind(src: &Source, v: &VarSection, line: usize, key: &str, origins: &mut Origins) -> String {
    let (name, at) = match &v.fmu {
        Some(f) => (f.get_ref().clone(), src.line(f.span())),
        None => (v.name.clone(), line),
    };
    origins.add(&name, at, key);
    name
}

/// The `[campaign]` section without its spans, `out` resolved.
fn campaign_section(src: &Source, c: raw::CampaignSection, base: &Path) -> CampaignSection {
    let mut lines = BTreeMap::new();
    let mut take = |key: &str, span: Option<Range<usize>>| {
        if let Some(span) = span {
            lines.insert(key.to_string(), src.line(span));
        }
    };
    macro_rules! field {
        ($name:ident) => {{
            take(stringify!($name), c.$name.as_ref().map(Spanned::span));
            c.$name.map(Spanned::into_inner)
        }};
    }
    let out = field!(out);
    CampaignSection {
        seed: field!(seed),
        budgets: field!(budgets),
        train_iterations: field!(train_iterations),
        eval_iterations: field!(eval_iterations),
        test_iterations: field!(test_iterations),
        baseline_train_iterations: field!(baseline_train_iterations),
        baseline_test_iterations: field!(baseline_test_iterations),
        fidelity_bins: field!(fidelity_bins),
        cost: field!(cost),
        window: field!(window),
        prior_strength: field!(prior_strength),
        out: out.map(|o| resolve(base, &o)),
        lines,
    }
}

/// The fidelity space, θ_HF and the fidelity bindings.
struct FidelityParts {
    space: Space,
    theta_hf: Assignment,
    bindings: Vec<Binding>,
}

fn fidelity(
    src: &Source,
    f: &raw::FidelitySection,
    campaign: &CampaignSection,
    paper: &dyn Fn(u32) -> (Space, Assignment),
    origins: &mut Origins,
) -> Result<FidelityParts, ConfigError> {
    if !f.paper {
        return listed_fidelity(src, &f.variables, origins);
    }
    if let Some(first) = f.variables.first() {
        return Err(src.err(
            Some(src.line(first.span())),
            Some("fidelity.variable"),
            "give either `paper = true` or variables, not both",
        ));
    }
    let bins = campaign.fidelity_bins.unwrap_or(10);
    if bins == 0 {
        return Err(src.err(
            campaign.lines.get("fidelity_bins").copied(),
            Some("campaign.fidelity_bins"),
            "must be at least 1",
        ));
    }
    let (space, theta_hf) = paper(bins);
    let bindings = space
        .variables()
        .iter()
        .map(|v| Binding {
            variable: v.name.to_string(),
            fmu_variable: v.name.to_string(),
            labels: crate::simulator::labels_of(&space, &v.name),
        })
        .collect();
    Ok(FidelityParts {
        space,
        theta_hf,
        bindings,
    })
}

/// `[[fidelity.variable]]`: each variable with its θ_HF value and FMU binding.
fn listed_fidelity(
    src: &Source,
    variables: &[Spanned<VarSection>],
    origins: &mut Origins,
) -> Result<FidelityParts, ConfigError> {
    let mut vars = Vec::new();
    let mut theta_hf = Assignment::new();
    let mut bound = Vec::new();
    for (k, sv) in variables.iter().enumerate() {
        let key = format!("fidelity.variable[{k}]");
        let line = src.line(sv.span());
        let v = sv.get_ref();
        let var = variable(v).map_err(|m| src.err(Some(line), Some(&key), m))?;
        let hf = v.hf.as_ref().and_then(toml_value).ok_or_else(|| {
            src.err(
                Some(line),
                Some(&format!("{key}.hf")),
                "θ_HF value missing or not a number/boolean/string",
            )
        })?;
        theta_hf.set(&v.name, hf);
        let fmu = bind(src, v, line, &format!("{key}.fmu"), origins);
        bound.push((v.name.clone(), fmu));
        vars.push(var);
    }
    let space = Space::new(vars).map_err(|e| src.err(None, Some("fidelity"), e.to_string()))?;
    space
        .arms_of(&theta_hf)
        .map_err(|e| src.err(None, Some("fidelity.variable.hf"), format!("θ_HF: {e}")))?;
    let bindings = bound
        .into_iter()
        .map(|(name, fmu)| Binding {
            labels: crate::simulator::labels_of(&space, &name),
            variable: name,
            fmu_variable: fmu,
        })
        .collect();
    Ok(FidelityParts {
        space,
        theta_hf,
        bindings,
    })
}

/// The scenarios: spaces, run specifications, roles and weights.
#[derive(Default)]
struct ScenarioParts {
    spaces: BTreeMap<String, Space>,
    specs: Vec<ScenarioSpec>,
    train: Vec<String>,
    test: Vec<String>,
    weights: BTreeMap<String, f64>,
}

fn scenarios(
    src: &Source,
    list: &[raw::ScenarioSection],
    origins: &mut Origins,
) -> Result<ScenarioParts, ConfigError> {
    let mut parts = ScenarioParts::default();
    for (k, s) in list.iter().enumerate() {
        let key = format!("scenario[{k}]");
        let name = s.name.get_ref();
        if parts.spaces.contains_key(name) {
            return Err(src.err(
                Some(src.line(s.name.span())),
                Some(&format!("{key}.name")),
                format!("scenario `{name}` is defined twice"),
            ));
        }
        match s.role.get_ref().as_str() {
            "train" => parts.train.push(name.clone()),
            "test" => parts.test.push(name.clone()),
            other => {
                return Err(src.err(
                    Some(src.line(s.role.span())),
                    Some(&format!("{key}.role")),
                    format!("`{other}`: expected \"train\" or \"test\""),
                ))
            }
        }
        if s.weight != 1.0 {
            parts.weights.insert(name.clone(), s.weight);
        }
        let (space, spec) = scenario(src, &key, s, origins)?;
        parts.spaces.insert(name.clone(), space);
        parts.specs.push(spec);
    }
    Ok(parts)
}

/// One scenario's φ-space and run specification (its φ bindings and fixed parameters).
fn scenario(
    src: &Source,
    key: &str,
    s: &raw::ScenarioSection,
    origins: &mut Origins,
) -> Result<(Space, ScenarioSpec), ConfigError> {
    let mut vars = Vec::new();
    let mut phi = Vec::new();
    for (j, sv) in s.phi.iter().enumerate() {
        let pkey = format!("{key}.phi[{j}]");
        let line = src.line(sv.span());
        let v = sv.get_ref();
        vars.push(variable(v).map_err(|m| src.err(Some(line), Some(&pkey), m))?);
        phi.push(Binding {
            variable: v.name.clone(),
            fmu_variable: bind(src, v, line, &format!("{pkey}.fmu"), origins),
            labels: None,
        });
    }
    let space = Space::new(vars).map_err(|e| src.err(None, Some(key), e.to_string()))?;
    let mut fixed = Vec::new();
    for (name, v) in &s.fixed {
        let fkey = format!("{key}.fixed.{name}");
        let line = src.line(v.span());
        let value = toml_value(v.get_ref()).ok_or_else(|| {
            src.err(
                Some(line),
                Some(&fkey),
                "expected a number, boolean or string",
            )
        })?;
        origins.add(name, line, fkey);
        fixed.push(Fixed {
            fmu_variable: name.clone(),
            value,
        });
    }
    let spec = ScenarioSpec {
        name: s.name.get_ref().clone(),
        phi,
        fixed,
    };
    Ok((space, spec))
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

/// A savme value from a TOML scalar (None for arrays, tables and dates).
fn toml_value(v: &toml::Value) -> Option<Value> {
    Some(match v {
        toml::Value::Boolean(b) => Value::Bool(*b),
        toml::Value::Integer(i) => Value::Int(*i),
        toml::Value::Float(f) => Value::Real(*f),
        toml::Value::String(s) => Value::from(s.as_str()),
        _ => return None,
    })
}

/// `[fmu] step`: fixed, or the rate a fidelity variable gives.
fn step(
    src: &Source,
    step: &Spanned<StepSection>,
    fidelity: &Space,
) -> Result<StepSize, ConfigError> {
    match step.get_ref() {
        StepSection::Fixed(h) => Ok(StepSize::Fixed(*h)),
        StepSection::Rate { rate_of } if fidelity.variable(rate_of).is_none() => Err(src.err(
            Some(src.line(step.span())),
            Some("fmu.step.rate_of"),
            format!("`{rate_of}` is not a fidelity variable"),
        )),
        StepSection::Rate { rate_of } => Ok(StepSize::RateOf(rate_of.clone())),
    }
}

/// `[failure]`: a Boolean output, or an output against a threshold.
fn failure(
    src: &Source,
    f: &raw::FailureSection,
    origins: &mut Origins,
) -> Result<Failure, ConfigError> {
    match (&f.boolean, &f.threshold, f.above, f.below) {
        (Some(b), None, None, None) => {
            origins.add(b.get_ref(), src.line(b.span()), "failure.boolean");
            Ok(Failure::Boolean {
                variable: b.get_ref().clone(),
            })
        }
        (None, Some(t), Some(value), None) | (None, Some(t), None, Some(value)) => {
            origins.add(t.get_ref(), src.line(t.span()), "failure.threshold");
            Ok(Failure::Threshold {
                variable: t.get_ref().clone(),
                when: if f.above.is_some() {
                    Crossing::Above
                } else {
                    Crossing::Below
                },
                value,
            })
        }
        _ => Err(src.err(
            None,
            Some("failure"),
            "give `boolean = \"output\"`, or `threshold = \"output\"` with one of `above` / `below`",
        )),
    }
}

/// `[fmu] cost`: wall-clock (the default, or `"wall"`), else the output it names.
fn cost_source(src: &Source, cost: Option<&Spanned<String>>, origins: &mut Origins) -> CostSource {
    match cost {
        Some(c) if c.get_ref() != "wall" => {
            origins.add(c.get_ref(), src.line(c.span()), "fmu.cost");
            CostSource::Output(c.get_ref().clone())
        }
        _ => CostSource::Wall,
    }
}

/// `[fmu] timeout_s`: positive, default 60 s.
fn timeout(src: &Source, t: Option<&Spanned<f64>>) -> Result<Duration, ConfigError> {
    let Some(t) = t else {
        return Ok(Duration::from_secs(60));
    };
    let s = *t.get_ref();
    Duration::try_from_secs_f64(s)
        .ok()
        .filter(|_| s > 0.0)
        .ok_or_else(|| {
            src.err(
                Some(src.line(t.span())),
                Some("fmu.timeout_s"),
                "must be positive",
            )
        })
}

/// Opens both FMUs and checks every binding now, naming the line and key of a bad variable.
fn check_fmus(
    src: &Source,
    init: &WorkerInit,
    fmu: &FmuSection,
    origins: &Origins,
) -> Result<(), ConfigError> {
    init.simulator().map(drop).map_err(|e| {
        let (line, key) = locate(src, &e, fmu, origins);
        src.err(line, key, e.to_string())
    })
}

/// The line and key an FMU error comes from: a variable's binding, the run specification
/// (`fmu`), or the FMU file (`fmu.hf / fmu.lf`, at the line of the one the error names).
fn locate<'a>(
    src: &Source,
    e: &FmuError,
    fmu: &FmuSection,
    origins: &'a Origins,
) -> (Option<usize>, Option<&'a str>) {
    match e {
        FmuError::UnknownVariable { variable, .. }
        | FmuError::WrongType { variable, .. }
        | FmuError::WrongCausality { variable, .. } => origins
            .of(variable)
            .map_or((None, None), |(line, key)| (Some(line), Some(key))),
        FmuError::Spec(_) => (None, Some("fmu")),
        _ => {
            let message = e.to_string();
            let span = match &fmu.lf {
                Some(lf) if message.contains(lf.get_ref().as_str()) => lf.span(),
                _ => fmu.hf.span(),
            };
            (Some(src.line(span)), Some("fmu.hf / fmu.lf"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use savme_kernel::Variable;

    /// A file every check before the FMUs accepts; its FMU does not exist, so a load that gets
    /// that far fails at line 3 (`fmu.hf`).
    const BASE: &str = r#"
[fmu]
hf = "nowhere.fmu"
stop_time = 1.0
step = { rate_of = "rate" }

[failure]
boolean = "failed"

[campaign]
budgets = [0.5]
out = "results"

[fidelity]
[[fidelity.variable]]
name = "rate"
values = [1.0, 2.0]
hf = 2.0

[[scenario]]
name = "grow"
role = "train"
fixed = { threshold = 0.5 }
[[scenario.phi]]
name = "start"
fmu = "x0"
range = [0.0, 1.0]

[[scenario]]
name = "other"
role = "test"
[[scenario.phi]]
name = "start"
range = [0.0, 1.0]
"#;

    fn dir(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("savme-campaign-file-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn no_paper(_: u32) -> (Space, Assignment) {
        panic!("the paper's space was asked for")
    }

    fn paper(bins: u32) -> (Space, Assignment) {
        let space = Space::new(vec![Variable::continuous(
            "rate",
            1.0,
            10.0,
            bins,
            Scale::Linear,
        )])
        .unwrap();
        (space, Assignment::new().with("rate", 10.0))
    }

    /// Loads `body` (BASE with replacements) and returns the error.
    fn error(name: &str, replace: &[(&str, &str)]) -> ConfigError {
        let mut body = BASE.to_string();
        for (from, to) in replace {
            assert!(body.contains(from), "{from}");
            body = body.replacen(from, to, 1);
        }
        let path = dir(name).join("campaign.toml");
        std::fs::write(&path, body).unwrap();
        let e = CampaignFile::load(&path, &no_paper).unwrap_err();
        assert_eq!(e.file, path.display().to_string());
        e
    }

    fn at(e: &ConfigError) -> (Option<usize>, Option<&str>) {
        (e.line, e.key.as_deref())
    }

    #[test]
    fn the_base_file_gets_as_far_as_its_fmu() {
        let e = error("base", &[]);
        assert_eq!(at(&e), (Some(3), Some("fmu.hf / fmu.lf")));
        assert!(e.message.contains("nowhere.fmu"), "{e}");
    }

    #[test]
    fn a_toml_syntax_error_names_its_line() {
        let e = error("syntax", &[("stop_time = 1.0", "stop_time = = 1.0")]);
        assert_eq!(at(&e), (Some(4), None));
        assert!(e.to_string().contains("campaign.toml, line 4: "), "{e}");
    }

    #[test]
    fn an_unknown_key_names_its_line() {
        let e = error(
            "unknown",
            &[("stop_time = 1.0", "stop_time = 1.0\nstop_tme = 3")],
        );
        assert_eq!(at(&e), (Some(5), None));
        assert!(e.message.starts_with("unknown field `stop_tme`"), "{e}");
        let e = error("unknown-campaign", &[("budgets = [0.5]", "sede = 1")]);
        assert_eq!(e.line, Some(11));
        assert!(e.message.starts_with("unknown field `sede`"), "{e}");
    }

    #[test]
    fn a_variable_with_values_and_range_is_refused() {
        let e = error(
            "both",
            &[("range = [0.0, 1.0]", "range = [0.0, 1.0]\nvalues = [1, 2]")],
        );
        assert_eq!(at(&e), (Some(24), Some("scenario[0].phi[0]")));
        assert_eq!(
            e.message,
            "give either `values` (discrete) or `range` (continuous)"
        );
    }

    #[test]
    fn bad_variables_name_their_table() {
        for (from, to, message) in [
            (
                "range = [0.0, 1.0]",
                "range = [1.0, 0.0]",
                "`range` = [1, 0] is empty",
            ),
            (
                "range = [0.0, 1.0]",
                "range = [0.0, 1.0]\nbins = 0",
                "`bins` must be at least 1",
            ),
            (
                "range = [0.0, 1.0]",
                "range = [0.0, 1.0]\nscale = \"log\"",
                "a log scale needs 0 < lo (range [0, 1])",
            ),
            ("range = [0.0, 1.0]", "values = []", "`values` is empty"),
            (
                "range = [0.0, 1.0]",
                "values = [[1]]",
                "`values` must be numbers, booleans or strings",
            ),
        ] {
            let e = error("variable", &[(from, to)]);
            assert_eq!(at(&e), (Some(24), Some("scenario[0].phi[0]")), "{e}");
            assert_eq!(e.message, message);
        }
    }

    #[test]
    fn rate_of_must_name_a_fidelity_variable() {
        let e = error("rate-of", &[("rate_of = \"rate\"", "rate_of = \"fps\"")]);
        assert_eq!(at(&e), (Some(5), Some("fmu.step.rate_of")));
        assert_eq!(e.message, "`fps` is not a fidelity variable");
    }

    #[test]
    fn a_scenario_defined_twice_is_refused() {
        let e = error("twice", &[("name = \"other\"", "name = \"grow\"")]);
        assert_eq!(at(&e), (Some(30), Some("scenario[1].name")));
        assert_eq!(e.message, "scenario `grow` is defined twice");
    }

    #[test]
    fn a_role_is_train_or_test() {
        let e = error("role", &[("role = \"test\"", "role = \"tset\"")]);
        assert_eq!(at(&e), (Some(31), Some("scenario[1].role")));
        assert_eq!(e.message, "`tset`: expected \"train\" or \"test\"");
    }

    #[test]
    fn fixed_parameters_are_scalars() {
        let e = error("fixed", &[("threshold = 0.5", "threshold = [0.5]")]);
        assert_eq!(at(&e), (Some(23), Some("scenario[0].fixed.threshold")));
        assert_eq!(e.message, "expected a number, boolean or string");
    }

    #[test]
    fn fidelity_variables_need_a_theta_hf_inside_their_space() {
        let e = error("no-hf", &[("hf = 2.0", "")]);
        assert_eq!(at(&e), (Some(15), Some("fidelity.variable[0].hf")));
        let e = error("hf-out", &[("hf = 2.0", "hf = 3.0")]);
        assert_eq!(at(&e), (None, Some("fidelity.variable.hf")));
        assert!(e.message.starts_with("θ_HF: "), "{e}");
    }

    #[test]
    fn paper_excludes_variables_and_needs_bins() {
        let e = error("paper-and", &[("[fidelity]", "[fidelity]\npaper = true")]);
        assert_eq!(at(&e), (Some(16), Some("fidelity.variable")));
        assert_eq!(
            e.message,
            "give either `paper = true` or variables, not both"
        );
        // Zero bins are refused before the paper's space is built (it could not be).
        let e = error(
            "paper-zero",
            &[
                ("budgets = [0.5]", "fidelity_bins = 0"),
                (
                    "[[fidelity.variable]]\nname = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0",
                    "",
                ),
                ("[fidelity]", "[fidelity]\npaper = true"),
            ],
        );
        assert_eq!(at(&e), (Some(11), Some("campaign.fidelity_bins")));
        assert_eq!(e.message, "must be at least 1");
    }

    #[test]
    fn the_paper_space_comes_from_the_caller() {
        let body = BASE
            .replacen("budgets = [0.5]", "fidelity_bins = 4", 1)
            .replacen(
                "[[fidelity.variable]]\nname = \"rate\"\nvalues = [1.0, 2.0]\nhf = 2.0",
                "",
                1,
            )
            .replacen("[fidelity]", "[fidelity]\npaper = true", 1);
        let path = dir("paper").join("campaign.toml");
        std::fs::write(&path, body).unwrap();
        let asked = std::cell::Cell::new(None);
        let e = CampaignFile::load(&path, &|bins| {
            asked.set(Some(bins));
            paper(bins)
        })
        .unwrap_err();
        assert_eq!(asked.get(), Some(4));
        // `rate` is the paper's: the file gets as far as its FMU.
        assert_eq!(e.key.as_deref(), Some("fmu.hf / fmu.lf"), "{e}");
    }

    #[test]
    fn the_failure_signal_is_boolean_or_a_threshold_with_one_side() {
        for (to, name) in [
            ("threshold = \"x\"", "no-side"),
            ("threshold = \"x\"\nabove = 1.0\nbelow = 0.0", "two-sides"),
            (
                "boolean = \"failed\"\nthreshold = \"x\"\nabove = 1.0",
                "both",
            ),
        ] {
            let e = error(name, &[("boolean = \"failed\"", to)]);
            assert_eq!(at(&e), (None, Some("failure")), "{name}");
            assert!(e.message.contains("`above` / `below`"), "{e}");
        }
    }

    #[test]
    fn a_missing_file_is_named() {
        let path = dir("missing").join("campaign.toml");
        let e = CampaignFile::load(&path, &no_paper).unwrap_err();
        assert_eq!(at(&e), (None, None));
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );
    }

    #[test]
    fn the_campaign_section_keeps_its_values_and_lines() {
        let text = BASE.replacen(
            "budgets = [0.5]",
            "budgets = [0.5]\nseed = 7\ncost = \"work\"\nprior_strength = 0.5",
            1,
        );
        let src = Source {
            file: "campaign.toml".into(),
            text: &text,
        };
        let f = src.parse().unwrap();
        let c = campaign_section(&src, f.campaign, Path::new("/runs"));
        assert_eq!(c.budgets, Some(vec![0.5]));
        assert_eq!(c.seed, Some(7));
        assert_eq!(c.cost, Some(Cost::Work));
        assert_eq!(c.prior_strength, Some(0.5));
        assert_eq!(c.train_iterations, None);
        assert_eq!(c.fidelity_bins, None);
        assert_eq!(c.out, Some(PathBuf::from("/runs/results")));
        let lines: Vec<(&str, usize)> = c.lines.iter().map(|(k, l)| (k.as_str(), *l)).collect();
        assert_eq!(
            lines,
            [
                ("budgets", 11),
                ("cost", 13),
                ("out", 15),
                ("prior_strength", 14),
                ("seed", 12)
            ]
        );
        // No [campaign] table: nothing given.
        let text = BASE.replacen("[campaign]\nbudgets = [0.5]\nout = \"results\"\n", "", 1);
        let src = Source {
            file: "campaign.toml".into(),
            text: &text,
        };
        let c = campaign_section(&src, src.parse().unwrap().campaign, Path::new("."));
        assert_eq!(c, CampaignSection::default());
    }

    #[test]
    fn a_wrong_cost_or_on_error_names_its_line() {
        let e = error("cost", &[("budgets = [0.5]", "cost = \"cpu\"")]);
        assert_eq!(at(&e), (Some(11), None));
        assert_eq!(
            e.message,
            "unknown variant `cpu`, expected `wall` or `work`"
        );
        let e = error(
            "on-error",
            &[("stop_time = 1.0", "stop_time = 1.0\non_error = \"ignore\"")],
        );
        assert_eq!(at(&e), (Some(5), None));
        assert_eq!(
            e.message,
            "unknown variant `ignore`, expected `abort` or `skip`"
        );
    }

    #[test]
    fn lines_and_errors_display_as_before() {
        assert_eq!(line_of("a\nb\nc", 0), 1);
        assert_eq!(line_of("a\nb\nc", 2), 2);
        assert_eq!(line_of("a\nb\nc", 99), 3);
        let e = ConfigError {
            file: "f.toml".into(),
            line: None,
            key: Some("failure".into()),
            message: "m".into(),
        };
        assert_eq!(e.to_string(), "f.toml, key `failure`: m");
        let e = ConfigError { key: None, ..e };
        assert_eq!(e.to_string(), "f.toml: m");
    }
}

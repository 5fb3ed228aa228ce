//! The JSON documents the `savme` command line prints for scripts, each with a
//! `format_version`, and their JSON Schemas (generated from these types with schemars,
//! published in `docs/schemas/`, and checked against real outputs by `tests/it/schemas.rs`).
//!
//! ```
//! let schemas = savme::json::schemas();
//! assert!(schemas.iter().any(|(name, _)| *name == "simulate"));
//! let (_, schema) = &schemas[0];
//! assert_eq!(schema["$schema"], "https://json-schema.org/draft/2020-12/schema");
//! ```

use savme_campaign::estimate::EstimateSummary;
use savme_campaign::report::failures::FoundFailure;
use savme_kernel::{Assignment, Domain, Value};
use schemars::JsonSchema;
use serde::Serialize;

/// The layout version of every JSON document savme writes or prints (the campaign files'
/// `format_version` too): a script checks it before reading a field.
pub const FORMAT_VERSION: u32 = savme_campaign::outputs::FORMAT_VERSION;

/// `savme fmu info --json`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct FmuInfo {
    /// The layout version of savme's JSON documents (1 for now; a script checks it).
    pub format_version: u32,
    /// The FMU.
    #[serde(flatten)]
    pub info: savme_fmu::inspect::Info,
}

/// `savme fmu validate --json`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct FmuValidation {
    /// The layout version of savme's JSON documents (1 for now; a script checks it).
    pub format_version: u32,
    /// The `.fmu` path as given.
    pub fmu: String,
    /// True when every check savme makes before a campaign passes.
    pub valid: bool,
    /// What is wrong, one sentence each, naming the element, line or function.
    pub problems: Vec<String>,
}

/// `savme simulate --json`: one run of the bundled driving simulator.
#[derive(Debug, Serialize, JsonSchema)]
pub struct Simulation {
    /// The layout version of savme's JSON documents (1 for now; a script checks it).
    pub format_version: u32,
    /// The scenario's name.
    pub scenario: String,
    /// The system under test's perception: `sensors` (camera + lidar, the paper's) or
    /// `ideal` (ground truth; blind to the sensor fidelity settings).
    pub perception: String,
    /// The scenario parameters φ.
    pub phi: Assignment,
    /// The fidelity setting θ the run used.
    pub fidelity: Assignment,
    /// The fidelity settings this perception ignores (empty for `sensors`).
    pub ignored_settings: Vec<String>,
    /// Whether the run failed (a collision).
    pub failure: bool,
    /// When the collision happened, in seconds (null: none).
    pub collision_time_s: Option<f64>,
    /// The smallest distance between the vehicles, in metres.
    pub min_distance_m: f64,
    /// Simulation steps.
    pub steps: u64,
    /// Deterministic work units (the `--cost work` measure).
    pub work: u64,
    /// Measured wall-clock seconds of the run.
    pub wall_seconds: f64,
}

/// One line of `savme failures --json`: an HF failure of a campaign.
#[derive(Debug, Serialize, JsonSchema)]
pub struct FailureLine {
    /// The layout version of savme's JSON documents (1 for now; a script checks it).
    pub format_version: u32,
    /// The failure.
    #[serde(flatten)]
    pub failure: FoundFailure,
    /// The `savme simulate` command that replays it (null when `savme simulate` cannot run
    /// the campaign's simulator: `replay_unavailable` says why).
    pub replay: Option<String>,
    /// Why `replay` is null (absent when it is not).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replay_unavailable: Option<String>,
}

/// `savme scenarios --json`: the bundled driving simulator's scenarios.
#[derive(Debug, Serialize, JsonSchema)]
pub struct ScenarioList {
    /// The layout version of savme's JSON documents (1 for now; a script checks it).
    pub format_version: u32,
    /// The scenarios in number order: meta-training (1–8), then meta-testing (9–10).
    pub scenarios: Vec<Scenario>,
}

/// One scenario of `savme scenarios --json`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct Scenario {
    /// Its number (what `--scenario` takes, as its name).
    pub id: u8,
    /// Its name.
    pub name: String,
    /// Whether the paper's protocol meta-trains or meta-tests on it.
    pub role: Role,
    /// Simulated driving per run, in seconds.
    pub duration_s: f64,
    /// What happens in it.
    pub description: String,
    /// Its parameters φ, in the order `--phi` lists them.
    pub parameters: Vec<Parameter>,
}

/// A scenario's part in the paper's protocol.
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub enum Role {
    /// A meta-training scenario (`--train-scenarios`).
    #[serde(rename = "meta-training")]
    MetaTraining,
    /// A meta-testing scenario (`--test-scenarios`).
    #[serde(rename = "meta-testing")]
    MetaTesting,
}

/// A scenario parameter: the kernel's variable (name and values) with its unit.
#[derive(Debug, Serialize, JsonSchema)]
pub struct Parameter {
    /// The parameter's name (as `--phi` takes it).
    pub name: String,
    /// Its values.
    #[serde(flatten)]
    pub domain: Domain,
    /// Its unit (`m/s`, `m/s²`, `m`, `s`; empty when it has none).
    pub unit: String,
}

/// `savme fidelity --json`: the 16 fidelity settings (the paper's Table II).
#[derive(Debug, Serialize, JsonSchema)]
pub struct FidelityList {
    /// The layout version of savme's JSON documents (1 for now; a script checks it).
    pub format_version: u32,
    /// The settings, in the order of the fidelity space.
    pub settings: Vec<Setting>,
}

/// One fidelity setting of `savme fidelity --json`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct Setting {
    /// The setting's name (as `--fidelity` takes it).
    pub name: String,
    /// Its values.
    #[serde(flatten)]
    pub domain: Domain,
    /// Its unit (`Hz`, `m`; null when it has none).
    pub unit: Option<String>,
    /// Its high-fidelity value θ_HF (null: none).
    pub hf: Option<Value>,
}

/// The schema of `T`'s JSON (what savme writes, 2020-12 draft), as a JSON value.
fn schema_of<T: JsonSchema>() -> serde_json::Value {
    let generator = schemars::generate::SchemaSettings::draft2020_12()
        .for_serialize()
        .into_generator();
    generator.into_root_schema_for::<T>().to_value()
}

/// Every document's schema by name (`docs/schemas/<name>.schema.json`): `estimate-summary`
/// (`summary.json` of `savme estimate`, and `savme estimate --json`), `failures-line`,
/// `fidelity`, `fmu-info`, `fmu-validate`, `scenarios` and `simulate`.
pub fn schemas() -> Vec<(&'static str, serde_json::Value)> {
    vec![
        ("estimate-summary", schema_of::<EstimateSummary<'static>>()),
        ("failures-line", schema_of::<FailureLine>()),
        ("fidelity", schema_of::<FidelityList>()),
        ("fmu-info", schema_of::<FmuInfo>()),
        ("fmu-validate", schema_of::<FmuValidation>()),
        ("scenarios", schema_of::<ScenarioList>()),
        ("simulate", schema_of::<Simulation>()),
    ]
}

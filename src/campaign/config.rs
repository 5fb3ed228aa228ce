//! A campaign's [`Protocol`] and [`Problem`], from a preset or a campaign file plus the
//! command line's flags — in one place, for every command: a preset (or a file's `[campaign]`
//! section) first, then the flags, then validation.

use super::{CampaignError, Cost, OnError, Problem, Protocol};
use crate::toy::{NullSimulator, Sleeping, ToySimulator};
use savme_fmu::campaign_file::{self, CampaignFile, CampaignSection, ConfigError};
use savme_kernel::{Assignment, SimError, SimResult, Simulator};
use savme_sim::sim::DrivingSimulator;
use std::path::Path;

/// The simulator label of the bundled simulator with camera + lidar perception.
pub const SENSORS: &str = "savme-sim/sensors";
/// The simulator label of the bundled simulator with idealised perception.
pub const IDEAL: &str = "savme-sim/ideal";

/// Protocol values given on the command line or in a campaign file (None: keep the value
/// before). Scenarios are given as the user wrote them and resolved by [`Overrides::apply`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Master seed.
    pub seed: Option<u64>,
    /// Cost measure.
    pub cost: Option<super::Cost>,
    /// Compute budgets.
    pub budgets: Option<Vec<f64>>,
    /// Meta-training iterations per budget.
    pub train_iterations: Option<u64>,
    /// Evaluation trials per budget.
    pub eval_iterations: Option<u64>,
    /// Meta-testing iterations per budget and prior.
    pub test_iterations: Option<u64>,
    /// Baseline trials on the meta-training scenarios.
    pub baseline_train_iterations: Option<u64>,
    /// Baseline trials on the meta-testing scenarios.
    pub baseline_test_iterations: Option<u64>,
    /// Bins per continuous fidelity setting.
    pub fidelity_bins: Option<u32>,
    /// Power-prior strength of the meta-testing prior.
    pub prior_strength: Option<f64>,
    /// Trials in flight.
    pub window: Option<usize>,
    /// Meta-training scenarios (numbers or names, resolved by the caller's lookup).
    pub train_scenarios: Option<Vec<String>>,
    /// Meta-testing scenarios.
    pub test_scenarios: Option<Vec<String>>,
}

impl Overrides {
    /// True when any value was given.
    pub fn any(&self) -> bool {
        *self != Overrides::default()
    }

    /// `self`, with every value `later` gives replacing this one's (a file's values, then the
    /// command line's).
    pub fn then(self, later: &Overrides) -> Overrides {
        let l = later.clone();
        Overrides {
            seed: l.seed.or(self.seed),
            cost: l.cost.or(self.cost),
            budgets: l.budgets.or(self.budgets),
            train_iterations: l.train_iterations.or(self.train_iterations),
            eval_iterations: l.eval_iterations.or(self.eval_iterations),
            test_iterations: l.test_iterations.or(self.test_iterations),
            baseline_train_iterations: l
                .baseline_train_iterations
                .or(self.baseline_train_iterations),
            baseline_test_iterations: l.baseline_test_iterations.or(self.baseline_test_iterations),
            fidelity_bins: l.fidelity_bins.or(self.fidelity_bins),
            prior_strength: l.prior_strength.or(self.prior_strength),
            window: l.window.or(self.window),
            train_scenarios: l.train_scenarios.or(self.train_scenarios),
            test_scenarios: l.test_scenarios.or(self.test_scenarios),
        }
    }

    /// Applies the values to `p`; `scenario` turns a scenario as given into its name (None:
    /// unknown, an error listing `known`). Does not validate.
    pub fn apply(
        &self,
        p: &mut Protocol,
        scenario: &dyn Fn(&str) -> Option<String>,
        known: &str,
    ) -> Result<(), CampaignError> {
        fn set<T: Clone>(slot: &mut T, v: &Option<T>) {
            if let Some(v) = v {
                *slot = v.clone();
            }
        }
        set(&mut p.seed, &self.seed);
        set(&mut p.cost, &self.cost);
        set(&mut p.budgets, &self.budgets);
        set(&mut p.train_iterations, &self.train_iterations);
        set(&mut p.eval_iterations, &self.eval_iterations);
        set(&mut p.test_iterations, &self.test_iterations);
        set(
            &mut p.baseline_train_iterations,
            &self.baseline_train_iterations,
        );
        set(
            &mut p.baseline_test_iterations,
            &self.baseline_test_iterations,
        );
        set(&mut p.fidelity_bins, &self.fidelity_bins);
        set(&mut p.prior_strength, &self.prior_strength);
        set(&mut p.window, &self.window);
        let names = |given: &[String]| -> Result<Vec<String>, CampaignError> {
            given
                .iter()
                .map(|k| {
                    scenario(k.trim()).ok_or_else(|| CampaignError::UnknownScenario {
                        name: k.trim().into(),
                        known: known.into(),
                    })
                })
                .collect()
        };
        if let Some(v) = &self.train_scenarios {
            p.train_scenarios = names(v)?;
        }
        if let Some(v) = &self.test_scenarios {
            p.test_scenarios = names(v)?;
        }
        Ok(())
    }
}

/// Which preset of the bundled simulator's protocol.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Preset {
    /// The short preset (one budget, fewer iterations) instead of the paper's protocol.
    pub quick: bool,
    /// Idealised perception instead of camera + lidar.
    pub ideal: bool,
}

/// The protocol and problem of a campaign on the bundled driving simulator, validated.
///
/// ```
/// use savme::campaign::config::{bundled, Overrides, Preset};
/// let o = Overrides { seed: Some(3), train_scenarios: Some(vec!["7".into()]), ..Default::default() };
/// let (p, problem) = bundled(Preset { quick: true, ideal: false }, &o)?;
/// assert_eq!((p.seed, p.budgets.clone()), (3, vec![0.3]));
/// assert_eq!(p.train_scenarios, ["lead_vehicle_brakes"]);
/// assert!(problem.scenarios.contains_key("on_ramp_merge"));
/// assert!(bundled(Preset::default(), &Overrides { budgets: Some(vec![2.0]), ..Default::default() }).is_err());
/// # Ok::<(), savme::campaign::CampaignError>(())
/// ```
pub fn bundled(preset: Preset, o: &Overrides) -> Result<(Protocol, Problem), CampaignError> {
    let (train, test) = savme_sim::scenario::train_test_names();
    let simulator = if preset.ideal { IDEAL } else { SENSORS };
    let mut p = if preset.quick {
        Protocol::quick(simulator, train, test)
    } else {
        Protocol::paper(simulator, train, test)
    };
    let lookup = |k: &str| savme_sim::scenario::find(k).map(|s| s.name.to_string());
    o.apply(
        &mut p,
        &lookup,
        "1–10 or their names (see `savme scenarios`)",
    )?;
    p.validate()?;
    let problem = Problem::driving(p.fidelity_bins);
    Ok((p, problem))
}

/// The simulator label of the toy simulator (`savme toy`).
pub const TOY: &str = "savme-toy";
/// The simulator label of the null simulator (`savme toy --null`).
pub const NULL: &str = "savme-null";

/// The simulators a protocol can name by its label alone (what a `savme worker` runs without
/// a campaign file): the bundled driving simulator, the toy (optionally sleeping before each
/// run: `savme-toy/sleep=20ms`) and the null simulator.
#[derive(Debug, Clone)]
pub enum NamedSimulator {
    /// The bundled driving simulator.
    Driving(DrivingSimulator),
    /// The toy simulator, sleeping first.
    Toy(Sleeping<ToySimulator>),
    /// The null simulator.
    Null(NullSimulator),
}

impl Simulator for NamedSimulator {
    fn simulate(
        &mut self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        match self {
            NamedSimulator::Driving(s) => s.simulate(scenario, phi, fidelity),
            NamedSimulator::Toy(s) => s.simulate(scenario, phi, fidelity),
            NamedSimulator::Null(s) => s.simulate(scenario, phi, fidelity),
        }
    }
}

/// The simulator a protocol's label names, if savme can build it from the label alone (an
/// FMU campaign's label needs its campaign file: None).
///
/// ```
/// use savme::campaign::config::{named_simulator, toy_label, NamedSimulator};
/// assert!(matches!(named_simulator("savme-sim/ideal"), Some(NamedSimulator::Driving(_))));
/// assert!(matches!(named_simulator(&toy_label(20)), Some(NamedSimulator::Toy(_))));
/// assert!(named_simulator("my-fmu-campaign").is_none());
/// ```
pub fn named_simulator(label: &str) -> Option<NamedSimulator> {
    let sleeping = |ms: u64| {
        NamedSimulator::Toy(Sleeping {
            inner: ToySimulator,
            sleep: std::time::Duration::from_millis(ms),
        })
    };
    match label {
        SENSORS => Some(NamedSimulator::Driving(DrivingSimulator::default())),
        IDEAL => Some(NamedSimulator::Driving(DrivingSimulator::ideal())),
        TOY => Some(sleeping(0)),
        NULL => Some(NamedSimulator::Null(NullSimulator)),
        other => other
            .strip_prefix("savme-toy/sleep=")
            .and_then(|ms| ms.strip_suffix("ms"))
            .and_then(|ms| ms.parse().ok())
            .map(sleeping),
    }
}

/// The label of the toy simulator sleeping `ms` milliseconds per run.
pub fn toy_label(ms: u64) -> String {
    if ms == 0 {
        TOY.into()
    } else {
        format!("{TOY}/sleep={ms}ms")
    }
}

/// The protocol and problem of a campaign on the toy simulator (`savme toy`): the quick
/// preset's stages on its two scenarios (`stopped_obstacle` for meta-training,
/// `braking_lead` for meta-testing), under the simulator `label`, validated.
pub fn toy(label: &str, o: &Overrides) -> Result<(Protocol, Problem), CampaignError> {
    let (train, test) = (
        vec![crate::toy::SCENARIOS[0].to_string()],
        vec![crate::toy::SCENARIOS[1].to_string()],
    );
    let mut p = Protocol::quick(label, train, test);
    let lookup = |k: &str| crate::toy::phi_space(k).map(|_| k.to_string());
    o.apply(&mut p, &lookup, &crate::toy::SCENARIOS.join(", "))?;
    p.validate()?;
    let (fidelity, theta_hf) = crate::toy::fidelity();
    let scenarios = crate::toy::SCENARIOS
        .iter()
        .filter_map(|s| crate::toy::phi_space(s).map(|space| (s.to_string(), space)))
        .collect();
    Ok((
        p,
        Problem {
            fidelity,
            theta_hf,
            scenarios,
        },
    ))
}

/// The bundled simulator a protocol names (for `--resume`).
pub fn bundled_simulator(p: &Protocol) -> Result<DrivingSimulator, CampaignError> {
    match p.simulator.as_str() {
        SENSORS => Ok(DrivingSimulator::default()),
        IDEAL => Ok(DrivingSimulator::ideal()),
        other => Err(CampaignError::Protocol {
            field: "simulator".into(),
            message: format!("`{other}` is not the bundled simulator ({SENSORS} or {IDEAL})"),
        }),
    }
}

impl From<&CampaignSection> for Overrides {
    /// A campaign file's `[campaign]` section as overrides of the paper's protocol.
    fn from(c: &CampaignSection) -> Self {
        Overrides {
            seed: c.seed,
            cost: c.cost.map(|c| match c {
                campaign_file::Cost::Wall => Cost::Wall,
                campaign_file::Cost::Work => Cost::Work,
            }),
            budgets: c.budgets.clone(),
            train_iterations: c.train_iterations,
            eval_iterations: c.eval_iterations,
            test_iterations: c.test_iterations,
            baseline_train_iterations: c.baseline_train_iterations,
            baseline_test_iterations: c.baseline_test_iterations,
            fidelity_bins: c.fidelity_bins,
            prior_strength: c.prior_strength,
            window: c.window,
            train_scenarios: None,
            test_scenarios: None,
        }
    }
}

/// A campaign on FMUs: its protocol and problem, and the checked campaign file (FMU paths,
/// bindings, isolation, output directory).
#[derive(Debug)]
pub struct FmuCampaign {
    /// The protocol: the paper's, the file's `[campaign]` section, then the flags.
    pub protocol: Protocol,
    /// The fidelity space with θ_HF and the scenario spaces of the file.
    pub problem: Problem,
    /// The file as read and checked against its FMUs.
    pub file: CampaignFile,
}

/// Reads and checks the campaign file at `path` (with the bundled simulator's fidelity table
/// for `[fidelity] paper = true`), then builds its protocol: the paper's, the file's
/// `[campaign]` section, then `flags`, validated. An error in a value the file gave names the
/// file, line and key; one in a flag names the protocol field.
pub fn fmu_file(path: &Path, flags: &Overrides) -> Result<FmuCampaign, CampaignError> {
    let paper = |bins| {
        (
            savme_sim::fidelity::space(bins),
            savme_sim::fidelity::theta_hf(),
        )
    };
    let file = CampaignFile::load(path, &paper)?;
    let mut p = Protocol::paper(&file.label, file.train.clone(), file.test.clone());
    p.weights = file.weights.clone();
    p.on_error = if file.skip_failed_runs {
        OnError::Skip
    } else {
        OnError::Abort
    };
    let known = file
        .scenarios
        .keys()
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    let lookup = |k: &str| file.scenarios.contains_key(k).then(|| k.to_string());
    let overrides = Overrides::from(&file.campaign).then(flags);
    overrides.apply(&mut p, &lookup, &known)?;
    p.validate().map_err(|e| in_file(e, &file, flags))?;
    let problem = Problem {
        fidelity: file.fidelity.clone(),
        theta_hf: file.theta_hf.clone(),
        scenarios: file.scenarios.clone(),
    };
    Ok(FmuCampaign {
        protocol: p,
        problem,
        file,
    })
}

/// A protocol error of a value the campaign file gave, as an error naming its key and line.
fn in_file(e: CampaignError, file: &CampaignFile, flags: &Overrides) -> CampaignError {
    let CampaignError::Protocol { field, message } = e else {
        return e;
    };
    let from_flags = Overrides::default().then(flags);
    let given_as_flag = match field.as_str() {
        "train_iterations" => from_flags.train_iterations.is_some(),
        "eval_iterations" => from_flags.eval_iterations.is_some(),
        "test_iterations" => from_flags.test_iterations.is_some(),
        "baseline_train_iterations" => from_flags.baseline_train_iterations.is_some(),
        "baseline_test_iterations" => from_flags.baseline_test_iterations.is_some(),
        "budgets" => from_flags.budgets.is_some(),
        "window" => from_flags.window.is_some(),
        "seed" => from_flags.seed.is_some(),
        "train_scenarios" => from_flags.train_scenarios.is_some(),
        "test_scenarios" => from_flags.test_scenarios.is_some(),
        _ => false,
    };
    if given_as_flag {
        return CampaignError::Protocol { field, message };
    }
    let (key, line, message) = match field.as_str() {
        "train_scenarios" => missing_role(file, "train", message),
        "test_scenarios" => missing_role(file, "test", message),
        "weights" => bad_weight(file, message),
        other => (
            format!("campaign.{other}"),
            file.campaign.lines.get(other).copied(),
            message,
        ),
    };
    CampaignError::File(ConfigError {
        file: file.path.display().to_string(),
        line,
        key: Some(key),
        message,
    })
}

/// The key, line and message of a file without a scenario of `role`: at the role of its first
/// scenario (they all have the other role).
fn missing_role(
    file: &CampaignFile,
    role: &str,
    message: String,
) -> (String, Option<usize>, String) {
    let message = format!("no scenario has role \"{role}\": {message}");
    match file.scenario_lines.first() {
        Some(s) => (format!("scenario[{}].role", s.index), Some(s.role), message),
        None => ("scenario".into(), None, message),
    }
}

/// The key, line and message of a weight the protocol refused: the weight of the first
/// scenario (by name, as [`Protocol::validate`] checks them) that is not positive and finite.
fn bad_weight(file: &CampaignFile, message: String) -> (String, Option<usize>, String) {
    let bad = file
        .weights
        .iter()
        .find(|(_, w)| !(**w > 0.0 && w.is_finite()))
        .and_then(|(name, _)| file.scenario_lines.iter().find(|s| &s.name == name));
    match bad {
        Some(s) => (format!("scenario[{}].weight", s.index), s.weight, message),
        None => ("scenario.weight".into(), None, message),
    }
}

//! How an estimation is set up ([`EstimationConfig`], with its [`Refine`] pilot and
//! [`Joint`] proposal) and why it may be refused ([`EstimationError`]).

use super::Nominal;
use super::Tilt;
use super::{Control, MAX_EXTRA};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How an estimation is set up: ε, the seed of its draws, and the nominal distribution of
/// any variable that is not uniform (by scenario, then variable).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimationConfig {
    /// The defensive share ε of the nominal in the proposal, in (0, 1]; ε = 1 is plain Monte
    /// Carlo under the nominal.
    pub epsilon: f64,
    /// Seed of the proposal's draws.
    pub seed: u64,
    /// Non-uniform nominals: `nominal[scenario][variable]`.
    #[serde(default)]
    pub nominal: BTreeMap<String, BTreeMap<String, Nominal>>,
    /// How p̂_ψ weighs the bins (default: by the posterior means alone).
    #[serde(default)]
    pub tilt: Tilt,
    /// Cross-entropy refinement of the proposal before the estimate (None: the proposal is
    /// the posterior's, as built).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine: Option<Refine>,
    /// A joint proposal fitted by the pilot rounds (None: the product proposal of the
    /// posterior's bins, refitted per variable by the pilot). Needs `refine`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint: Option<Joint>,
    /// The fidelity the cross-entropy pilot rounds run at: `hf` (default) or `lf` — the
    /// multi-fidelity estimator: the proposal is fitted on cheap LF runs and the estimate
    /// still uses HF runs only, so it stays unbiased for the HF probability whatever the LF's
    /// errors (the defensive share keeps q > 0 wherever p > 0). Needs `refine`; pilot runs
    /// at LF are never part of the estimate (`refine.reuse` must be 0).
    #[serde(default, skip_serializing_if = "Fidelity::is_hf")]
    pub pilot_fidelity: Fidelity,
    /// LF runs at θ_LF* as control variates for the HF estimate (None: HF runs only).
    /// Calibration pairs choose α and the LF runs per pair; see [`Control`]. `refine.reuse`
    /// must be 0 with it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control: Option<Control>,
}

/// Which simulator fidelity an estimation trial runs at: `hf` (θ_HF, the truth the estimate
/// is about) or `lf` (the campaign's learned θ_LF*: only the pilot rounds of a multi-fidelity
/// estimation, [`EstimationConfig::pilot_fidelity`]).
///
/// ```
/// use savme_kernel::estimation::Fidelity;
/// assert_eq!(Fidelity::default(), Fidelity::Hf);
/// assert_eq!(serde_json::to_string(&Fidelity::Lf).unwrap(), "\"lf\"");
/// assert_eq!(serde_json::from_str::<Fidelity>("\"hf\"").unwrap(), Fidelity::Hf);
/// ```
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fidelity {
    /// High fidelity, θ_HF.
    #[default]
    Hf,
    /// The learned low fidelity, θ_LF*.
    Lf,
}

impl Fidelity {
    /// Whether this is [`Fidelity::Hf`] (the default, left out of serialised forms).
    pub fn is_hf(&self) -> bool {
        *self == Fidelity::Hf
    }

    /// `hf` or `lf`.
    pub fn key(self) -> &'static str {
        match self {
            Fidelity::Hf => "hf",
            Fidelity::Lf => "lf",
        }
    }
}

/// The joint proposal: after each pilot round, every scenario's learned part p̂ becomes a
/// mixture of `components` components over the whole of φ (not a product over the
/// variables), fitted to the pilot's weighted failures — or, while they are fewer than 100,
/// to its failures and closest near-misses by robustness — by the cross-entropy method
/// (docs/ESTIMATION.md). The defensive share ε of the nominal stays; every weight is the
/// exact p/q of normalised densities.
///
/// ```
/// use savme_kernel::estimation::Joint;
/// let j: Joint = serde_json::from_str(r#"{"components":6}"#)?;
/// assert_eq!(j, Joint { components: 6 });
/// assert!(serde_json::from_str::<Joint>(r#"{"components":6,"k":2}"#).is_err());
/// # Ok::<(), serde_json::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Joint {
    /// The most mixture components per scenario, in 1 ..= [`MAX_COMPONENTS`] (fewer when
    /// the pilot's weighted elite is small: about 10 effective points per component).
    pub components: u32,
}

/// The most components a joint proposal may have.
pub const MAX_COMPONENTS: u32 = 64;

/// The components of a joint proposal when the campaign's `joint_components` is not given.
pub const DEFAULT_COMPONENTS: u32 = 4;

/// Which proposal the pilot rounds fit: the campaign's `proposal` setting
/// ([`EstimationConfig::joint`] in the kernel).
///
/// ```
/// use savme_kernel::estimation::ProposalKind;
/// assert_eq!(ProposalKind::default(), ProposalKind::Product);
/// assert_eq!(serde_json::to_string(&ProposalKind::Joint).unwrap(), "\"joint\"");
/// ```
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ProposalKind {
    /// Per-variable bins (the posterior's, refitted per variable by the pilot).
    #[default]
    Product,
    /// A mixture over the whole of φ fitted by the pilot ([`Joint`]).
    Joint,
}

/// Cross-entropy pilot rounds that refit the proposal before the estimate.
///
/// ```
/// use savme_kernel::estimation::Refine;
/// let r: Refine = serde_json::from_str(r#"{"rounds":3,"runs":1000}"#)?;
/// assert_eq!(r, Refine { rounds: 3, runs: 1000, reuse: 0 });
/// let r: Refine = serde_json::from_str(r#"{"rounds":3,"runs":1000,"reuse":1}"#)?;
/// assert_eq!(r.reuse, 1);
/// # Ok::<(), serde_json::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Refine {
    /// Pilot rounds, ≥ 1; each refits every scenario's proposal once.
    pub rounds: u32,
    /// HF runs per round over all scenarios (shared by p(s)), ≥ 1.
    pub runs: u64,
    /// How many of the last pilot rounds also count toward the estimate, 0 ..= `rounds`
    /// (0: none, the estimate uses only the final proposal's trials). A reused trial keeps
    /// the weight p/q of the proposal it was drawn from — fixed before its round began — so
    /// the estimate stays unbiased; see the module docs for its interval.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub reuse: u32,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

/// How far a refit moves the bin probabilities toward the pilot's weighted failures. Larger
/// values chase the few heaviest failures of an early round and collapse onto them: on the
/// rare benchmark setting (docs/BENCHMARKS.md) 0.7 was 0.2–0.4× plain Monte Carlo, 0.2–0.5
/// were 3.1–3.6×.
pub const REFINE_SMOOTHING: f64 = 0.3;

impl EstimationConfig {
    /// ε and a seed, every variable's nominal uniform.
    pub fn new(epsilon: f64, seed: u64) -> Self {
        EstimationConfig {
            epsilon,
            seed,
            nominal: BTreeMap::new(),
            tilt: Tilt::Posterior,
            refine: None,
            joint: None,
            pilot_fidelity: Fidelity::Hf,
            control: None,
        }
    }
}

/// Why an estimation cannot be built or a tell was refused. Nothing changes on an error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EstimationError {
    /// ε outside (0, 1].
    #[error("epsilon (the nominal's share of the proposal) must lie in (0, 1], got {0}")]
    BadEpsilon(f64),
    /// A refinement with no rounds or no runs per round.
    #[error("refine needs at least 1 round of at least 1 run, got {rounds} rounds of {runs} runs")]
    BadRefine {
        /// Rounds given.
        rounds: u32,
        /// Runs per round given.
        runs: u64,
    },
    /// More pilot rounds to reuse in the estimate than there are.
    #[error(
        "refine reuse: {reuse} rounds to reuse in the estimate, but only {rounds} pilot rounds"
    )]
    BadReuse {
        /// Rounds to reuse given.
        reuse: u32,
        /// Pilot rounds given.
        rounds: u32,
    },
    /// No scenario to estimate.
    #[error("no scenarios to estimate")]
    NoScenarios,
    /// A nominal declared for a scenario the estimation does not have.
    #[error("nominal declared for unknown scenario `{scenario}` (known: {known})")]
    UnknownScenario {
        /// The name given.
        scenario: String,
        /// The scenarios there are.
        known: String,
    },
    /// A nominal declared for a variable the scenario does not have.
    #[error("nominal declared for unknown variable `{variable}` of scenario `{scenario}` (its variables: {known})")]
    UnknownVariable {
        /// The scenario.
        scenario: String,
        /// The name given.
        variable: String,
        /// The variables there are.
        known: String,
    },
    /// A nominal that does not fit its variable (or has bad parameters).
    #[error("nominal of variable `{variable}` of scenario `{scenario}`: {message}")]
    BadNominal {
        /// The scenario.
        scenario: String,
        /// The variable.
        variable: String,
        /// What is wrong.
        message: String,
    },
    /// A posterior that does not fit its scenario's space.
    #[error("scenario `{scenario}`: the posterior does not fit its space: {message}")]
    Posterior {
        /// The scenario.
        scenario: String,
        /// What is wrong.
        message: String,
    },
    /// A joint proposal without pilot rounds to fit it.
    #[error("joint: the joint proposal is fitted by the cross-entropy pilot rounds: give `refine` (at least 1 round) too")]
    JointNeedsRefine,
    /// A joint proposal with no components or too many.
    #[error("joint.components: must lie in 1..={MAX_COMPONENTS}, got {0}")]
    BadComponents(u32),
    /// An LF pilot without pilot rounds.
    #[error("pilot_fidelity: `lf` runs the cross-entropy pilot rounds at the learned low fidelity: give `refine` (at least 1 round) too, or leave pilot_fidelity at `hf`")]
    LowFidelityNeedsRefine,
    /// LF pilot rounds to reuse in the (HF) estimate.
    #[error("refine reuse: {0} pilot rounds to reuse, but the pilot runs at low fidelity (pilot_fidelity = `lf`) and LF outcomes are not the HF failures the estimate is about: reuse must be 0")]
    ReuseLowFidelity(u32),
    /// Control variates with too few calibration pairs.
    #[error("control: calibration must be at least 2 pairs per scenario ({scenarios} scenarios: at least {min}), got {calibration}")]
    BadCalibration {
        /// Calibration pairs given.
        calibration: u64,
        /// The least allowed.
        min: u64,
        /// Scenarios.
        scenarios: usize,
    },
    /// Control variates with too many extra LF runs per pair.
    #[error("control: extra must lie in 0..={MAX_EXTRA} LF runs per pair, got {0}")]
    BadExtra(u32),
    /// Control variates with reused pilot rounds.
    #[error("refine reuse: {0} pilot rounds to reuse, but with control variates (`control`) the estimate is the control-variate estimate of its own pairs: reuse must be 0")]
    ReuseWithControl(u32),
    /// A cost that is negative, NaN or infinite.
    #[error("estimation trial {id}: cost must be a finite number ≥ 0, got {cost}")]
    BadCost {
        /// The trial.
        id: u64,
        /// The value given.
        cost: f64,
    },
    /// A robustness that is NaN or infinite.
    #[error("estimation trial {id}: robustness must be a finite number, got {robustness}")]
    BadRobustness {
        /// The trial.
        id: u64,
        /// The value given.
        robustness: f64,
    },
    /// A tell for a trial that was never asked, or was told already.
    #[error("estimation trial {0} is not pending (never asked, or told already)")]
    NotPending(u64),
}

/// Checks ε, the refinement and the joint proposal's options.
pub(crate) fn check_config(
    config: &EstimationConfig,
    scenarios: usize,
) -> Result<(), EstimationError> {
    let eps = config.epsilon;
    if !(eps > 0.0 && eps <= 1.0) {
        return Err(EstimationError::BadEpsilon(eps));
    }
    if let Some(Refine {
        rounds,
        runs,
        reuse,
    }) = config.refine
    {
        if rounds == 0 || runs == 0 {
            return Err(EstimationError::BadRefine { rounds, runs });
        }
        if reuse > rounds {
            return Err(EstimationError::BadReuse { reuse, rounds });
        }
    }
    if config.pilot_fidelity == Fidelity::Lf {
        match config.refine {
            None => return Err(EstimationError::LowFidelityNeedsRefine),
            Some(r) if r.reuse > 0 => return Err(EstimationError::ReuseLowFidelity(r.reuse)),
            Some(_) => {}
        }
    }
    if let Some(c) = config.control {
        if let Some(r) = config.refine.filter(|r| r.reuse > 0) {
            return Err(EstimationError::ReuseWithControl(r.reuse));
        }
        check_control(c, scenarios)?;
    }
    if let Some(j) = config.joint {
        if j.components == 0 || j.components > MAX_COMPONENTS {
            return Err(EstimationError::BadComponents(j.components));
        }
        if config.refine.is_none() {
            return Err(EstimationError::JointNeedsRefine);
        }
    }
    Ok(())
}

/// At least 2 calibration pairs per scenario, at most [`MAX_EXTRA`] extra LF runs per pair.
fn check_control(c: Control, scenarios: usize) -> Result<(), EstimationError> {
    let min = 2 * scenarios.max(1) as u64;
    if c.calibration < min {
        return Err(EstimationError::BadCalibration {
            calibration: c.calibration,
            min,
            scenarios,
        });
    }
    match c.extra {
        Some(k) if k > MAX_EXTRA => Err(EstimationError::BadExtra(k)),
        _ => Ok(()),
    }
}

//! What a trial produced (observations), how the pair of runs is classified (TP/TN/FP/FN), and
//! what the bandits are credited for it — the paper's Table I.

use serde::{Deserialize, Serialize};

/// One simulator run: did the system under test fail, how long did the run take, and —
/// optionally — how close it came to failing.
///
/// `runtime` is in whatever unit the harness uses (seconds of wall-clock by convention, or
/// deterministic work units); only ratios `t_LF / t_HF` and sums are ever taken. It must be
/// finite and strictly positive.
///
/// `robustness` is a continuous margin of the run (e.g. the smallest clearance in metres):
/// `≤ 0` on a failure by convention, and the smaller, the closer the run came to failing. It is
/// optional (the paper credits the failure flag only, and that stays the default); searches
/// that learn from near-misses ([`crate::SearchModel::EliteMixture`]) use it. A run without it
/// serialises exactly as before, so older journals load unchanged.
///
/// ```
/// use savme_kernel::Run;
/// let near_miss = Run::new(false, 2.0).with_robustness(0.4);
/// assert_eq!(near_miss.robustness, Some(0.4));
/// let json = serde_json::to_string(&Run::new(true, 1.0)).unwrap();
/// assert_eq!(json, r#"{"failure":true,"runtime":1.0}"#);
/// let old: Run = serde_json::from_str(&json).unwrap();
/// assert_eq!(old.robustness, None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Run {
    /// The system under test failed (e.g. a collision).
    pub failure: bool,
    /// Cost of the run (> 0).
    pub runtime: f64,
    /// How close the run came to failing (finite; `≤ 0` = failed, smaller = closer), if the
    /// harness measures it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robustness: Option<f64>,
}

impl Run {
    /// A run with the given outcome and cost, without a robustness value.
    pub fn new(failure: bool, runtime: f64) -> Self {
        Run {
            failure,
            runtime,
            robustness: None,
        }
    }

    /// The same run with robustness `margin` (finite; `≤ 0` = failed, smaller = closer).
    pub fn with_robustness(mut self, margin: f64) -> Self {
        self.robustness = Some(margin);
        self
    }
}

/// What the harness reports for a trial.
///
/// ```
/// use savme_kernel::{Observation, Run};
/// let paired = Observation::Paired { hf: Run::new(true, 2.0), lf: Run::new(true, 0.5) };
/// assert_eq!(paired.cost_ratio(), Some(0.25));
/// let baseline = Observation::HfOnly(Run::new(false, 2.0));
/// assert_eq!(baseline.cost_ratio(), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Observation {
    /// The high- and learned-fidelity runs of a paired trial (train, evaluate, test phases).
    Paired {
        /// The high-fidelity run.
        hf: Run,
        /// The learned-fidelity run.
        lf: Run,
    },
    /// The high-fidelity run only (baseline phase).
    HfOnly(Run),
}

impl Observation {
    /// `t_LF / t_HF` of a paired observation.
    pub fn cost_ratio(&self) -> Option<f64> {
        match self {
            Observation::Paired { hf, lf } => Some(lf.runtime / hf.runtime),
            Observation::HfOnly(_) => None,
        }
    }

    /// The high-fidelity run (present in both kinds).
    pub fn hf(&self) -> &Run {
        match self {
            Observation::Paired { hf, .. } | Observation::HfOnly(hf) => hf,
        }
    }

    /// The learned-fidelity run, if any.
    pub fn lf(&self) -> Option<&Run> {
        match self {
            Observation::Paired { lf, .. } => Some(lf),
            Observation::HfOnly(_) => None,
        }
    }

    /// The TP/TN/FP/FN class of a paired observation.
    pub fn outcome(&self) -> Option<Outcome> {
        match self {
            Observation::Paired { hf, lf } => Some(Outcome::classify(hf.failure, lf.failure)),
            Observation::HfOnly(_) => None,
        }
    }
}

/// The class of a paired trial, with *failure* as the positive class.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Outcome {
    /// Both runs failed.
    TP,
    /// Neither run failed.
    TN,
    /// Only the learned-fidelity run failed.
    FP,
    /// Only the high-fidelity run failed.
    FN,
}

impl Outcome {
    /// Classifies a pair of failure flags.
    ///
    /// ```
    /// use savme_kernel::Outcome;
    /// assert_eq!(Outcome::classify(true, false), Outcome::FN);
    /// ```
    pub fn classify(hf_failure: bool, lf_failure: bool) -> Outcome {
        match (hf_failure, lf_failure) {
            (true, true) => Outcome::TP,
            (false, false) => Outcome::TN,
            (false, true) => Outcome::FP,
            (true, false) => Outcome::FN,
        }
    }

    /// Table I, fidelity column: a success when the simulators agree (TP or TN) *and*
    /// `t_LF / t_HF ≤ C_budget`; a loss otherwise.
    pub fn fidelity_success(self, cost_ratio: f64, budget: f64) -> bool {
        matches!(self, Outcome::TP | Outcome::TN) && cost_ratio <= budget
    }

    /// Table I, scenario column: a success when the high-fidelity run failed (TP or FN).
    pub fn scenario_success(self) -> bool {
        matches!(self, Outcome::TP | Outcome::FN)
    }
}

/// What one tell credited to the bandits: `Some(true)` a success, `Some(false)` a loss,
/// `None` nothing (evaluation and baseline trials update nothing).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Credit {
    /// Credit to the fidelity bandits p_ω(θ_LF).
    pub fidelity: Option<bool>,
    /// Credit to the trial scenario's bandits p_ψ(φ | s).
    pub scenario: Option<bool>,
}

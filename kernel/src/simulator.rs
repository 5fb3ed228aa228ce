//! The interface every simulator adapter implements (the bundled driving simulator, FMUs, …).

use crate::outcome::Run;
use crate::value::Assignment;

/// How a run's cost is measured when it is turned into a [`Run`] for the kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CostMeasure {
    /// Measured wall-clock seconds (the paper's runtime).
    #[default]
    Wall,
    /// Deterministic work units (steps, rays, pixels): noise-free, for tests and reproducible
    /// campaigns.
    Work,
}

/// What one simulation produced.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SimResult {
    /// The system under test failed.
    pub failure: bool,
    /// Measured wall-clock time of the run, in seconds.
    pub wall_seconds: f64,
    /// Deterministic work units, if the simulator counts them.
    pub work: Option<u64>,
    /// How close the run came to failing (finite; `≤ 0` = failed, smaller = closer), if the
    /// simulator measures it: passed on to [`Run::robustness`].
    pub robustness: Option<f64>,
}

impl SimResult {
    /// A result with a measured wall-clock time and an optional work count.
    pub fn new(failure: bool, wall_seconds: f64, work: Option<u64>) -> Self {
        SimResult {
            failure,
            wall_seconds,
            work,
            robustness: None,
        }
    }

    /// The same result with a robustness margin (see [`Run::robustness`]); a non-finite
    /// margin is dropped (the run then reports none), so a simulator cannot make its trial
    /// untellable by it.
    ///
    /// ```
    /// use savme_kernel::{CostMeasure, SimResult};
    /// let r = SimResult::new(false, 0.02, Some(400)).with_robustness(1.5);
    /// assert_eq!(r.run(CostMeasure::Work)?.robustness, Some(1.5));
    /// assert_eq!(SimResult::new(false, 0.02, None).with_robustness(f64::INFINITY).robustness, None);
    /// # Ok::<(), savme_kernel::SimError>(())
    /// ```
    pub fn with_robustness(mut self, margin: f64) -> Self {
        self.robustness = margin.is_finite().then_some(margin);
        self
    }

    /// The run as the kernel sees it, with its cost measured as asked.
    ///
    /// ```
    /// use savme_kernel::{CostMeasure, SimResult};
    /// let r = SimResult::new(true, 0.02, Some(400));
    /// assert_eq!(r.run(CostMeasure::Work)?.runtime, 400.0);
    /// assert!(SimResult::new(true, 0.02, None).run(CostMeasure::Work).is_err());
    /// # Ok::<(), savme_kernel::SimError>(())
    /// ```
    pub fn run(&self, measure: CostMeasure) -> Result<Run, SimError> {
        let runtime = match measure {
            CostMeasure::Wall => self.wall_seconds,
            CostMeasure::Work => self.work.ok_or(SimError::NoWorkCount)? as f64,
        };
        let run = Run::new(self.failure, runtime);
        Ok(match self.robustness {
            Some(r) => run.with_robustness(r),
            None => run,
        })
    }
}

/// Why a simulation could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The simulator does not know the scenario.
    #[error("unknown scenario `{0}`")]
    UnknownScenario(String),
    /// A variable the simulator needs is missing.
    #[error("no value for `{variable}`")]
    MissingVariable {
        /// The variable.
        variable: String,
    },
    /// A variable's value is of the wrong kind or out of range.
    #[error("`{variable}` = {value}: {expected}")]
    BadValue {
        /// The variable.
        variable: String,
        /// The value given.
        value: String,
        /// What was expected.
        expected: String,
    },
    /// Work units were asked for, but the simulator does not count them.
    #[error("this simulator does not count work units; measure wall-clock time instead")]
    NoWorkCount,
    /// The simulator itself failed.
    #[error("simulation failed: {0}")]
    Failed(String),
}

/// Which of a trial's two runs a simulation is: the one role type of the whole toolkit (the
/// executor, the work queue, the FMU workers and the viewer all speak it). Serialised as
/// `"hf"` / `"lf"`.
///
/// ```
/// use savme_kernel::Role;
/// assert_eq!((Role::High.key(), Role::Learned.name()), ("hf", "LF"));
/// assert_eq!(Role::from_key("lf"), Some(Role::Learned));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Role {
    /// The high-fidelity run (θ_HF).
    #[serde(rename = "hf")]
    High,
    /// The learned-fidelity run (θ_LF).
    #[serde(rename = "lf")]
    Learned,
}

impl Role {
    /// `hf` or `lf` (as stored and sent).
    pub fn key(self) -> &'static str {
        match self {
            Role::High => "hf",
            Role::Learned => "lf",
        }
    }

    /// `HF` or `LF` (as messages name it).
    pub fn name(self) -> &'static str {
        match self {
            Role::High => "HF",
            Role::Learned => "LF",
        }
    }

    /// The role of a key written by [`Role::key`].
    pub fn from_key(key: &str) -> Option<Role> {
        match key {
            "hf" => Some(Role::High),
            "lf" => Some(Role::Learned),
            _ => None,
        }
    }
}

/// A simulator the kernel's trials can be run on: one call runs scenario `scenario` with
/// parameters `phi` under fidelity settings `fidelity` and reports failure and cost.
///
/// A paired trial calls it twice, with θ_HF and with θ_LF. Implementations take `&mut self` so
/// that stateful back-ends (an FMU instance) fit; a campaign running trials in parallel makes
/// one simulator per worker.
pub trait Simulator {
    /// Runs one simulation as the HF or the LF run of a trial (`role`): a simulator whose HF
    /// and LF runs are different programs (two FMUs) runs the role's one; one program for both
    /// may ignore it. The role is always explicit — never guessed from θ.
    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError>;
}

//! The campaign driver: runs the paper's protocol (baseline, meta-training, evaluation,
//! meta-testing) on any [`Simulator`](savme_kernel::Simulator), in parallel, resumable, and
//! writes its results. One [`Campaign`] loop serves every front end.
//!
//! - [`protocol`]: what runs (stages, iterations, budgets, seeds); [`config`]: the protocol and
//!   problem from presets, campaign files and command-line flags, in one place;
//! - [`Campaign`] (`builder`): the loop; [`executor`]: how trials run (worker threads, trials
//!   told in ask order); `kernels`: the kernel of each stage;
//! - [`store`]: where trial lines live ([`store::TrialStore`], the locked JSON-lines default);
//!   [`log`]: what a trial line holds;
//! - [`observer`]: progress displays and other watchers; [`Stop`]: asking a running campaign
//!   to stop between trials (it resumes where it stopped);
//! - [`report`], [`figures`] (drawn by savme-plot), [`outputs`]: tables, figures and files
//!   computed from the trials.
//!
//! ```no_run
//! use savme_campaign::{Campaign, Problem, Protocol};
//! use savme_sim::sim::DrivingSimulator;
//!
//! let (train, test) = savme_sim::scenario::train_test_names();
//! let protocol = Protocol::quick("savme-sim/sensors", train, test);
//! let problem = Problem::from(savme_sim::problem(protocol.fidelity_bins));
//! let outcome = Campaign::new(protocol, problem)
//!     .out("results")
//!     .run(&DrivingSimulator::default())?;
//! println!("{}", outcome.report.table_md());
//! # Ok::<(), savme_campaign::CampaignError>(())
//! ```

mod builder;
pub mod config;
mod error;
pub mod estimate;
pub mod executor;
pub mod figures;
mod kernels;
pub mod log;
pub mod observer;
pub mod outputs;
pub mod protocol;
mod repeat;
pub mod report;
mod shell;
pub mod source;
pub mod stage;
mod stop;
pub mod toy;
pub mod values;

/// Where trial lines live: the [`store::TrialStore`] seam and the locked JSON-lines default
/// (crate `savme-store`).
pub use savme_store as store;

pub use builder::Campaign;
pub use error::{CampaignError, SimulationError};
pub use observer::{Observer, ProgressBars, ProgressLines};
pub use outputs::{load_protocol, Outputs};
pub use protocol::{
    Allocate, Cost, Deploy, LadderTraining, LogBins, Method, OnError, Protocol, ScreenLf, Search,
    ThetaLfChoice, Transfer, TUNED_PAIR_FRACTION, TUNED_PAIR_SETTLE,
};
pub use repeat::{load_repeat, RepeatFile, Repeated, RepeatedOutcome, MAX_REPEAT};
pub use report::Report;
pub use shell::shell_quote;
pub use stage::{Stage, StageId, StageKind};
pub use stop::Stop;

use savme_kernel::Space;
use std::collections::BTreeMap;

/// What a finished campaign returns.
#[derive(Debug, Clone)]
pub struct CampaignOutcome {
    /// The results.
    pub report: Report,
    /// Where they were written.
    pub outputs: Outputs,
    /// Trials replayed from `trials.jsonl` (resume) and run by this process.
    pub replayed: u64,
    /// Trials run by this process.
    pub ran: u64,
    /// Wall-clock seconds this process spent.
    pub elapsed_seconds: f64,
    /// Every told trial (replayed and run), in store order.
    pub trials: Vec<log::TrialLine>,
    /// Trials withdrawn because a simulation failed (`on_error = "skip"`; stored as failed
    /// lines with their error), replayed and run.
    pub withdrawn: u64,
}

/// What is searched: the fidelity space with θ_HF, and each scenario's parameter space.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// The fidelity settings θ.
    pub fidelity: Space,
    /// θ_HF.
    pub theta_hf: savme_kernel::Assignment,
    /// Scenario parameter spaces φ by scenario name.
    pub scenarios: BTreeMap<String, Space>,
}

impl Problem {
    /// The problem as `protocol` runs it: its log-scaled variables (fidelity settings and
    /// scenario parameters) binned as `log_bins` says — unchanged with savme's bins.
    pub fn binned_for(&self, protocol: &Protocol) -> Result<Problem, CampaignError> {
        if protocol.log_bins == LogBins::Savme {
            return Ok(self.clone());
        }
        let scale = protocol.log_bins.scale();
        let bad = |e: savme_kernel::SpaceError| CampaignError::Protocol {
            field: "log_bins".into(),
            message: e.to_string(),
        };
        Ok(Problem {
            fidelity: self.fidelity.with_log_scale(scale).map_err(bad)?,
            theta_hf: self.theta_hf.clone(),
            scenarios: self
                .scenarios
                .iter()
                .map(|(name, s)| Ok((name.clone(), s.with_log_scale(scale).map_err(bad)?)))
                .collect::<Result<_, CampaignError>>()?,
        })
    }
}

impl From<(Space, savme_kernel::Assignment, BTreeMap<String, Space>)> for Problem {
    /// A problem from its fidelity space, θ_HF and scenario spaces (e.g. what
    /// `savme_sim::problem` returns).
    fn from(
        (fidelity, theta_hf, scenarios): (Space, savme_kernel::Assignment, BTreeMap<String, Space>),
    ) -> Self {
        Problem {
            fidelity,
            theta_hf,
            scenarios,
        }
    }
}

//! # savme-kernel
//!
//! The ask/tell kernel of SAVME (Schlichting, Boord, Corso, Kochenderfer, ITSC 2023): it learns,
//! at the same time, where an autonomous system fails — per-scenario distributions p_ψ(φ | s)
//! over scenario parameters — and which cheap simulator fidelity settings θ_LF agree with the
//! high-fidelity simulator within a compute budget — one scenario-agnostic p_ω(θ_LF). Both are
//! independent Beta–Bernoulli Thompson-sampling bandits, one per variable; continuous variables
//! are binned. Beyond the paper, [`SearchModel::EliteMixture`] replaces the independent φ bins
//! of the learning phases with a joint proposal learned from failures (and, optionally,
//! near-misses by a run's [`Run::robustness`]); [`SearchModel::IndependentBins`], the paper's,
//! stays the default of [`Kernel::builder`].
//!
//! **Defaults.** [`Kernel::builder`] starts from the paper's SAVME ([`Preset::Paper`]: θ_LF* =
//! MAP, independent bins, a frozen deployment, scenarios from p(s)), so that a kernel built in
//! Rust reproduces the paper unless told otherwise; `.preset(Preset::Tuned)`
//! ([`KernelBuilder::preset`]) takes savme's tuned settings (θ_LF* from evidence, the elite
//! search, an adaptive deployment, the cost-rate allocation). Each entry point's default:
//!
//! | entry point | default |
//! |---|---|
//! | [`Kernel::builder`] (Rust) | paper (MAP) |
//! | a configuration's JSON ([`KernelConfig`]: `savme serve --config`, `Kernel.from_config`, `savme_kernel_new`) | as written: `"estimator"` is required; a missing `search`, `deployment` or `allocation` is the paper's |
//! | `savme example-config` | tuned (evidence); `--method paper` |
//! | Python's `savme.Kernel(...)` | tuned (evidence); `method="paper"` or `estimator="map"` |
//! | the C ABI's builder (`savme_builder_*`) | tuned (evidence); `savme_builder_method(b, SAVME_METHOD_PAPER)` or `savme_builder_estimator(b, SAVME_ESTIMATOR_MAP)` |
//! | a campaign (`savme run`, a campaign file, Python's `Campaign`) | tuned (evidence); `--method paper` |
//! | `savme reproduce` | paper (MAP) |
//!
//! The kernel is pure: it suggests trials ([`Kernel::ask`]) and ingests their outcomes
//! ([`Kernel::tell`]); the harness runs the simulators, in any language, in any order.
//!
//! ```
//! use savme_kernel::{Assignment, Kernel, Observation, Run, Scale, Space, Variable};
//! let fidelity = Space::new(vec![
//!     Variable::discrete("rate_hz", [2, 5, 10]),
//!     Variable::continuous("view_m", 10.0, 5000.0, 10, Scale::Log),
//! ])?;
//! let theta_hf = Assignment::new().with("rate_hz", 10).with("view_m", 5000.0);
//! let phi = Space::new(vec![Variable::continuous("gap_m", 5.0, 50.0, 9, Scale::Linear)])?;
//! let mut kernel = Kernel::builder(fidelity, theta_hf)
//!     .scenario("lead_brakes", phi, 1.0)
//!     .budget(0.3)
//!     .seed(1)
//!     .build()?;
//! for _ in 0..100 {
//!     let t = kernel.ask();
//!     let gap = t.phi.get_f64("gap_m").unwrap();
//!     let rate = t.theta_lf.as_ref().unwrap().get_f64("rate_hz").unwrap();
//!     let hf = Run::new(gap < 15.0, 1.0);
//!     let lf = Run::new(gap < 15.0 || rate < 3.0, rate / 10.0);
//!     kernel.tell(t.id, Observation::Paired { hf, lf })?;
//! }
//! println!("θ_LF* = {}", kernel.fidelity_estimate(savme_kernel::Estimator::Map));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

mod allocation;
mod deployment;
pub mod estimation;
pub mod evidence;
pub mod journal;
mod kernel;
pub mod metrics;
mod outcome;
mod pairing;
pub mod phi_transfer;
mod posterior;
mod sampler;
pub mod screening;
mod search;
mod simulator;
mod space;
mod value;

pub use allocation::{Allocation, AllocationError, CostRate, Ledger, RECENT_HALF_LIFE};
pub use deployment::Deployment;
pub use kernel::{
    ConfigError, FidelityPrior, Kernel, KernelBuilder, KernelConfig, KernelStats, Phase, Preset,
    RestoreError, Scenario, ScenarioPrior, Snapshot, TellError, Trial, TrialRecord,
};
pub use outcome::{Credit, Observation, Outcome, Run};
pub use pairing::{Pairing, PairingError};
pub use posterior::{Arm, Estimator, Posterior, PosteriorError, PriorCounts};
pub use search::{EliteMixture, SearchError, SearchModel, PARZEN_POINTS};
pub use simulator::{CostMeasure, Role, SimError, SimResult, Simulator};
pub use space::{Domain, Scale, Space, SpaceError, Variable, MAX_ARMS};
pub use value::{Assignment, Num, Value};

/// The crate README's example, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

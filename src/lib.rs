//! # savme
//!
//! Find the failures of an autonomous system in simulation fast. This package is the toolkit's
//! library and the `savme` command line over it:
//! - [`kernel`]: the ask/tell kernel (crate `savme-kernel`);
//! - [`campaign`]: the one campaign loop ([`campaign::Campaign`]), its protocol and problem,
//!   reports and figures (crate `savme-campaign`); [`store`]: the trial store seam;
//!   [`compose`]: the composition layer the CLI and Python share; [`adapter`]: the simulator
//!   adapters (each registers itself);
//!   `postgres`: campaigns in PostgreSQL (feature `postgres`);
//! - [`viewer`]: recording to the rerun viewer (feature `rerun`);
//! - [`json`]: the JSON documents the command line prints, and their schemas;
//! - [`serve`]: the kernel behind a JSON-lines protocol, for harnesses in any language;
//! - [`toy`]: a small paired simulator to try things on.
//!
//! The command line (`savme reproduce`, `savme run`, `savme serve`, …) is a thin layer over
//! this library. Embedding the kernel in a harness of your own takes an ask, your simulators,
//! and a tell:
//!
//! ```
//! use savme::kernel::{Estimator, Observation, Role, Run, Simulator};
//! use savme::toy::{kernel_builder, ToySimulator};
//!
//! let mut kernel = kernel_builder().budget(0.3).seed(1).build()?;
//! let mut sim = ToySimulator;
//! for _ in 0..20 {
//!     let trial = kernel.ask();
//!     let theta_lf = trial.theta_lf.clone().expect("meta-training pairs HF with LF");
//!     let hf = sim.simulate_as(Role::High, &trial.scenario, &trial.phi, kernel.theta_hf())?;
//!     let lf = sim.simulate_as(Role::Learned, &trial.scenario, &trial.phi, &theta_lf)?;
//!     let (hf, lf) = (Run::new(hf.failure, hf.wall_seconds), Run::new(lf.failure, lf.wall_seconds));
//!     kernel.tell(trial.id, Observation::Paired { hf, lf })?;
//! }
//! println!("θ_LF* so far: {}", kernel.fidelity_estimate(Estimator::Map));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! A whole campaign (the paper's protocol, outputs, resume) is [`campaign::Campaign`].
#![warn(missing_docs)]

/// The campaign layer (crate `savme-campaign`).
pub use savme_campaign as campaign;
pub use savme_campaign::toy;
pub use savme_kernel as kernel;
/// OpenSCENARIO parameter value distributions as φ-spaces and nominals.
pub use savme_openscenario as openscenario;
/// Campaigns in PostgreSQL (crate `savme-postgres`, feature `postgres`).
#[cfg(feature = "postgres")]
pub use savme_postgres as postgres;
/// The kernel served: a plain or journaled session and its JSON-lines protocol (crate
/// `savme-serve`).
pub use savme_serve as serve;
/// The trial store seam and the JSON-lines store (crate `savme-store`).
pub use savme_store as store;
/// Recording to the rerun viewer (crate `savme-viewer`; the recorder needs feature `rerun`).
pub use savme_viewer as viewer;
pub mod adapter;
pub mod compose;
pub mod json;

/// The README's code, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

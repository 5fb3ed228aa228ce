//! # savme
//!
//! Find the failures of an autonomous system in simulation fast. This package is the toolkit's
//! library and the `savme` command line over it:
//! - [`kernel`]: the ask/tell kernel (crate `savme-kernel`);
//! - [`campaign`]: the one campaign loop ([`campaign::Campaign`]), its protocol and problem,
//!   the trial store ([`campaign::store`]), reports and figures;
//! - [`viewer`]: recording to the rerun viewer (feature `rerun`);
//! - [`serve`]: the kernel behind a JSON-lines protocol, for harnesses in any language;
//! - [`toy`]: a small paired simulator to try things on.
//!
//! The command line (`savme reproduce`, `savme run`, `savme serve`, …) is a thin layer over
//! this library. Embedding the kernel in a harness of your own takes an ask, your simulators,
//! and a tell:
//!
//! ```
//! use savme::kernel::{Estimator, Observation, Run, Simulator};
//! use savme::toy::{kernel_builder, ToySimulator};
//!
//! let mut kernel = kernel_builder().budget(0.3).seed(1).build()?;
//! let mut sim = ToySimulator;
//! for _ in 0..20 {
//!     let trial = kernel.ask();
//!     let theta_lf = trial.theta_lf.clone().expect("meta-training pairs HF with LF");
//!     let hf = sim.simulate(&trial.scenario, &trial.phi, kernel.theta_hf())?;
//!     let lf = sim.simulate(&trial.scenario, &trial.phi, &theta_lf)?;
//!     let (hf, lf) = (Run::new(hf.failure, hf.wall_seconds), Run::new(lf.failure, lf.wall_seconds));
//!     kernel.tell(trial.id, Observation::Paired { hf, lf })?;
//! }
//! println!("θ_LF* so far: {}", kernel.fidelity_estimate(Estimator::Map));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! A whole campaign (the paper's protocol, outputs, resume) is [`campaign::Campaign`].
#![warn(missing_docs)]

pub use savme_kernel as kernel;
pub mod campaign;
pub mod serve;
pub mod toy;
pub mod viewer;

/// The README's code, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

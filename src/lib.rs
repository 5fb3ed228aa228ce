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

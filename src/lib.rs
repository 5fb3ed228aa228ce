//! # savme
//!
//! Find the failures of an autonomous system in simulation fast. This package gathers the
//! toolkit: the ask/tell kernel ([`kernel`], crate `savme-kernel`) and a small paired
//! simulator to try it on ([`toy`]). The campaign driver, the bundled camera/lidar driving
//! simulator and the FMU adapter join it as they land.
#![warn(missing_docs)]

pub use savme_kernel as kernel;
pub mod campaign;
pub mod cli;
pub mod fmu_campaign;
#[cfg(feature = "rerun")]
pub mod record;
pub mod recording;
pub mod reproduce;
pub mod serve;
pub mod toy;

/// The README's code, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

//! Export a Rust model as an FMI 2.0 co-simulation FMU.
//!
//! A model implements [`Model`] (its variables, how it initialises from its parameters and how
//! it steps); [`export_fmi2!`] then defines every function of the FMI 2.0 co-simulation C API
//! in the `cdylib` crate that invokes it — those fmu-runner calls and all the others FMPy binds
//! (`fmi2Reset`, `fmi2Terminate`, FMU state, status queries, …). [`model_description`] writes
//! the matching `modelDescription.xml` (with `ModelStructure`: outputs and initial unknowns) and
//! [`pack`] zips it with the shared library into an `.fmu`.
//!
//! Values live in the export layer, indexed by value reference; the model reads its parameters
//! from them when initialised and writes its outputs into them when stepped.

#![warn(missing_docs)]

mod description;
mod ffi;
mod instance;
mod macros;
mod model;
mod pack;
mod state;
mod status;
mod values;

pub use description::model_description;
pub use ffi::{CallbackFunctions, Logger, Status};
pub use instance::{
    do_step, enter_initialization_mode, exit_initialization_mode, free_instance, instantiate,
    reset, set_debug_logging, setup_experiment, terminate, types_platform, version, Instance,
};
pub use model::{Causality, Kind, Model, Scalar, Variable};
pub use pack::{pack, pack_with, platform_folder, PackError};
pub use state::{free_state, get_state, set_state};
pub use status::{last_successful_time, terminated, unsupported};
pub use values::{get_set, strings, Access};

//! Export a Rust model as an FMI 2.0 or FMI 3.0 co-simulation FMU.
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
//!
//! ```
//! use savme_fmi_export::{model_description, Model, Scalar, Variable};
//! use std::sync::OnceLock;
//!
//! /// A car braking from `speed` at `decel`: fails when it has not stopped within `room` metres.
//! #[derive(Clone)]
//! struct Braking { speed: f64, decel: f64, room: f64, travelled: f64 }
//!
//! impl Model for Braking {
//!     const MODEL_NAME: &'static str = "braking";
//!     const MODEL_IDENTIFIER: &'static str = "braking";
//!     const GUID: &'static str = "{0b7a1c2e-0000-4000-8000-000000000001}";
//!     const DESCRIPTION: &'static str = "a braking car";
//!     const DEFAULT_EXPERIMENT: (f64, f64) = (10.0, 0.01);
//!
//!     fn variables() -> &'static [Variable] {
//!         static VARS: OnceLock<Vec<Variable>> = OnceLock::new();
//!         VARS.get_or_init(|| vec![
//!             Variable::parameter("speed", Scalar::Real(20.0), "initial speed").unit("m/s"),
//!             Variable::parameter("decel", Scalar::Real(6.0), "deceleration").range(1.0, 10.0),
//!             Variable::parameter("room", Scalar::Real(30.0), "distance to the obstacle"),
//!             Variable::output("collision", Scalar::Boolean(false), "hit the obstacle"),
//!         ])
//!     }
//!
//!     fn initialize(v: &mut [Scalar], _start: f64) -> Result<Self, String> {
//!         let [speed, decel, room] = [0, 1, 2].map(|i| v[i].as_f64());
//!         Ok(Braking { speed, decel, room, travelled: 0.0 })
//!     }
//!
//!     fn do_step(&mut self, v: &mut [Scalar], _time: f64, step: f64) -> Result<(), String> {
//!         self.travelled += self.speed * step;
//!         self.speed = (self.speed - self.decel * step).max(0.0);
//!         v[3] = Scalar::Boolean(self.travelled >= self.room);
//!         Ok(())
//!     }
//! }
//!
//! // In a `cdylib` crate: `savme_fmi_export::export_fmi2!(Braking);` defines the C API, and
//! // `pack` zips this description with the built library into `braking.fmu`.
//! let xml = model_description::<Braking>();
//! assert!(xml.contains(r#"modelIdentifier="braking""#) && xml.contains(r#"name="collision""#));
//! ```

#![warn(missing_docs)]

mod description;
mod ffi;
mod instance;
mod macros;
mod macros3;
mod model;
mod pack;
mod state;
mod status;
mod values;

pub use description::{model_description, model_description3};
pub use ffi::{CallbackFunctions, LogMessage3, Logger, Status};
pub use instance::{
    do_step, do_step3, enter_initialization_mode, enter_initialization_mode3,
    exit_initialization_mode, free_instance, instantiate, instantiate3, reset, set_debug_logging,
    setup_experiment, terminate, types_platform, version, version3, Instance,
};
pub use model::{Causality, Kind, Model, Scalar, Variable};
pub use pack::{
    pack, pack_bytes, pack_library_bytes, pack_with, platform_folder, platform_tuple, FmiVersion,
    PackError,
};
pub use state::{free_state, get_state, set_state};
pub use status::{last_successful_time, terminated, unsupported};
pub use values::{get_set, get_set3, no_variables, strings, Access};

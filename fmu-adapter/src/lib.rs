//! # savme-fmu
//!
//! FMI 2.0 and FMI 3.0 co-simulation FMUs as savme's paired simulators. [`FmuFile::open`] checks and loads
//! an `.fmu` once (its library is shared by every instance); [`FmuSimulator`] maps φ and θ to
//! FMU variables by name (type-checked: Real / Integer / Boolean, parameters or inputs), runs
//! `fmi2SetupExperiment` → initialisation → `fmi2DoStep` up to the stop time (the step size may
//! be a fidelity variable), reads a failure signal (a Boolean output, or a Real output against
//! a threshold; optionally stopping at the failure) and a cost (wall-clock or an output);
//! [`worker`] runs evaluations in a child process so that a crashing or hanging FMU costs one
//! trial, not the campaign; [`campaign_file`] reads and checks the TOML campaign file of
//! `savme run --config` against its FMUs.
//!
//! The model description is parsed here ([`description`], quick-xml, both schemas) and the
//! archive unpacked with the zip crate; the calls on an instance go through libfmi's bindings
//! of the FMI 2.0 C API or this crate's of the FMI 3.0 one ([`fmi3`]), behind one
//! [`instance::Instance`]: everything above it is the same for both versions.

#![warn(missing_docs)]

pub mod backend;
pub mod campaign_file;
pub mod declared;
pub mod description;
pub mod file;
pub mod fmi3;
pub mod inspect;
pub mod instance;
pub mod log;
pub mod simulator;
pub mod worker;

pub use backend::FmuBackend;
pub use description::{ModelDescription, Repr, VarCausality, VarInfo, VarType};
pub use file::{FmuDescription, FmuFile};
pub use simulator::{
    Binding, CostSource, Crossing, Failure, Fixed, FmuSimulator, RunSpec, ScenarioSpec, StepSize,
    Tolerance, Trace,
};

/// Why an FMU could not be used. Every variant names the FMU (its path) and, where there is
/// one, the variable or the FMI call.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FmuError {
    /// The file does not exist or cannot be read.
    #[error("{fmu}: {source}")]
    Missing {
        /// The FMU.
        fmu: String,
        /// The error.
        source: std::io::Error,
    },
    /// Not a zip archive.
    #[error("{fmu}: not an FMU (not a zip archive: {message})")]
    NotAZip {
        /// The FMU.
        fmu: String,
        /// What the zip reader said.
        message: String,
    },
    /// No `modelDescription.xml` in the archive.
    #[error("{fmu}: no modelDescription.xml in the archive")]
    NoModelDescription {
        /// The FMU.
        fmu: String,
    },
    /// The model description cannot be read.
    #[error("{fmu}: modelDescription.xml: {message}")]
    BadModelDescription {
        /// The FMU.
        fmu: String,
        /// What is wrong.
        message: String,
    },
    /// Neither FMI 2.0 nor FMI 3.0.
    #[error("{fmu}: fmiVersion is \"{version}\"; savme runs FMI 2.0 and FMI 3.0 co-simulation FMUs only")]
    UnsupportedVersion {
        /// The FMU.
        fmu: String,
        /// The version found.
        version: String,
    },
    /// No co-simulation interface.
    #[error(
        "{fmu}: no CoSimulation element; savme runs co-simulation FMUs only (this one is {kinds})"
    )]
    NoCoSimulation {
        /// The FMU.
        fmu: String,
        /// What it is instead: `model exchange`, `scheduled execution` (FMI 3.0, clocked
        /// partitions), both, or `neither`.
        kinds: String,
    },
    /// No binary for this platform.
    #[error("{fmu}: no binary for this platform ({expected})")]
    NoBinary {
        /// The FMU.
        fmu: String,
        /// The path inside the archive.
        expected: String,
    },
    /// The shared library cannot be loaded.
    #[error("{fmu}: cannot load the library: {message}")]
    Load {
        /// The FMU.
        fmu: String,
        /// The loader's message.
        message: String,
    },
    /// A required FMI function is missing.
    #[error("{fmu}: the library does not export {function}")]
    MissingFunction {
        /// The FMU.
        fmu: String,
        /// The function.
        function: String,
    },
    /// No variable of that name.
    #[error("{fmu}: no variable `{variable}` (the FMU has: {known})")]
    UnknownVariable {
        /// The FMU.
        fmu: String,
        /// The name asked for.
        variable: String,
        /// The FMU's variables.
        known: String,
    },
    /// A variable of the wrong type.
    #[error("{fmu}: variable `{variable}` is {found}, expected {expected}")]
    WrongType {
        /// The FMU.
        fmu: String,
        /// The variable.
        variable: String,
        /// What it is.
        found: String,
        /// What was needed.
        expected: String,
    },
    /// A variable of the wrong causality.
    #[error("{fmu}: variable `{variable}` cannot be used here: expected {expected}")]
    WrongCausality {
        /// The FMU.
        fmu: String,
        /// The variable.
        variable: String,
        /// What was needed.
        expected: String,
    },
    /// A value outside what the model description declares for a variable (its `min` / `max`,
    /// its enumeration items).
    #[error("{fmu}: variable `{variable}` {message}")]
    OutOfRange {
        /// The FMU.
        fmu: String,
        /// The variable.
        variable: String,
        /// What is declared and what lies outside.
        message: String,
    },
    /// An FMU that can be instantiated only once per process, asked to run in this one.
    #[error("{fmu}: the FMU declares canBeInstantiatedOnlyOncePerProcess=\"true\": savme runs it in worker processes only (set [fmu] isolate = true)")]
    OnlyOncePerProcess {
        /// The FMU.
        fmu: String,
    },
    /// A trial lacks a value for a bound variable.
    #[error("no value for `{variable}` in the trial")]
    MissingValue {
        /// The savme variable.
        variable: String,
    },
    /// An FMI call failed.
    #[error("{fmu}: {call} failed ({status}){log}")]
    Call {
        /// The FMU.
        fmu: String,
        /// The FMI function.
        call: String,
        /// Its status.
        status: String,
        /// The FMU's last log messages of the run (bounded), as `; the FMU logged: …`, or
        /// `""`.
        log: String,
    },
    /// An FMU worker could not load the FMUs (the message names the FMU and, for a crash, the
    /// signal).
    #[error("{0}")]
    Worker(String),
    /// The FMU's library crashed while a child process loaded and instantiated it (the check
    /// before a campaign runs it in this process, where the crash would end savme).
    #[error("{fmu}: the FMU's library crashed while it was loaded and instantiated in a test process ({status}); in this process it would end the campaign at once — `isolate = true` in [fmu] runs the FMU in worker processes, where a crash costs one run, not savme")]
    CrashedOnLoad {
        /// The FMU.
        fmu: String,
        /// How the test process ended (`killed by signal 7 (SIGBUS: …)`).
        status: String,
    },
    /// The run specification is invalid.
    #[error("run specification: {0}")]
    Spec(String),
    /// A local I/O problem.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The error.
        source: std::io::Error,
    },
}

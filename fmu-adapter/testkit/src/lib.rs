//! A trivial co-simulation FMU: `x` grows at `rate` from `x0`; `failed` turns true once `x`
//! reaches `threshold`. Its `fault` parameter makes it misbehave on purpose, for the adapter's
//! bad-input tests: 1 = `fmi2DoStep` returns an error from `fault_time` on, 2 = the process
//! aborts there, 3 = `fmi2DoStep` never returns (a hang), 4 = the process dies of a segfault.
//!
//! Its `modelDescription.xml` is [`model_description`]; the shared library built from this
//! crate (`libsavme_fmu_testkit.so`) is the binary.

use savme_fmi_export::{Model, Scalar, Variable};
use std::sync::OnceLock;

/// The trivial model.
#[derive(Debug, Clone)]
pub struct Trivial {
    x0: f64,
    rate: f64,
    threshold: f64,
    fault: i32,
    fault_time: f64,
    steps: i32,
}

/// Value references.
pub mod vr {
    /// `x0` (Real parameter).
    pub const X0: u32 = 0;
    /// `rate` (Real parameter).
    pub const RATE: u32 = 1;
    /// `threshold` (Real parameter).
    pub const THRESHOLD: u32 = 2;
    /// `fault` (Integer parameter).
    pub const FAULT: u32 = 3;
    /// `fault_time` (Real parameter).
    pub const FAULT_TIME: u32 = 4;
    /// `enabled` (Boolean parameter, unused by the model: a Boolean to map in tests).
    pub const ENABLED: u32 = 5;
    /// `x` (Real output).
    pub const X: u32 = 6;
    /// `failed` (Boolean output).
    pub const FAILED: u32 = 7;
    /// `steps` (Integer output).
    pub const STEPS: u32 = 8;
}

impl Model for Trivial {
    const MODEL_NAME: &'static str = "savme_fmu_testkit";
    const MODEL_IDENTIFIER: &'static str = "savme_fmu_testkit";
    const GUID: &'static str = "{5a1e7e57-0000-4000-8000-7e57c0ffee01}";
    const DESCRIPTION: &'static str = "A trivial model with injectable faults (savme tests)";
    const DEFAULT_EXPERIMENT: (f64, f64) = (1.0, 0.01);

    fn variables() -> &'static [Variable] {
        static VARS: OnceLock<Vec<Variable>> = OnceLock::new();
        VARS.get_or_init(|| {
            vec![
                Variable::parameter("x0", Scalar::Real(0.0), "initial value"),
                Variable::parameter("rate", Scalar::Real(1.0), "growth per second"),
                Variable::parameter("threshold", Scalar::Real(0.5), "failure threshold"),
                Variable::parameter(
                    "fault",
                    Scalar::Integer(0),
                    "0 none, 1 doStep error, 2 abort, 3 hang, 4 segfault",
                )
                .range(0.0, 4.0),
                Variable::parameter("fault_time", Scalar::Real(0.0), "when the fault strikes"),
                Variable::parameter("enabled", Scalar::Boolean(true), "unused"),
                Variable::output("x", Scalar::Real(0.0), "the state"),
                Variable::output("failed", Scalar::Boolean(false), "x reached the threshold"),
                Variable::output("steps", Scalar::Integer(0), "steps taken"),
            ]
        })
    }

    fn initialize(values: &mut [Scalar], _start: f64) -> Result<Self, String> {
        let real = |r: u32| values[r as usize].as_f64();
        let m = Trivial {
            x0: real(vr::X0),
            rate: real(vr::RATE),
            threshold: real(vr::THRESHOLD),
            fault: real(vr::FAULT) as i32,
            fault_time: real(vr::FAULT_TIME),
            steps: 0,
        };
        values[vr::X as usize] = Scalar::Real(m.x0);
        values[vr::FAILED as usize] = Scalar::Boolean(m.x0 >= m.threshold);
        values[vr::STEPS as usize] = Scalar::Integer(0);
        Ok(m)
    }

    fn do_step(&mut self, values: &mut [Scalar], time: f64, step: f64) -> Result<(), String> {
        if time + step > self.fault_time {
            match self.fault {
                1 => return Err(format!("injected fault at t = {time}")),
                2 => std::process::abort(),
                3 => loop {
                    std::thread::sleep(std::time::Duration::from_secs(1));
                },
                4 => {
                    // SAFETY: not safe at all — a deliberate segfault for the crash test.
                    unsafe { std::ptr::null_mut::<u64>().write_volatile(1) };
                }
                _ => {}
            }
        }
        self.steps += 1;
        let x = self.x0 + self.rate * (time + step);
        values[vr::X as usize] = Scalar::Real(x);
        values[vr::FAILED as usize] = Scalar::Boolean(x >= self.threshold);
        values[vr::STEPS as usize] = Scalar::Integer(self.steps);
        Ok(())
    }
}

// The library exports both C APIs; the model description packed with it picks one.
savme_fmi_export::export_fmi2!(Trivial);
savme_fmi_export::export_fmi3!(Trivial);

/// The FMU's `modelDescription.xml` (FMI 2.0).
pub fn model_description() -> String {
    savme_fmi_export::model_description::<Trivial>()
}

/// The FMU's FMI 3.0 `modelDescription.xml` (the same library: it exports the FMI 3.0 API
/// too).
pub fn model_description3() -> String {
    savme_fmi_export::model_description3::<Trivial>()
}

/// The `braking` test FMU written in C (`examples/fmu/braking`), compiled by this crate's build
/// script: its shared library.
pub fn braking_library() -> std::path::PathBuf {
    env!("SAVME_BRAKING_LIB").into()
}

/// The `braking` FMU's `modelDescription.xml`.
pub const BRAKING_MODEL_DESCRIPTION: &str =
    include_str!("../../../examples/fmu/braking/modelDescription.xml");

/// The `braking` model against the FMI 3.0 C API (`examples/fmu/braking/braking3.c`), compiled
/// by this crate's build script.
pub fn braking3_library() -> std::path::PathBuf {
    env!("SAVME_BRAKING3_LIB").into()
}

/// The FMI 3.0 `braking` FMU's `modelDescription.xml`.
pub const BRAKING3_MODEL_DESCRIPTION: &str =
    include_str!("../../../examples/fmu/braking/modelDescription3.xml");

/// Packs the FMI 3.0 `braking` FMU into `out` (with its resources unless `with_resources` is
/// false).
pub fn pack_braking3(
    out: &std::path::Path,
    with_resources: bool,
) -> Result<(), savme_fmi_export::PackError> {
    pack_braking_library(
        out,
        BRAKING3_MODEL_DESCRIPTION,
        with_resources,
        &braking3_library(),
    )
}

/// The `braking` FMU's `resources/friction.txt`.
pub const BRAKING_FRICTION: &str =
    include_str!("../../../examples/fmu/braking/resources/friction.txt");

/// The `braking` FMU built to refuse a second live instance in a process (for a model
/// description that declares `canBeInstantiatedOnlyOncePerProcess="true"`).
pub fn braking_once_library() -> std::path::PathBuf {
    env!("SAVME_BRAKING_ONCE_LIB").into()
}

/// Packs the `braking` FMU into `out` with `model_description` and, when `with_resources`, its
/// `resources/friction.txt`.
pub fn pack_braking(
    out: &std::path::Path,
    model_description: &str,
    with_resources: bool,
) -> Result<(), savme_fmi_export::PackError> {
    pack_braking_library(out, model_description, with_resources, &braking_library())
}

/// [`pack_braking`] with another build of its library.
pub fn pack_braking_library(
    out: &std::path::Path,
    model_description: &str,
    with_resources: bool,
    library: &std::path::Path,
) -> Result<(), savme_fmi_export::PackError> {
    let files: &[(&str, &[u8])] = if with_resources {
        &[("resources/friction.txt", BRAKING_FRICTION.as_bytes())]
    } else {
        &[]
    };
    savme_fmi_export::pack_with(model_description, "braking", library, files, out)
}

/// A shared library that dies of SIGBUS while it is loaded (its constructor raises it).
pub fn crash_on_load_library() -> std::path::PathBuf {
    env!("SAVME_CRASH_ON_LOAD_LIB").into()
}

/// The `stairs` test FMU (`testkit/c/stairs.c`, both C APIs): the third-party behaviours of
/// issue 26 — failures at t = 0, FMI 3.0 early returns at events computed as k·period, a stop
/// request at the failure (fmi2Discard / terminateSimulation) and a reset that keeps it.
pub fn stairs_library() -> std::path::PathBuf {
    env!("SAVME_STAIRS_LIB").into()
}

/// The `stairs` FMU's FMI 2.0 `modelDescription.xml`.
pub const STAIRS_MODEL_DESCRIPTION: &str = include_str!("../c/stairs.xml");

/// The `stairs` FMU's FMI 3.0 `modelDescription.xml`.
pub const STAIRS3_MODEL_DESCRIPTION: &str = include_str!("../c/stairs3.xml");

/// Packs the `stairs` FMU of FMI version `fmi` (2 or 3) into `out`, its model description
/// edited by `edit` (e.g. to declare a fixed step size).
pub fn pack_stairs(
    out: &std::path::Path,
    fmi: u8,
    edit: impl FnOnce(&str) -> String,
) -> Result<(), savme_fmi_export::PackError> {
    let xml = if fmi == 3 {
        STAIRS3_MODEL_DESCRIPTION
    } else {
        STAIRS_MODEL_DESCRIPTION
    };
    savme_fmi_export::pack(&edit(xml), "stairs", &stairs_library(), out)
}

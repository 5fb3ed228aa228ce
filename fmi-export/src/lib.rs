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

use std::ffi::{c_char, c_void, CStr, CString};
use std::io::Write;
use std::path::Path;

/// The type of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `fmi2Real` (f64).
    Real,
    /// `fmi2Integer` (i32).
    Integer,
    /// `fmi2Boolean`.
    Boolean,
}

/// A variable's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scalar {
    /// A real.
    Real(f64),
    /// An integer.
    Integer(i32),
    /// A boolean.
    Boolean(bool),
}

impl Scalar {
    /// Its kind.
    pub fn kind(self) -> Kind {
        match self {
            Scalar::Real(_) => Kind::Real,
            Scalar::Integer(_) => Kind::Integer,
            Scalar::Boolean(_) => Kind::Boolean,
        }
    }

    /// As f64 (integers and booleans converted).
    pub fn as_f64(self) -> f64 {
        match self {
            Scalar::Real(x) => x,
            Scalar::Integer(i) => f64::from(i),
            Scalar::Boolean(b) => f64::from(u8::from(b)),
        }
    }

    fn xml(self) -> String {
        match self {
            Scalar::Real(x) => format!("{x:?}"),
            Scalar::Integer(i) => i.to_string(),
            Scalar::Boolean(b) => b.to_string(),
        }
    }
}

/// Who sets a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set before initialisation, fixed afterwards.
    Parameter,
    /// Computed by the model.
    Output,
}

/// One scalar variable; its value reference is its position in [`Model::variables`].
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Unique name.
    pub name: String,
    /// Who sets it.
    pub causality: Causality,
    /// Start value (parameters); the initial value of an output.
    pub start: Scalar,
    /// Lower bound of a parameter, if any (Real and Integer only).
    pub min: Option<f64>,
    /// Upper bound of a parameter, if any.
    pub max: Option<f64>,
    /// Unit, if any (Real only).
    pub unit: Option<&'static str>,
    /// What it is.
    pub description: String,
}

impl Variable {
    /// A parameter with a start value.
    pub fn parameter(name: &str, start: Scalar, description: &str) -> Self {
        Variable {
            name: name.into(),
            causality: Causality::Parameter,
            start,
            min: None,
            max: None,
            unit: None,
            description: description.into(),
        }
    }

    /// An output, initially `start`.
    pub fn output(name: &str, start: Scalar, description: &str) -> Self {
        Variable {
            causality: Causality::Output,
            ..Variable::parameter(name, start, description)
        }
    }

    /// With bounds.
    pub fn range(mut self, min: f64, max: f64) -> Self {
        self.min = Some(min);
        self.max = Some(max);
        self
    }

    /// With a unit.
    pub fn unit(mut self, unit: &'static str) -> Self {
        self.unit = Some(unit);
        self
    }
}

/// A model to export.
pub trait Model: Sized + Clone + Send + 'static {
    /// `modelName`.
    const MODEL_NAME: &'static str;
    /// `modelIdentifier`: the shared library's file stem.
    const MODEL_IDENTIFIER: &'static str;
    /// `guid`, checked by `fmi2Instantiate`.
    const GUID: &'static str;
    /// What the model is.
    const DESCRIPTION: &'static str;
    /// `DefaultExperiment`: stop time and step size.
    const DEFAULT_EXPERIMENT: (f64, f64);

    /// The variables; value reference = index.
    fn variables() -> &'static [Variable];

    /// Builds the model from the parameter values (all variables, by value reference) at
    /// `fmi2ExitInitializationMode`; may write initial outputs.
    fn initialize(values: &mut [Scalar], start_time: f64) -> Result<Self, String>;

    /// Advances from `time` by `step`, writing outputs into `values`.
    fn do_step(&mut self, values: &mut [Scalar], time: f64, step: f64) -> Result<(), String>;
}

// ---- The C side ----------------------------------------------------------------------------

/// `fmi2Status`.
#[allow(missing_docs)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

/// `fmi2CallbackLogger` (C-variadic).
pub type Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char, ...);

/// `fmi2CallbackFunctions`.
#[allow(missing_docs)]
#[repr(C)]
#[derive(Clone, Copy)]
pub struct CallbackFunctions {
    pub logger: Option<Logger>,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, Status)>,
    pub component_environment: *mut c_void,
}

/// Where an instance is in the FMI 2.0 co-simulation state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Instantiated,
    Initialization,
    Stepping,
    Terminated,
    Failed,
}

/// An FMU instance (what `fmi2Component` points to).
pub struct Instance<M: Model> {
    name: CString,
    callbacks: Option<CallbackFunctions>,
    logging: bool,
    values: Vec<Scalar>,
    phase: Phase,
    start: f64,
    time: f64,
    model: Option<M>,
}

impl<M: Model> Clone for Instance<M> {
    fn clone(&self) -> Self {
        Instance {
            name: self.name.clone(),
            callbacks: self.callbacks,
            logging: self.logging,
            values: self.values.clone(),
            phase: self.phase,
            start: self.start,
            time: self.time,
            model: self.model.clone(),
        }
    }
}

impl<M: Model> Instance<M> {
    fn new(name: CString, callbacks: Option<CallbackFunctions>, logging: bool) -> Self {
        Instance {
            name,
            callbacks,
            logging,
            values: M::variables().iter().map(|v| v.start).collect(),
            phase: Phase::Instantiated,
            start: 0.0,
            time: 0.0,
            model: None,
        }
    }

    /// Reports through the environment's logger (errors always, the rest with logging on).
    fn log(&self, status: Status, category: &str, message: &str) {
        if status == Status::Ok && !self.logging {
            return;
        }
        let Some(logger) = self.callbacks.and_then(|c| c.logger) else {
            return;
        };
        let env = self
            .callbacks
            .map_or(std::ptr::null_mut(), |c| c.component_environment);
        let category = CString::new(category).unwrap_or_default();
        let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
        // SAFETY: the logger is the environment's C function; "%s" with one C string.
        unsafe {
            logger(
                env,
                self.name.as_ptr(),
                status,
                category.as_ptr(),
                c"%s".as_ptr(),
                message.as_ptr(),
            )
        };
    }

    fn fail(&mut self, call: &str, message: &str) -> Status {
        self.log(
            Status::Error,
            "logStatusError",
            &format!("{call}: {message}"),
        );
        Status::Error
    }

    fn reset(&mut self) {
        self.values = M::variables().iter().map(|v| v.start).collect();
        self.phase = Phase::Instantiated;
        self.start = 0.0;
        self.time = 0.0;
        self.model = None;
    }
}

/// The instance behind a component pointer.
///
/// # Safety
/// `c` must be null or a pointer returned by [`instantiate`] for the same model and not freed.
unsafe fn instance<'a, M: Model>(c: *mut c_void) -> Option<&'a mut Instance<M>> {
    // SAFETY: by the caller's contract.
    unsafe { (c as *mut Instance<M>).as_mut() }
}

/// `fmi2GetTypesPlatform`.
pub fn types_platform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`.
pub fn version() -> *const c_char {
    c"2.0".as_ptr()
}

/// `fmi2Instantiate`.
///
/// # Safety
/// Pointers as in the FMI 2.0 standard (C strings may be null; `functions` null or valid).
pub unsafe fn instantiate<M: Model>(
    instance_name: *const c_char,
    fmu_type: i32,
    guid: *const c_char,
    functions: *const CallbackFunctions,
    logging_on: i32,
) -> *mut c_void {
    // SAFETY: C strings from the environment.
    let text = |p: *const c_char| unsafe { (!p.is_null()).then(|| CStr::from_ptr(p).to_owned()) };
    // SAFETY: the environment's callbacks struct, copied.
    let callbacks = unsafe { functions.as_ref().copied() };
    let name = text(instance_name).unwrap_or_default();
    let probe = Instance::<M>::new(name.clone(), callbacks, logging_on != 0);
    if fmu_type != 1 {
        probe.log(
            Status::Error,
            "logStatusError",
            "fmi2Instantiate: this FMU supports co-simulation only (fmuType = fmi2CoSimulation)",
        );
        return std::ptr::null_mut();
    }
    let given = text(guid).map(|g| g.to_string_lossy().into_owned());
    if given.as_deref() != Some(M::GUID) {
        probe.log(
            Status::Error,
            "logStatusError",
            &format!(
                "fmi2Instantiate: GUID {:?} does not match this FMU's {}",
                given.unwrap_or_default(),
                M::GUID
            ),
        );
        return std::ptr::null_mut();
    }
    Box::into_raw(Box::new(probe)) as *mut c_void
}

/// `fmi2FreeInstance`.
///
/// # Safety
/// See [`instance`].
pub unsafe fn free_instance<M: Model>(c: *mut c_void) {
    if !c.is_null() {
        // SAFETY: created by `instantiate` with Box::into_raw.
        drop(unsafe { Box::from_raw(c as *mut Instance<M>) });
    }
}

/// `fmi2SetDebugLogging`.
///
/// # Safety
/// See [`instance`].
pub unsafe fn set_debug_logging<M: Model>(c: *mut c_void, on: i32) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    i.logging = on != 0;
    Status::Ok
}

/// `fmi2SetupExperiment`.
///
/// # Safety
/// See [`instance`].
pub unsafe fn setup_experiment<M: Model>(c: *mut c_void, start: f64) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if i.phase != Phase::Instantiated {
        return i.fail(
            "fmi2SetupExperiment",
            "only allowed after fmi2Instantiate or fmi2Reset",
        );
    }
    i.start = start;
    i.time = start;
    Status::Ok
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// See [`instance`].
pub unsafe fn enter_initialization_mode<M: Model>(c: *mut c_void) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if i.phase != Phase::Instantiated {
        return i.fail("fmi2EnterInitializationMode", "called twice or too late");
    }
    i.phase = Phase::Initialization;
    Status::Ok
}

/// `fmi2ExitInitializationMode`: builds the model from the parameters.
///
/// # Safety
/// See [`instance`].
pub unsafe fn exit_initialization_mode<M: Model>(c: *mut c_void) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if i.phase != Phase::Initialization {
        return i.fail(
            "fmi2ExitInitializationMode",
            "not in initialization mode (call fmi2EnterInitializationMode first)",
        );
    }
    match M::initialize(&mut i.values, i.start) {
        Ok(m) => {
            i.model = Some(m);
            i.phase = Phase::Stepping;
            Status::Ok
        }
        Err(e) => {
            i.phase = Phase::Failed;
            i.fail("fmi2ExitInitializationMode", &e)
        }
    }
}

/// `fmi2Terminate`.
///
/// # Safety
/// See [`instance`].
pub unsafe fn terminate<M: Model>(c: *mut c_void) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    i.phase = Phase::Terminated;
    Status::Ok
}

/// `fmi2Reset`: back to the state after `fmi2Instantiate` (start values restored).
///
/// # Safety
/// See [`instance`].
pub unsafe fn reset<M: Model>(c: *mut c_void) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    i.reset();
    Status::Ok
}

/// `fmi2DoStep`.
///
/// # Safety
/// See [`instance`].
pub unsafe fn do_step<M: Model>(c: *mut c_void, time: f64, step: f64) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if i.phase != Phase::Stepping {
        return i.fail("fmi2DoStep", "not initialised, or terminated, or failed");
    }
    if !(step > 0.0 && step.is_finite()) {
        return i.fail(
            "fmi2DoStep",
            &format!("communication step size {step} is not positive"),
        );
    }
    if (time - i.time).abs() > 1e-9 * (1.0 + time.abs()) {
        return i.fail(
            "fmi2DoStep",
            &format!(
                "communication point {time} is not the current time {}",
                i.time
            ),
        );
    }
    let Some(model) = i.model.as_mut() else {
        return i.fail("fmi2DoStep", "no model");
    };
    match model.do_step(&mut i.values, time, step) {
        Ok(()) => {
            i.time = time + step;
            Status::Ok
        }
        Err(e) => {
            i.phase = Phase::Failed;
            i.fail("fmi2DoStep", &e)
        }
    }
}

/// Checks the value references and kinds of a get or set call.
fn check<M: Model>(
    i: &mut Instance<M>,
    call: &str,
    vr: &[u32],
    kind: Kind,
    set: bool,
) -> Result<(), Status> {
    let vars = M::variables();
    for &r in vr {
        let Some(v) = vars.get(r as usize) else {
            return Err(i.fail(call, &format!("unknown value reference {r}")));
        };
        if v.start.kind() != kind {
            return Err(i.fail(
                call,
                &format!("`{}` is {:?}, not {kind:?}", v.name, v.start.kind()),
            ));
        }
        if set {
            let allowed = v.causality == Causality::Parameter
                && matches!(i.phase, Phase::Instantiated | Phase::Initialization);
            if !allowed {
                return Err(i.fail(
                    call,
                    &format!(
                        "`{}` cannot be set now (parameters are set before fmi2ExitInitializationMode; outputs never)",
                        v.name
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A get or a set of one kind of value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Access {
    /// The kind of the values.
    pub kind: Kind,
    /// Set (true) or get.
    pub set: bool,
}

/// Reads or writes `n` values of one kind: the body of the `fmi2Get*` / `fmi2Set*` functions.
///
/// # Safety
/// `vr` points to `n` value references and `values` to `n` values (FMI 2.0 standard).
pub unsafe fn get_set<M: Model, T: Copy>(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *mut T,
    access: Access,
    convert_in: impl Fn(T) -> Scalar,
    convert_out: impl Fn(Scalar) -> T,
) -> Status {
    let Access { kind, set } = access;
    let call = match (set, kind) {
        (false, Kind::Real) => "fmi2GetReal",
        (false, Kind::Integer) => "fmi2GetInteger",
        (false, Kind::Boolean) => "fmi2GetBoolean",
        (true, Kind::Real) => "fmi2SetReal",
        (true, Kind::Integer) => "fmi2SetInteger",
        (true, Kind::Boolean) => "fmi2SetBoolean",
    };
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if n == 0 {
        return Status::Ok;
    }
    if vr.is_null() || values.is_null() {
        return i.fail(call, "null array");
    }
    // SAFETY: n value references, by the caller's contract.
    let refs = unsafe { std::slice::from_raw_parts(vr, n) };
    if let Err(s) = check(i, call, refs, kind, set) {
        return s;
    }
    for (k, &r) in refs.iter().enumerate() {
        // SAFETY: n values, by the caller's contract.
        let slot = unsafe { values.add(k) };
        if set {
            // SAFETY: see above.
            let v = convert_in(unsafe { *slot });
            if let (Scalar::Real(x), Some(var)) = (v, M::variables().get(r as usize)) {
                if !x.is_finite() {
                    return i.fail(call, &format!("`{}` = {x} is not finite", var.name));
                }
            }
            i.values[r as usize] = v;
        } else {
            // SAFETY: see above.
            unsafe { *slot = convert_out(i.values[r as usize]) };
        }
    }
    Status::Ok
}

/// `fmi2GetString` / `fmi2SetString`: this FMU has no string variables.
///
/// # Safety
/// See [`instance`].
pub unsafe fn strings<M: Model>(c: *mut c_void, n: usize, set: bool) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if n == 0 {
        return Status::Ok;
    }
    let call = if set {
        "fmi2SetString"
    } else {
        "fmi2GetString"
    };
    i.fail(call, "this FMU has no string variables")
}

/// `fmi2GetFMUstate`: a copy of the instance.
///
/// # Safety
/// See [`instance`]; `state` points to a writable `fmi2FMUstate`.
pub unsafe fn get_state<M: Model>(c: *mut c_void, state: *mut *mut c_void) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if state.is_null() {
        return i.fail("fmi2GetFMUstate", "null state pointer");
    }
    let copy = Box::into_raw(Box::new(i.clone())) as *mut c_void;
    // SAFETY: writable by contract. A state passed in is overwritten in place (FMI 2.0 §2.1.8).
    unsafe {
        let old = *state;
        if !old.is_null() {
            drop(Box::from_raw(old as *mut Instance<M>));
        }
        *state = copy;
    }
    Status::Ok
}

/// `fmi2SetFMUstate`.
///
/// # Safety
/// See [`instance`]; `state` from [`get_state`].
pub unsafe fn set_state<M: Model>(c: *mut c_void, state: *mut c_void) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    // SAFETY: a state made by `get_state`.
    let Some(s) = (unsafe { (state as *mut Instance<M>).as_ref() }) else {
        return i.fail("fmi2SetFMUstate", "null state");
    };
    let (name, callbacks, logging) = (i.name.clone(), i.callbacks, i.logging);
    *i = s.clone();
    i.name = name;
    i.callbacks = callbacks;
    i.logging = logging;
    Status::Ok
}

/// `fmi2FreeFMUstate`.
///
/// # Safety
/// `state` points to a state from [`get_state`] or null.
pub unsafe fn free_state<M: Model>(state: *mut *mut c_void) -> Status {
    if state.is_null() {
        return Status::Ok;
    }
    // SAFETY: by contract.
    unsafe {
        let s = *state;
        if !s.is_null() {
            drop(Box::from_raw(s as *mut Instance<M>));
        }
        *state = std::ptr::null_mut();
    }
    Status::Ok
}

/// A function this FMU does not provide (its capability flag is false in the model
/// description): logs why and returns `fmi2Error`.
///
/// # Safety
/// See [`instance`].
pub unsafe fn unsupported<M: Model>(c: *mut c_void, call: &str, why: &str) -> Status {
    // SAFETY: see above.
    match unsafe { instance::<M>(c) } {
        Some(i) => {
            i.log(Status::Error, "logStatusError", &format!("{call}: {why}"));
            Status::Error
        }
        None => Status::Error,
    }
}

/// `fmi2GetRealStatus(fmi2LastSuccessfulTime)` and friends: the time reached.
///
/// # Safety
/// See [`instance`].
pub unsafe fn last_successful_time<M: Model>(c: *mut c_void, kind: i32, value: *mut f64) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if kind != 2 || value.is_null() {
        return i.fail(
            "fmi2GetRealStatus",
            "only fmi2LastSuccessfulTime is available",
        );
    }
    // SAFETY: writable by contract.
    unsafe { *value = i.time };
    Status::Ok
}

/// `fmi2GetBooleanStatus(fmi2Terminated)`: this FMU never asks to terminate early.
///
/// # Safety
/// See [`instance`].
pub unsafe fn terminated<M: Model>(c: *mut c_void, kind: i32, value: *mut i32) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    if kind != 3 || value.is_null() {
        return i.fail("fmi2GetBooleanStatus", "only fmi2Terminated is available");
    }
    // SAFETY: writable by contract.
    unsafe { *value = 0 };
    Status::Ok
}

/// Defines the FMI 2.0 co-simulation C API for `$model` (a [`Model`]) in the invoking crate,
/// which must be a `cdylib`.
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        mod fmi2_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc)]
            use super::*;
            use std::ffi::{c_char, c_void};
            use $crate::{Access, CallbackFunctions, Kind, Scalar, Status};
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                $crate::types_platform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                $crate::version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: *mut c_void,
                on: i32,
                _n: usize,
                _categories: *const *const c_char,
            ) -> Status {
                unsafe { $crate::set_debug_logging::<M>(c, on) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: *const c_char,
                fmu_type: i32,
                guid: *const c_char,
                _resources: *const c_char,
                functions: *const CallbackFunctions,
                _visible: i32,
                logging_on: i32,
            ) -> *mut c_void {
                unsafe { $crate::instantiate::<M>(name, fmu_type, guid, functions, logging_on) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: *mut c_void) {
                unsafe { $crate::free_instance::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: *mut c_void,
                _tolerance_defined: i32,
                _tolerance: f64,
                start: f64,
                _stop_defined: i32,
                _stop: f64,
            ) -> Status {
                unsafe { $crate::setup_experiment::<M>(c, start) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: *mut c_void) -> Status {
                unsafe { $crate::enter_initialization_mode::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: *mut c_void) -> Status {
                unsafe { $crate::exit_initialization_mode::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: *mut c_void) -> Status {
                unsafe { $crate::terminate::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: *mut c_void) -> Status {
                unsafe { $crate::reset::<M>(c) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *mut f64,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, f64>(
                        c,
                        vr,
                        n,
                        v,
                        Access {
                            kind: Kind::Real,
                            set: false,
                        },
                        Scalar::Real,
                        |s| s.as_f64(),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *mut i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v,
                        Access {
                            kind: Kind::Integer,
                            set: false,
                        },
                        Scalar::Integer,
                        |s| match s {
                            Scalar::Integer(i) => i,
                            other => other.as_f64() as i32,
                        },
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *mut i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v,
                        Access {
                            kind: Kind::Boolean,
                            set: false,
                        },
                        |b| Scalar::Boolean(b != 0),
                        |s| i32::from(s.as_f64() != 0.0),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: *mut c_void,
                _vr: *const u32,
                n: usize,
                _v: *mut *const c_char,
            ) -> Status {
                unsafe { $crate::strings::<M>(c, n, false) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *const f64,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, f64>(
                        c,
                        vr,
                        n,
                        v as *mut f64,
                        Access {
                            kind: Kind::Real,
                            set: true,
                        },
                        Scalar::Real,
                        |s| s.as_f64(),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *const i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v as *mut i32,
                        Access {
                            kind: Kind::Integer,
                            set: true,
                        },
                        Scalar::Integer,
                        |s| s.as_f64() as i32,
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: *mut c_void,
                vr: *const u32,
                n: usize,
                v: *const i32,
            ) -> Status {
                unsafe {
                    $crate::get_set::<M, i32>(
                        c,
                        vr,
                        n,
                        v as *mut i32,
                        Access {
                            kind: Kind::Boolean,
                            set: true,
                        },
                        |b| Scalar::Boolean(b != 0),
                        |s| i32::from(s.as_f64() != 0.0),
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: *mut c_void,
                _vr: *const u32,
                n: usize,
                _v: *const *const c_char,
            ) -> Status {
                unsafe { $crate::strings::<M>(c, n, true) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: *mut c_void,
                state: *mut *mut c_void,
            ) -> Status {
                unsafe { $crate::get_state::<M>(c, state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(c: *mut c_void, state: *mut c_void) -> Status {
                unsafe { $crate::set_state::<M>(c, state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                _c: *mut c_void,
                state: *mut *mut c_void,
            ) -> Status {
                unsafe { $crate::free_state::<M>(state) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: *mut c_void,
                _state: *mut c_void,
                _size: *mut usize,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2SerializedFMUstateSize",
                        "canSerializeFMUstate is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: *mut c_void,
                _state: *mut c_void,
                _bytes: *mut c_char,
                _size: usize,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2SerializeFMUstate",
                        "canSerializeFMUstate is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: *mut c_void,
                _bytes: *const c_char,
                _size: usize,
                _state: *mut *mut c_void,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2DeSerializeFMUstate",
                        "canSerializeFMUstate is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: *mut c_void,
                _unknown: *const u32,
                _n_unknown: usize,
                _known: *const u32,
                _n_known: usize,
                _dv_known: *const f64,
                _dv_unknown: *mut f64,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetDirectionalDerivative",
                        "providesDirectionalDerivative is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: *mut c_void,
                _vr: *const u32,
                _n: usize,
                _order: *const i32,
                _v: *const f64,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2SetRealInputDerivatives",
                        "canInterpolateInputs is false",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: *mut c_void,
                _vr: *const u32,
                _n: usize,
                _order: *const i32,
                _v: *mut f64,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetRealOutputDerivatives",
                        "maxOutputDerivativeOrder is 0",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: *mut c_void,
                time: f64,
                step: f64,
                _no_set_prior: i32,
            ) -> Status {
                unsafe { $crate::do_step::<M>(c, time, step) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: *mut c_void) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2CancelStep",
                        "fmi2DoStep never returns fmi2Pending",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: *mut c_void,
                _kind: i32,
                _value: *mut Status,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetStatus",
                        "fmi2DoStep never returns fmi2Pending",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: *mut c_void,
                kind: i32,
                value: *mut f64,
            ) -> Status {
                unsafe { $crate::last_successful_time::<M>(c, kind, value) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: *mut c_void,
                _kind: i32,
                _value: *mut i32,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetIntegerStatus",
                        "no integer status is defined",
                    )
                }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: *mut c_void,
                kind: i32,
                value: *mut i32,
            ) -> Status {
                unsafe { $crate::terminated::<M>(c, kind, value) }
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: *mut c_void,
                _kind: i32,
                _value: *mut *const c_char,
            ) -> Status {
                unsafe {
                    $crate::unsupported::<M>(
                        c,
                        "fmi2GetStringStatus",
                        "fmi2DoStep never returns fmi2Pending",
                    )
                }
            }
        }
    };
}

// ---- modelDescription.xml and packing ------------------------------------------------------

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The `modelDescription.xml` of `M`.
pub fn model_description<M: Model>() -> String {
    let mut x = String::new();
    let (stop, step) = M::DEFAULT_EXPERIMENT;
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x.push_str(&format!(
        "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{}\" guid=\"{}\" description=\"{}\" \
         generationTool=\"savme-fmi-export {}\" variableNamingConvention=\"structured\" \
         numberOfEventIndicators=\"0\">\n",
        escape(M::MODEL_NAME),
        escape(M::GUID),
        escape(M::DESCRIPTION),
        env!("CARGO_PKG_VERSION"),
    ));
    x.push_str(&format!(
        "  <CoSimulation modelIdentifier=\"{}\" canHandleVariableCommunicationStepSize=\"true\" \
         canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"false\" \
         providesDirectionalDerivative=\"false\" canInterpolateInputs=\"false\" \
         canNotUseMemoryManagementFunctions=\"true\"/>\n",
        escape(M::MODEL_IDENTIFIER)
    ));
    let units: Vec<&str> = {
        let mut u: Vec<&str> = M::variables().iter().filter_map(|v| v.unit).collect();
        u.sort_unstable();
        u.dedup();
        u
    };
    if !units.is_empty() {
        x.push_str("  <UnitDefinitions>\n");
        for u in &units {
            x.push_str(&format!("    <Unit name=\"{}\"/>\n", escape(u)));
        }
        x.push_str("  </UnitDefinitions>\n");
    }
    x.push_str(&format!(
        "  <DefaultExperiment startTime=\"0.0\" stopTime=\"{stop:?}\" stepSize=\"{step:?}\"/>\n"
    ));
    x.push_str("  <ModelVariables>\n");
    for (r, v) in M::variables().iter().enumerate() {
        let (causality, variability, initial) = match (v.causality, v.start.kind()) {
            (Causality::Parameter, _) => ("parameter", "fixed", "exact"),
            (Causality::Output, Kind::Real) => ("output", "continuous", "calculated"),
            (Causality::Output, _) => ("output", "discrete", "calculated"),
        };
        x.push_str(&format!(
            "    <ScalarVariable name=\"{}\" valueReference=\"{r}\" description=\"{}\" \
             causality=\"{causality}\" variability=\"{variability}\" initial=\"{initial}\">\n",
            escape(&v.name),
            escape(&v.description)
        ));
        let tag = match v.start.kind() {
            Kind::Real => "Real",
            Kind::Integer => "Integer",
            Kind::Boolean => "Boolean",
        };
        let mut attrs = String::new();
        if let (Some(u), Kind::Real) = (v.unit, v.start.kind()) {
            attrs.push_str(&format!(" unit=\"{}\"", escape(u)));
        }
        if v.start.kind() != Kind::Boolean {
            let num = |y: f64| match v.start.kind() {
                Kind::Integer => format!("{}", y as i64),
                _ => format!("{y:?}"),
            };
            if let Some(m) = v.min {
                attrs.push_str(&format!(" min=\"{}\"", num(m)));
            }
            if let Some(m) = v.max {
                attrs.push_str(&format!(" max=\"{}\"", num(m)));
            }
        }
        if v.causality == Causality::Parameter {
            attrs.push_str(&format!(" start=\"{}\"", v.start.xml()));
        }
        x.push_str(&format!("      <{tag}{attrs}/>\n    </ScalarVariable>\n"));
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n");
    let outputs: Vec<usize> = M::variables()
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(r, _)| r + 1)
        .collect();
    for i in &outputs {
        x.push_str(&format!(
            "      <Unknown index=\"{i}\" dependencies=\"\"/>\n"
        ));
    }
    x.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    for i in &outputs {
        x.push_str(&format!(
            "      <Unknown index=\"{i}\" dependencies=\"\"/>\n"
        ));
    }
    x.push_str("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n");
    x
}

/// The `binaries/` folder of this platform (`linux64`, `darwin64`, `win64`).
pub fn platform_folder() -> String {
    let os = match std::env::consts::OS {
        "macos" => "darwin",
        "windows" => "win",
        other => other,
    };
    let bits = if cfg!(target_pointer_width = "64") {
        "64"
    } else {
        "32"
    };
    format!("{os}{bits}")
}

/// Why packing failed.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// The zip archive could not be written.
    #[error("{path}: {source}")]
    Zip {
        /// The archive.
        path: String,
        /// The error.
        source: zip::result::ZipError,
    },
}

/// Writes `out` (an `.fmu`): `modelDescription.xml` (the given text) and `library` as
/// `binaries/<platform>/<identifier>.<so|dylib|dll>`.
pub fn pack(
    model_description: &str,
    identifier: &str,
    library: &Path,
    out: &Path,
) -> Result<(), PackError> {
    let io = |path: &Path| {
        let path = path.display().to_string();
        move |source| PackError::Io { path, source }
    };
    let zip_err = |source| PackError::Zip {
        path: out.display().to_string(),
        source,
    };
    let lib = std::fs::read(library).map_err(io(library))?;
    let file = std::fs::File::create(out).map_err(io(out))?;
    let mut z = zip::ZipWriter::new(file);
    let opts = zip::write::FileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .unix_permissions(0o755);
    z.start_file("modelDescription.xml", opts)
        .map_err(zip_err)?;
    z.write_all(model_description.as_bytes()).map_err(io(out))?;
    let ext = std::env::consts::DLL_EXTENSION;
    z.start_file(
        format!("binaries/{}/{identifier}.{ext}", platform_folder()),
        opts,
    )
    .map_err(zip_err)?;
    z.write_all(&lib).map_err(io(out))?;
    z.finish().map_err(zip_err)?;
    Ok(())
}

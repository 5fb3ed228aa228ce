//! An FMU instance and its co-simulation state machine (instantiated → initialisation →
//! stepping → terminated, or failed): the bodies of the life-cycle functions `export_fmi2!` and
//! `export_fmi3!` define, from `fmi2Instantiate` / `fmi3InstantiateCoSimulation` to
//! `fmi2DoStep` / `fmi3DoStep`. One state machine serves both versions; only the logger and
//! the entry points differ.

use crate::ffi::{CallbackFunctions, LogMessage3, Status};
use crate::model::{Model, Scalar};
use std::ffi::{c_char, c_void, CStr, CString};

/// Where an instance is in the FMI 2.0 co-simulation state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    Instantiated,
    Initialization,
    Stepping,
    Terminated,
    Failed,
}

/// Where an instance's log messages go: FMI 2.0's callbacks (a C-variadic logger) or FMI 3.0's
/// `logMessage` with its instance environment.
#[derive(Clone, Copy)]
pub(crate) enum LogTarget {
    Fmi2(Option<CallbackFunctions>),
    Fmi3 {
        env: *mut c_void,
        log: Option<LogMessage3>,
    },
}

/// An FMU instance (what `fmi2Component` / `fmi3Instance` points to).
pub struct Instance<M: Model> {
    pub(crate) name: CString,
    pub(crate) target: LogTarget,
    pub(crate) logging: bool,
    pub(crate) values: Vec<Scalar>,
    pub(crate) phase: Phase,
    pub(crate) start: f64,
    pub(crate) time: f64,
    pub(crate) model: Option<M>,
}

impl<M: Model> Clone for Instance<M> {
    fn clone(&self) -> Self {
        Instance {
            name: self.name.clone(),
            target: self.target,
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
    pub(crate) fn new(name: CString, target: LogTarget, logging: bool) -> Self {
        Instance {
            name,
            target,
            logging,
            values: M::variables().iter().map(|v| v.start).collect(),
            phase: Phase::Instantiated,
            start: 0.0,
            time: 0.0,
            model: None,
        }
    }

    /// Reports through the environment's logger (errors always, the rest with logging on).
    pub(crate) fn log(&self, status: Status, category: &str, message: &str) {
        if status == Status::Ok && !self.logging {
            return;
        }
        let category = CString::new(category).unwrap_or_default();
        let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
        match self.target {
            LogTarget::Fmi2(Some(CallbackFunctions {
                logger: Some(logger),
                component_environment,
                ..
            })) => {
                // SAFETY: the logger is the environment's C function; "%s" with one C string.
                unsafe {
                    logger(
                        component_environment,
                        self.name.as_ptr(),
                        status,
                        category.as_ptr(),
                        c"%s".as_ptr(),
                        message.as_ptr(),
                    )
                };
            }
            LogTarget::Fmi3 {
                env,
                log: Some(log),
            } => {
                // SAFETY: the environment's C function and its own environment pointer.
                unsafe { log(env, status, category.as_ptr(), message.as_ptr()) };
            }
            _ => {}
        }
    }

    /// Logs `call`'s error (named as FMI 2.0 names it; `fmi3…` for an FMI 3.0 instance) and
    /// returns `Error`.
    pub(crate) fn fail(&mut self, call: &str, message: &str) -> Status {
        let call = match self.target {
            LogTarget::Fmi3 { .. } => call.replacen("fmi2", "fmi3", 1),
            LogTarget::Fmi2(_) => call.to_string(),
        };
        self.log(
            Status::Error,
            "logStatusError",
            &format!("{call}: {message}"),
        );
        Status::Error
    }

    pub(crate) fn reset(&mut self) {
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
pub(crate) unsafe fn instance<'a, M: Model>(c: *mut c_void) -> Option<&'a mut Instance<M>> {
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
    let probe = Instance::<M>::new(name.clone(), LogTarget::Fmi2(callbacks), logging_on != 0);
    if fmu_type != 1 {
        probe.log(
            Status::Error,
            "logStatusError",
            "fmi2Instantiate: this FMU supports co-simulation only (fmuType = fmi2CoSimulation)",
        );
        return std::ptr::null_mut();
    }
    accept("fmi2Instantiate", "GUID", probe, text(guid))
}

/// The new instance `probe` if the environment gave this model's GUID (FMI 2.0) or
/// instantiation token (FMI 3.0: the same string); null, with a log message, otherwise.
fn accept<M: Model>(
    call: &str,
    what: &str,
    probe: Instance<M>,
    given: Option<CString>,
) -> *mut c_void {
    let given = given.map(|g| g.to_string_lossy().into_owned());
    if given.as_deref() != Some(M::GUID) {
        probe.log(
            Status::Error,
            "logStatusError",
            &format!(
                "{call}: {what} {:?} does not match this FMU's {}",
                given.unwrap_or_default(),
                M::GUID
            ),
        );
        return std::ptr::null_mut();
    }
    Box::into_raw(Box::new(probe)) as *mut c_void
}

/// `fmi3GetVersion`.
pub fn version3() -> *const c_char {
    c"3.0".as_ptr()
}

/// `fmi3InstantiateCoSimulation` (no event mode: an environment asking for it is refused;
/// early return is never needed, so `earlyReturnAllowed` changes nothing).
///
/// # Safety
/// Pointers as in the FMI 3.0 standard (C strings may be null; `log` null or valid with `env`).
pub unsafe fn instantiate3<M: Model>(
    instance_name: *const c_char,
    token: *const c_char,
    logging_on: bool,
    event_mode_used: bool,
    env: *mut c_void,
    log: Option<LogMessage3>,
) -> *mut c_void {
    // SAFETY: C strings from the environment.
    let text = |p: *const c_char| unsafe { (!p.is_null()).then(|| CStr::from_ptr(p).to_owned()) };
    let name = text(instance_name).unwrap_or_default();
    let probe = Instance::<M>::new(name, LogTarget::Fmi3 { env, log }, logging_on);
    if event_mode_used {
        probe.log(
            Status::Error,
            "logStatusError",
            "fmi3InstantiateCoSimulation: this FMU has no event mode (hasEventMode=\"false\")",
        );
        return std::ptr::null_mut();
    }
    accept(
        "fmi3InstantiateCoSimulation",
        "instantiationToken",
        probe,
        text(token),
    )
}

/// `fmi3EnterInitializationMode`: FMI 2.0's `fmi2SetupExperiment` (the start time) and
/// `fmi2EnterInitializationMode` in one call.
///
/// # Safety
/// `c` is null or an instance returned by [`instantiate3`](crate::instantiate3) for the same
/// model and not yet freed.
pub unsafe fn enter_initialization_mode3<M: Model>(c: *mut c_void, start: f64) -> Status {
    // SAFETY: see above.
    match unsafe { setup_experiment::<M>(c, start) } {
        Status::Ok => unsafe { enter_initialization_mode::<M>(c) },
        other => other,
    }
}

/// `fmi3DoStep`: [`do_step`], then its outputs — never an event, a stop request or an early
/// return; `lastSuccessfulTime` is the time reached.
///
/// # Safety
/// `c` is null or an instance returned by [`instantiate3`](crate::instantiate3) for the same
/// model and not yet freed; the four output pointers are null or writable.
pub unsafe fn do_step3<M: Model>(
    c: *mut c_void,
    time: f64,
    step: f64,
    event: *mut bool,
    terminate: *mut bool,
    early: *mut bool,
    last: *mut f64,
) -> Status {
    // SAFETY: see above.
    let status = unsafe { do_step::<M>(c, time, step) };
    // SAFETY: see above (null pointers are skipped).
    unsafe {
        for flag in [event, terminate, early] {
            if let Some(f) = flag.as_mut() {
                *f = false;
            }
        }
        if let (Some(l), Some(i)) = (last.as_mut(), instance::<M>(c)) {
            *l = i.time;
        }
    }
    status
}

/// `fmi2FreeInstance`.
///
/// # Safety
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
pub unsafe fn free_instance<M: Model>(c: *mut c_void) {
    if !c.is_null() {
        // SAFETY: created by `instantiate` with Box::into_raw.
        drop(unsafe { Box::from_raw(c as *mut Instance<M>) });
    }
}

/// `fmi2SetDebugLogging`.
///
/// # Safety
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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

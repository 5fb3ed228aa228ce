//! An FMU instance and its FMI 2.0 co-simulation state machine (instantiated → initialisation →
//! stepping → terminated, or failed): the bodies of the life-cycle functions `export_fmi2!`
//! defines, from `fmi2Instantiate` to `fmi2DoStep`.

use crate::ffi::{CallbackFunctions, Status};
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

/// An FMU instance (what `fmi2Component` points to).
pub struct Instance<M: Model> {
    pub(crate) name: CString,
    pub(crate) callbacks: Option<CallbackFunctions>,
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
    pub(crate) fn new(name: CString, callbacks: Option<CallbackFunctions>, logging: bool) -> Self {
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
    pub(crate) fn log(&self, status: Status, category: &str, message: &str) {
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

    pub(crate) fn fail(&mut self, call: &str, message: &str) -> Status {
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

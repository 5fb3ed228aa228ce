//! One FMU instance, driven through the FMI 2.0 C functions directly (libfmi's bindings on the
//! library loaded once in [`FmuFile`]): fmu-runner has no `fmi2Reset`, allocates a hash map per
//! get/set call and treats `fmi2Warning` as an error — an evaluation here allocates nothing and
//! reuses its instance with `fmi2Reset`.

use crate::file::FmuFile;
use crate::log::{savme_fmu_logger, LogSink};
use crate::FmuError;
use libfmi::{fmi2CallbackFunctions, fmi2Component, fmi2Status, fmi2StatusKind, fmi2Type};
use std::ffi::CString;
use std::sync::Arc;

/// How an `fmi2DoStep` ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// The step completed: the FMU is at the next communication point.
    Completed,
    /// The FMU returned `fmi2Discard`: it asks to end the simulation at the last completed
    /// communication point. `terminated` is its `fmi2GetBooleanStatus(fmi2Terminated)` answer
    /// (`None` when it does not give one).
    StopRequested {
        /// The FMU's `fmi2Terminated` status.
        terminated: Option<bool>,
    },
}

/// A live instance of an FMU.
pub struct Instance {
    file: Arc<FmuFile>,
    component: fmi2Component,
    // The environment's callbacks and the log sink they point to must outlive the instance.
    _callbacks: Box<fmi2CallbackFunctions>,
    log: Box<LogSink>,
    _name: CString,
}

// SAFETY: an instance is used by one thread at a time (it moves between threads only whole);
// FMI 2.0 allows calls on different instances from different threads.
unsafe impl Send for Instance {}

impl std::fmt::Debug for Instance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Instance")
            .field("fmu", &self.file.path)
            .finish()
    }
}

impl Instance {
    /// `fmi2Instantiate` (co-simulation, not visible, logging off), with the `file://` URI of
    /// the unpacked `resources/` directory as `fmuResourceLocation`.
    pub fn new(file: Arc<FmuFile>, name: &str) -> Result<Instance, FmuError> {
        Instance::with_log(file, name, false)
    }

    /// `fmi2Instantiate` whose log messages are kept for errors and, with `echo`, printed to
    /// standard error as they come (the instance is then created with `loggingOn`).
    pub fn with_log(file: Arc<FmuFile>, name: &str, echo: bool) -> Result<Instance, FmuError> {
        let log = Box::new(LogSink::new(file.path.display().to_string(), echo));
        let callbacks = Box::new(fmi2CallbackFunctions {
            logger: Some(savme_fmu_logger),
            allocateMemory: Some(libc_calloc),
            freeMemory: Some(libc_free),
            stepFinished: None,
            componentEnvironment: &*log as *const LogSink as *mut std::ffi::c_void,
        });
        let name = CString::new(name).unwrap_or_default();
        let guid = CString::new(file.model.guid.clone()).unwrap_or_default();
        // SAFETY: valid C strings and callbacks that outlive the instance.
        let component = unsafe {
            file.dll.fmi2Instantiate(
                name.as_ptr(),
                fmi2Type::fmi2CoSimulation,
                guid.as_ptr(),
                file.resource_uri.as_ptr(),
                &*callbacks,
                0,
                i32::from(echo),
            )
        };
        if component.is_null() {
            return Err(FmuError::Call {
                fmu: file.path.display().to_string(),
                call: "fmi2Instantiate".into(),
                status: "returned no instance".into(),
                log: log.suffix(),
            });
        }
        Ok(Instance {
            file,
            component,
            _callbacks: callbacks,
            log,
            _name: name,
        })
    }

    /// The FMU.
    pub fn file(&self) -> &Arc<FmuFile> {
        &self.file
    }

    fn status(&self, call: &str, s: fmi2Status) -> Result<(), FmuError> {
        match s {
            fmi2Status::fmi2OK | fmi2Status::fmi2Warning => Ok(()),
            other => Err(FmuError::Call {
                fmu: self.file.path.display().to_string(),
                call: call.into(),
                status: format!("{other:?}"),
                log: self.log.suffix(),
            }),
        }
    }

    /// Forgets the log messages kept so far (a new run begins).
    pub fn clear_log(&mut self) {
        self.log.clear();
    }

    /// `fmi2Reset`.
    pub fn reset(&mut self) -> Result<(), FmuError> {
        // SAFETY: a live component of this library.
        let s = unsafe { self.file.dll.fmi2Reset(self.component) };
        self.status("fmi2Reset", s)
    }

    /// `fmi2SetupExperiment` with a start time, an optional stop time and an optional
    /// tolerance.
    pub fn setup(
        &mut self,
        start: f64,
        stop: Option<f64>,
        tolerance: Option<f64>,
    ) -> Result<(), FmuError> {
        // SAFETY: a live component of this library.
        let s = unsafe {
            self.file.dll.fmi2SetupExperiment(
                self.component,
                i32::from(tolerance.is_some()),
                tolerance.unwrap_or(0.0),
                start,
                i32::from(stop.is_some()),
                stop.unwrap_or(0.0),
            )
        };
        self.status("fmi2SetupExperiment", s)
    }

    /// `fmi2EnterInitializationMode` then `fmi2ExitInitializationMode`.
    pub fn initialize(&mut self) -> Result<(), FmuError> {
        // SAFETY: a live component of this library.
        let s = unsafe { self.file.dll.fmi2EnterInitializationMode(self.component) };
        self.status("fmi2EnterInitializationMode", s)?;
        // SAFETY: as above.
        let s = unsafe { self.file.dll.fmi2ExitInitializationMode(self.component) };
        self.status("fmi2ExitInitializationMode", s)
    }

    /// `fmi2DoStep`. `fmi2Discard` is the FMU asking to end the simulation (FMI 2.0 §4.2.2:
    /// it could not complete the step; `fmi2GetBooleanStatus(fmi2Terminated)` then says whether
    /// it wants to terminate): both come back as [`Step::StopRequested`], not as an error.
    pub fn step(&mut self, time: f64, h: f64) -> Result<Step, FmuError> {
        // SAFETY: a live component of this library.
        let s = unsafe { self.file.dll.fmi2DoStep(self.component, time, h, 1) };
        if s == fmi2Status::fmi2Discard {
            return Ok(Step::StopRequested {
                terminated: self.terminated(),
            });
        }
        self.status("fmi2DoStep", s).map(|()| Step::Completed)
    }

    /// `fmi2GetBooleanStatus(fmi2Terminated)`, when the FMU exports it and answers.
    fn terminated(&mut self) -> Option<bool> {
        self.file.dll.fmi2GetBooleanStatus.as_ref().ok()?;
        let mut v = 0;
        // SAFETY: the function exists (checked above); one writable slot.
        let s = unsafe {
            self.file.dll.fmi2GetBooleanStatus(
                self.component,
                fmi2StatusKind::fmi2Terminated,
                &mut v,
            )
        };
        matches!(s, fmi2Status::fmi2OK | fmi2Status::fmi2Warning).then_some(v != 0)
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<(), FmuError> {
        // SAFETY: a live component of this library.
        let s = unsafe { self.file.dll.fmi2Terminate(self.component) };
        self.status("fmi2Terminate", s)
    }

    /// `fmi2SetReal` of one variable.
    pub fn set_real(&mut self, vr: u32, v: f64) -> Result<(), FmuError> {
        // SAFETY: one value reference and one value.
        let s = unsafe { self.file.dll.fmi2SetReal(self.component, &vr, 1, &v) };
        self.status("fmi2SetReal", s)
    }

    /// `fmi2SetInteger` of one variable.
    pub fn set_integer(&mut self, vr: u32, v: i32) -> Result<(), FmuError> {
        // SAFETY: one value reference and one value.
        let s = unsafe { self.file.dll.fmi2SetInteger(self.component, &vr, 1, &v) };
        self.status("fmi2SetInteger", s)
    }

    /// `fmi2SetBoolean` of one variable.
    pub fn set_boolean(&mut self, vr: u32, v: bool) -> Result<(), FmuError> {
        let b = i32::from(v);
        // SAFETY: one value reference and one value.
        let s = unsafe { self.file.dll.fmi2SetBoolean(self.component, &vr, 1, &b) };
        self.status("fmi2SetBoolean", s)
    }

    /// `fmi2GetReal` of one variable.
    pub fn real(&mut self, vr: u32) -> Result<f64, FmuError> {
        let mut v = 0.0;
        // SAFETY: one value reference and one slot.
        let s = unsafe { self.file.dll.fmi2GetReal(self.component, &vr, 1, &mut v) };
        self.status("fmi2GetReal", s).map(|()| v)
    }

    /// `fmi2GetInteger` of one variable.
    pub fn integer(&mut self, vr: u32) -> Result<i32, FmuError> {
        let mut v = 0;
        // SAFETY: one value reference and one slot.
        let s = unsafe { self.file.dll.fmi2GetInteger(self.component, &vr, 1, &mut v) };
        self.status("fmi2GetInteger", s).map(|()| v)
    }

    /// `fmi2GetBoolean` of one variable.
    pub fn boolean(&mut self, vr: u32) -> Result<bool, FmuError> {
        let mut v = 0;
        // SAFETY: one value reference and one slot.
        let s = unsafe { self.file.dll.fmi2GetBoolean(self.component, &vr, 1, &mut v) };
        self.status("fmi2GetBoolean", s).map(|()| v != 0)
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: the component is live and freed exactly once.
        unsafe { self.file.dll.fmi2FreeInstance(self.component) };
    }
}

unsafe extern "C" fn libc_calloc(n: usize, size: usize) -> *mut std::ffi::c_void {
    // SAFETY: C's calloc.
    unsafe { calloc(n, size) }
}

unsafe extern "C" fn libc_free(p: *mut std::ffi::c_void) {
    // SAFETY: C's free, of memory from calloc.
    unsafe { free(p) }
}

extern "C" {
    fn calloc(n: usize, size: usize) -> *mut std::ffi::c_void;
    fn free(p: *mut std::ffi::c_void);
}

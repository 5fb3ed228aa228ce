//! One FMU instance, driven through the C functions directly — libfmi's bindings of FMI 2.0 or
//! [`crate::fmi3`]'s of FMI 3.0, on the library loaded once in [`FmuFile`]. The two APIs sit
//! behind this one type: the run loop, the campaign and the worker never ask which version
//! they drive. An evaluation allocates nothing and reuses its instance with `fmi2Reset` /
//! `fmi3Reset`; `fmi2Warning` / `fmi3Warning` count as success.
//!
//! One file of ~640 lines because it is one type over two C APIs: each operation (set, get,
//! step, reset, terminate) is written once with its FMI 2.0 and FMI 3.0 arms side by side.

use crate::description::{Repr, VarInfo};
use crate::file::{Api, FmuFile};
use crate::fmi3;
use crate::log::{savme_fmu_log3, savme_fmu_logger, LogSink};
use crate::FmuError;
use libfmi::{fmi2CallbackFunctions, fmi2Status, fmi2StatusKind, fmi2Type};
use std::ffi::{c_void, CString};
use std::sync::Arc;

/// How a `fmi2DoStep` / `fmi3DoStep` ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// The step completed: the FMU is at the next communication point.
    Completed,
    /// FMI 3.0 early return: the FMU stopped at `time`, before the communication point (an
    /// event inside the step). Its signals are those at `time`; the run goes on from there to
    /// the communication point it was heading for.
    EarlyReturn {
        /// `lastSuccessfulTime`.
        time: f64,
    },
    /// The FMU asks to end the simulation: `fmi2Discard` / `fmi3Discard` (the step did not
    /// complete), or FMI 3.0 `terminateSimulation`. The FMU's signals are those at its last
    /// successful time — `reached: Some(t)`, when it got past the step's start: FMI 2.0's
    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`, FMI 3.0's `lastSuccessfulTime` (or the end
    /// of the step it completed); `None` when it made no progress or does not say. The run ends
    /// there, judged on its signals read after the stop. `terminated` is FMI 2.0's
    /// `fmi2GetBooleanStatus(fmi2Terminated)` answer (`None` when it gives none), `Some(true)`
    /// for `terminateSimulation`.
    StopRequested {
        /// The FMU's terminated status.
        terminated: Option<bool>,
        /// Where the FMU's signals are valid, if the step completed.
        reached: Option<f64>,
    },
}

/// A live instance of an FMU (either version).
pub struct Instance {
    file: Arc<FmuFile>,
    component: *mut c_void,
    // The environment's callbacks (FMI 2.0) and the log sink they point to must outlive the
    // instance.
    _callbacks: Option<Box<fmi2CallbackFunctions>>,
    log: Box<LogSink>,
    _name: CString,
    /// FMI 3.0: the experiment [`Instance::setup`] remembered for
    /// `fmi3EnterInitializationMode` (start, stop, tolerance).
    experiment: (f64, Option<f64>, Option<f64>),
}

// SAFETY: an instance is used by one thread at a time (it moves between threads only whole);
// FMI 2.0 and 3.0 allow calls on different instances from different threads.
unsafe impl Send for Instance {}

impl std::fmt::Debug for Instance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Instance")
            .field("fmu", &self.file.path)
            .finish()
    }
}

/// A status of either API: OK or warning, discard, or a failure (its name).
fn ok2(s: fmi2Status) -> bool {
    matches!(s, fmi2Status::fmi2OK | fmi2Status::fmi2Warning)
}

fn ok3(s: fmi3::Status) -> bool {
    matches!(s, fmi3::OK | fmi3::WARNING)
}

fn name3(s: fmi3::Status) -> String {
    match s {
        0 => "fmi3OK",
        1 => "fmi3Warning",
        2 => "fmi3Discard",
        3 => "fmi3Error",
        4 => "fmi3Fatal",
        _ => return format!("status {s}"),
    }
    .into()
}

impl Instance {
    /// Instantiates the FMU for co-simulation (not visible, logging off) with its resources:
    /// `fmi2Instantiate` with the `file://` URI, or `fmi3InstantiateCoSimulation` with the path
    /// (no event mode, early return allowed, no intermediate update).
    pub fn new(file: Arc<FmuFile>, name: &str) -> Result<Instance, FmuError> {
        Instance::with_log(file, name, false)
    }

    /// Instantiates the FMU, its log messages kept for errors and, with `echo`, printed to
    /// standard error as they come (the instance is then created with `loggingOn`).
    pub fn with_log(file: Arc<FmuFile>, name: &str, echo: bool) -> Result<Instance, FmuError> {
        let log = Box::new(LogSink::new(file.path.display().to_string(), echo).named(name));
        let env = &*log as *const LogSink as *mut c_void;
        let name = CString::new(name).unwrap_or_default();
        let guid = CString::new(file.model.guid.clone()).unwrap_or_default();
        let (component, callbacks, call) = match &file.api {
            Api::Fmi2(dll) => {
                let callbacks = Box::new(fmi2CallbackFunctions {
                    logger: Some(savme_fmu_logger),
                    allocateMemory: Some(libc_calloc),
                    freeMemory: Some(libc_free),
                    stepFinished: None,
                    componentEnvironment: env,
                });
                // SAFETY: valid C strings and callbacks that outlive the instance.
                let c = unsafe {
                    dll.fmi2Instantiate(
                        name.as_ptr(),
                        fmi2Type::fmi2CoSimulation,
                        guid.as_ptr(),
                        file.resource_uri.as_ptr(),
                        &*callbacks,
                        0,
                        i32::from(echo),
                    )
                };
                (c, Some(callbacks), "fmi2Instantiate")
            }
            Api::Fmi3(api) => {
                // SAFETY: valid C strings; the log sink (the environment) outlives the instance.
                let c = unsafe {
                    (api.instantiate)(
                        name.as_ptr(),
                        guid.as_ptr(),
                        file.resource_uri.as_ptr(),
                        false,
                        echo,
                        false,
                        true,
                        std::ptr::null(),
                        0,
                        env,
                        Some(savme_fmu_log3),
                        std::ptr::null(),
                    )
                };
                (c, None, "fmi3InstantiateCoSimulation")
            }
        };
        if component.is_null() {
            return Err(FmuError::Call {
                fmu: file.path.display().to_string(),
                call: call.into(),
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
            experiment: (0.0, None, None),
        })
    }

    /// The FMU.
    pub fn file(&self) -> &Arc<FmuFile> {
        &self.file
    }

    /// OK for `fmi2OK` and `fmi2Warning`; the error of `call` otherwise. Inlined into every
    /// call on the hot path, its error built out of line.
    #[inline]
    fn status2(&self, call: &str, s: fmi2Status) -> Result<(), FmuError> {
        if ok2(s) {
            Ok(())
        } else {
            Err(self.call_error(call, format!("{s:?}")))
        }
    }

    /// [`Instance::status2`] of FMI 3.0.
    #[inline]
    fn status3(&self, call: &str, s: fmi3::Status) -> Result<(), FmuError> {
        if ok3(s) {
            Ok(())
        } else {
            Err(self.call_error(call, name3(s)))
        }
    }

    #[cold]
    #[inline(never)]
    fn call_error(&self, call: &str, status: String) -> FmuError {
        FmuError::Call {
            fmu: self.file.path.display().to_string(),
            call: call.into(),
            status,
            log: self.log.suffix(),
        }
    }

    #[cold]
    #[inline(never)]
    fn missing(&self, function: &str) -> FmuError {
        FmuError::MissingFunction {
            fmu: self.file.path.display().to_string(),
            function: function.into(),
        }
    }

    /// Forgets the log messages kept so far (a new run begins).
    pub fn clear_log(&mut self) {
        self.log.clear();
    }

    /// `fmi2Reset` / `fmi3Reset`.
    pub fn reset(&mut self) -> Result<(), FmuError> {
        // SAFETY (every call below): a live component of this library, and one value
        // reference with one value or slot of the C type the function takes.
        match &self.file.api {
            Api::Fmi2(dll) => self.status2("fmi2Reset", unsafe { dll.fmi2Reset(self.component) }),
            Api::Fmi3(api) => self.status3("fmi3Reset", unsafe { (api.reset)(self.component) }),
        }
    }

    /// Starts the run: FMI 2.0 `fmi2SetupExperiment` (start time, optional stop time and
    /// tolerance) — the values are set after it, then [`Instance::initialize`]; FMI 3.0 takes
    /// them in `fmi3EnterInitializationMode`, so this only remembers them.
    pub fn setup(
        &mut self,
        start: f64,
        stop: Option<f64>,
        tolerance: Option<f64>,
    ) -> Result<(), FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                // SAFETY: a live component of this library.
                let s = unsafe {
                    dll.fmi2SetupExperiment(
                        self.component,
                        i32::from(tolerance.is_some()),
                        tolerance.unwrap_or(0.0),
                        start,
                        i32::from(stop.is_some()),
                        stop.unwrap_or(0.0),
                    )
                };
                self.status2("fmi2SetupExperiment", s)
            }
            Api::Fmi3(_) => {
                // FMI 3.0: the values are set in the Instantiated state (as FMPy sets them:
                // variables with initial="approx" can be set only there), then
                // `fmi3EnterInitializationMode` takes the experiment's times and tolerance.
                self.experiment = (start, stop, tolerance);
                Ok(())
            }
        }
    }

    /// FMI 3.0 configuration mode around `set` (which sets structural parameters):
    /// `fmi3EnterConfigurationMode`, `set`, `fmi3ExitConfigurationMode` — in the Instantiated
    /// state, before the other values are set. An FMI 2.0 FMU has no structural parameters:
    /// `set` runs as it is.
    pub fn configure(
        &mut self,
        set: impl FnOnce(&mut Instance) -> Result<(), FmuError>,
    ) -> Result<(), FmuError> {
        let (enter, exit) = match &self.file.api {
            Api::Fmi2(_) => return set(self),
            Api::Fmi3(api) => (api.enter_configuration_mode, api.exit_configuration_mode),
        };
        let enter = enter.ok_or_else(|| self.missing("fmi3EnterConfigurationMode"))?;
        let exit = exit.ok_or_else(|| self.missing("fmi3ExitConfigurationMode"))?;
        // SAFETY: a live component of this library, in the Instantiated state.
        let s = unsafe { enter(self.component) };
        self.status3("fmi3EnterConfigurationMode", s)?;
        set(self)?;
        // SAFETY: as above, in configuration mode.
        let s = unsafe { exit(self.component) };
        self.status3("fmi3ExitConfigurationMode", s)
    }

    /// Initialises: `fmi2EnterInitializationMode` / `fmi3EnterInitializationMode` (with the
    /// experiment of [`Instance::setup`]) then `fmi2ExitInitializationMode` /
    /// `fmi3ExitInitializationMode`, after which the instance is in step mode.
    pub fn initialize(&mut self) -> Result<(), FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                // SAFETY: a live component of this library.
                let s = unsafe { dll.fmi2EnterInitializationMode(self.component) };
                self.status2("fmi2EnterInitializationMode", s)?;
                // SAFETY: as above.
                let s = unsafe { dll.fmi2ExitInitializationMode(self.component) };
                self.status2("fmi2ExitInitializationMode", s)
            }
            Api::Fmi3(api) => {
                let (start, stop, tolerance) = self.experiment;
                // SAFETY: a live component of this library.
                let s = unsafe {
                    (api.enter_initialization_mode)(
                        self.component,
                        tolerance.is_some(),
                        tolerance.unwrap_or(0.0),
                        start,
                        stop.is_some(),
                        stop.unwrap_or(0.0),
                    )
                };
                self.status3("fmi3EnterInitializationMode", s)?;
                // SAFETY: as above.
                let s = unsafe { (api.exit_initialization_mode)(self.component) };
                self.status3("fmi3ExitInitializationMode", s)
            }
        }
    }

    /// One communication step from `time` by `h`. `fmi2Discard` / `fmi3Discard` and FMI 3.0's
    /// `terminateSimulation` are the FMU asking to end the simulation (FMI 2.0 §4.2.2,
    /// FMI 3.0 §4.2.1): [`Step::StopRequested`], not an error. FMI 3.0's `earlyReturn` with a
    /// `lastSuccessfulTime` before `time + h` is [`Step::EarlyReturn`]; `eventHandlingNeeded`
    /// needs nothing, since savme instantiates without event mode (the FMU handles its events
    /// inside `fmi3DoStep`).
    #[inline]
    pub fn step(&mut self, time: f64, h: f64) -> Result<Step, FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                // SAFETY: a live component of this library.
                let s = unsafe { dll.fmi2DoStep(self.component, time, h, 1) };
                if s == fmi2Status::fmi2Discard {
                    return Ok(self.stop_requested(time));
                }
                self.status2("fmi2DoStep", s).map(|()| Step::Completed)
            }
            Api::Fmi3(api) => {
                let (mut event, mut terminate, mut early, mut reached) = (false, false, false, 0.0);
                // SAFETY: a live component of this library; four writable outputs.
                let s = unsafe {
                    (api.do_step)(
                        self.component,
                        time,
                        h,
                        true,
                        &mut event,
                        &mut terminate,
                        &mut early,
                        &mut reached,
                    )
                };
                if s == fmi3::DISCARD {
                    return Ok(Step::StopRequested {
                        terminated: Some(terminate),
                        reached: (reached > time && reached.is_finite()).then_some(reached),
                    });
                }
                self.status3("fmi3DoStep", s)?;
                let end = if early && reached < time + h {
                    reached
                } else {
                    time + h
                };
                Ok(if terminate {
                    Step::StopRequested {
                        terminated: Some(true),
                        reached: (end > time).then_some(end),
                    }
                } else if end < time + h {
                    Step::EarlyReturn { time: end }
                } else {
                    Step::Completed
                })
            }
        }
    }

    #[cold]
    fn stop_requested(&mut self, time: f64) -> Step {
        Step::StopRequested {
            terminated: self.terminated(),
            reached: self.last_successful_time().filter(|t| *t > time),
        }
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`, when the FMU exports it and answers.
    fn last_successful_time(&mut self) -> Option<f64> {
        let Api::Fmi2(dll) = &self.file.api else {
            return None;
        };
        dll.fmi2GetRealStatus.as_ref().ok()?;
        let mut v = f64::NAN;
        // SAFETY: the function exists (checked above); one writable slot.
        let s = unsafe {
            dll.fmi2GetRealStatus(
                self.component,
                fmi2StatusKind::fmi2LastSuccessfulTime,
                &mut v,
            )
        };
        (ok2(s) && v.is_finite()).then_some(v)
    }

    /// `fmi2GetBooleanStatus(fmi2Terminated)`, when the FMU exports it and answers.
    fn terminated(&mut self) -> Option<bool> {
        let Api::Fmi2(dll) = &self.file.api else {
            return None;
        };
        dll.fmi2GetBooleanStatus.as_ref().ok()?;
        let mut v = 0;
        // SAFETY: the function exists (checked above); one writable slot.
        let s = unsafe {
            dll.fmi2GetBooleanStatus(self.component, fmi2StatusKind::fmi2Terminated, &mut v)
        };
        ok2(s).then_some(v != 0)
    }

    /// `fmi2Terminate` / `fmi3Terminate`.
    pub fn terminate(&mut self) -> Result<(), FmuError> {
        // SAFETY: a live component of this library.
        match &self.file.api {
            Api::Fmi2(dll) => self.status2("fmi2Terminate", unsafe {
                dll.fmi2Terminate(self.component)
            }),
            Api::Fmi3(api) => {
                self.status3("fmi3Terminate", unsafe { (api.terminate)(self.component) })
            }
        }
    }

    /// FMI 3.0: calls `fmi3Set<T>` (`call`) of one value, or `fmi3Get<T>` into `slot`.
    #[inline]
    fn set3<T>(&self, access: &fmi3::Access<T>, call: &str, vr: u32, v: T) -> Result<(), FmuError> {
        let f = access.set.ok_or_else(|| self.missing(call))?;
        // SAFETY: a live component of this library; one value reference and one value.
        let s = unsafe { f(self.component, &vr, 1, &v, 1) };
        self.status3(call, s)
    }

    #[inline]
    fn get3<T: Default>(
        &self,
        access: &fmi3::Access<T>,
        call: &str,
        vr: u32,
    ) -> Result<T, FmuError> {
        let f = access.get.ok_or_else(|| self.missing(call))?;
        let mut v = T::default();
        // SAFETY: a live component of this library; one value reference and one slot.
        let s = unsafe { f(self.component, &vr, 1, &mut v, 1) };
        self.status3(call, s).map(|()| v)
    }

    /// `fmi2SetReal` / `fmi3SetFloat64` of one variable.
    pub fn set_real(&mut self, vr: u32, v: f64) -> Result<(), FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                // SAFETY: one value reference and one value.
                let s = unsafe { dll.fmi2SetReal(self.component, &vr, 1, &v) };
                self.status2("fmi2SetReal", s)
            }
            Api::Fmi3(api) => self.set3(&api.float64, "fmi3SetFloat64", vr, v),
        }
    }

    /// `fmi2SetInteger` / `fmi3SetInt32` of one variable.
    pub fn set_integer(&mut self, vr: u32, v: i32) -> Result<(), FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                // SAFETY: one value reference and one value.
                let s = unsafe { dll.fmi2SetInteger(self.component, &vr, 1, &v) };
                self.status2("fmi2SetInteger", s)
            }
            Api::Fmi3(api) => self.set3(&api.int32, "fmi3SetInt32", vr, v),
        }
    }

    /// `fmi2SetBoolean` / `fmi3SetBoolean` of one variable.
    pub fn set_boolean(&mut self, vr: u32, v: bool) -> Result<(), FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                let b = i32::from(v);
                // SAFETY: one value reference and one value.
                let s = unsafe { dll.fmi2SetBoolean(self.component, &vr, 1, &b) };
                self.status2("fmi2SetBoolean", s)
            }
            Api::Fmi3(api) => self.set3(&api.boolean, "fmi3SetBoolean", vr, v),
        }
    }

    /// `fmi2SetString` / `fmi3SetString` of one variable (a string with a NUL byte is
    /// refused).
    pub fn set_string(&mut self, vr: u32, v: &str) -> Result<(), FmuError> {
        let text =
            CString::new(v).map_err(|_| FmuError::Spec(format!("{v:?} holds a NUL byte")))?;
        let p = text.as_ptr();
        match &self.file.api {
            Api::Fmi2(dll) => {
                if dll.fmi2SetString.is_err() {
                    return Err(self.missing("fmi2SetString"));
                }
                // SAFETY: the function exists (checked above); one value reference and one C
                // string that outlives the call.
                let s = unsafe { dll.fmi2SetString(self.component, &vr, 1, &p) };
                self.status2("fmi2SetString", s)
            }
            Api::Fmi3(api) => self.set3(&api.string, "fmi3SetString", vr, p),
        }
    }

    /// Sets a number on `var` through the function of its C type (`Float64`/`Float32`, or an
    /// integer type — the number must then be integral and inside the type's range).
    pub fn set_number(&mut self, var: &VarInfo, x: f64) -> Result<(), FmuError> {
        match var.repr {
            Repr::Float64 => self.set_real(var.vr, x),
            Repr::Float32 => match &self.file.api {
                Api::Fmi3(api) => self.set3(&api.float32, "fmi3SetFloat32", var.vr, x as f32),
                Api::Fmi2(_) => Err(self.missing("fmi3SetFloat32")),
            },
            // Integral and finite: the integer it is, exactly (`as` saturates only beyond
            // i128, which no integer type takes).
            _ if x.fract() == 0.0 => self.set_int(var, x as i128),
            _ => Err(FmuError::Spec(format!(
                "`{}` takes integers, not {x}",
                var.name
            ))),
        }
    }

    /// Sets an integer on `var` (an integer or enumeration variable) through the function of
    /// its C type, exactly (an Int64 or UInt64 is never passed through a double); a value
    /// outside the type's range is refused.
    pub fn set_int(&mut self, var: &VarInfo, i: i128) -> Result<(), FmuError> {
        let range = || FmuError::Spec(format!("{i} does not fit `{}` ({:?})", var.name, var.repr));
        let api = match (&self.file.api, var.repr) {
            (_, Repr::Int32) => {
                return self.set_integer(var.vr, i32::try_from(i).map_err(|_| range())?)
            }
            (Api::Fmi3(api), _) => api,
            (Api::Fmi2(_), _) => return Err(range()),
        };
        macro_rules! set {
            ($acc:ident, $call:literal) => {
                self.set3(&api.$acc, $call, var.vr, i.try_into().map_err(|_| range())?)
            };
        }
        match var.repr {
            Repr::Int8 => set!(int8, "fmi3SetInt8"),
            Repr::Int16 => set!(int16, "fmi3SetInt16"),
            Repr::Int64 => set!(int64, "fmi3SetInt64"),
            Repr::UInt8 => set!(uint8, "fmi3SetUInt8"),
            Repr::UInt16 => set!(uint16, "fmi3SetUInt16"),
            Repr::UInt32 => set!(uint32, "fmi3SetUInt32"),
            Repr::UInt64 => set!(uint64, "fmi3SetUInt64"),
            _ => Err(range()),
        }
    }

    /// Reads a number from `var` (any Real or integer type) as f64.
    #[inline]
    pub fn number(&mut self, var: &VarInfo) -> Result<f64, FmuError> {
        match var.repr {
            Repr::Float64 => return self.real(var.vr),
            Repr::Int32 => return self.integer(var.vr).map(f64::from),
            _ => {}
        }
        let Api::Fmi3(api) = &self.file.api else {
            return Err(FmuError::Spec(format!("`{}` is not a number", var.name)));
        };
        let vr = var.vr;
        Ok(match var.repr {
            Repr::Float32 => f64::from(self.get3(&api.float32, "fmi3GetFloat32", vr)?),
            Repr::Int8 => f64::from(self.get3(&api.int8, "fmi3GetInt8", vr)?),
            Repr::Int16 => f64::from(self.get3(&api.int16, "fmi3GetInt16", vr)?),
            Repr::Int64 => self.get3(&api.int64, "fmi3GetInt64", vr)? as f64,
            Repr::UInt8 => f64::from(self.get3(&api.uint8, "fmi3GetUInt8", vr)?),
            Repr::UInt16 => f64::from(self.get3(&api.uint16, "fmi3GetUInt16", vr)?),
            Repr::UInt32 => f64::from(self.get3(&api.uint32, "fmi3GetUInt32", vr)?),
            Repr::UInt64 => self.get3(&api.uint64, "fmi3GetUInt64", vr)? as f64,
            _ => return Err(FmuError::Spec(format!("`{}` is not a number", var.name))),
        })
    }

    /// `fmi2GetReal` / `fmi3GetFloat64` of one variable.
    #[inline]
    pub fn real(&mut self, vr: u32) -> Result<f64, FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                let mut v = 0.0;
                // SAFETY: one value reference and one slot.
                let s = unsafe { dll.fmi2GetReal(self.component, &vr, 1, &mut v) };
                self.status2("fmi2GetReal", s).map(|()| v)
            }
            Api::Fmi3(api) => self.get3(&api.float64, "fmi3GetFloat64", vr),
        }
    }

    /// `fmi2GetInteger` / `fmi3GetInt32` of one variable.
    #[inline]
    pub fn integer(&mut self, vr: u32) -> Result<i32, FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                let mut v = 0;
                // SAFETY: one value reference and one slot.
                let s = unsafe { dll.fmi2GetInteger(self.component, &vr, 1, &mut v) };
                self.status2("fmi2GetInteger", s).map(|()| v)
            }
            Api::Fmi3(api) => self.get3(&api.int32, "fmi3GetInt32", vr),
        }
    }

    /// `fmi2GetBoolean` / `fmi3GetBoolean` of one variable.
    #[inline]
    pub fn boolean(&mut self, vr: u32) -> Result<bool, FmuError> {
        match &self.file.api {
            Api::Fmi2(dll) => {
                let mut v = 0;
                // SAFETY: one value reference and one slot.
                let s = unsafe { dll.fmi2GetBoolean(self.component, &vr, 1, &mut v) };
                self.status2("fmi2GetBoolean", s).map(|()| v != 0)
            }
            Api::Fmi3(api) => self.get3(&api.boolean, "fmi3GetBoolean", vr),
        }
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: the component is live and freed exactly once.
        match &self.file.api {
            Api::Fmi2(dll) => unsafe { dll.fmi2FreeInstance(self.component) },
            Api::Fmi3(api) => unsafe { (api.free)(self.component) },
        }
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

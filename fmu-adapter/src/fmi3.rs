//! The FMI 3.0 co-simulation C functions savme calls, bound from the FMU's library with
//! libloading: the declarations follow the standard's `fmi3FunctionTypes.h` (FMI 3.0, §2.3 and
//! §4). Written here because no maintained crate binds FMI 3.0 without pulling a large
//! dependency tree (see docs/FMU.md). Functions savme always calls are required when the
//! library is loaded; the typed get/set functions of the other C types are looked up too and
//! reported missing only when a variable of that type is used.

use std::ffi::{c_char, c_void};

/// `fmi3Status` (OK, Warning, Discard, Error, Fatal).
pub type Status = i32;
/// `fmi3OK`.
pub const OK: Status = 0;
/// `fmi3Warning`.
pub const WARNING: Status = 1;
/// `fmi3Discard`.
pub const DISCARD: Status = 2;

/// `fmi3LogMessageCallback` (not variadic in FMI 3.0).
pub type LogMessage = unsafe extern "C" fn(*mut c_void, Status, *const c_char, *const c_char);

type Instantiate = unsafe extern "C" fn(
    *const c_char,
    *const c_char,
    *const c_char,
    bool,
    bool,
    bool,
    bool,
    *const u32,
    usize,
    *mut c_void,
    Option<LogMessage>,
    *const c_void,
) -> *mut c_void;
type Free = unsafe extern "C" fn(*mut c_void);
type Plain = unsafe extern "C" fn(*mut c_void) -> Status;
type EnterInit = unsafe extern "C" fn(*mut c_void, bool, f64, f64, bool, f64) -> Status;
type DoStep = unsafe extern "C" fn(
    *mut c_void,
    f64,
    f64,
    bool,
    *mut bool,
    *mut bool,
    *mut bool,
    *mut f64,
) -> Status;
type Set<T> = unsafe extern "C" fn(*mut c_void, *const u32, usize, *const T, usize) -> Status;
type Get<T> = unsafe extern "C" fn(*mut c_void, *const u32, usize, *mut T, usize) -> Status;

/// The get and set function of one C type.
pub struct Access<T> {
    /// `fmi3Get<Type>`, if exported.
    pub get: Option<Get<T>>,
    /// `fmi3Set<Type>`, if exported.
    pub set: Option<Set<T>>,
}

/// The FMI 3.0 functions of a loaded library (the library stays loaded while this lives).
pub struct Library {
    /// `fmi3InstantiateCoSimulation`.
    pub instantiate: Instantiate,
    /// `fmi3FreeInstance`.
    pub free: Free,
    /// `fmi3EnterInitializationMode`.
    pub enter_initialization_mode: EnterInit,
    /// `fmi3ExitInitializationMode`.
    pub exit_initialization_mode: Plain,
    /// `fmi3Terminate`.
    pub terminate: Plain,
    /// `fmi3Reset`.
    pub reset: Plain,
    /// `fmi3DoStep`.
    pub do_step: DoStep,
    /// `fmi3EnterConfigurationMode`, if exported (called only to set structural parameters).
    pub enter_configuration_mode: Option<Plain>,
    /// `fmi3ExitConfigurationMode`, if exported.
    pub exit_configuration_mode: Option<Plain>,
    /// Float64 … UInt64, Boolean, String.
    pub float64: Access<f64>,
    /// Float32.
    pub float32: Access<f32>,
    /// Int8.
    pub int8: Access<i8>,
    /// Int16.
    pub int16: Access<i16>,
    /// Int32.
    pub int32: Access<i32>,
    /// Int64.
    pub int64: Access<i64>,
    /// UInt8.
    pub uint8: Access<u8>,
    /// UInt16.
    pub uint16: Access<u16>,
    /// UInt32.
    pub uint32: Access<u32>,
    /// UInt64.
    pub uint64: Access<u64>,
    /// Boolean (C `bool`).
    pub boolean: Access<bool>,
    /// String.
    pub string: Access<*const c_char>,
    _lib: libloading::Library,
}

/// The functions savme calls on every FMI 3.0 run (checked when the library is loaded).
pub const REQUIRED: [&str; 13] = [
    "fmi3InstantiateCoSimulation",
    "fmi3FreeInstance",
    "fmi3EnterInitializationMode",
    "fmi3ExitInitializationMode",
    "fmi3Terminate",
    "fmi3Reset",
    "fmi3DoStep",
    "fmi3GetFloat64",
    "fmi3SetFloat64",
    "fmi3GetInt32",
    "fmi3SetInt32",
    "fmi3GetBoolean",
    "fmi3SetBoolean",
];

impl Library {
    /// Binds the functions of `lib`, which must export the [`REQUIRED`] ones (the caller
    /// checks that first, naming a missing one).
    ///
    /// # Safety
    /// `lib` is an FMI 3.0 library: its `fmi3*` symbols have the standard's signatures.
    pub unsafe fn bind(lib: libloading::Library) -> Result<Library, libloading::Error> {
        // SAFETY: the symbols have the standard's signatures (the caller's contract); the
        // pointers stay valid while `_lib` keeps the library loaded.
        unsafe {
            let req = |name: &str| -> Result<*const (), libloading::Error> {
                lib.get::<*const ()>(format!("{name}\0").as_bytes())
                    .map(|s| *s)
            };
            let opt = |name: &str| req(name).ok();
            macro_rules! access {
                ($t:literal) => {
                    Access {
                        get: opt(concat!("fmi3Get", $t)).map(|p| std::mem::transmute(p)),
                        set: opt(concat!("fmi3Set", $t)).map(|p| std::mem::transmute(p)),
                    }
                };
            }
            Ok(Library {
                instantiate: std::mem::transmute::<*const (), Instantiate>(req(
                    "fmi3InstantiateCoSimulation",
                )?),
                free: std::mem::transmute::<*const (), Free>(req("fmi3FreeInstance")?),
                enter_initialization_mode: std::mem::transmute::<*const (), EnterInit>(req(
                    "fmi3EnterInitializationMode",
                )?),
                exit_initialization_mode: std::mem::transmute::<*const (), Plain>(req(
                    "fmi3ExitInitializationMode",
                )?),
                terminate: std::mem::transmute::<*const (), Plain>(req("fmi3Terminate")?),
                reset: std::mem::transmute::<*const (), Plain>(req("fmi3Reset")?),
                do_step: std::mem::transmute::<*const (), DoStep>(req("fmi3DoStep")?),
                enter_configuration_mode: opt("fmi3EnterConfigurationMode")
                    .map(|p| std::mem::transmute::<*const (), Plain>(p)),
                exit_configuration_mode: opt("fmi3ExitConfigurationMode")
                    .map(|p| std::mem::transmute::<*const (), Plain>(p)),
                float64: access!("Float64"),
                float32: access!("Float32"),
                int8: access!("Int8"),
                int16: access!("Int16"),
                int32: access!("Int32"),
                int64: access!("Int64"),
                uint8: access!("UInt8"),
                uint16: access!("UInt16"),
                uint32: access!("UInt32"),
                uint64: access!("UInt64"),
                boolean: access!("Boolean"),
                string: access!("String"),
                _lib: lib,
            })
        }
    }
}

//! The C types of the FMI 2.0 and 3.0 APIs that the exported functions take and return.

use std::ffi::{c_char, c_void};

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

/// `fmi3LogMessageCallback` (FMI 3.0: not variadic; `fmi3Status` has the numbers of
/// [`Status`] without `Pending`).
pub type LogMessage3 = unsafe extern "C" fn(*mut c_void, Status, *const c_char, *const c_char);

//! Status codes, the last-error messages and the guard every entry point runs in.

use std::cell::RefCell;
use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// What a call returns: `SAVME_OK` or why it failed. The message of a failure is in
/// `savme_last_error()` (this thread) and, for a call on a kernel, `savme_kernel_last_error()`.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_status {
    /// Success.
    SAVME_OK = 0,
    /// A pointer argument the call needs is NULL.
    SAVME_ERROR_NULL = 1,
    /// A handle that is not live: freed, freed twice, never made, or a handle of another kind.
    SAVME_ERROR_HANDLE = 2,
    /// An argument's value is refused: text that is not UTF-8, an index out of range, an enum
    /// value out of range, a batch size of 0, a value of another type than asked for.
    SAVME_ERROR_ARGUMENT = 3,
    /// No variable, scenario or value by that name.
    SAVME_ERROR_NOT_FOUND = 4,
    /// A kernel configuration or snapshot that is not valid (the message names the line,
    /// column, variable or value).
    SAVME_ERROR_CONFIG = 5,
    /// The kernel refused a tell or a cancel (a trial never asked or told twice, the wrong kind
    /// of observation, a runtime that is not finite and > 0, …); nothing changed.
    SAVME_ERROR_REFUSED = 6,
    /// The journal or a file failed (locked by another process, I/O, an edited or foreign
    /// line); nothing changed.
    SAVME_ERROR_JOURNAL = 7,
    /// An estimation of P(failure) refused its configuration or a tell, or none is running.
    SAVME_ERROR_ESTIMATION = 8,
    /// A JSON request (`savme_request`) was answered with `"ok":false`.
    SAVME_ERROR_REQUEST = 9,
    /// An internal error (a bug in savme) was caught before it crossed into C. A kernel it
    /// happened on refuses every further call but `savme_kernel_free` and
    /// `savme_kernel_last_error`.
    SAVME_ERROR_INTERNAL = 10,
}

pub(crate) use savme_status::*;

/// A failed call: its status and a message naming the argument, trial or file.
#[derive(Debug)]
pub(crate) struct Failure {
    pub(crate) status: savme_status,
    pub(crate) message: String,
}

impl Failure {
    pub(crate) fn new(status: savme_status, message: impl Into<String>) -> Self {
        Failure {
            status,
            message: message.into(),
        }
    }
}

/// A call's result inside the library.
pub(crate) type Outcome<T = ()> = Result<T, Failure>;

thread_local! {
    static LAST: RefCell<CString> = RefCell::new(CString::default());
}

/// The message as a C string (an interior NUL, which no savme message has, becomes `?`).
pub(crate) fn c_message(message: &str) -> CString {
    CString::new(message.replace('\0', "?")).unwrap_or_default()
}

/// Records `message` as this thread's last error.
pub(crate) fn set_thread_error(message: &str) {
    LAST.with(|l| *l.borrow_mut() = c_message(message));
}

/// The message of a caught panic.
pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".into());
    format!("internal error (a bug in savme, please report it): {what}")
}

/// Runs one entry point: a panic is caught and turned into `SAVME_ERROR_INTERNAL`; a failure's
/// message becomes this thread's last error. `function` names the entry point in messages.
pub(crate) fn guard(function: &str, body: impl FnOnce() -> Outcome) -> savme_status {
    let result = catch_unwind(AssertUnwindSafe(body))
        .unwrap_or_else(|p| Err(Failure::new(SAVME_ERROR_INTERNAL, panic_message(&*p))));
    match result {
        Ok(()) => SAVME_OK,
        Err(f) => {
            set_thread_error(&format!("{function}: {}", f.message));
            f.status
        }
    }
}

/// A required pointer argument, or `SAVME_ERROR_NULL` naming it.
///
/// # Safety
/// `p` is NULL or valid for writes of a `T` for `'a`.
pub(crate) unsafe fn required<'a, T>(p: *mut T, name: &str) -> Outcome<&'a mut T> {
    // SAFETY: the caller promises a non-NULL pointer is valid for writes of a T (the
    // header's contract for every out-parameter).
    unsafe { p.as_mut() }.ok_or_else(|| Failure::new(SAVME_ERROR_NULL, format!("`{name}` is NULL")))
}

/// A NUL-terminated UTF-8 string argument.
///
/// # Safety
/// `p` is NULL or a NUL-terminated string that lives for `'a`.
pub(crate) unsafe fn text<'a>(p: *const c_char, name: &str) -> Outcome<&'a str> {
    if p.is_null() {
        return Err(Failure::new(SAVME_ERROR_NULL, format!("`{name}` is NULL")));
    }
    // SAFETY: the caller promises a NUL-terminated string.
    let s = unsafe { CStr::from_ptr(p) };
    s.to_str().map_err(|e| {
        Failure::new(
            SAVME_ERROR_ARGUMENT,
            format!("`{name}` is not UTF-8 (byte {})", e.valid_up_to() + 1),
        )
    })
}

/// An optional NUL-terminated UTF-8 string argument (NULL: none).
///
/// # Safety
/// As [`text`].
pub(crate) unsafe fn optional_text<'a>(p: *const c_char, name: &str) -> Outcome<Option<&'a str>> {
    if p.is_null() {
        Ok(None)
    } else {
        text(p, name).map(Some)
    }
}

/// This thread's last error message: the message of the last call on this thread that did not
/// return `SAVME_OK` (an empty string before any). The pointer stays valid until the next
/// failing call on this thread. Never NULL.
#[no_mangle]
pub extern "C" fn savme_last_error() -> *const c_char {
    LAST.with(|l| l.borrow().as_ptr())
}

/// A short constant description of a status code, e.g. `"a handle that is not live"`. Never
/// NULL (an unknown code gives `"unknown status"`).
#[no_mangle]
pub extern "C" fn savme_status_name(status: i32) -> *const c_char {
    let s: &'static str = match status {
        0 => "ok\0",
        1 => "a required pointer is NULL\0",
        2 => "a handle that is not live\0",
        3 => "an argument's value is refused\0",
        4 => "no such name\0",
        5 => "an invalid configuration or snapshot\0",
        6 => "the kernel refused the tell or cancel\0",
        7 => "the journal or a file failed\0",
        8 => "the estimation refused the call\0",
        9 => "the request was answered with an error\0",
        10 => "an internal error in savme\0",
        _ => "unknown status\0",
    };
    s.as_ptr().cast()
}

//! Status queries (`fmi2Get*Status`) and the functions whose capability this FMU declares false.

use crate::ffi::Status;
use crate::instance::instance;
use crate::model::Model;
use std::ffi::c_void;

/// A function this FMU does not provide (its capability flag is false in the model
/// description): logs why and returns `fmi2Error`.
///
/// # Safety
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed.
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

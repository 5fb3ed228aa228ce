//! FMU state (`fmi2GetFMUstate`, `fmi2SetFMUstate`, `fmi2FreeFMUstate`): a state is a clone of
//! the instance.

use crate::ffi::Status;
use crate::instance::{instance, Instance};
use crate::model::Model;
use std::ffi::c_void;

/// `fmi2GetFMUstate`: a copy of the instance.
///
/// # Safety
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed; `state` points to a writable
/// `fmi2FMUstate`.
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
/// `c` is null or a component returned by [`instantiate`](crate::instantiate) for the same
/// model and not yet freed; `state` is null or from [`get_state`].
pub unsafe fn set_state<M: Model>(c: *mut c_void, state: *mut c_void) -> Status {
    // SAFETY: see above.
    let Some(i) = (unsafe { instance::<M>(c) }) else {
        return Status::Error;
    };
    // SAFETY: a state made by `get_state`.
    let Some(s) = (unsafe { (state as *mut Instance<M>).as_ref() }) else {
        return i.fail("fmi2SetFMUstate", "null state");
    };
    let (name, target, logging) = (i.name.clone(), i.target, i.logging);
    *i = s.clone();
    i.name = name;
    i.target = target;
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

//! Strings the library hands out (JSON documents, snapshots): registered while live, so that
//! `savme_string_free` refuses a pointer it did not give out or freed before.

use crate::status::*;
use std::collections::HashSet;
use std::ffi::{c_char, CString};
use std::sync::{Mutex, PoisonError};

static LIVE: Mutex<Option<HashSet<usize>>> = Mutex::new(None);

/// `s` as a NUL-terminated string the caller frees with `savme_string_free`.
pub(crate) fn give_string(s: String) -> *mut c_char {
    let p = c_message(&s).into_raw();
    LIVE.lock()
        .unwrap_or_else(PoisonError::into_inner)
        .get_or_insert_with(HashSet::new)
        .insert(p as usize);
    p
}

/// Frees a string the library gave out (a JSON document, a snapshot). NULL does nothing; a
/// pointer the library did not give out, or freed before, is refused with
/// `SAVME_ERROR_HANDLE` and not touched.
#[no_mangle]
pub unsafe extern "C" fn savme_string_free(s: *mut c_char) -> savme_status {
    guard("savme_string_free", || {
        if s.is_null() {
            return Ok(());
        }
        let known = LIVE
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get_or_insert_with(HashSet::new)
            .remove(&(s as usize));
        if !known {
            return Err(Failure::new(
                SAVME_ERROR_HANDLE,
                "`s` is not a string savme gave out (freed before, or never savme's)",
            ));
        }
        // SAFETY: `s` came from CString::into_raw in give_string and is freed once (it was
        // just removed from the live set).
        drop(unsafe { CString::from_raw(s) });
        Ok(())
    })
}

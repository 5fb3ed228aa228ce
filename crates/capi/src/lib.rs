//! # savme-capi
//!
//! savme's C ABI: the SAVME ask/tell kernel for C and C++ test harnesses. The header
//! `include/savme.h` is generated from this crate by cbindgen; `include/savme.hpp` is a
//! header-only C++17 RAII wrapper over it. Built as `libsavme.so` / `libsavme.a` (the rlib
//! serves the Rust tests and benchmark, which call the very entry points C calls).
//!
//! Rules every entry point follows:
//! - it returns a [`savme_status`] (`SAVME_OK` or why not) — except the functions returning a
//!   message, which never fail;
//! - a failure's message names the function and the argument, trial or file; it is this
//!   thread's [`savme_last_error`] and, for a call on a kernel, that kernel's
//!   [`savme_kernel_last_error`];
//! - no panic crosses into C: each call runs under `catch_unwind` and a panic becomes
//!   `SAVME_ERROR_INTERNAL` (the library must be built with `panic = "unwind"`, Rust's default);
//! - a NULL pointer where a value is needed is refused (`SAVME_ERROR_NULL`); handles are slot
//!   numbers in a registry, never pointers to memory: a freed, double-freed, never-made or
//!   other kind's handle is refused (`SAVME_ERROR_HANDLE`), never dereferenced;
//! - enum arguments are passed as `int32_t` and checked (an out-of-range value is refused,
//!   never converted);
//! - every handle may be used from any thread; calls on one handle are serialised by a lock.
//!
//! # Safety
//!
//! The entry points are `unsafe`: a pointer argument must be NULL or valid for what the
//! header says (an out-parameter writable, `n` readable handles, `len` readable bytes), and a
//! string NUL-terminated. Handles need no such care: a stale one is refused.
//!
//! A kernel is made from the same JSON configuration `savme serve --config` reads
//! ([`savme_serve::parse_config`], one parser) and journaled by the same code as
//! `savme serve --journal` ([`savme_store::journal`]), so a journal resumes after `kill -9` in
//! either, and [`savme_request`] answers every request of `savme serve`'s protocol.
#![warn(missing_docs)]
// The entry points are `unsafe extern "C"`: their safety contract (pointers valid for what
// the header says, strings NUL-terminated) is the header's, stated once in the crate docs.
#![allow(clippy::missing_safety_doc)]
// `c"…"` literals would be clearer, but cbindgen 0.24 (Debian's, which CI installs) cannot
// parse them.
#![allow(clippy::manual_c_str_literals)]

mod builder;
mod kernel;
mod registry;
mod status;
mod strings;
mod values;

pub use builder::*;
pub use kernel::*;
pub use status::{savme_last_error, savme_status, savme_status_name};
pub use strings::savme_string_free;
pub use values::*;

/// The version of the C ABI this header describes. It changes only when a function's
/// signature, a struct's layout or an enum value changes; additions (new functions, new enum
/// values at the end) keep it. Compare it with `savme_abi_version()` to catch a header used
/// with another library.
pub const SAVME_ABI_VERSION: u32 = 1;

/// The C ABI version of the library loaded (`SAVME_ABI_VERSION` of the header it was built
/// with). Never fails.
#[no_mangle]
pub extern "C" fn savme_abi_version() -> u32 {
    SAVME_ABI_VERSION
}

/// The library's version (the savme workspace's), e.g. `"0.1.0"`. Never NULL.
#[no_mangle]
pub extern "C" fn savme_version() -> *const std::ffi::c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_inside_a_call_is_caught_and_the_kernel_refuses_further_calls() {
        // SAFETY: valid pointers throughout.
        unsafe {
            let config = std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/examples/config.json"
            ))
            .unwrap();
            let config = std::ffi::CString::new(config).unwrap();
            let mut k = std::ptr::null_mut();
            assert_eq!(
                savme_kernel_new(config.as_ptr(), &mut k),
                savme_status::SAVME_OK
            );
            assert_eq!(kernel::panic_inside(k), savme_status::SAVME_ERROR_INTERNAL);
            let message = std::ffi::CStr::from_ptr(savme_kernel_last_error(k));
            assert!(
                message
                    .to_str()
                    .unwrap()
                    .contains("internal error (a bug in savme, please report it): deliberate"),
                "{message:?}"
            );
            let mut stats = savme_stats::default();
            assert_eq!(
                savme_get_stats(k, &mut stats),
                savme_status::SAVME_ERROR_INTERNAL
            );
            let message = std::ffi::CStr::from_ptr(savme_last_error());
            assert!(
                message
                    .to_str()
                    .unwrap()
                    .contains("an earlier call on this kernel failed inside savme"),
                "{message:?}"
            );
            assert_eq!(savme_kernel_free(k), savme_status::SAVME_OK);
        }
    }

    #[test]
    fn a_panic_in_a_call_without_a_handle_is_caught() {
        let s = status::guard("f", || panic!("boom"));
        assert_eq!(s, savme_status::SAVME_ERROR_INTERNAL);
        let message = unsafe { std::ffi::CStr::from_ptr(savme_last_error()) };
        assert_eq!(
            message.to_str().unwrap(),
            "f: internal error (a bug in savme, please report it): boom"
        );
    }
}

//! The builder: the example configuration put together variable by variable gives the very
//! kernel the JSON gives; a bad variable, scenario or θ_HF value is refused, named.
#![allow(clippy::undocumented_unsafe_blocks)]

use savme_capi::*;
use savme_status::*;
use std::ffi::{c_char, CStr, CString};
use std::ptr::null_mut;

fn c(s: &str) -> CString {
    CString::new(s).unwrap()
}

fn last() -> String {
    unsafe { CStr::from_ptr(savme_last_error()) }
        .to_str()
        .unwrap()
        .to_string()
}

#[track_caller]
fn refused(status: savme_status, expected: savme_status, needle: &str) {
    assert_eq!(status, expected, "{}", last());
    assert!(last().contains(needle), "{:?} lacks {needle:?}", last());
}

fn config_of(k: *const savme_kernel) -> serde_json::Value {
    let mut json = null_mut();
    assert_eq!(unsafe { savme_config(k, &mut json) }, SAVME_OK);
    let text = unsafe { CStr::from_ptr(json) }
        .to_str()
        .unwrap()
        .to_string();
    assert_eq!(unsafe { savme_string_free(json) }, SAVME_OK);
    serde_json::from_str(&text).unwrap()
}

/// The example configuration (examples/config.json) through the builder.
unsafe fn example(b: *mut savme_builder) {
    let rates = [5i64, 10, 20, 50];
    assert_eq!(
        savme_builder_fidelity_ints(b, c("rate_hz").as_ptr(), rates.as_ptr(), 4, 50),
        SAVME_OK
    );
    let (euler, exact) = (c("euler"), c("exact"));
    let integrators: [*const c_char; 2] = [euler.as_ptr(), exact.as_ptr()];
    assert_eq!(
        savme_builder_fidelity_labels(
            b,
            c("integrator").as_ptr(),
            integrators.as_ptr(),
            2,
            exact.as_ptr()
        ),
        SAVME_OK
    );
    assert_eq!(
        savme_builder_fidelity_bool(b, c("skip_latency").as_ptr(), false),
        SAVME_OK
    );
    assert_eq!(
        savme_builder_fidelity_continuous(b, c("horizon_s").as_ptr(), 1.0, 4.0, 3, false, 4.0),
        SAVME_OK
    );
    let (lead, cut) = (c("lead_brakes"), c("cut_in"));
    assert_eq!(savme_builder_scenario(b, lead.as_ptr(), 1.0), SAVME_OK);
    assert_eq!(
        savme_builder_phi_continuous(b, lead.as_ptr(), c("speed").as_ptr(), 5.0, 30.0, 5, false),
        SAVME_OK
    );
    assert_eq!(
        savme_builder_phi_continuous(b, lead.as_ptr(), c("gap").as_ptr(), 5.0, 60.0, 5, false),
        SAVME_OK
    );
    assert_eq!(savme_builder_scenario(b, cut.as_ptr(), 1.0), SAVME_OK);
    assert_eq!(
        savme_builder_phi_continuous(b, cut.as_ptr(), c("speed").as_ptr(), 5.0, 30.0, 5, false),
        SAVME_OK
    );
    assert_eq!(
        savme_builder_phi_continuous(b, cut.as_ptr(), c("gap").as_ptr(), 2.0, 30.0, 4, false),
        SAVME_OK
    );
    let (dry, wet) = (c("dry"), c("wet"));
    let roads: [*const c_char; 2] = [dry.as_ptr(), wet.as_ptr()];
    assert_eq!(
        savme_builder_phi_labels(b, cut.as_ptr(), c("road").as_ptr(), roads.as_ptr(), 2),
        SAVME_OK
    );
}

#[test]
fn the_builder_makes_the_kernel_the_json_configuration_makes() {
    unsafe {
        let mut b = null_mut();
        assert_eq!(savme_builder_new(7, 0.3, &mut b), SAVME_OK);
        example(b);
        let mut built = null_mut();
        assert_eq!(savme_builder_build(b, &mut built), SAVME_OK, "{}", last());
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/config.json"))
                .unwrap();
        let mut from_json = null_mut();
        assert_eq!(
            savme_kernel_new(c(&text).as_ptr(), &mut from_json),
            SAVME_OK
        );
        assert_eq!(config_of(built), config_of(from_json));
        // The builder's JSON is a configuration savme_kernel_new reads.
        let mut json = null_mut();
        assert_eq!(savme_builder_config(b, &mut json), SAVME_OK);
        let mut again = null_mut();
        assert_eq!(savme_kernel_new(json, &mut again), SAVME_OK);
        assert_eq!(savme_string_free(json), SAVME_OK);
        assert_eq!(config_of(again), config_of(from_json));
        for k in [built, from_json, again] {
            assert_eq!(savme_kernel_free(k), SAVME_OK);
        }
        assert_eq!(savme_builder_free(b), SAVME_OK);
        refused(
            savme_builder_free(b),
            SAVME_ERROR_HANDLE,
            "`b` is not a live savme_builder handle",
        );
    }
}

#[test]
fn bad_variables_scenarios_and_settings_are_refused_naming_them() {
    unsafe {
        let mut b = null_mut();
        assert_eq!(savme_builder_new(1, 0.3, &mut b), SAVME_OK);
        let mut k = null_mut();
        refused(
            savme_builder_build(b, &mut k),
            SAVME_ERROR_CONFIG,
            "savme_builder_build:",
        );
        refused(
            savme_builder_fidelity_continuous(b, c("view_m").as_ptr(), 5.0, 1.0, 4, false, 5.0),
            SAVME_ERROR_CONFIG,
            "view_m",
        );
        refused(
            savme_builder_fidelity_continuous(b, c("fog").as_ptr(), 0.0, 1.0, 4, true, 1.0),
            SAVME_ERROR_CONFIG,
            "fog",
        );
        refused(
            savme_builder_fidelity_ints(b, c("rate").as_ptr(), std::ptr::null(), 2, 5),
            SAVME_ERROR_NULL,
            "`values` is NULL",
        );
        let rates = [5i64, 10];
        assert_eq!(
            savme_builder_fidelity_ints(b, c("rate").as_ptr(), rates.as_ptr(), 2, 7),
            SAVME_OK
        );
        refused(
            savme_builder_fidelity_bool(b, c("rate").as_ptr(), true),
            SAVME_ERROR_CONFIG,
            "fidelity variable `rate` was added before",
        );
        refused(
            savme_builder_phi_bool(b, c("ghost").as_ptr(), c("x").as_ptr()),
            SAVME_ERROR_NOT_FOUND,
            "no scenario `ghost`: add it with savme_builder_scenario first",
        );
        assert_eq!(savme_builder_scenario(b, c("s").as_ptr(), 1.0), SAVME_OK);
        refused(
            savme_builder_scenario(b, c("s").as_ptr(), 1.0),
            SAVME_ERROR_CONFIG,
            "scenario `s` was added before",
        );
        let bad = [b'x', 0xc3, 0];
        let labels: [*const c_char; 1] = [bad.as_ptr().cast()];
        refused(
            savme_builder_phi_labels(b, c("s").as_ptr(), c("l").as_ptr(), labels.as_ptr(), 1),
            SAVME_ERROR_ARGUMENT,
            "`values[0]` is not UTF-8",
        );
        assert_eq!(
            savme_builder_phi_continuous(b, c("s").as_ptr(), c("gap").as_ptr(), 1.0, 9.0, 4, false),
            SAVME_OK
        );
        // θ_HF 7 is no value of `rate`.
        refused(
            savme_builder_build(b, &mut k),
            SAVME_ERROR_CONFIG,
            "θ_HF: value 7 is outside variable `rate` (one of {5, 10})",
        );
        assert!(k.is_null());
        assert_eq!(savme_builder_free(b), SAVME_OK);
    }
}

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

/// The kernel-level settings of `preset` as a configuration's JSON keys.
fn preset_keys(preset: ::savme_kernel::Preset) -> serde_json::Value {
    let fidelity =
        ::savme_kernel::Space::new(vec![::savme_kernel::Variable::discrete("r", [1, 2])]).unwrap();
    let phi = ::savme_kernel::Space::new(vec![::savme_kernel::Variable::boolean("x")]).unwrap();
    let kernel =
        ::savme_kernel::Kernel::builder(fidelity, ::savme_kernel::Assignment::new().with("r", 2))
            .scenario("s", phi, 1.0)
            .preset(preset)
            .build()
            .unwrap();
    let config = serde_json::to_value(kernel.config()).unwrap();
    keys(&config)
}

fn keys(config: &serde_json::Value) -> serde_json::Value {
    let pick = |k: &str| config.get(k).cloned().unwrap_or(serde_json::Value::Null);
    serde_json::json!({
        "estimator": pick("estimator"),
        "search": pick("search"),
        "deployment": pick("deployment"),
        "allocation": pick("allocation"),
    })
}

#[test]
fn a_built_kernel_takes_the_tuned_method_and_the_paper_or_map_is_one_call_away() {
    unsafe {
        let mut b = null_mut();
        assert_eq!(savme_builder_new(7, 0.3, &mut b), SAVME_OK);
        example(b);
        let built = |b| {
            let mut k = null_mut();
            assert_eq!(savme_builder_build(b, &mut k), SAVME_OK, "{}", last());
            let config = config_of(k);
            assert_eq!(savme_kernel_free(k), SAVME_OK);
            config
        };
        // The default: savme's tuned settings, θ_LF* by evidence (as `savme example-config`
        // and Python's Kernel).
        let tuned = built(b);
        assert_eq!(tuned["estimator"], "evidence");
        assert_eq!(keys(&tuned), preset_keys(::savme_kernel::Preset::Tuned));
        // The paper's: MAP and the paper's search, deployment and allocation.
        assert_eq!(savme_builder_method(b, 1), SAVME_OK);
        let paper = built(b);
        assert_eq!(paper["estimator"], "map");
        assert_eq!(keys(&paper), preset_keys(::savme_kernel::Preset::Paper));
        // MAP alone, with the tuned method's other settings.
        assert_eq!(savme_builder_method(b, 0), SAVME_OK);
        assert_eq!(savme_builder_estimator(b, 1), SAVME_OK);
        let map = built(b);
        assert_eq!(map["estimator"], "map");
        assert_eq!(map["search"], tuned["search"]);
        assert_eq!(map["allocation"], tuned["allocation"]);
        // Back to the method's.
        assert_eq!(savme_builder_estimator(b, 0), SAVME_OK);
        assert_eq!(built(b)["estimator"], "evidence");
        refused(
            savme_builder_method(b, 2),
            SAVME_ERROR_ARGUMENT,
            "savme_builder_method: `method` must be a savme_method (0 or 1), got 2",
        );
        refused(
            savme_builder_estimator(b, 4),
            SAVME_ERROR_ARGUMENT,
            "savme_builder_estimator: `estimator` must be a savme_estimator (0 to 3), got 4",
        );
        assert_eq!(savme_builder_free(b), SAVME_OK);
    }
}

#[test]
fn the_estimate_reports_each_chosen_settings_evidence_as_serve_does() {
    unsafe {
        let mut b = null_mut();
        assert_eq!(savme_builder_new(3, 0.3, &mut b), SAVME_OK);
        example(b);
        let mut k = null_mut();
        assert_eq!(savme_builder_build(b, &mut k), SAVME_OK, "{}", last());
        assert_eq!(savme_builder_free(b), SAVME_OK);
        let mut t = null_mut();
        assert_eq!(savme_trial_new(&mut t), SAVME_OK);
        // 40 learning trials: HF fails on every other one; LF always says pass (false alarms
        // none, misses half).
        for i in 0..40 {
            assert_eq!(savme_ask(k, t), SAVME_OK, "{}", last());
            let mut id = 0;
            assert_eq!(savme_trial_id(t, &mut id), SAVME_OK);
            let run = |failure, runtime| savme_run {
                failure,
                runtime,
                has_robustness: false,
                robustness: 0.0,
            };
            let status =
                savme_tell_paired(k, id, run(i % 2 == 0, 1.0), run(false, 0.1), null_mut());
            assert_eq!(status, SAVME_OK, "{}", last());
        }
        let mut json = null_mut();
        assert_eq!(
            savme_estimate_evidence(k, 0, &mut json),
            SAVME_OK,
            "{}",
            last()
        );
        let ours: serde_json::Value =
            serde_json::from_str(CStr::from_ptr(json).to_str().unwrap()).unwrap();
        assert_eq!(savme_string_free(json), SAVME_OK);
        let mut response = null_mut();
        assert_eq!(
            savme_request(k, c(r#"{"op":"estimate"}"#).as_ptr(), &mut response),
            SAVME_OK
        );
        let served: serde_json::Value =
            serde_json::from_str(CStr::from_ptr(response).to_str().unwrap()).unwrap();
        assert_eq!(savme_string_free(response), SAVME_OK);
        assert_eq!(served["estimator"], "evidence");
        assert_eq!(ours, served["settings"]);
        let settings = ours.as_array().unwrap();
        assert_eq!(settings.len(), 4, "{ours}");
        let tried: u64 = settings.iter().map(|s| s["tried"].as_u64().unwrap()).sum();
        assert!(tried > 0, "{ours}");
        for s in settings {
            assert_eq!(s["fp"], 0, "{s}");
            assert!(
                s["miss_rate"].is_number() || s["miss_rate"].is_null(),
                "{s}"
            );
        }
        // Under MAP the same kernel names MAP's arms, still with their tallies.
        assert_eq!(savme_estimate_evidence(k, 1, &mut json), SAVME_OK);
        let map: serde_json::Value =
            serde_json::from_str(CStr::from_ptr(json).to_str().unwrap()).unwrap();
        assert_eq!(savme_string_free(json), SAVME_OK);
        assert_eq!(map.as_array().unwrap().len(), 4);
        refused(
            savme_estimate_evidence(k, 4, &mut json),
            SAVME_ERROR_ARGUMENT,
            "`estimator` must be a savme_estimator (0 to 3), got 4",
        );
        assert_eq!(savme_trial_free(t), SAVME_OK);
        assert_eq!(savme_kernel_free(k), SAVME_OK);
    }
}

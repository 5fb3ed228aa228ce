//! Every error path of the C ABI, called as C calls it (the `extern "C"` entry points): NULL
//! pointers, dead and foreign handles, refused arguments, configurations, tells, journals,
//! snapshots, estimations and requests — each with its status, a message naming the argument,
//! trial or file, and nothing changed. (A panic inside a call: the crate's unit tests.)
#![allow(clippy::undocumented_unsafe_blocks)]

use savme_capi::*;
use savme_status::*;
use std::ffi::{c_char, CStr, CString};
use std::ptr::{null, null_mut};

fn config() -> CString {
    CString::new(
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/config.json"))
            .unwrap(),
    )
    .unwrap()
}

fn c(s: &str) -> CString {
    CString::new(s).unwrap()
}

/// This thread's last error.
fn last() -> String {
    unsafe { CStr::from_ptr(savme_last_error()) }
        .to_str()
        .unwrap()
        .to_string()
}

fn kernel_last(k: *const savme_kernel) -> String {
    unsafe { CStr::from_ptr(savme_kernel_last_error(k)) }
        .to_str()
        .unwrap()
        .to_string()
}

/// Asserts `status` is `expected` and this thread's last error contains every needle.
#[track_caller]
fn refused(status: savme_status, expected: savme_status, needles: &[&str]) {
    assert_eq!(status, expected, "{}", last());
    let message = last();
    for n in needles {
        assert!(message.contains(n), "{message:?} lacks {n:?}");
    }
}

fn kernel() -> *mut savme_kernel {
    let mut k = null_mut();
    assert_eq!(
        unsafe { savme_kernel_new(config().as_ptr(), &mut k) },
        SAVME_OK,
        "{}",
        last()
    );
    k
}

fn trial() -> *mut savme_trial {
    let mut t = null_mut();
    assert_eq!(unsafe { savme_trial_new(&mut t) }, SAVME_OK);
    t
}

fn snapshot(k: *const savme_kernel) -> String {
    let (mut data, mut len) = (null_mut(), 0);
    assert_eq!(unsafe { savme_snapshot(k, &mut data, &mut len) }, SAVME_OK);
    let s = unsafe { CStr::from_ptr(data) }
        .to_str()
        .unwrap()
        .to_string();
    assert_eq!(unsafe { savme_string_free(data) }, SAVME_OK);
    s
}

fn run(failure: bool, runtime: f64) -> savme_run {
    savme_run {
        failure,
        runtime,
        has_robustness: false,
        robustness: 0.0,
    }
}

#[test]
fn null_pointers_are_refused_naming_the_argument_and_change_nothing() {
    unsafe {
        let k = kernel();
        let t = trial();
        let before = snapshot(k);
        let mut out = null_mut();
        refused(
            savme_kernel_new(null(), &mut out),
            SAVME_ERROR_NULL,
            &["savme_kernel_new: `config_json` is NULL"],
        );
        refused(
            savme_kernel_new(config().as_ptr(), null_mut()),
            SAVME_ERROR_NULL,
            &["`out` is NULL"],
        );
        refused(
            savme_kernel_open_journal(null(), config().as_ptr(), &mut out),
            SAVME_ERROR_NULL,
            &["`path` is NULL"],
        );
        refused(
            savme_kernel_from_snapshot(null(), 3, &mut out),
            SAVME_ERROR_NULL,
            &["`data` is NULL"],
        );
        refused(
            savme_trial_new(null_mut()),
            SAVME_ERROR_NULL,
            &["savme_trial_new: `out` is NULL"],
        );
        refused(
            savme_assignment_new(null_mut()),
            SAVME_ERROR_NULL,
            &["`out` is NULL"],
        );
        refused(
            savme_ask(null_mut(), t),
            SAVME_ERROR_NULL,
            &["savme_ask: `k` is NULL"],
        );
        refused(
            savme_ask(k, null_mut()),
            SAVME_ERROR_NULL,
            &["savme_ask: `t` is NULL"],
        );
        refused(
            savme_ask_batch(k, null(), 2),
            SAVME_ERROR_NULL,
            &["`trials` is NULL"],
        );
        let with_null = [t, null_mut()];
        refused(
            savme_ask_batch(k, with_null.as_ptr(), 2),
            SAVME_ERROR_NULL,
            &["`trials[1]` is NULL"],
        );
        refused(
            savme_get_stats(k, null_mut()),
            SAVME_ERROR_NULL,
            &["`stats` is NULL"],
        );
        refused(
            savme_get_phase(k, null_mut()),
            SAVME_ERROR_NULL,
            &["`phase` is NULL"],
        );
        refused(
            savme_snapshot(k, null_mut(), &mut 0),
            SAVME_ERROR_NULL,
            &["`data` is NULL"],
        );
        refused(
            savme_config(k, null_mut()),
            SAVME_ERROR_NULL,
            &["`json` is NULL"],
        );
        refused(
            savme_estimate_evidence(k, 0, null_mut()),
            SAVME_ERROR_NULL,
            &["savme_estimate_evidence", "`json` is NULL"],
        );
        refused(
            savme_request(k, null(), &mut null_mut()),
            SAVME_ERROR_NULL,
            &["`request` is NULL"],
        );
        refused(
            savme_request(k, c("{\"op\":\"ask\"}").as_ptr(), null_mut()),
            SAVME_ERROR_NULL,
            &["`response` is NULL"],
        );
        refused(
            savme_theta_hf(k, null_mut()),
            SAVME_ERROR_NULL,
            &["`out` is NULL"],
        );
        refused(
            savme_estimate(k, 0, null_mut(), null_mut()),
            SAVME_ERROR_NULL,
            &["`out` is NULL"],
        );
        refused(
            savme_scenario(k, 0, null_mut(), null_mut()),
            SAVME_ERROR_NULL,
            &["`name` is NULL"],
        );
        refused(
            savme_posterior_arm(k, null(), 0, 0, null_mut(), &mut 0.0),
            SAVME_ERROR_NULL,
            &["`alpha` is NULL"],
        );
        refused(
            savme_estimation_start(k, null()),
            SAVME_ERROR_NULL,
            &["`config_json` is NULL"],
        );
        refused(
            savme_estimation_ask(k, t, null_mut()),
            SAVME_ERROR_NULL,
            &["`asked` is NULL"],
        );
        refused(
            savme_pending_trial(k, 0, null_mut()),
            SAVME_ERROR_NULL,
            &["`t` is NULL"],
        );
        refused(
            savme_tell_paired(null_mut(), 0, run(true, 1.0), run(true, 1.0), null_mut()),
            SAVME_ERROR_NULL,
            &["`k` is NULL"],
        );
        // A filled trial refuses NULL out-parameters and names.
        assert_eq!(savme_ask(k, t), SAVME_OK);
        refused(
            savme_trial_id(t, null_mut()),
            SAVME_ERROR_NULL,
            &["savme_trial_id: `id` is NULL"],
        );
        refused(
            savme_trial_value(t, 0, 0, null_mut()),
            SAVME_ERROR_NULL,
            &["`value` is NULL"],
        );
        refused(
            savme_trial_find(t, 0, null(), &mut std::mem::zeroed()),
            SAVME_ERROR_NULL,
            &["`name` is NULL"],
        );
        refused(
            savme_trial_number(t, 0, c("gap").as_ptr(), null_mut()),
            SAVME_ERROR_NULL,
            &["`number` is NULL"],
        );
        refused(
            savme_trial_scenario(t, null_mut(), null_mut()),
            SAVME_ERROR_NULL,
            &["`name` is NULL"],
        );
        // The one ask above is all that changed.
        let mut stats = savme_stats::default();
        assert_eq!(savme_get_stats(k, &mut stats), SAVME_OK);
        assert_eq!((stats.asked, stats.pending), (1, 1));
        assert_ne!(before, snapshot(k));
        assert_eq!(savme_trial_free(t), SAVME_OK);
        assert_eq!(savme_kernel_free(k), SAVME_OK);
    }
}

#[test]
fn freed_double_freed_foreign_and_made_up_handles_are_refused_never_dereferenced() {
    unsafe {
        let k = kernel();
        let t = trial();
        let mut a = null_mut();
        assert_eq!(savme_assignment_new(&mut a), SAVME_OK);
        // Another kind's handle, and numbers that were never handles (dereferencing them would
        // crash this test).
        refused(
            savme_ask(t as *mut savme_kernel, t),
            SAVME_ERROR_HANDLE,
            &["savme_ask: `k` is not a live savme_kernel handle"],
        );
        refused(
            savme_ask(k, k as *mut savme_trial),
            SAVME_ERROR_HANDLE,
            &["`t` is not a live savme_trial handle"],
        );
        refused(
            savme_theta_hf(k, t as *mut savme_assignment),
            SAVME_ERROR_HANDLE,
            &["`out` is not a live savme_assignment handle"],
        );
        for made_up in [1usize, 0xdead_beef, usize::MAX, 0x5a00_0000_0000_0001 + 7] {
            let fake = std::ptr::without_provenance_mut::<savme_kernel>(made_up);
            refused(
                savme_get_stats(fake, &mut savme_stats::default()),
                SAVME_ERROR_HANDLE,
                &["`k` is not a live savme_kernel handle"],
            );
            refused(
                savme_kernel_free(fake),
                SAVME_ERROR_HANDLE,
                &["savme_kernel_free"],
            );
        }
        // Freed, then used or freed again.
        assert_eq!(savme_kernel_free(k), SAVME_OK);
        refused(
            savme_ask(k, t),
            SAVME_ERROR_HANDLE,
            &["`k` is not a live savme_kernel handle (freed"],
        );
        refused(
            savme_kernel_free(k),
            SAVME_ERROR_HANDLE,
            &["savme_kernel_free: `k` is not a live"],
        );
        assert!(kernel_last(k).contains("`k` is not a live savme_kernel handle"));
        assert!(kernel_last(null()).contains("not a live savme_kernel handle"));
        assert_eq!(savme_trial_free(t), SAVME_OK);
        refused(
            savme_trial_free(t),
            SAVME_ERROR_HANDLE,
            &["savme_trial_free: `t` is not a live savme_trial handle"],
        );
        refused(
            savme_trial_id(t, &mut 0),
            SAVME_ERROR_HANDLE,
            &["`t` is not a live savme_trial handle"],
        );
        assert_eq!(savme_assignment_free(a), SAVME_OK);
        refused(
            savme_assignment_free(a),
            SAVME_ERROR_HANDLE,
            &["`a` is not a live savme_assignment handle"],
        );
        // A new kernel may reuse the freed slot: the stale handle still is refused.
        let k2 = kernel();
        refused(
            savme_get_stats(k, &mut savme_stats::default()),
            SAVME_ERROR_HANDLE,
            &["not a live"],
        );
        // Strings: only those savme gave out, once.
        let (mut data, mut len) = (null_mut(), 0);
        assert_eq!(savme_snapshot(k2, &mut data, &mut len), SAVME_OK);
        assert_eq!(savme_string_free(data), SAVME_OK);
        refused(
            savme_string_free(data),
            SAVME_ERROR_HANDLE,
            &["savme_string_free: `s` is not a string savme gave out"],
        );
        let mine = c("not savme's");
        refused(
            savme_string_free(mine.as_ptr() as *mut c_char),
            SAVME_ERROR_HANDLE,
            &["not a string savme gave out"],
        );
        // NULL frees nothing, as free(NULL).
        assert_eq!(savme_kernel_free(null_mut()), SAVME_OK);
        assert_eq!(savme_trial_free(null_mut()), SAVME_OK);
        assert_eq!(savme_assignment_free(null_mut()), SAVME_OK);
        assert_eq!(savme_string_free(null_mut()), SAVME_OK);
        assert_eq!(savme_kernel_free(k2), SAVME_OK);
    }
}

#[test]
fn refused_argument_values_are_named() {
    unsafe {
        let k = kernel();
        let t = trial();
        let mut v = std::mem::zeroed::<savme_value>();
        refused(
            savme_trial_id(t, &mut 0),
            SAVME_ERROR_ARGUMENT,
            &["holds no trial yet: fill it with savme_ask"],
        );
        refused(
            savme_set_phase(k, 7),
            SAVME_ERROR_ARGUMENT,
            &["`phase` must be a savme_phase (0 to 3), got 7"],
        );
        refused(savme_set_phase(k, -1), SAVME_ERROR_ARGUMENT, &["got -1"]);
        let mut a = null_mut();
        assert_eq!(savme_assignment_new(&mut a), SAVME_OK);
        refused(
            savme_estimate(k, 4, a, null_mut()),
            SAVME_ERROR_ARGUMENT,
            &["`estimator` must be a savme_estimator (0 to 3), got 4"],
        );
        refused(
            savme_assignment_count(a, &mut 0),
            SAVME_ERROR_ARGUMENT,
            &["holds nothing yet"],
        );
        assert_eq!(savme_ask(k, t), SAVME_OK);
        refused(
            savme_trial_count(t, 9, &mut 0),
            SAVME_ERROR_ARGUMENT,
            &["`part` must be a savme_part (0 to 2), got 9"],
        );
        refused(
            savme_trial_value(t, 0, 5, &mut v),
            SAVME_ERROR_ARGUMENT,
            &["`index` 5 is out of range: trial 0's φ has 2 values"],
        );
        let bad = [b'g', 0xff, 0];
        refused(
            savme_trial_find(t, 0, bad.as_ptr().cast(), &mut v),
            SAVME_ERROR_ARGUMENT,
            &["`name` is not UTF-8 (byte 2)"],
        );
        refused(
            savme_trial_find(t, 0, c("gapp").as_ptr(), &mut v),
            SAVME_ERROR_NOT_FOUND,
            &["trial 0's φ has no variable `gapp` (it has: speed, gap)"],
        );
        refused(
            savme_trial_number(t, 2, c("integrator").as_ptr(), &mut 0.0),
            SAVME_ERROR_ARGUMENT,
            &["θ_HF's `integrator` is not a number"],
        );
        refused(
            savme_trial_densities(t, null_mut(), null_mut(), null_mut(), null_mut()),
            SAVME_ERROR_ARGUMENT,
            &["not an estimation trial"],
        );
        refused(
            savme_posterior_count(k, c("lane_change").as_ptr(), &mut 0),
            SAVME_ERROR_NOT_FOUND,
            &["no scenario `lane_change` (there are: lead_brakes, cut_in)"],
        );
        refused(
            savme_posterior_arm(k, null(), 0, 99, &mut 0.0, &mut 0.0),
            SAVME_ERROR_ARGUMENT,
            &["`arm` 99 is out of range (0 to 3)"],
        );
        refused(
            savme_posterior_variable(k, null(), 4, &mut std::mem::zeroed(), null_mut()),
            SAVME_ERROR_ARGUMENT,
            &["`variable` 4 is out of range (0 to 3)"],
        );
        refused(
            savme_scenario(k, 2, &mut std::mem::zeroed(), null_mut()),
            SAVME_ERROR_ARGUMENT,
            &["the kernel has 2 scenarios"],
        );
        refused(
            savme_pending_trial(k, 1, t),
            SAVME_ERROR_ARGUMENT,
            &["`index` 1 is out of range: 1 trials are pending"],
        );
        // Batches: 0, too many, the same handle twice; nothing asked.
        let t2 = trial();
        let same = [t, t2, t];
        refused(
            savme_ask_batch(k, same.as_ptr(), 0),
            SAVME_ERROR_ARGUMENT,
            &["`n` must be between 1 and 100000, got 0"],
        );
        refused(
            savme_ask_batch(k, same.as_ptr(), 100_001),
            SAVME_ERROR_ARGUMENT,
            &["got 100001"],
        );
        refused(
            savme_ask_batch(k, same.as_ptr(), 3),
            SAVME_ERROR_ARGUMENT,
            &["`trials[0]` and `trials[2]` are the same handle"],
        );
        // A baseline trial has no θ_LF.
        assert_eq!(
            savme_set_phase(k, savme_phase::SAVME_PHASE_BASELINE as i32),
            SAVME_OK
        );
        assert_eq!(savme_ask(k, t2), SAVME_OK);
        let mut n = 9;
        assert_eq!(savme_trial_count(t2, 1, &mut n), SAVME_OK);
        assert_eq!(n, 0);
        refused(
            savme_trial_find(t2, 1, c("rate_hz").as_ptr(), &mut v),
            SAVME_ERROR_NOT_FOUND,
            &["trial 1 has no θ_LF (a baseline or unpaired trial"],
        );
        let mut stats = savme_stats::default();
        assert_eq!(savme_get_stats(k, &mut stats), SAVME_OK);
        assert_eq!(stats.asked, 2);
        for h in [t, t2] {
            assert_eq!(savme_trial_free(h), SAVME_OK);
        }
        assert_eq!(savme_assignment_free(a), SAVME_OK);
        assert_eq!(savme_kernel_free(k), SAVME_OK);
    }
}

#[test]
fn bad_configurations_and_snapshots_are_refused_naming_what_is_wrong() {
    unsafe {
        let mut k = null_mut();
        refused(
            savme_kernel_new(c("{\"scenarios\": [").as_ptr(), &mut k),
            SAVME_ERROR_CONFIG,
            &[
                "savme_kernel_new: `config_json`: not a kernel configuration",
                "line 1 column 15",
            ],
        );
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/config.json"))
                .unwrap();
        let unknown = text.replacen("\"budget\"", "\"budgt\"", 1);
        refused(
            savme_kernel_new(c(&unknown).as_ptr(), &mut k),
            SAVME_ERROR_CONFIG,
            &["unknown field `budgt`"],
        );
        let off_grid = text.replacen("\"rate_hz\": 50,", "\"rate_hz\": 51,", 1);
        refused(
            savme_kernel_new(c(&off_grid).as_ptr(), &mut k),
            SAVME_ERROR_CONFIG,
            &["rate_hz"],
        );
        assert!(k.is_null(), "a refused kernel is not made");
        let garbage = b"{\"not\": \"a snapshot\"}";
        refused(
            savme_kernel_from_snapshot(garbage.as_ptr(), garbage.len(), &mut k),
            SAVME_ERROR_CONFIG,
            &["snapshot is not valid JSON for a kernel state"],
        );
        let bytes = [b'{', 0xfe];
        refused(
            savme_kernel_from_snapshot(bytes.as_ptr(), 2, &mut k),
            SAVME_ERROR_CONFIG,
            &["the snapshot is not UTF-8 (byte 2)"],
        );
        // A snapshot of the wrong length (cut short) is refused, not read past.
        let good = kernel();
        let s = snapshot(good);
        refused(
            savme_kernel_from_snapshot(s.as_ptr(), s.len() - 1, &mut k),
            SAVME_ERROR_CONFIG,
            &["snapshot is not valid JSON"],
        );
        assert_eq!(
            savme_kernel_from_snapshot(s.as_ptr(), s.len(), &mut k),
            SAVME_OK
        );
        assert_eq!(snapshot(k), s);
        assert_eq!(savme_kernel_free(k), SAVME_OK);
        assert_eq!(savme_kernel_free(good), SAVME_OK);
    }
}

#[test]
fn refused_tells_and_cancels_name_the_trial_and_change_nothing() {
    unsafe {
        let k = kernel();
        let t = trial();
        assert_eq!(savme_ask(k, t), SAVME_OK);
        let before = snapshot(k);
        refused(
            savme_tell_paired(k, 99, run(true, 1.0), run(true, 0.1), null_mut()),
            SAVME_ERROR_REFUSED,
            &["savme_tell_paired: trial 99 was never asked"],
        );
        refused(
            savme_tell_hf_only(k, 0, run(true, 1.0), null_mut()),
            SAVME_ERROR_REFUSED,
            &["trial 0 is a train trial and needs a paired (HF and LF) observation"],
        );
        refused(
            savme_tell_paired(k, 0, run(true, 0.0), run(true, 0.1), null_mut()),
            SAVME_ERROR_REFUSED,
            &["trial 0: HF runtime must be finite and > 0, got 0"],
        );
        refused(
            savme_tell_paired(k, 0, run(true, 1.0), run(true, f64::NAN), null_mut()),
            SAVME_ERROR_REFUSED,
            &["LF runtime must be finite and > 0, got NaN"],
        );
        let nan_margin = savme_run {
            robustness: f64::INFINITY,
            has_robustness: true,
            ..run(false, 1.0)
        };
        refused(
            savme_tell_paired(k, 0, nan_margin, run(true, 0.1), null_mut()),
            SAVME_ERROR_REFUSED,
            &["HF robustness must be a finite number, got inf"],
        );
        refused(
            savme_cancel(k, 5),
            SAVME_ERROR_REFUSED,
            &["savme_cancel: trial 5 was never asked"],
        );
        // The kernel's own last error is the last failure on it.
        assert_eq!(kernel_last(k), "savme_cancel: trial 5 was never asked");
        assert_eq!(snapshot(k), before, "a refused tell changed the kernel");
        let mut record = std::mem::zeroed::<savme_record>();
        assert_eq!(
            savme_tell_paired(k, 0, run(true, 1.0), run(true, 0.1), &mut record),
            SAVME_OK
        );
        assert_eq!(record.outcome, savme_outcome::SAVME_OUTCOME_TP);
        assert_eq!(record.fidelity, savme_credit::SAVME_CREDIT_SUCCESS);
        refused(
            savme_tell_paired(k, 0, run(true, 1.0), run(true, 0.1), null_mut()),
            SAVME_ERROR_REFUSED,
            &["trial 0 was already told or cancelled"],
        );
        assert_eq!(savme_set_phase(k, 2), SAVME_OK);
        assert_eq!(savme_ask(k, t), SAVME_OK);
        refused(
            savme_tell_paired(k, 1, run(true, 1.0), run(true, 0.1), null_mut()),
            SAVME_ERROR_REFUSED,
            &["trial 1 has no θ_LF and takes the HF run only"],
        );
        assert_eq!(savme_cancel(k, 1), SAVME_OK);
        refused(
            savme_cancel(k, 1),
            SAVME_ERROR_REFUSED,
            &["trial 1 was already told or cancelled"],
        );
        assert_eq!(savme_trial_free(t), SAVME_OK);
        assert_eq!(savme_kernel_free(k), SAVME_OK);
    }
}

fn temp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("savme-capi-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    let _ = std::fs::remove_file(&p);
    let _ = std::fs::remove_file(p.with_extension("jsonl.lock"));
    p
}

fn cpath(p: &std::path::Path) -> CString {
    c(p.to_str().unwrap())
}

#[test]
fn journal_failures_name_the_file_and_line() {
    unsafe {
        let path = temp("journal.jsonl");
        let mut k = null_mut();
        refused(
            savme_kernel_open_journal(cpath(&path).as_ptr(), null(), &mut k),
            SAVME_ERROR_CONFIG,
            &["journal.jsonl is new: give `config_json` (a kernel configuration) to start it"],
        );
        let missing = path.parent().unwrap().join("no-such-dir/j.jsonl");
        refused(
            savme_kernel_open_journal(cpath(&missing).as_ptr(), config().as_ptr(), &mut k),
            SAVME_ERROR_JOURNAL,
            &["no-such-dir", "does not exist"],
        );
        assert_eq!(
            savme_kernel_open_journal(cpath(&path).as_ptr(), config().as_ptr(), &mut k),
            SAVME_OK,
            "{}",
            last()
        );
        let t = trial();
        assert_eq!(savme_ask(k, t), SAVME_OK);
        // A second opener, in this process as in another, is refused while the first lives.
        let mut second = null_mut();
        refused(
            savme_kernel_open_journal(cpath(&path).as_ptr(), null(), &mut second),
            SAVME_ERROR_JOURNAL,
            &["journal.jsonl", "this process"],
        );
        assert_eq!(savme_kernel_free(k), SAVME_OK);
        // Resumed: the pending trial is there.
        assert_eq!(
            savme_kernel_open_journal(cpath(&path).as_ptr(), null(), &mut k),
            SAVME_OK,
            "{}",
            last()
        );
        let mut info = savme_journal_info::default();
        assert_eq!(savme_journal_info_of(k, &mut info), SAVME_OK);
        assert!(info.journaled && info.resumed && info.pending == 1 && info.torn_line == 0);
        assert_eq!(savme_kernel_free(k), SAVME_OK);
        // Another configuration than the journal's.
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/config.json"))
                .unwrap();
        let other = c(&text.replacen("\"seed\": 7", "\"seed\": 8", 1));
        refused(
            savme_kernel_open_journal(cpath(&path).as_ptr(), other.as_ptr(), &mut k),
            SAVME_ERROR_CONFIG,
            &["was started with a different configuration"],
        );
        // A torn last line (a kill mid-write) is dropped and reported; an edited line refused.
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.extend_from_slice(b"{\"v\":1,\"ask\":");
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(
            savme_kernel_open_journal(cpath(&path).as_ptr(), null(), &mut k),
            SAVME_OK,
            "{}",
            last()
        );
        assert_eq!(savme_journal_info_of(k, &mut info), SAVME_OK);
        assert_eq!((info.torn_line, info.pending), (3, 1));
        assert_eq!(savme_kernel_free(k), SAVME_OK);
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, text.replacen("\"seed\":7", "\"seed\":9", 1)).unwrap();
        refused(
            savme_kernel_open_journal(cpath(&path).as_ptr(), null(), &mut k),
            SAVME_ERROR_JOURNAL,
            &["journal.jsonl, line 2: replay diverged"],
        );
        assert_eq!(savme_trial_free(t), SAVME_OK);
        std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
    }
}

#[test]
fn estimation_and_request_failures_are_named() {
    unsafe {
        let k = kernel();
        let t = trial();
        let mut asked = false;
        refused(
            savme_estimation_ask(k, t, &mut asked),
            SAVME_ERROR_ESTIMATION,
            &["no estimation is running: start one with savme_estimation_start"],
        );
        refused(
            savme_estimation_result(k, &mut null_mut()),
            SAVME_ERROR_ESTIMATION,
            &["no estimation is running"],
        );
        refused(
            savme_estimation_start(k, c("{\"epsilon\":0,\"seed\":1}").as_ptr()),
            SAVME_ERROR_ESTIMATION,
            &["epsilon (the nominal's share of the proposal) must lie in (0, 1], got 0"],
        );
        refused(
            savme_estimation_start(k, c("{\"epsilon\":0.1}").as_ptr()),
            SAVME_ERROR_ESTIMATION,
            &["`config_json`: missing field `seed`"],
        );
        assert_eq!(
            savme_estimation_start(k, c("{\"epsilon\":0.1,\"seed\":1}").as_ptr()),
            SAVME_OK
        );
        refused(
            savme_estimation_tell(k, 4, true, false, 0.0),
            SAVME_ERROR_ESTIMATION,
            &["estimation trial 4 is not pending"],
        );
        assert_eq!(savme_estimation_ask(k, t, &mut asked), SAVME_OK);
        assert!(asked);
        refused(
            savme_trial_phase(t, &mut savme_phase::SAVME_PHASE_TRAIN),
            SAVME_ERROR_ARGUMENT,
            &["an estimation trial has no phase"],
        );
        refused(
            savme_estimation_tell(k, 0, false, true, f64::NAN),
            SAVME_ERROR_ESTIMATION,
            &["robustness"],
        );
        // A JSON request answered with "ok":false: the response is still given (and freed).
        let mut response = null_mut();
        refused(
            savme_request(k, c("{\"op\":\"fly\"}").as_ptr(), &mut response),
            SAVME_ERROR_REQUEST,
            &["savme_request: not a request: unknown variant `fly`"],
        );
        let answer = CStr::from_ptr(response).to_str().unwrap().to_string();
        assert!(
            answer.starts_with("{\"ok\":false,\"error\":\"not a request"),
            "{answer}"
        );
        assert_eq!(savme_string_free(response), SAVME_OK);
        refused(savme_request(k, c("{\"op\":\"tell\",\"id\":3,\"observation\":{\"hf_only\":{\"failure\":true,\"runtime\":1}}}").as_ptr(), &mut response), SAVME_ERROR_REQUEST, &["trial 3 was never asked"]);
        assert_eq!(savme_string_free(response), SAVME_OK);
        assert_eq!(
            savme_request(k, c("{\"op\":\"ask\",\"n\":2}").as_ptr(), &mut response),
            SAVME_OK
        );
        assert_eq!(savme_string_free(response), SAVME_OK);
        let mut stats = savme_stats::default();
        assert_eq!(savme_get_stats(k, &mut stats), SAVME_OK);
        assert_eq!(stats.asked, 2);
        assert_eq!(savme_trial_free(t), SAVME_OK);
        assert_eq!(savme_kernel_free(k), SAVME_OK);
    }
}

#[test]
fn each_kernel_keeps_its_last_error_and_each_thread_its_own() {
    unsafe {
        let (k1, k2) = (kernel(), kernel());
        assert_eq!(kernel_last(k1), "");
        assert_eq!(savme_cancel(k1, 1), SAVME_ERROR_REFUSED);
        assert_eq!(savme_cancel(k2, 2), SAVME_ERROR_REFUSED);
        assert_eq!(kernel_last(k1), "savme_cancel: trial 1 was never asked");
        assert_eq!(kernel_last(k2), "savme_cancel: trial 2 was never asked");
        assert_eq!(last(), "savme_cancel: trial 2 was never asked");
        // Another thread's failure leaves this thread's message alone.
        std::thread::spawn(|| {
            assert_eq!(savme_trial_new(null_mut()), SAVME_ERROR_NULL);
            assert_eq!(last(), "savme_trial_new: `out` is NULL");
        })
        .join()
        .unwrap();
        assert_eq!(last(), "savme_cancel: trial 2 was never asked");
        assert_eq!(
            CStr::from_ptr(savme_status_name(6)).to_str().unwrap(),
            "the kernel refused the tell or cancel"
        );
        assert_eq!(
            CStr::from_ptr(savme_status_name(77)).to_str().unwrap(),
            "unknown status"
        );
        assert_eq!(savme_kernel_free(k1), SAVME_OK);
        assert_eq!(savme_kernel_free(k2), SAVME_OK);
    }
}

#[test]
fn one_kernel_serves_many_threads_at_once() {
    let k = kernel() as usize;
    let threads: Vec<_> = (0..4)
        .map(|_| {
            std::thread::spawn(move || unsafe {
                let k = std::ptr::without_provenance_mut::<savme_kernel>(k);
                let t = trial();
                for _ in 0..200 {
                    assert_eq!(savme_ask(k, t), SAVME_OK);
                    let mut id = 0;
                    assert_eq!(savme_trial_id(t, &mut id), SAVME_OK);
                    assert_eq!(
                        savme_tell_paired(
                            k,
                            id,
                            run(id % 3 == 0, 1.0),
                            run(id % 3 == 0, 0.2),
                            null_mut()
                        ),
                        SAVME_OK,
                        "{}",
                        last()
                    );
                }
                assert_eq!(savme_trial_free(t), SAVME_OK);
            })
        })
        .collect();
    for t in threads {
        t.join().unwrap();
    }
    let mut stats = savme_stats::default();
    unsafe {
        let k = std::ptr::without_provenance_mut::<savme_kernel>(k);
        assert_eq!(savme_get_stats(k, &mut stats), SAVME_OK);
        assert_eq!((stats.asked, stats.told, stats.pending), (800, 800, 0));
        assert_eq!(savme_kernel_free(k), SAVME_OK);
    }
}

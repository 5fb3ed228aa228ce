//! The kernel handle: made from a JSON configuration, a journal or a snapshot; asked, told,
//! cancelled, switched between phases; read (θ_LF*, posteriors, statistics, snapshots).

use crate::registry::{Kind, Registry};
use crate::status::*;
use crate::strings::give_string;
use crate::values::*;
use ::savme_kernel::estimation::{Estimation, EstimationConfig};
use ::savme_kernel::{
    Estimator, Kernel, Observation, Outcome as Class, Posterior, Run, TrialRecord,
};
use savme_serve::{OpenError, Session, SessionError};
use savme_store::journal::JournalError;
use savme_store::JsonlStore;
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

/// A kernel: the SAVME ask/tell state, in memory or journaled to a file. Thread-safety: a
/// kernel may be used from any thread, and from several at once — calls on one kernel are
/// serialised by a lock (asks and tells keep their order per caller). Its last error
/// (`savme_kernel_last_error`) is shared by all threads using it; each thread also has its own
/// (`savme_last_error`).
#[allow(non_camel_case_types)]
pub struct savme_kernel {
    _private: [u8; 0],
}

/// What opening a kernel found in its journal.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct savme_journal_info {
    /// The kernel logs every change to a journal file.
    pub journaled: bool,
    /// The journal existed and was replayed (false: it was started).
    pub resumed: bool,
    /// Trials told when the journal was opened.
    pub told: u64,
    /// Trials pending (asked, not told) when the journal was opened: read them with
    /// `savme_pending_trial`.
    pub pending: u64,
    /// The 1-based line of an incomplete last line that was dropped (a process killed
    /// mid-write), 0 if none.
    pub torn_line: u64,
    /// That line's length in bytes.
    pub torn_bytes: u64,
}

/// One simulator run as the harness reports it.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct savme_run {
    /// The system under test failed.
    pub failure: bool,
    /// The run's cost (finite, > 0; seconds or work units — only ratios and sums are taken).
    pub runtime: f64,
    /// `robustness` holds a value.
    pub has_robustness: bool,
    /// How close the run came to failing (finite; ≤ 0 failed, smaller = closer).
    pub robustness: f64,
}

/// How the HF and LF runs of a paired trial compare.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_outcome {
    /// Not a paired trial.
    SAVME_OUTCOME_NONE = 0,
    /// Both runs failed.
    SAVME_OUTCOME_TP = 1,
    /// Neither run failed.
    SAVME_OUTCOME_TN = 2,
    /// Only the LF run failed.
    SAVME_OUTCOME_FP = 3,
    /// Only the HF run failed.
    SAVME_OUTCOME_FN = 4,
}

/// What one bandit was credited by a tell.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_credit {
    /// Not updated (a phase that does not learn, or an HF-only trial's fidelity bandit).
    SAVME_CREDIT_NONE = 0,
    /// Credited a success.
    SAVME_CREDIT_SUCCESS = 1,
    /// Credited a failure.
    SAVME_CREDIT_FAILURE = 2,
}

/// What a tell recorded.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct savme_record {
    /// TP/TN/FP/FN of a paired trial.
    pub outcome: savme_outcome,
    /// t_LF / t_HF of a paired trial (NaN otherwise).
    pub cost_ratio: f64,
    /// The fidelity bandit's credit.
    pub fidelity: savme_credit,
    /// The scenario bandit's credit.
    pub scenario: savme_credit,
}

/// A kernel's counters.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct savme_stats {
    /// Trials asked.
    pub asked: u64,
    /// Trials told.
    pub told: u64,
    /// Trials cancelled.
    pub cancelled: u64,
    /// Trials asked and neither told nor cancelled.
    pub pending: u64,
}

/// Which estimator picks θ_LF* from the fidelity posterior.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_estimator {
    /// The configuration's (`"estimator"`; the builder's method's: evidence for the tuned
    /// one, MAP for the paper's).
    SAVME_ESTIMATOR_CONFIGURED = 0,
    /// The paper's: the arm with the highest posterior mode.
    SAVME_ESTIMATOR_MAP = 1,
    /// The arm with the highest posterior mean.
    SAVME_ESTIMATOR_MEAN = 2,
    /// savme's tuned one: the arm with the highest lower 10 % quantile of its Beta belief,
    /// every false alarm charged as 1 / C_budget losses (needs a kernel configured with it to
    /// have the false-alarm tallies; otherwise it counts none).
    SAVME_ESTIMATOR_EVIDENCE = 3,
}

/// The estimator a `savme_estimator` other than `SAVME_ESTIMATOR_CONFIGURED` names.
pub(crate) fn estimator_of(estimator: i32) -> Outcome<Estimator> {
    match estimator {
        1 => Ok(Estimator::Map),
        2 => Ok(Estimator::Mean),
        3 => Ok(Estimator::Evidence),
        _ => Err(Failure::new(
            SAVME_ERROR_ARGUMENT,
            format!("`estimator` must be a savme_estimator (0 to 3), got {estimator}"),
        )),
    }
}

pub(crate) struct KernelState {
    session: Session,
    estimation: Option<Estimation>,
    info: savme_journal_info,
    last_error: CString,
    /// A panic happened inside a call: the state may be half-changed.
    broken: bool,
}

static KERNELS: Registry<KernelState> = Registry::new(Kind::Kernel);

/// Runs `body` on the live kernel `k`: a failure is also recorded as the kernel's last error;
/// a panic inside marks the kernel broken.
fn with_kernel(
    function: &str,
    k: *const savme_kernel,
    body: impl FnOnce(&mut KernelState) -> Outcome,
) -> savme_status {
    guard(function, || {
        let kernel = KERNELS
            .get(k as usize)
            .map_err(|l| lookup_failure(l, "k", "savme_kernel"))?;
        let mut state = lock(&kernel);
        if state.broken {
            return Err(Failure::new(
                SAVME_ERROR_INTERNAL,
                "an earlier call on this kernel failed inside savme: free it (its journal, if any, holds every change that was answered)",
            ));
        }
        let result = catch_unwind(AssertUnwindSafe(|| body(&mut state))).unwrap_or_else(|p| {
            state.broken = true;
            Err(Failure::new(SAVME_ERROR_INTERNAL, panic_message(&*p)))
        });
        if let Err(f) = &result {
            state.last_error = c_message(&format!("{function}: {}", f.message));
        }
        result
    })
}

fn register(session: Session, info: savme_journal_info, out: &mut *mut savme_kernel) {
    let handle = KERNELS.insert(KernelState {
        session,
        estimation: None,
        info,
        last_error: CString::default(),
        broken: false,
    });
    *out = std::ptr::without_provenance_mut(handle);
}

/// Registers a plain (not journaled) kernel as a handle into `*out`.
pub(crate) fn register_plain(kernel: Kernel, out: &mut *mut savme_kernel) {
    register(Session::Plain(kernel), savme_journal_info::default(), out);
}

fn config_failure(e: savme_serve::ParseConfigError) -> Failure {
    Failure::new(SAVME_ERROR_CONFIG, format!("`config_json`: {e}"))
}

fn session_failure(e: SessionError) -> Failure {
    let status = match &e {
        SessionError::Refused(_) => SAVME_ERROR_REFUSED,
        SessionError::Journal(_) => SAVME_ERROR_JOURNAL,
        SessionError::BadBatch(_) | SessionError::NoSuchLevel { .. } => SAVME_ERROR_ARGUMENT,
        SessionError::Estimation(_) | SessionError::NoEstimation => SAVME_ERROR_ESTIMATION,
    };
    let message = match e {
        SessionError::NoEstimation => {
            "no estimation is running: start one with savme_estimation_start".into()
        }
        e => e.to_string(),
    };
    Failure::new(status, message)
}

/// Makes a kernel (in memory, not journaled) from `config_json`, a kernel configuration as
/// `savme example-config` prints it and `savme serve --config` reads it, into `*out`.
/// `SAVME_ERROR_CONFIG` names the line and column, or the variable or value, that is wrong.
/// Free it with `savme_kernel_free`.
#[no_mangle]
pub unsafe extern "C" fn savme_kernel_new(
    config_json: *const c_char,
    out: *mut *mut savme_kernel,
) -> savme_status {
    guard("savme_kernel_new", || {
        let text = text(config_json, "config_json")?;
        let out = required(out, "out")?;
        let config = savme_serve::parse_config(text).map_err(config_failure)?;
        let opened = Session::open(Some(config), None)
            .map_err(|e| Failure::new(SAVME_ERROR_CONFIG, e.to_string()))?;
        register(opened.session, savme_journal_info::default(), out);
        Ok(())
    })
}

/// The path argument `path` (any bytes on Unix; UTF-8 elsewhere).
unsafe fn path_of(path: *const c_char) -> Outcome<PathBuf> {
    if path.is_null() {
        return Err(Failure::new(SAVME_ERROR_NULL, "`path` is NULL"));
    }
    // SAFETY: the caller promises a NUL-terminated string.
    let bytes = unsafe { std::ffi::CStr::from_ptr(path) }.to_bytes();
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        Ok(PathBuf::from(std::ffi::OsStr::from_bytes(bytes)))
    }
    #[cfg(not(unix))]
    {
        text(path, "path").map(PathBuf::from)
    }
}

/// Opens a kernel journaled to the file `path`, exactly as `savme serve --journal` does: a new
/// file is started with `config_json` (required then); an existing one is replayed — after a
/// crash or `kill -9` too (a torn last line is dropped) — and `config_json`, if not NULL, must
/// be the one it was started with. Every ask, tell, cancel and phase change is written to the
/// file before it takes effect; the file is locked against a second opener (another process, or
/// this one) until the kernel is freed. `SAVME_ERROR_JOURNAL` names the file (and line);
/// `SAVME_ERROR_CONFIG` a configuration that is wrong. Read what was found with
/// `savme_journal_info`, and the trials pending at the crash with `savme_pending_trial`.
#[no_mangle]
pub unsafe extern "C" fn savme_kernel_open_journal(
    path: *const c_char,
    config_json: *const c_char,
    out: *mut *mut savme_kernel,
) -> savme_status {
    guard("savme_kernel_open_journal", || {
        let path = path_of(path)?;
        let config = optional_text(config_json, "config_json")?
            .map(savme_serve::parse_config)
            .transpose()
            .map_err(config_failure)?;
        let out = required(out, "out")?;
        let store = JsonlStore::open(&path)
            .map_err(|e| Failure::new(SAVME_ERROR_JOURNAL, e.to_string()))?;
        let opened = Session::open(config, Some(Box::new(store))).map_err(|e| match e {
            OpenError::Journal(JournalError::NoConfig { store }) => Failure::new(
                SAVME_ERROR_CONFIG,
                format!("{store} is new: give `config_json` (a kernel configuration) to start it"),
            ),
            OpenError::Journal(JournalError::Config { store, source }) => {
                Failure::new(SAVME_ERROR_CONFIG, format!("{store}: {source}"))
            }
            e @ OpenError::Journal(JournalError::OtherConfig { .. }) => {
                Failure::new(SAVME_ERROR_CONFIG, e.to_string())
            }
            e => Failure::new(SAVME_ERROR_JOURNAL, e.to_string()),
        })?;
        let (told, pending) = opened
            .resumed
            .as_ref()
            .map_or((0, 0), |(told, p)| (*told, p.len() as u64));
        let info = savme_journal_info {
            journaled: true,
            resumed: opened.resumed.is_some(),
            told,
            pending,
            torn_line: opened.torn.as_ref().map_or(0, |t| t.line),
            torn_bytes: opened.torn.as_ref().map_or(0, |t| t.bytes),
        };
        register(opened.session, info, out);
        Ok(())
    })
}

/// Makes a kernel (in memory) from a snapshot: the `len` bytes at `data` as `savme_snapshot`
/// wrote them (JSON). `SAVME_ERROR_CONFIG` names what is wrong.
#[no_mangle]
pub unsafe extern "C" fn savme_kernel_from_snapshot(
    data: *const u8,
    len: usize,
    out: *mut *mut savme_kernel,
) -> savme_status {
    guard("savme_kernel_from_snapshot", || {
        if data.is_null() {
            return Err(Failure::new(SAVME_ERROR_NULL, "`data` is NULL"));
        }
        let out = required(out, "out")?;
        // SAFETY: the caller promises `len` readable bytes at `data`.
        let bytes = unsafe { std::slice::from_raw_parts(data, len) };
        let json = std::str::from_utf8(bytes).map_err(|e| {
            Failure::new(
                SAVME_ERROR_CONFIG,
                format!("the snapshot is not UTF-8 (byte {})", e.valid_up_to() + 1),
            )
        })?;
        let kernel =
            Kernel::from_json(json).map_err(|e| Failure::new(SAVME_ERROR_CONFIG, e.to_string()))?;
        register(Session::Plain(kernel), savme_journal_info::default(), out);
        Ok(())
    })
}

/// Frees a kernel (a journaled one closes and unlocks its file; what was answered is in it).
/// NULL does nothing (as `free(NULL)`); a handle freed before, or any pointer that is not a
/// live kernel handle, is refused with `SAVME_ERROR_HANDLE` and nothing happens. Wait until
/// no other thread calls into the kernel.
#[no_mangle]
pub unsafe extern "C" fn savme_kernel_free(k: *mut savme_kernel) -> savme_status {
    guard("savme_kernel_free", || {
        if k.is_null() {
            return Ok(());
        }
        KERNELS
            .remove(k as usize)
            .map_err(|l| lookup_failure(l, "k", "savme_kernel"))
    })
}

/// The message of the last call on `k` that did not return `SAVME_OK` (an empty string before
/// any), naming the function and the argument, trial or file. Valid until the next failing
/// call on `k` or until `k` is freed. For a NULL or dead handle, a constant message saying so.
/// Never NULL.
#[no_mangle]
pub extern "C" fn savme_kernel_last_error(k: *const savme_kernel) -> *const c_char {
    let found = catch_unwind(|| {
        KERNELS
            .get(k as usize)
            .ok()
            .map(|kernel| lock(&kernel).last_error.as_ptr())
    });
    match found {
        // The pointer stays valid while the kernel lives: its message is replaced only by a
        // later failing call.
        Ok(Some(p)) => p,
        _ => "savme_kernel_last_error: `k` is not a live savme_kernel handle\0"
            .as_ptr()
            .cast(),
    }
}

/// What opening the kernel found in its journal into `*info` (all zero for a kernel without
/// one).
#[no_mangle]
pub unsafe extern "C" fn savme_journal_info_of(
    k: *const savme_kernel,
    info: *mut savme_journal_info,
) -> savme_status {
    with_kernel("savme_journal_info_of", k, |s| {
        *required(info, "info")? = s.info;
        Ok(())
    })
}

/// Fills the trial handle `t` with `trial` of kernel `s`.
fn fill(t: &mut TrialState, trial: ::savme_kernel::Trial, s: &KernelState) {
    t.held = Held::Kernel {
        trial,
        theta_hf: s.session.kernel().theta_hf().clone(),
    };
}

/// Asks the next trial in the current phase and fills the trial handle `t` with it (the
/// handle is reused: no allocation beyond the kernel's own). Any number of trials may be pending.
/// With a journal, the ask is written first (`SAVME_ERROR_JOURNAL`: nothing was asked).
#[no_mangle]
pub unsafe extern "C" fn savme_ask(k: *mut savme_kernel, t: *mut savme_trial) -> savme_status {
    with_kernel("savme_ask", k, |s| {
        let trial = trial_of(t, "t")?;
        let asked = s.session.ask_one().map_err(session_failure)?;
        fill(&mut lock(&trial), asked, s);
        Ok(())
    })
}

/// Asks `n` trials at once, all or none (a journal writes them in one go), filling the `n`
/// distinct trial handles `trials[0..n)`. `n` must be 1 to 100000.
#[no_mangle]
pub unsafe extern "C" fn savme_ask_batch(
    k: *mut savme_kernel,
    trials: *const *mut savme_trial,
    n: usize,
) -> savme_status {
    with_kernel("savme_ask_batch", k, |s| {
        if trials.is_null() {
            return Err(Failure::new(SAVME_ERROR_NULL, "`trials` is NULL"));
        }
        if n == 0 || n > savme_serve::MAX_BATCH {
            return Err(Failure::new(
                SAVME_ERROR_ARGUMENT,
                format!(
                    "`n` must be between 1 and {}, got {n}",
                    savme_serve::MAX_BATCH
                ),
            ));
        }
        // SAFETY: the caller promises `n` readable handles at `trials`.
        let handles = unsafe { std::slice::from_raw_parts(trials, n) };
        let mut seen: Vec<usize> = handles.iter().map(|h| *h as usize).collect();
        seen.sort_unstable();
        if let Some(w) = seen.windows(2).find(|w| w[0] == w[1] && w[0] != 0) {
            let at: Vec<usize> = (0..n).filter(|&i| handles[i] as usize == w[0]).collect();
            return Err(Failure::new(
                SAVME_ERROR_ARGUMENT,
                format!(
                    "`trials[{}]` and `trials[{}]` are the same handle",
                    at[0], at[1]
                ),
            ));
        }
        let held = handles
            .iter()
            .enumerate()
            .map(|(i, h)| trial_of(*h, &format!("trials[{i}]")))
            .collect::<Outcome<Vec<_>>>()?;
        let asked = s.session.ask(n).map_err(session_failure)?;
        for (trial, handle) in asked.into_iter().zip(&held) {
            fill(&mut lock(handle), trial, s);
        }
        Ok(())
    })
}

fn run_of(r: &savme_run) -> Run {
    let run = Run::new(r.failure, r.runtime);
    if r.has_robustness {
        run.with_robustness(r.robustness)
    } else {
        run
    }
}

fn credit(c: Option<bool>) -> savme_credit {
    match c {
        None => savme_credit::SAVME_CREDIT_NONE,
        Some(true) => savme_credit::SAVME_CREDIT_SUCCESS,
        Some(false) => savme_credit::SAVME_CREDIT_FAILURE,
    }
}

fn c_record(r: &TrialRecord) -> savme_record {
    savme_record {
        outcome: match r.outcome {
            None => savme_outcome::SAVME_OUTCOME_NONE,
            Some(Class::TP) => savme_outcome::SAVME_OUTCOME_TP,
            Some(Class::TN) => savme_outcome::SAVME_OUTCOME_TN,
            Some(Class::FP) => savme_outcome::SAVME_OUTCOME_FP,
            Some(Class::FN) => savme_outcome::SAVME_OUTCOME_FN,
        },
        cost_ratio: r.cost_ratio.unwrap_or(f64::NAN),
        fidelity: credit(r.credit.fidelity),
        scenario: credit(r.credit.scenario),
    }
}

fn tell(
    s: &mut KernelState,
    id: u64,
    observation: Observation,
    record: *mut savme_record,
) -> Outcome {
    let told = s.session.tell(id, observation).map_err(session_failure)?;
    // SAFETY: NULL or valid for writes (the header's contract).
    if let Some(out) = unsafe { record.as_mut() } {
        *out = c_record(&told);
    }
    Ok(())
}

/// Tells trial `id`'s paired observation: its HF run (at θ_HF) and its LF run (at the trial's
/// θ_LF). `record`, if not NULL, receives what the tell credited. Refused
/// (`SAVME_ERROR_REFUSED`, naming the trial; nothing changes) for a trial never asked, told
/// or cancelled before, one without θ_LF, or a runtime or robustness out of range.
#[no_mangle]
pub unsafe extern "C" fn savme_tell_paired(
    k: *mut savme_kernel,
    id: u64,
    hf: savme_run,
    lf: savme_run,
    record: *mut savme_record,
) -> savme_status {
    with_kernel("savme_tell_paired", k, |s| {
        let observation = Observation::Paired {
            hf: run_of(&hf),
            lf: run_of(&lf),
        };
        tell(s, id, observation, record)
    })
}

/// Tells trial `id`'s HF run alone: a baseline trial, or a learning trial the kernel left
/// unpaired (`savme_trial_is_paired` false). Refused as `savme_tell_paired` is.
#[no_mangle]
pub unsafe extern "C" fn savme_tell_hf_only(
    k: *mut savme_kernel,
    id: u64,
    hf: savme_run,
    record: *mut savme_record,
) -> savme_status {
    with_kernel("savme_tell_hf_only", k, |s| {
        tell(s, id, Observation::HfOnly(run_of(&hf)), record)
    })
}

/// Withdraws pending trial `id` (its runs failed or will never come): it credits nothing.
/// Refused (`SAVME_ERROR_REFUSED`) for a trial that is not pending.
#[no_mangle]
pub unsafe extern "C" fn savme_cancel(k: *mut savme_kernel, id: u64) -> savme_status {
    with_kernel("savme_cancel", k, |s| {
        s.session.cancel(id).map_err(session_failure)?;
        Ok(())
    })
}

/// Switches the phase (a `savme_phase`) of the asks that follow; pending trials keep theirs.
#[no_mangle]
pub unsafe extern "C" fn savme_set_phase(k: *mut savme_kernel, phase: i32) -> savme_status {
    with_kernel("savme_set_phase", k, |s| {
        let phase = rust_phase(phase)?;
        s.session.set_phase(phase).map_err(session_failure)
    })
}

/// The phase of the next ask into `*phase`.
#[no_mangle]
pub unsafe extern "C" fn savme_get_phase(
    k: *const savme_kernel,
    phase: *mut savme_phase,
) -> savme_status {
    with_kernel("savme_get_phase", k, |s| {
        *required(phase, "phase")? = c_phase(s.session.kernel().phase());
        Ok(())
    })
}

/// The kernel's counters into `*stats`.
#[no_mangle]
pub unsafe extern "C" fn savme_get_stats(
    k: *const savme_kernel,
    stats: *mut savme_stats,
) -> savme_status {
    with_kernel("savme_get_stats", k, |s| {
        let out = required(stats, "stats")?;
        let kernel = s.session.kernel();
        let st = kernel.stats();
        *out = savme_stats {
            asked: st.asked,
            told: st.told,
            cancelled: st.cancelled,
            pending: kernel.pending().count() as u64,
        };
        Ok(())
    })
}

/// Fills `t` with the `index`th pending trial, in id order (`savme_get_stats`'s `pending`
/// counts them): after a journal was resumed, these are the trials to run again or cancel.
#[no_mangle]
pub unsafe extern "C" fn savme_pending_trial(
    k: *const savme_kernel,
    index: usize,
    t: *mut savme_trial,
) -> savme_status {
    with_kernel("savme_pending_trial", k, |s| {
        let trial = trial_of(t, "t")?;
        let kernel = s.session.kernel();
        let found = kernel.pending().nth(index).cloned().ok_or_else(|| {
            Failure::new(
                SAVME_ERROR_ARGUMENT,
                format!(
                    "`index` {index} is out of range: {} trials are pending",
                    kernel.pending().count()
                ),
            )
        })?;
        fill(&mut lock(&trial), found, s);
        Ok(())
    })
}

fn assignment_of(
    a: *const savme_assignment,
) -> Outcome<std::sync::Arc<std::sync::Mutex<Option<::savme_kernel::Assignment>>>> {
    ASSIGNMENTS
        .get(a as usize)
        .map_err(|l| lookup_failure(l, "out", "savme_assignment"))
}

/// Fills the assignment handle `out` with the high-fidelity settings θ_HF.
#[no_mangle]
pub unsafe extern "C" fn savme_theta_hf(
    k: *const savme_kernel,
    out: *mut savme_assignment,
) -> savme_status {
    with_kernel("savme_theta_hf", k, |s| {
        let held = assignment_of(out)?;
        *lock(&held) = Some(s.session.kernel().theta_hf().clone());
        Ok(())
    })
}

/// Fills the assignment handle `out` with θ_LF*, the learned fidelity settings the posterior
/// favours under `estimator` (a `savme_estimator`), and, if `evidence` is not NULL, writes how
/// many observations stand behind it (told or transferred; 0: nothing was learned yet and
/// θ_LF* is only the prior's choice) — `savme serve`'s `estimate`.
#[no_mangle]
pub unsafe extern "C" fn savme_estimate(
    k: *const savme_kernel,
    estimator: i32,
    out: *mut savme_assignment,
    evidence: *mut f64,
) -> savme_status {
    with_kernel("savme_estimate", k, |s| {
        let kernel = s.session.kernel();
        let est = match estimator {
            0 => kernel.config().estimator,
            e => estimator_of(e)?,
        };
        let held = assignment_of(out)?;
        *lock(&held) = Some(kernel.fidelity_estimate(est));
        // SAFETY: NULL or valid for writes.
        if let Some(e) = unsafe { evidence.as_mut() } {
            *e = savme_serve::evidence(kernel.fidelity_posterior());
        }
        Ok(())
    })
}

/// The evidence behind θ_LF* under `estimator` (a `savme_estimator`), as JSON into `*json`
/// (free it with `savme_string_free`): per fidelity setting the chosen arm, how often the
/// learning trials tried it (`tried`, `successes`, `tp`, `tn`, `fp`, `fn`, `cost`) and its
/// `false_alarm_rate` and `miss_rate` on HF (null without an HF pass or failure) — the
/// `settings` of `savme serve`'s `estimate`, Python's `Kernel.estimate_evidence()`; `null`
/// when the kernel keeps no tallies (its configuration's estimator is not evidence).
#[no_mangle]
pub unsafe extern "C" fn savme_estimate_evidence(
    k: *const savme_kernel,
    estimator: i32,
    json: *mut *mut c_char,
) -> savme_status {
    with_kernel("savme_estimate_evidence", k, |s| {
        let kernel = s.session.kernel();
        let est = match estimator {
            0 => kernel.config().estimator,
            e => estimator_of(e)?,
        };
        let json = required(json, "json")?;
        let settings = savme_serve::chosen_settings(kernel, est);
        let text = serde_json::to_string(&settings)
            .map_err(|e| Failure::new(SAVME_ERROR_INTERNAL, e.to_string()))?;
        *json = give_string(text);
        Ok(())
    })
}

/// How many scenarios the kernel has into `*count`.
#[no_mangle]
pub unsafe extern "C" fn savme_scenario_count(
    k: *const savme_kernel,
    count: *mut usize,
) -> savme_status {
    with_kernel("savme_scenario_count", k, |s| {
        *required(count, "count")? = s.session.kernel().config().scenarios.len();
        Ok(())
    })
}

/// The `index`th scenario's name into `*name` (valid until the kernel is freed) and, if
/// `weight` is not NULL, its weight in p(s).
#[no_mangle]
pub unsafe extern "C" fn savme_scenario(
    k: *const savme_kernel,
    index: usize,
    name: *mut savme_str,
    weight: *mut f64,
) -> savme_status {
    with_kernel("savme_scenario", k, |s| {
        let name = required(name, "name")?;
        let scenarios = &s.session.kernel().config().scenarios;
        let sc = scenarios.get(index).ok_or_else(|| {
            Failure::new(
                SAVME_ERROR_ARGUMENT,
                format!(
                    "`index` {index} is out of range: the kernel has {} scenarios",
                    scenarios.len()
                ),
            )
        })?;
        *name = savme_str::of(&sc.name);
        // SAFETY: NULL or valid for writes.
        if let Some(w) = unsafe { weight.as_mut() } {
            *w = sc.weight;
        }
        Ok(())
    })
}

/// The posterior of `scenario` (NULL: the fidelity posterior).
unsafe fn posterior_of(s: &KernelState, scenario: *const c_char) -> Outcome<&Posterior> {
    let kernel = s.session.kernel();
    match optional_text(scenario, "scenario")? {
        None => Ok(kernel.fidelity_posterior()),
        Some(name) => kernel.scenario_posterior(name).ok_or_else(|| {
            let names: Vec<&str> = kernel.config().scenarios.iter().map(|s| &*s.name).collect();
            Failure::new(
                SAVME_ERROR_NOT_FOUND,
                format!("no scenario `{name}` (there are: {})", names.join(", ")),
            )
        }),
    }
}

/// How many variables the posterior of `scenario` (NULL: the fidelity posterior) has.
#[no_mangle]
pub unsafe extern "C" fn savme_posterior_count(
    k: *const savme_kernel,
    scenario: *const c_char,
    count: *mut usize,
) -> savme_status {
    with_kernel("savme_posterior_count", k, |s| {
        let count = required(count, "count")?;
        *count = posterior_of(s, scenario)?.names().len();
        Ok(())
    })
}

/// The `variable`th variable of the posterior of `scenario` (NULL: the fidelity posterior):
/// its name into `*name` (valid until the kernel is freed) and, if `arms` is not NULL, its
/// number of arms (bins or values).
#[no_mangle]
pub unsafe extern "C" fn savme_posterior_variable(
    k: *const savme_kernel,
    scenario: *const c_char,
    variable: usize,
    name: *mut savme_str,
    arms: *mut usize,
) -> savme_status {
    with_kernel("savme_posterior_variable", k, |s| {
        let name = required(name, "name")?;
        let p = posterior_of(s, scenario)?;
        let n = p
            .names()
            .get(variable)
            .ok_or_else(|| out_of_range("variable", variable, p.names().len()))?;
        *name = savme_str::of(n);
        // SAFETY: NULL or valid for writes.
        if let Some(a) = unsafe { arms.as_mut() } {
            *a = p.arms()[variable].len();
        }
        Ok(())
    })
}

fn out_of_range(what: &str, index: usize, len: usize) -> Failure {
    Failure::new(
        SAVME_ERROR_ARGUMENT,
        format!("`{what}` {index} is out of range (0 to {})", len as i64 - 1),
    )
}

/// Arm `arm` of variable `variable` of the posterior of `scenario` (NULL: the fidelity
/// posterior): its Beta(α, β) into `*alpha` and `*beta`.
#[no_mangle]
pub unsafe extern "C" fn savme_posterior_arm(
    k: *const savme_kernel,
    scenario: *const c_char,
    variable: usize,
    arm: usize,
    alpha: *mut f64,
    beta: *mut f64,
) -> savme_status {
    with_kernel("savme_posterior_arm", k, |s| {
        let alpha = required(alpha, "alpha")?;
        let beta = required(beta, "beta")?;
        let p = posterior_of(s, scenario)?;
        let arms = p
            .arms()
            .get(variable)
            .ok_or_else(|| out_of_range("variable", variable, p.arms().len()))?;
        let a = arms
            .get(arm)
            .ok_or_else(|| out_of_range("arm", arm, arms.len()))?;
        *alpha = a.alpha;
        *beta = a.beta;
        Ok(())
    })
}

/// The kernel's state as a snapshot (JSON bytes, NUL-terminated) into `*data` and its length
/// (without the NUL) into `*len`; free it with `savme_string_free`. `savme_kernel_from_snapshot`
/// restores it: the restored kernel asks what this one would.
#[no_mangle]
pub unsafe extern "C" fn savme_snapshot(
    k: *const savme_kernel,
    data: *mut *mut c_char,
    len: *mut usize,
) -> savme_status {
    with_kernel("savme_snapshot", k, |s| {
        let data = required(data, "data")?;
        let len = required(len, "len")?;
        let json = s.session.kernel().to_json();
        *len = json.len();
        *data = give_string(json);
        Ok(())
    })
}

/// The kernel's configuration (JSON, as `savme_kernel_new` reads it) into `*json`; free it with
/// `savme_string_free`.
#[no_mangle]
pub unsafe extern "C" fn savme_config(
    k: *const savme_kernel,
    json: *mut *mut c_char,
) -> savme_status {
    with_kernel("savme_config", k, |s| {
        let json = required(json, "json")?;
        let text = serde_json::to_string(s.session.kernel().config())
            .map_err(|e| Failure::new(SAVME_ERROR_INTERNAL, e.to_string()))?;
        *json = give_string(text);
        Ok(())
    })
}

/// Answers one request of `savme serve`'s JSON-lines protocol (`{"op":"ask","n":4}`, `tell`,
/// `cancel`, `phase`, `estimate`, `posterior`, `stats`, `pending`, `estimation`,
/// `estimation_ask`, `estimation_tell`, `estimation_result`) exactly as the server does, on
/// this kernel (journaled like the typed calls); the response object into `*response` (free it
/// with `savme_string_free`). `SAVME_ERROR_REQUEST` when the response is `"ok":false`
/// (`*response` is set then too, and the error is also the last error).
#[no_mangle]
pub unsafe extern "C" fn savme_request(
    k: *mut savme_kernel,
    request: *const c_char,
    response: *mut *mut c_char,
) -> savme_status {
    with_kernel("savme_request", k, |s| {
        let line = text(request, "request")?;
        let response = required(response, "response")?;
        let answer = s.session.handle_with(line, &mut s.estimation);
        let failed = answer.get("ok") != Some(&serde_json::Value::Bool(true));
        let message = answer
            .get("error")
            .and_then(|e| e.as_str())
            .unwrap_or("")
            .to_string();
        *response = give_string(answer.to_string());
        if failed {
            return Err(Failure::new(SAVME_ERROR_REQUEST, message));
        }
        Ok(())
    })
}

/// Starts an importance-sampling estimation of P(failure) from the current posteriors
/// (docs/ESTIMATION.md), replacing any earlier one: `config_json` as `savme serve`'s
/// `estimation` request without `"op"`, e.g. `{"epsilon":0.1,"seed":7}`. Never changes the
/// kernel and is not journaled.
#[no_mangle]
pub unsafe extern "C" fn savme_estimation_start(
    k: *mut savme_kernel,
    config_json: *const c_char,
) -> savme_status {
    with_kernel("savme_estimation_start", k, |s| {
        let text = text(config_json, "config_json")?;
        let config: EstimationConfig = serde_json::from_str(text)
            .map_err(|e| Failure::new(SAVME_ERROR_ESTIMATION, format!("`config_json`: {e}")))?;
        let e = s
            .session
            .kernel()
            .estimation(&config)
            .map_err(|e| session_failure(SessionError::Estimation(e)))?;
        s.estimation = Some(e);
        Ok(())
    })
}

/// Asks the running estimation's next trial into `t` and sets `*asked`; `*asked` is false (and
/// `t` unchanged) while a refinement round waits for its outcomes. Read its densities with
/// `savme_trial_densities`.
#[no_mangle]
pub unsafe extern "C" fn savme_estimation_ask(
    k: *mut savme_kernel,
    t: *mut savme_trial,
    asked: *mut bool,
) -> savme_status {
    with_kernel("savme_estimation_ask", k, |s| {
        let asked = required(asked, "asked")?;
        let trial = trial_of(t, "t")?;
        let e = s
            .estimation
            .as_mut()
            .ok_or_else(|| session_failure(SessionError::NoEstimation))?;
        *asked = false;
        if let Some(next) = e.ask() {
            lock(&trial).held = Held::Estimation {
                trial: next,
                theta_hf: s.session.kernel().theta_hf().clone(),
            };
            *asked = true;
        }
        Ok(())
    })
}

/// Tells estimation trial `id`'s HF failure (and, if `has_robustness`, its robustness).
#[no_mangle]
pub unsafe extern "C" fn savme_estimation_tell(
    k: *mut savme_kernel,
    id: u64,
    failure: bool,
    has_robustness: bool,
    robustness: f64,
) -> savme_status {
    with_kernel("savme_estimation_tell", k, |s| {
        let e = s
            .estimation
            .as_mut()
            .ok_or_else(|| session_failure(SessionError::NoEstimation))?;
        e.tell_run(id, failure, has_robustness.then_some(robustness))
            .map_err(|e| session_failure(SessionError::Estimation(e)))
    })
}

/// The running estimation's result (JSON, as `savme serve`'s `estimation_result`: `estimate`,
/// `told`, `round`) into `*json`; free it with `savme_string_free`.
#[no_mangle]
pub unsafe extern "C" fn savme_estimation_result(
    k: *const savme_kernel,
    json: *mut *mut c_char,
) -> savme_status {
    with_kernel("savme_estimation_result", k, |s| {
        let json = required(json, "json")?;
        let e = s
            .estimation
            .as_ref()
            .ok_or_else(|| session_failure(SessionError::NoEstimation))?;
        let answer = serde_json::json!({
            "estimate": e.estimate(),
            "told": e.told(),
            "round": e.round(),
        });
        *json = give_string(answer.to_string());
        Ok(())
    })
}

#[cfg(test)]
pub(crate) fn panic_inside(k: *const savme_kernel) -> savme_status {
    with_kernel("panic_inside", k, |_| panic!("deliberate"))
}

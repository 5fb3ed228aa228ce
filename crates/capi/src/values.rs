//! Trials and assignments as C sees them: the reusable `savme_trial` and `savme_assignment`
//! handles and their typed values, read by index or by name.

use crate::registry::{Kind, Lookup, Registry};
use crate::status::*;
use savme_kernel::estimation::EstimationTrial;
use savme_kernel::{Assignment, Phase, Trial, Value};
use std::ffi::c_char;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

/// A trial the kernel asked, held for reading: φ, θ_LF, θ_HF, its id, phase and scenario.
/// Made once with `savme_trial_new` and filled again by each `savme_ask` (no allocation per
/// ask); freed with `savme_trial_free`. Thread-safety: may be used from any thread (calls on
/// one trial are serialised by a lock), but the strings a trial hands out (`savme_str`) stay
/// valid only until the trial is filled again or freed.
#[allow(non_camel_case_types)]
pub struct savme_trial {
    _private: [u8; 0],
}

/// Named values (θ_LF*, θ_HF) held for reading. Made with `savme_assignment_new`, filled by
/// `savme_estimate` or `savme_theta_hf`, freed with `savme_assignment_free`. Thread-safety: as
/// `savme_trial`.
#[allow(non_camel_case_types)]
pub struct savme_assignment {
    _private: [u8; 0],
}

/// A string the library owns, as a pointer and a length in bytes (UTF-8, not NUL-terminated:
/// print it with `printf("%.*s", (int)s.len, s.ptr)`). Never NULL; valid as long as the
/// handle that gave it says.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct savme_str {
    /// The first byte.
    pub ptr: *const c_char,
    /// The length in bytes.
    pub len: usize,
}

impl savme_str {
    pub(crate) fn of(s: &str) -> Self {
        savme_str {
            ptr: s.as_ptr().cast(),
            len: s.len(),
        }
    }
}

/// The type of a value.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_type {
    /// A boolean (`boolean`).
    SAVME_TYPE_BOOL = 0,
    /// An integer (`integer`; also in `real`).
    SAVME_TYPE_INT = 1,
    /// A real number (`real`).
    SAVME_TYPE_REAL = 2,
    /// A label (`label`).
    SAVME_TYPE_LABEL = 3,
}

/// One variable's value in a trial or an assignment.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct savme_value {
    /// The variable's name.
    pub name: savme_str,
    /// Which of the fields below holds the value.
    pub kind: savme_type,
    /// The value of a `SAVME_TYPE_BOOL` (false otherwise).
    pub boolean: bool,
    /// The value of a `SAVME_TYPE_INT` (0 otherwise).
    pub integer: i64,
    /// The value of a `SAVME_TYPE_REAL`, or of a `SAVME_TYPE_INT` as a double (NaN otherwise).
    pub real: f64,
    /// The value of a `SAVME_TYPE_LABEL` (empty otherwise).
    pub label: savme_str,
}

/// Which values of a trial: its scenario parameters φ, its learned-fidelity settings θ_LF
/// (none for a baseline or unpaired trial), or the high-fidelity settings θ_HF.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_part {
    /// φ.
    SAVME_PHI = 0,
    /// θ_LF.
    SAVME_THETA_LF = 1,
    /// θ_HF.
    SAVME_THETA_HF = 2,
}

/// What a trial handle holds.
pub(crate) enum Held {
    Empty,
    Kernel {
        trial: Trial,
        theta_hf: Assignment,
    },
    Estimation {
        trial: EstimationTrial,
        theta_hf: Assignment,
    },
}

pub(crate) struct TrialState {
    pub(crate) held: Held,
}

pub(crate) static TRIALS: Registry<TrialState> = Registry::new(Kind::Trial);
pub(crate) static ASSIGNMENTS: Registry<Option<Assignment>> = Registry::new(Kind::Assignment);

/// The failure of a lookup of argument `name`, a handle of kind `what`.
pub(crate) fn lookup_failure(l: Lookup, name: &str, what: &str) -> Failure {
    match l {
        Lookup::Null => Failure::new(SAVME_ERROR_NULL, format!("`{name}` is NULL")),
        Lookup::Dead => Failure::new(
            SAVME_ERROR_HANDLE,
            format!("`{name}` is not a live {what} handle (freed, freed twice, never made, or another kind of handle)"),
        ),
    }
}

/// The live trial behind `t`.
pub(crate) fn trial_of(t: *const savme_trial, name: &str) -> Outcome<Arc<Mutex<TrialState>>> {
    TRIALS
        .get(t as usize)
        .map_err(|l| lookup_failure(l, name, "savme_trial"))
}

/// Locks a handle's value (a panic while one was held is caught at the boundary and leaves no
/// half-done change behind in a trial or an assignment, so a poisoned lock is taken over).
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A phase as C sees it.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_phase {
    /// Meta-training: φ and θ_LF by Thompson sampling; both bandits learn.
    SAVME_PHASE_TRAIN = 0,
    /// Evaluation: θ_LF the estimate, φ by Thompson draw; nothing learns.
    SAVME_PHASE_EVALUATE = 1,
    /// Baseline: φ uniform, HF only; nothing learns.
    SAVME_PHASE_BASELINE = 2,
    /// Meta-testing: like train, on new scenarios.
    SAVME_PHASE_TEST = 3,
}

pub(crate) fn c_phase(p: Phase) -> savme_phase {
    match p {
        Phase::Train => savme_phase::SAVME_PHASE_TRAIN,
        Phase::Evaluate => savme_phase::SAVME_PHASE_EVALUATE,
        Phase::Baseline => savme_phase::SAVME_PHASE_BASELINE,
        Phase::Test => savme_phase::SAVME_PHASE_TEST,
    }
}

pub(crate) fn rust_phase(p: i32) -> Outcome<Phase> {
    Ok(match p {
        0 => Phase::Train,
        1 => Phase::Evaluate,
        2 => Phase::Baseline,
        3 => Phase::Test,
        _ => {
            return Err(Failure::new(
                SAVME_ERROR_ARGUMENT,
                format!("`phase` must be a savme_phase (0 to 3), got {p}"),
            ))
        }
    })
}

fn part_of(part: i32) -> Outcome<savme_part> {
    Ok(match part {
        0 => savme_part::SAVME_PHI,
        1 => savme_part::SAVME_THETA_LF,
        2 => savme_part::SAVME_THETA_HF,
        _ => {
            return Err(Failure::new(
                SAVME_ERROR_ARGUMENT,
                format!("`part` must be a savme_part (0 to 2), got {part}"),
            ))
        }
    })
}

const EMPTY: &str = "";

/// `v` named `name` as C sees it (pointing into the assignment that holds it).
pub(crate) fn c_value(name: &str, v: &Value) -> savme_value {
    let mut out = savme_value {
        name: savme_str::of(name),
        kind: savme_type::SAVME_TYPE_BOOL,
        boolean: false,
        integer: 0,
        real: f64::NAN,
        label: savme_str::of(EMPTY),
    };
    match v {
        Value::Bool(b) => out.boolean = *b,
        Value::Int(i) => {
            out.kind = savme_type::SAVME_TYPE_INT;
            out.integer = *i;
            out.real = *i as f64;
        }
        Value::Real(x) => {
            out.kind = savme_type::SAVME_TYPE_REAL;
            out.real = *x;
        }
        Value::Label(s) => {
            out.kind = savme_type::SAVME_TYPE_LABEL;
            out.label = savme_str::of(s);
        }
    }
    out
}

/// The `index`th value of `a` (`what` names it in messages).
pub(crate) fn value_at(a: &Assignment, index: usize, what: &str) -> Outcome<savme_value> {
    a.iter()
        .nth(index)
        .map(|(n, v)| c_value(n, v))
        .ok_or_else(|| {
            Failure::new(
                SAVME_ERROR_ARGUMENT,
                format!(
                    "`index` {index} is out of range: {what} has {} values",
                    a.len()
                ),
            )
        })
}

/// The value of `a` named `name`.
pub(crate) fn value_named(a: &Assignment, name: &str, what: &str) -> Outcome<savme_value> {
    a.iter()
        .find(|(n, _)| *n == name)
        .map(|(n, v)| c_value(n, v))
        .ok_or_else(|| {
            let names: Vec<&str> = a.iter().map(|(n, _)| n).collect();
            Failure::new(
                SAVME_ERROR_NOT_FOUND,
                format!(
                    "{what} has no variable `{name}` (it has: {})",
                    names.join(", ")
                ),
            )
        })
}

/// The value named `name` as a number (a boolean or label refused).
fn number_named(a: &Assignment, name: &str, what: &str) -> Outcome<f64> {
    let v = value_named(a, name, what)?;
    match v.kind {
        savme_type::SAVME_TYPE_INT | savme_type::SAVME_TYPE_REAL => Ok(v.real),
        _ => Err(Failure::new(
            SAVME_ERROR_ARGUMENT,
            format!("{what}'s `{name}` is not a number: read it with savme_*_find"),
        )),
    }
}

impl TrialState {
    fn filled(&self) -> Outcome<&Held> {
        match &self.held {
            Held::Empty => Err(Failure::new(
                SAVME_ERROR_ARGUMENT,
                "the trial handle holds no trial yet: fill it with savme_ask",
            )),
            h => Ok(h),
        }
    }

    /// The values of `part`, and how to name them in messages.
    fn part(&self, part: i32) -> Outcome<(&Assignment, String)> {
        let part = part_of(part)?;
        match (self.filled()?, part) {
            (Held::Kernel { trial, .. }, savme_part::SAVME_PHI) => {
                Ok((&trial.phi, format!("trial {}'s φ", trial.id)))
            }
            (Held::Kernel { trial, .. }, savme_part::SAVME_THETA_LF) => match &trial.theta_lf {
                Some(t) => Ok((t, format!("trial {}'s θ_LF", trial.id))),
                None => Err(Failure::new(
                    SAVME_ERROR_NOT_FOUND,
                    format!("trial {} has no θ_LF (a baseline or unpaired trial: run HF only and tell it with savme_tell_hf_only)", trial.id),
                )),
            },
            (Held::Kernel { theta_hf, .. }, savme_part::SAVME_THETA_HF) => {
                Ok((theta_hf, "θ_HF".to_string()))
            }
            (Held::Estimation { trial, .. }, savme_part::SAVME_PHI) => {
                Ok((&trial.phi, format!("estimation trial {}'s φ", trial.id)))
            }
            (Held::Estimation { theta_hf, .. }, savme_part::SAVME_THETA_HF) => {
                Ok((theta_hf, "θ_HF".to_string()))
            }
            (Held::Estimation { trial, .. }, savme_part::SAVME_THETA_LF) => Err(Failure::new(
                SAVME_ERROR_NOT_FOUND,
                format!("estimation trial {} has no θ_LF (it runs HF only)", trial.id),
            )),
            (Held::Empty, _) => unreachable!("filled() refused an empty trial"),
        }
    }
}

fn with_trial(
    function: &str,
    t: *const savme_trial,
    body: impl FnOnce(&TrialState) -> Outcome,
) -> savme_status {
    guard(function, || {
        let trial = trial_of(t, "t")?;
        let state = lock(&trial);
        body(&state)
    })
}

/// Makes an empty trial handle into `*out` (fill it with `savme_ask`). Free it with
/// `savme_trial_free`.
#[no_mangle]
pub unsafe extern "C" fn savme_trial_new(out: *mut *mut savme_trial) -> savme_status {
    guard("savme_trial_new", || {
        let out = required(out, "out")?;
        let handle = TRIALS.insert(TrialState { held: Held::Empty });
        *out = std::ptr::without_provenance_mut(handle);
        Ok(())
    })
}

/// Frees a trial handle. NULL is allowed and does nothing (as `free(NULL)`); a handle freed
/// before, or any pointer that is not a live trial handle, is refused with `SAVME_ERROR_HANDLE`
/// and nothing happens.
#[no_mangle]
pub unsafe extern "C" fn savme_trial_free(t: *mut savme_trial) -> savme_status {
    guard("savme_trial_free", || {
        if t.is_null() {
            return Ok(());
        }
        TRIALS
            .remove(t as usize)
            .map_err(|l| lookup_failure(l, "t", "savme_trial"))
    })
}

/// The trial's id (ids count up from 0 in ask order; estimation trials count apart).
#[no_mangle]
pub unsafe extern "C" fn savme_trial_id(t: *const savme_trial, id: *mut u64) -> savme_status {
    with_trial("savme_trial_id", t, |s| {
        let id = required(id, "id")?;
        *id = match s.filled()? {
            Held::Kernel { trial, .. } => trial.id,
            Held::Estimation { trial, .. } => trial.id,
            Held::Empty => 0,
        };
        Ok(())
    })
}

/// The phase the trial was asked in (`SAVME_ERROR_ARGUMENT` for an estimation trial, which has
/// none).
#[no_mangle]
pub unsafe extern "C" fn savme_trial_phase(
    t: *const savme_trial,
    phase: *mut savme_phase,
) -> savme_status {
    with_trial("savme_trial_phase", t, |s| {
        let phase = required(phase, "phase")?;
        match s.filled()? {
            Held::Kernel { trial, .. } => *phase = c_phase(trial.phase),
            _ => {
                return Err(Failure::new(
                    SAVME_ERROR_ARGUMENT,
                    "an estimation trial has no phase",
                ))
            }
        }
        Ok(())
    })
}

/// The trial's scenario: its name into `*name` (valid until the trial is filled again or
/// freed) and, if `index` is not NULL, its index in the configuration's list into `*index`.
#[no_mangle]
pub unsafe extern "C" fn savme_trial_scenario(
    t: *const savme_trial,
    name: *mut savme_str,
    index: *mut usize,
) -> savme_status {
    with_trial("savme_trial_scenario", t, |s| {
        let name = required(name, "name")?;
        let (scenario, i) = match s.filled()? {
            Held::Kernel { trial, .. } => (&trial.scenario, trial.scenario_index),
            Held::Estimation { trial, .. } => (&trial.scenario, trial.scenario_index),
            Held::Empty => unreachable!("filled() refused an empty trial"),
        };
        *name = savme_str::of(scenario);
        // SAFETY: NULL or valid for writes (the header's contract).
        if let Some(index) = unsafe { index.as_mut() } {
            *index = i;
        }
        Ok(())
    })
}

/// Whether the trial runs both simulators (`*paired` true: tell it with `savme_tell_paired`)
/// or HF only (baseline and unpaired trials, estimation trials: `savme_tell_hf_only`).
#[no_mangle]
pub unsafe extern "C" fn savme_trial_is_paired(
    t: *const savme_trial,
    paired: *mut bool,
) -> savme_status {
    with_trial("savme_trial_is_paired", t, |s| {
        let paired = required(paired, "paired")?;
        *paired = matches!(s.filled()?, Held::Kernel { trial, .. } if trial.theta_lf.is_some());
        Ok(())
    })
}

/// How many values `part` (a `savme_part`) of the trial has (0 for θ_LF of a trial without it).
#[no_mangle]
pub unsafe extern "C" fn savme_trial_count(
    t: *const savme_trial,
    part: i32,
    count: *mut usize,
) -> savme_status {
    with_trial("savme_trial_count", t, |s| {
        let count = required(count, "count")?;
        *count = match s.part(part) {
            Ok((a, _)) => a.len(),
            Err(f) if f.status == SAVME_ERROR_NOT_FOUND => 0,
            Err(f) => return Err(f),
        };
        Ok(())
    })
}

/// The `index`th value (in the space's order) of `part` (a `savme_part`) into `*value`; its
/// strings stay valid until the trial is filled again or freed.
#[no_mangle]
pub unsafe extern "C" fn savme_trial_value(
    t: *const savme_trial,
    part: i32,
    index: usize,
    value: *mut savme_value,
) -> savme_status {
    with_trial("savme_trial_value", t, |s| {
        let value = required(value, "value")?;
        let (a, what) = s.part(part)?;
        *value = value_at(a, index, &what)?;
        Ok(())
    })
}

/// The value of the variable named `name` in `part` (a `savme_part`) into `*value`
/// (`SAVME_ERROR_NOT_FOUND` naming the variables there are if there is none).
#[no_mangle]
pub unsafe extern "C" fn savme_trial_find(
    t: *const savme_trial,
    part: i32,
    name: *const c_char,
    value: *mut savme_value,
) -> savme_status {
    with_trial("savme_trial_find", t, |s| {
        let name = text(name, "name")?;
        let value = required(value, "value")?;
        let (a, what) = s.part(part)?;
        *value = value_named(a, name, &what)?;
        Ok(())
    })
}

/// The numeric value (an integer or a real) of the variable named `name` in `part` into
/// `*number`; a boolean or a label is refused with `SAVME_ERROR_ARGUMENT`.
#[no_mangle]
pub unsafe extern "C" fn savme_trial_number(
    t: *const savme_trial,
    part: i32,
    name: *const c_char,
    number: *mut f64,
) -> savme_status {
    with_trial("savme_trial_number", t, |s| {
        let name = text(name, "name")?;
        let number = required(number, "number")?;
        let (a, what) = s.part(part)?;
        *number = number_named(a, name, &what)?;
        Ok(())
    })
}

/// An estimation trial's densities: q(φ) (the proposal's), p(φ) (the nominal's), the weight
/// p/q and its refinement round (-1 for a trial of the estimate itself); any pointer may be
/// NULL. `SAVME_ERROR_ARGUMENT` for a kernel trial.
#[no_mangle]
pub unsafe extern "C" fn savme_trial_densities(
    t: *const savme_trial,
    q: *mut f64,
    p: *mut f64,
    weight: *mut f64,
    round: *mut i64,
) -> savme_status {
    with_trial("savme_trial_densities", t, |s| {
        let Held::Estimation { trial: e, .. } = s.filled()? else {
            return Err(Failure::new(
                SAVME_ERROR_ARGUMENT,
                "not an estimation trial (fill it with savme_estimation_ask)",
            ));
        };
        // SAFETY: each pointer is NULL or valid for writes (the header's contract).
        unsafe {
            if let Some(q) = q.as_mut() {
                *q = e.q;
            }
            if let Some(p) = p.as_mut() {
                *p = e.p;
            }
            if let Some(w) = weight.as_mut() {
                *w = e.weight;
            }
            if let Some(r) = round.as_mut() {
                *r = e.round.map_or(-1, i64::from);
            }
        }
        Ok(())
    })
}

fn with_assignment(
    function: &str,
    a: *const savme_assignment,
    body: impl FnOnce(&Assignment) -> Outcome,
) -> savme_status {
    guard(function, || {
        let held = ASSIGNMENTS
            .get(a as usize)
            .map_err(|l| lookup_failure(l, "a", "savme_assignment"))?;
        let state = lock(&held);
        match &*state {
            Some(assignment) => body(assignment),
            None => Err(Failure::new(
                SAVME_ERROR_ARGUMENT,
                "the assignment handle holds nothing yet: fill it with savme_estimate or savme_theta_hf",
            )),
        }
    })
}

/// Makes an empty assignment handle into `*out`. Free it with `savme_assignment_free`.
#[no_mangle]
pub unsafe extern "C" fn savme_assignment_new(out: *mut *mut savme_assignment) -> savme_status {
    guard("savme_assignment_new", || {
        let out = required(out, "out")?;
        *out = std::ptr::without_provenance_mut(ASSIGNMENTS.insert(None));
        Ok(())
    })
}

/// Frees an assignment handle. NULL does nothing; a handle that is not live is refused with
/// `SAVME_ERROR_HANDLE`.
#[no_mangle]
pub unsafe extern "C" fn savme_assignment_free(a: *mut savme_assignment) -> savme_status {
    guard("savme_assignment_free", || {
        if a.is_null() {
            return Ok(());
        }
        ASSIGNMENTS
            .remove(a as usize)
            .map_err(|l| lookup_failure(l, "a", "savme_assignment"))
    })
}

/// How many values the assignment has.
#[no_mangle]
pub unsafe extern "C" fn savme_assignment_count(
    a: *const savme_assignment,
    count: *mut usize,
) -> savme_status {
    with_assignment("savme_assignment_count", a, |v| {
        *required(count, "count")? = v.len();
        Ok(())
    })
}

/// The `index`th value of the assignment into `*value` (strings valid until the assignment is
/// filled again or freed).
#[no_mangle]
pub unsafe extern "C" fn savme_assignment_value(
    a: *const savme_assignment,
    index: usize,
    value: *mut savme_value,
) -> savme_status {
    with_assignment("savme_assignment_value", a, |v| {
        let value = required(value, "value")?;
        *value = value_at(v, index, "the assignment")?;
        Ok(())
    })
}

/// The value named `name` into `*value` (`SAVME_ERROR_NOT_FOUND` if there is none).
#[no_mangle]
pub unsafe extern "C" fn savme_assignment_find(
    a: *const savme_assignment,
    name: *const c_char,
    value: *mut savme_value,
) -> savme_status {
    with_assignment("savme_assignment_find", a, |v| {
        let name = text(name, "name")?;
        let value = required(value, "value")?;
        *value = value_named(v, name, "the assignment")?;
        Ok(())
    })
}

/// The numeric value named `name` into `*number` (a boolean or label: `SAVME_ERROR_ARGUMENT`).
#[no_mangle]
pub unsafe extern "C" fn savme_assignment_number(
    a: *const savme_assignment,
    name: *const c_char,
    number: *mut f64,
) -> savme_status {
    with_assignment("savme_assignment_number", a, |v| {
        let name = text(name, "name")?;
        let number = required(number, "number")?;
        *number = number_named(v, name, "the assignment")?;
        Ok(())
    })
}

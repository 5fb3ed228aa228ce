//! Rust errors as Python exceptions: `ValueError` for bad spaces and configurations,
//! `savme.TellError` (a `ValueError`) for refused tells and cancels, `KeyError` for unknown
//! names, `savme.JournalError` for journal and store failures. Every message names the
//! variable, trial, scenario, file or line at fault (the Rust messages already do).

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError, PyValueError};
use pyo3::PyErr;
use savme::campaign::store::journal::JournalError as OpenError;
use savme::campaign::store::StoreError;
use savme::serve::SessionError;

create_exception!(
    savme,
    TellError,
    PyValueError,
    "A tell or cancel the kernel refused (unknown or already told trial, wrong observation kind, bad runtime); the kernel is unchanged."
);
create_exception!(
    savme,
    JournalError,
    PyException,
    "A journal or trial store could not be opened, replayed or written (locked by another process, a bad line, a full disk); the kernel is unchanged."
);

create_exception!(
    savme,
    CampaignError,
    PyException,
    "A campaign could not run or finish: its directory, store or stored trials, or a simulation that failed (the message names the trial and the simulator's error). A campaign stopped this way resumes with resume=True."
);

/// A campaign error: a bad protocol field or campaign file line is a `ValueError`, anything
/// else a `savme.CampaignError`.
/// The messages that name a command-line flag are said in Python's words (`resume=True`,
/// `out=`, `campaign=`).
pub fn campaign(e: savme::campaign::CampaignError) -> PyErr {
    use savme::campaign::CampaignError as E;
    match e {
        E::Protocol { .. } | E::File(_) | E::UnknownScenario { .. } => {
            PyValueError::new_err(e.to_string())
        }
        E::OutputExists { path } => CampaignError::new_err(format!(
            "{} already holds a campaign; resume it with resume=True (protocol=None takes its protocol), or choose another out=",
            path.display()
        )),
        E::CampaignExists { store } => CampaignError::new_err(format!(
            "{store} already holds a campaign; resume it with resume=True, or give another campaign= name"
        )),
        E::NothingToResumeIn { store } => CampaignError::new_err(format!(
            "{store}: no campaign to resume (none was started under this name) — start it with resume=False"
        )),
        _ => CampaignError::new_err(e.to_string()),
    }
}

/// A campaign failure described by a message (a `savme.CampaignError`).
pub fn campaign_message(message: String) -> PyErr {
    CampaignError::new_err(message)
}

/// A [`SessionError`] as the matching Python exception.
pub fn session(e: SessionError) -> PyErr {
    match e {
        SessionError::Refused(e) => TellError::new_err(e.to_string()),
        SessionError::Journal(e) => store(e),
        SessionError::BadBatch(_)
        | SessionError::Estimation(_)
        | SessionError::NoEstimation
        | SessionError::NoSuchLevel { .. } => PyValueError::new_err(e.to_string()),
    }
}

/// A store failure.
pub fn store(e: StoreError) -> PyErr {
    JournalError::new_err(e.to_string())
}

/// A journal that could not be opened: an invalid configuration is a `ValueError`, the rest
/// are journal errors.
pub fn open(e: OpenError) -> PyErr {
    match e {
        OpenError::Config { .. } => PyValueError::new_err(e.to_string()),
        OpenError::NoConfig { store } => JournalError::new_err(format!(
            "{store} holds no journal yet: start it with a configuration \
             (savme.Kernel(..., journal=...) or savme.Kernel.from_config(..., journal=...))"
        )),
        _ => JournalError::new_err(e.to_string()),
    }
}

/// Any error as a `ValueError`.
pub fn value(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The kernel's lock was poisoned by a panic in another thread.
pub fn poisoned() -> PyErr {
    PyRuntimeError::new_err("the kernel is unusable: a call on another thread panicked")
}

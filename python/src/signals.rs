//! SIGTERM during `Campaign.run`: stops the campaign between trials as Ctrl-C does (see
//! `savme/_signals.py`), instead of Python's default of dying at once.

use pyo3::prelude::*;

/// While alive, SIGTERM raises `savme._signals.Terminated` on the main thread (if it had its
/// default action); dropping it restores the default.
pub struct SigtermStops {
    previous: Option<Py<PyAny>>,
}

impl SigtermStops {
    /// Installs the handler (nothing off the main thread, or when SIGTERM has a handler).
    pub fn install(py: Python<'_>) -> PyResult<Self> {
        let previous = py.import("savme._signals")?.call_method0("install")?;
        Ok(SigtermStops {
            previous: (!previous.is_none()).then(|| previous.unbind()),
        })
    }
}

impl Drop for SigtermStops {
    fn drop(&mut self) {
        if let Some(previous) = self.previous.take() {
            Python::attach(|py| {
                let restored = py
                    .import("savme._signals")
                    .and_then(|m| m.call_method1("restore", (previous,)));
                if let Err(e) = restored {
                    e.write_unraisable(py, None);
                }
            });
        }
    }
}

/// Whether `e` is the `Terminated` the SIGTERM handler raised.
pub fn is_terminated(py: Python<'_>, e: &PyErr) -> bool {
    py.import("savme._signals")
        .and_then(|m| m.getattr("Terminated"))
        .is_ok_and(|t| e.value(py).is_instance(&t).unwrap_or(false))
}

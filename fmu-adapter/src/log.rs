//! The FMU's log messages: the logger callback every instance gets feeds a [`LogSink`] per
//! instance — FMI 2.0's logger is C-variadic (a C shim formats the printf-style message,
//! `csrc/logger.c`), FMI 3.0's `fmi3LogMessageCallback` takes the finished text
//! ([`savme_fmu_log3`]). The sink keeps the
//! last few messages of the current run, bounded, for the error of a failed call (and so for
//! the trial's log line); with `fmu_log` on it also prints every message to standard error.

use std::collections::VecDeque;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::fmt::Write as _;
use std::sync::Mutex;

/// Messages kept per run for an error.
const KEPT: usize = 6;
/// Characters kept per message.
const MESSAGE_CHARS: usize = 300;

/// Where one instance's log messages go.
#[derive(Debug)]
pub struct LogSink {
    /// The FMU, as errors name it.
    fmu: String,
    /// Print every message to standard error.
    echo: bool,
    /// The instance's name (FMI 3.0's logger does not pass it).
    instance: String,
    recent: Mutex<VecDeque<String>>,
}

impl LogSink {
    /// A sink for an instance of `fmu`; `echo` prints every message to standard error.
    pub fn new(fmu: String, echo: bool) -> LogSink {
        LogSink {
            fmu,
            echo,
            instance: String::new(),
            recent: Mutex::new(VecDeque::new()),
        }
    }

    /// With the instance's name, shown with each printed message of an FMI 3.0 FMU.
    pub fn named(mut self, instance: &str) -> LogSink {
        self.instance = instance.into();
        self
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<String>> {
        // A poisoned lock only means another thread panicked while logging: the queue is fine.
        self.recent.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Forgets the messages kept (at the start of a run).
    pub fn clear(&self) {
        self.lock().clear();
    }

    /// One message from the FMU.
    pub fn push(&self, instance: &str, status: i32, category: &str, message: &str) {
        let status = status_name(status);
        if self.echo {
            eprintln!("{} [{instance}] {status} {category}: {message}", self.fmu);
        }
        let mut text: String = message.chars().take(MESSAGE_CHARS).collect();
        if text.len() < message.len() {
            text.push('…');
        }
        let mut recent = self.lock();
        if recent.len() == KEPT {
            recent.pop_front();
        }
        recent.push_back(format!("[{status}] {text}"));
    }

    /// The messages kept, as an error's suffix (`""` when there are none):
    /// `; the FMU logged: [error] … | [warning] …`.
    pub fn suffix(&self) -> String {
        let recent = self.lock();
        if recent.is_empty() {
            return String::new();
        }
        let mut s = String::from("; the FMU logged: ");
        for (k, m) in recent.iter().enumerate() {
            let _ = write!(s, "{}{m}", if k > 0 { " | " } else { "" });
        }
        s
    }
}

fn status_name(status: i32) -> &'static str {
    match status {
        0 => "ok",
        1 => "warning",
        2 => "discard",
        3 => "error",
        4 => "fatal",
        5 => "pending",
        _ => "?",
    }
}

extern "C" {
    /// `fmi2CallbackLogger`, defined in `csrc/logger.c`: formats and calls [`savme_fmu_log`].
    pub fn savme_fmu_logger(
        env: libfmi::fmi2ComponentEnvironment,
        instance: libfmi::fmi2String,
        status: libfmi::fmi2Status,
        category: libfmi::fmi2String,
        message: libfmi::fmi2String,
        ...
    );
}

/// Called by the C logger with the formatted text; `env` is the instance's [`LogSink`].
///
/// # Safety
/// `env` is null or the `LogSink` the instance was created with (alive while it is); the
/// strings are null or NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn savme_fmu_log(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // SAFETY: by the caller's contract.
    unsafe { deliver(env, Some(instance), status, category, message) }
}

/// `fmi3LogMessageCallback`: `env` is the instance's [`LogSink`] (FMI 3.0 passes no instance
/// name: the sink's is shown).
///
/// # Safety
/// As [`savme_fmu_log`].
pub unsafe extern "C" fn savme_fmu_log3(
    env: *mut c_void,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // SAFETY: by the caller's contract.
    unsafe { deliver(env, None, status, category, message) }
}

/// One message to the sink `env` (the instance named by `instance`, or the sink's own name).
///
/// # Safety
/// As [`savme_fmu_log`].
unsafe fn deliver(
    env: *mut c_void,
    instance: Option<*const c_char>,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // SAFETY: by the caller's contract.
    let Some(sink) = (unsafe { (env as *const LogSink).as_ref() }) else {
        return;
    };
    // SAFETY: null or NUL-terminated, by the caller's contract.
    let text = |p: *const c_char| unsafe {
        if p.is_null() {
            String::new()
        } else {
            CStr::from_ptr(p).to_string_lossy().into_owned()
        }
    };
    let instance = instance.map_or_else(|| sink.instance.clone(), text);
    // Never unwind into the FMU's C code.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        sink.push(&instance, status, &text(category), &text(message));
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_messages_kept_are_bounded_in_number_and_length() {
        let sink = LogSink::new("x.fmu".into(), false);
        assert_eq!(sink.suffix(), "");
        for k in 0..20 {
            sink.push(
                "i",
                3,
                "logStatusError",
                &format!("{k:02} {}", "y".repeat(1000)),
            );
        }
        let s = sink.suffix();
        assert!(
            s.starts_with("; the FMU logged: [error] 14 yyy"),
            "{}",
            &s[..60]
        );
        assert_eq!(s.matches("[error]").count(), KEPT);
        assert_eq!(s.matches('…').count(), KEPT);
        assert!(s.chars().count() < KEPT * (MESSAGE_CHARS + 20) + 20);
        sink.clear();
        assert_eq!(sink.suffix(), "");
    }
}

//! SIGINT (Ctrl-C) and SIGTERM (what `kill`, `timeout`, a scheduler, systemd or Kubernetes
//! send) handled alike in every long command: the first asks the running campaign or estimate
//! to stop between runs (the runs in flight finish, every told trial is stored); the command
//! then prints how to resume and exits 128 + the signal (130, 143). A second signal quits at
//! once, printing the resume command too (the told trials are kept either way).
//!
//! The handlers are installed before a command reads its campaign file ([`while_loading`]):
//! a signal during the reading (of its OpenSCENARIO files, say) stops it within 1024
//! elements, and the command exits 130 or 143 with nothing run ([`loaded`]).

use super::Failure;
use savme::campaign::Stop;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::OnceLock;

/// The first signal received (0: none).
static RECEIVED: AtomicI32 = AtomicI32::new(0);
/// The stop the first signal requests.
static STOP: OnceLock<Stop> = OnceLock::new();
/// Whether a campaign file is being read (what the first signal prints).
static LOADING: AtomicBool = AtomicBool::new(false);
/// What a second signal prints before quitting: `savme: quit at once; continue with …`.
static QUIT_LINE: OnceLock<Vec<u8>> = OnceLock::new();
/// What the first signal prints, when the command said (else: stopping after the runs in
/// flight).
static FIRST_LINE: OnceLock<Vec<u8>> = OnceLock::new();

const SIGINT: i32 = 2;
const SIGTERM: i32 = 15;

/// The stop every SIGINT and SIGTERM requests, the handlers installed on the first call.
/// `resume_hint` (e.g. `continue with --resume DIR`) is what a second signal prints.
pub fn stop_on_signals(resume_hint: &str) -> Stop {
    let _ = QUIT_LINE.set(
        format!("savme: quit at once; the told trials are kept: {resume_hint}\n").into_bytes(),
    );
    handlers().clone()
}

/// The stop of the first signal, the handlers installed on the first call (and every later
/// OpenSCENARIO reading stopped by a signal).
fn handlers() -> &'static Stop {
    let mut fresh = false;
    let stop = STOP.get_or_init(|| {
        fresh = true;
        Stop::new()
    });
    if fresh {
        savme::openscenario::stop_reading_when(|| RECEIVED.load(Ordering::SeqCst) != 0);
        if let Err(e) = install() {
            eprintln!(
                "savme: warning: Ctrl-C will end the run at once ({e}); --resume continues it"
            );
        }
    }
    stop
}

/// Before a command reads its campaign file: the handlers installed, so that a signal stops
/// the reading (see [`loaded`]).
pub fn while_loading() {
    handlers();
    LOADING.store(true, Ordering::SeqCst);
}

/// After the reading of campaign file `file` (whether it succeeded or not): an interrupted
/// failure (exit 130 or 143) if a signal came meanwhile.
pub fn loaded(file: &std::path::Path) -> Result<(), Failure> {
    LOADING.store(false, Ordering::SeqCst);
    if RECEIVED.load(Ordering::SeqCst) == 0 {
        return Ok(());
    }
    Err(Failure::Interrupted(format!(
        "interrupted ({}) while reading the campaign file {}; nothing ran",
        received_name(),
        file.display()
    )))
}

/// As [`stop_on_signals`], for a command whose first signal does something else than
/// finishing the runs in flight (`savme serve` stops between requests): `first_line` is what
/// the first signal prints (its name, `SIGTERM: ` or `Ctrl-C: `, is put in front).
pub fn stop_on_signals_saying(first_line: &str, resume_hint: &str) -> Stop {
    let _ = FIRST_LINE.set(first_line.as_bytes().to_vec());
    stop_on_signals(resume_hint)
}

/// The exit status of a command a signal stopped: 128 + the signal (130 for SIGINT and when no
/// signal was received, 143 for SIGTERM).
pub fn interrupted_code() -> u8 {
    match RECEIVED.load(Ordering::SeqCst) {
        SIGTERM => 128 + SIGTERM as u8,
        _ => 128 + SIGINT as u8,
    }
}

/// The name of the signal received, for messages (`"Ctrl-C"` when none was).
pub fn received_name() -> &'static str {
    match RECEIVED.load(Ordering::SeqCst) {
        SIGTERM => "SIGTERM",
        _ => "Ctrl-C",
    }
}

#[cfg(unix)]
fn install() -> Result<(), String> {
    // Taken first so that a later `ctrlc` handler (the recording's) stays out of the way, as it
    // did when the campaign's handler was a `ctrlc` one; ours then replace its signal actions.
    let _ = ctrlc::set_handler(|| {});
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is valid; the handler only touches atomics, write(2)
        // and _exit(2), which are async-signal-safe.
        let failed = unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            action.sa_flags = libc::SA_RESTART;
            libc::sigemptyset(&mut action.sa_mask);
            libc::sigaction(sig, &action, std::ptr::null_mut()) != 0
        };
        if failed {
            return Err(std::io::Error::last_os_error().to_string());
        }
    }
    Ok(())
}

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    let write = |bytes: &[u8]| {
        // SAFETY: write(2) on stderr with a valid buffer.
        let _ = unsafe { libc::write(2, bytes.as_ptr().cast(), bytes.len()) };
    };
    if RECEIVED
        .compare_exchange(0, sig, Ordering::SeqCst, Ordering::SeqCst)
        .is_err()
    {
        if let Some(line) = QUIT_LINE.get() {
            write(line);
        }
        // SAFETY: _exit(2) is async-signal-safe.
        unsafe { libc::_exit(128 + sig) };
    }
    if let Some(stop) = STOP.get() {
        stop.request();
    }
    if LOADING.load(Ordering::SeqCst) {
        write(if sig == libc::SIGTERM {
            b"savme: SIGTERM: stopping the reading of the campaign file\n"
        } else {
            b"savme: Ctrl-C: stopping the reading of the campaign file\n"
        });
        return;
    }
    if let Some(line) = FIRST_LINE.get() {
        write(if sig == libc::SIGTERM {
            b"savme: SIGTERM: "
        } else {
            b"savme: Ctrl-C: "
        });
        write(line);
        write(b"\n");
        return;
    }
    write(if sig == libc::SIGTERM {
        b"savme: SIGTERM: stopping after the runs in flight; a second signal quits at once (the told trials are kept either way)\n"
    } else {
        b"savme: stopping after the runs in flight; Ctrl-C again quits at once (the told trials are kept either way)\n"
    });
}

#[cfg(not(unix))]
fn install() -> Result<(), String> {
    ctrlc::set_handler(|| {
        if RECEIVED.swap(SIGINT, Ordering::SeqCst) != 0 {
            if let Some(line) = QUIT_LINE.get() {
                eprint!("{}", String::from_utf8_lossy(line));
            }
            std::process::exit(130);
        }
        if let Some(stop) = STOP.get() {
            stop.request();
        }
        eprintln!("savme: stopping after the runs in flight; Ctrl-C again quits at once (the told trials are kept either way)");
    })
    .map_err(|e| e.to_string())
}

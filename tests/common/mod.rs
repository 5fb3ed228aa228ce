//! Helpers shared by the integration tests (each test file takes what it needs).
#![allow(dead_code)]

pub mod braking;
pub mod campaign;
pub mod manifest;
pub mod postgres;
pub mod serve;

use serde_json::Value;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The savme binary under test.
pub const EXE: &str = env!("CARGO_BIN_EXE_savme");

/// A tiny protocol on the bundled camera + lidar simulator (60 trials: one budget, few
/// iterations), work-unit cost, seed 7, quiet.
pub const TINY_PROTOCOL: &[&str] = &[
    "--budgets",
    "0.3",
    "--iterations",
    "16",
    "--eval-iterations",
    "6",
    "--test-iterations",
    "8",
    "--baseline-iterations",
    "14",
    "--baseline-test-iterations",
    "8",
    "--cost",
    "work",
    "--seed",
    "7",
    "--quiet",
];

/// A fresh (absent) temporary directory for `name`, unique to the calling test file and this
/// process: `$TMPDIR/savme-<test file>-<pid>-<name>`. The test file is the caller's (tests/it/
/// holds many in one test binary, whose tests run side by side: two files' `temp_dir("bad")`
/// must not be one directory).
#[track_caller]
pub fn temp_dir(name: &str) -> PathBuf {
    let caller = Path::new(std::panic::Location::caller().file());
    let file = caller
        .file_stem()
        .map_or_else(|| "test".into(), |s| s.to_string_lossy());
    let dir = std::env::temp_dir().join(format!("savme-{file}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// `savme ARGS` run to its end: whether it succeeded, stdout, stderr.
pub fn savme<S: AsRef<OsStr>>(args: &[S]) -> (bool, String, String) {
    let (code, out, err) = run(args);
    (code == Some(0), out, err)
}

/// `savme reproduce --quiet --resume DIR` run to its end (see [`savme`]).
pub fn resume(dir: &Path) -> (bool, String, String) {
    savme(&[
        OsStr::new("reproduce"),
        "--quiet".as_ref(),
        "--resume".as_ref(),
        dir.as_os_str(),
    ])
}

/// The trial lines of `dir/trials.jsonl`, as stored (without the protocol record that a
/// campaign's store begins with).
pub fn trial_lines(dir: &Path) -> Vec<Value> {
    std::fs::read_to_string(dir.join("trials.jsonl"))
        .expect("trials.jsonl")
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).expect("a JSON trial line"))
        .filter(|v| v.get("protocol").is_none())
        .collect()
}

/// Trial lines without their store version, checksum and wall-clock seconds (the only fields
/// that differ between runs of a work-cost campaign; the checksum covers the seconds).
pub fn without_wall(mut t: Vec<Value>) -> Vec<Value> {
    for v in &mut t {
        if let Some(o) = v.as_object_mut() {
            o.remove("v");
            o.remove("c");
        }
        for run in ["hf", "lf"] {
            if let Some(r) = v[run].as_object_mut() {
                r.remove("wall_seconds");
            }
        }
        // A fidelity ladder's lower levels (screening lines).
        if let Some(rungs) = v.get_mut("ladder").and_then(Value::as_array_mut) {
            for rung in rungs {
                if let Some(r) = rung["lf"].as_object_mut() {
                    r.remove("wall_seconds");
                }
            }
        }
    }
    t
}

/// [`temp_dir`], created (empty).
#[track_caller]
pub fn made_dir(name: &str) -> PathBuf {
    let dir = temp_dir(name);
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    dir
}

/// `savme ARGS` run to its end: the exit code (`None` if a signal ended it), stdout, stderr.
pub fn run<S: AsRef<OsStr>>(args: &[S]) -> (Option<i32>, String, String) {
    let o = Command::new(EXE).args(args).output().expect("savme runs");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The SQL block that follows the marker `<!-- NAME -->` in `docs/DISTRIBUTED.md` (so that the
/// tests run exactly what the docs show).
pub fn doc_sql(marker: &str) -> String {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/DISTRIBUTED.md"))
        .expect("docs/DISTRIBUTED.md");
    let at = doc
        .find(&format!("<!-- {marker} -->"))
        .unwrap_or_else(|| panic!("no `<!-- {marker} -->` in docs/DISTRIBUTED.md"));
    let rest = &doc[at..];
    let start = rest.find("```sql\n").expect("a ```sql block") + "```sql\n".len();
    let end = rest[start..].find("```").expect("the block's end");
    rest[start..start + end].to_string()
}

/// FMPy (PyPI `fmpy`), the independent FMI client, if the environment provides it:
/// `scripts/test` installs it into a virtual environment and sets SAVME_FMPY_PYTHON and
/// SAVME_REQUIRE_FMPY=1 (then a missing FMPy fails instead of skipping).
pub fn fmpy_python() -> Option<String> {
    let python = std::env::var("SAVME_FMPY_PYTHON").ok();
    let required = std::env::var("SAVME_REQUIRE_FMPY").is_ok_and(|v| v == "1");
    match python {
        Some(p) => Some(p),
        None if required => panic!("SAVME_REQUIRE_FMPY=1 but SAVME_FMPY_PYTHON is not set"),
        None => {
            eprintln!("FMPy cross-check skipped: set SAVME_FMPY_PYTHON to a python with fmpy");
            None
        }
    }
}

/// Sends `signal` (`INT`, `TERM`) to `child` with kill(1), as a shell, `timeout` or a
/// scheduler does.
pub fn send(child: &std::process::Child, signal: &str) {
    let sent = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
}

/// Spawns `cmd` (a campaign writing `trials`) and kills it with SIGKILL once `trials` holds
/// `needle` `n` times; it must not finish first, and must make progress within 120 s.
pub fn kill_once_written(mut cmd: std::process::Command, trials: &Path, needle: &str, n: usize) {
    use std::process::Stdio;
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while std::fs::read_to_string(trials).map_or(0, |s| s.matches(needle).count()) < n {
        assert!(start.elapsed().as_secs() < 120, "no progress");
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before the kill"
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
}

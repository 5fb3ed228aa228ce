//! Helpers shared by this crate's integration tests.
#![allow(dead_code)] // each test binary uses its own subset

use std::path::PathBuf;

/// A fresh temporary directory for one test (`prefix` keeps test binaries apart).
pub fn temp_dir(prefix: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("{prefix}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The test kit's shared library, built by cargo next to this test binary.
pub fn testkit_library() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    let name = format!(
        "{}savme_fmu_testkit{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    for dir in [deps, deps.parent().unwrap()] {
        if dir.join(&name).exists() {
            return dir.join(&name);
        }
    }
    panic!("{name} not found next to {}", exe.display());
}

/// FMPy (PyPI `fmpy`), the independent FMI client, if the environment provides it: the python
/// in SAVME_FMPY_PYTHON (`scripts/test` sets it with SAVME_REQUIRE_FMPY=1, which turns a
/// missing FMPy into a failure instead of a loud skip).
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

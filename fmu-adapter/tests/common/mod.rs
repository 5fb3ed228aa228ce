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

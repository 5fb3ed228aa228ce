//! The Python package's pytest suite (python/tests), run with the virtual environment that
//! `python/develop.sh` fills, so that the README's test command covers it.
//!
//! Without that environment the test skips loudly; with SAVME_REQUIRE_PYTHON_PACKAGE=1 (set
//! by .ci/run) it fails instead. An installed extension older than the Rust sources fails too
//! (it would test other code): run `python/develop.sh` again. The test starts a throwaway
//! PostgreSQL server (tests/common/postgres.rs) for the suite's storage tests.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The virtual environment's python: $SAVME_PYTHON, else `py-venv` in the target directory.
fn python() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("SAVME_PYTHON") {
        return Some(PathBuf::from(p));
    }
    // The test binary is <target>/debug/deps/it-…
    let exe = std::env::current_exe().ok()?;
    let target = exe.parent()?.parent()?.parent()?;
    let p = target.join("py-venv").join("bin").join("python");
    p.is_file().then_some(p)
}

fn newest_source(dir: &Path, newest: &mut SystemTime) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            newest_source(&p, newest);
        } else if p.extension().is_some_and(|x| x == "rs") {
            if let Ok(m) = e.metadata().and_then(|m| m.modified()) {
                *newest = (*newest).max(m);
            }
        }
    }
}

#[test]
fn the_pytest_suite_passes() {
    let required = std::env::var("SAVME_REQUIRE_PYTHON_PACKAGE").is_ok_and(|v| v == "1");
    let Some(python) = python() else {
        let msg = "the savme Python package is not installed (run python/develop.sh, or set \
                   SAVME_PYTHON): SKIPPING the pytest suite";
        assert!(
            !required,
            "{msg} — but SAVME_REQUIRE_PYTHON_PACKAGE=1 requires it"
        );
        eprintln!("\n*** {msg} ***\n");
        return;
    };
    let module = Command::new(&python)
        .args(["-c", "import savme._savme as m; print(m.__file__)"])
        .output()
        .expect("start the virtual environment's python");
    assert!(
        module.status.success(),
        "{}: `import savme` failed (run python/develop.sh):\n{}",
        python.display(),
        String::from_utf8_lossy(&module.stderr)
    );
    let so = PathBuf::from(String::from_utf8_lossy(&module.stdout).trim());
    let built = std::fs::metadata(&so)
        .and_then(|m| m.modified())
        .expect("the extension module's mtime");
    let mut newest = SystemTime::UNIX_EPOCH;
    for dir in [
        "src",
        "kernel/src",
        "python/src",
        "reference-sim/src",
        "fmu-adapter/src",
    ] {
        newest_source(&repo().join(dir), &mut newest);
    }
    assert!(
        built >= newest,
        "{} is older than the Rust sources: run python/develop.sh to rebuild it",
        so.display()
    );
    // python/tests/test_storage.py keeps campaigns in this throwaway PostgreSQL server.
    let server = common::postgres::Server::start("python_package (test_storage.py)");
    let mut pytest = Command::new(&python);
    if let Some(s) = &server {
        pytest.env("SAVME_TEST_POSTGRES_URL", s.create_db("python_package"));
    }
    let out = pytest
        .args([
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .current_dir(repo())
        .env("SAVME_BIN", env!("CARGO_BIN_EXE_savme"))
        .output()
        .expect("run pytest");
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "pytest failed:\n{text}");
    let summary = text.lines().last().unwrap_or_default();
    // Without PostgreSQL (said loudly above) test_storage.py's tests skip; nothing else may.
    assert!(
        summary.contains(" passed") && (server.is_none() || !summary.contains("skipped")),
        "pytest ran no test or skipped some: {summary}"
    );
}

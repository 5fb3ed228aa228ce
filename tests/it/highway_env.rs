//! savme on a third-party Python simulator: highway-env (issue 29, item 1). Runs
//! python/tests_highway_env with the virtual environment `scripts/highway-env-venv` fills
//! (highway-env, gymnasium, pytest and savme's wheel), so that the README's test command covers
//! it: four highway-env environments as scenarios, a small campaign through savme's loop, and
//! the example campaign from its one command.
//!
//! Without that environment the test skips loudly; with SAVME_REQUIRE_HIGHWAY_ENV=1 (set by
//! scripts/test) it fails instead. An installed adapter that differs from the repository's
//! (python/savme/integrations/highway_env.py) fails too: run the venv script again.

use std::path::PathBuf;
use std::process::Command;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The venv's python: $SAVME_HIGHWAY_PYTHON, else `highway-venv` in the target directory.
fn python() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("SAVME_HIGHWAY_PYTHON") {
        let p = PathBuf::from(p);
        assert!(
            p.is_file(),
            "SAVME_HIGHWAY_PYTHON={}: no such file (a venv's bin/python, as \
             scripts/highway-env-venv makes in target/highway-venv)",
            p.display()
        );
        return Some(p);
    }
    // The test binary is <target>/debug/deps/highway_env-…
    let exe = std::env::current_exe().ok()?;
    let target = exe.parent()?.parent()?.parent()?;
    let p = target.join("highway-venv").join("bin").join("python");
    p.is_file().then_some(p)
}

#[test]
fn savme_runs_on_highway_env() {
    let required = std::env::var("SAVME_REQUIRE_HIGHWAY_ENV").is_ok_and(|v| v == "1");
    let Some(python) = python() else {
        let msg = "no highway-env virtual environment (run python/develop.sh --wheel, then \
                   scripts/highway-env-venv; or set SAVME_HIGHWAY_PYTHON): SKIPPING the \
                   highway-env tests";
        assert!(
            !required,
            "{msg} — but SAVME_REQUIRE_HIGHWAY_ENV=1 requires them"
        );
        eprintln!("\n*** {msg} ***\n");
        return;
    };
    let installed = Command::new(&python)
        .args([
            "-c",
            "import savme.integrations.highway_env as m, highway_env; print(m.__file__)",
        ])
        .output()
        .expect("start the highway-env venv's python");
    assert!(
        installed.status.success(),
        "{}: importing savme's highway-env adapter and highway_env failed (run \
         scripts/highway-env-venv):\n{}",
        python.display(),
        String::from_utf8_lossy(&installed.stderr)
    );
    let path = PathBuf::from(String::from_utf8_lossy(&installed.stdout).trim());
    let ours = repo().join("python/savme/integrations/highway_env.py");
    assert_eq!(
        std::fs::read_to_string(&path).expect("read the installed adapter"),
        std::fs::read_to_string(&ours).expect("read the repository's adapter"),
        "{} differs from {}: rebuild the wheel (python/develop.sh --wheel) and run \
         scripts/highway-env-venv",
        path.display(),
        ours.display()
    );
    let out = Command::new(&python)
        .args([
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "-W",
            "ignore::DeprecationWarning",
            "python/tests_highway_env",
        ])
        .current_dir(repo())
        .output()
        .expect("run pytest");
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "pytest failed:\n{text}");
    let summary = text.lines().last().unwrap_or_default();
    assert!(
        summary.contains(" passed") && !summary.contains("skipped"),
        "pytest ran no test or skipped some: {summary}"
    );
}

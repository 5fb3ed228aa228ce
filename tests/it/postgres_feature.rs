//! PostgreSQL is the `postgres` feature, off by default (issue 39 item 1: the main job's build
//! leaves out the PostgreSQL client, its TLS stack and tokio). A default build answers every
//! PostgreSQL entry — `--storage`, `--storage-file`, `--remote`, `savme worker`, and the readers
//! and `serve` given a database — with one line naming the feature and the command that builds
//! it, as a usage error (exit status 2), and creates nothing.
//!
//! The binary checked: this build's, when it lacks the feature (`cargo test`); and the binary
//! `scripts/test` installs with `cargo install --path .` as docs/INSTALL.md's first command
//! does (`SAVME_INSTALLED_SAVME`), so that the suite, built with `--features postgres` for the
//! PostgreSQL tests, also runs the default build.

use std::path::{Path, PathBuf};
use std::process::Command;

/// What the refusal says (src/commands/database.rs `MISSING`).
const FEATURE: &str = "built without PostgreSQL support (the `postgres` feature)";
const INSTALL: &str = "`cargo install --path . --features postgres`";
const BUILD: &str = "`cargo build --release --features postgres`";

/// Every command line that needs a database.
fn entries() -> Vec<Vec<String>> {
    let db = "--storage postgresql://u@localhost/d --campaign c";
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/fmu/campaign.toml");
    let run = format!("run --config {} {db}", file.display());
    [
        format!("reproduce {db}"),
        format!("reproduce --quick {db} --remote"),
        "reproduce --quick --remote".to_string(),
        "toy --storage-file db.url --campaign c".to_string(),
        format!("toy {db} --remote --worker-role w"),
        run,
        "worker".to_string(),
        format!("worker {db} --jobs 2"),
        format!("failures {db}"),
        format!("estimate {db} --target-width 0.1"),
        format!("serve {db}"),
    ]
    .iter()
    .map(|line| line.split_whitespace().map(String::from).collect())
    .collect()
}

/// Runs every entry with `exe` in an empty directory: each is refused with one line naming
/// the feature and both commands, exit status 2, nothing on stdout, nothing created.
fn check_refusals(exe: &Path, what: &str) {
    let dir = std::env::temp_dir().join(format!(
        "savme-postgres-feature-{what}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("db.url"), "postgresql://u@localhost/d\n").unwrap();
    for args in entries() {
        let out = Command::new(exe)
            .args(&args)
            .current_dir(&dir)
            .output()
            .unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert_eq!(out.status.code(), Some(2), "{what} {args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{what} {args:?}: {stderr}");
        for words in [FEATURE, INSTALL, BUILD] {
            assert_eq!(
                stderr.matches(words).count(),
                1,
                "{what} {args:?}: {stderr}"
            );
        }
        assert!(stdout.is_empty(), "{what} {args:?}: {stdout}");
        let left: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert_eq!(left, [dir.join("db.url")], "{what} {args:?} created files");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(not(feature = "postgres"))]
#[test]
fn the_default_build_refuses_every_postgresql_entry_naming_the_feature() {
    check_refusals(Path::new(env!("CARGO_BIN_EXE_savme")), "built");
}

/// The binary `cargo install --path .` installs (no features) is the default build: it says so
/// in `--version` and refuses every PostgreSQL entry.
#[test]
fn the_installed_default_binary_refuses_every_postgresql_entry_naming_the_feature() {
    let Some(path) = std::env::var_os("SAVME_INSTALLED_SAVME") else {
        assert!(
            std::env::var_os("SAVME_REQUIRE_INSTALL").is_none(),
            "SAVME_REQUIRE_INSTALL is set but SAVME_INSTALLED_SAVME is not"
        );
        eprintln!("SKIPPED: SAVME_INSTALLED_SAVME is not set (scripts/test sets it)");
        return;
    };
    let exe = Path::new(&path);
    let version = Command::new(exe).arg("--version").output().unwrap();
    let version = String::from_utf8_lossy(&version.stdout);
    assert!(version.contains("features: none"), "{version}");
    check_refusals(exe, "installed");
}

/// CI requires the PostgreSQL tests (`SAVME_REQUIRE_POSTGRES=1`): they build only with the
/// feature (`cfg(feature = "postgres")` in tests/it/main.rs), so a suite built without it must fail, not skip.
#[test]
fn required_postgresql_tests_are_built() {
    let required = std::env::var_os("SAVME_REQUIRE_POSTGRES").is_some_and(|v| v == "1");
    assert!(
        !required || cfg!(feature = "postgres"),
        "SAVME_REQUIRE_POSTGRES=1, but this suite was built without `--features postgres`: \
         tests/it/postgres.rs and tests/it/distributed.rs were not built"
    );
}

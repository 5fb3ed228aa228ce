//! Every `--help`'s Examples run as printed, in order, from an empty directory: what a user
//! who copies them one after the other gets.
use crate::common;

use common::{temp_dir, EXE};
use std::path::Path;
use std::process::{Command, Stdio};

/// The example lines of `savme PATH --help`, as printed.
fn examples(path: &str) -> Vec<String> {
    let out = Command::new(EXE)
        .args(path.split(' '))
        .arg("--help")
        .output()
        .expect("savme --help");
    assert!(out.status.success(), "savme {path} --help");
    let help = String::from_utf8_lossy(&out.stdout).into_owned();
    let (_, text) = help
        .split_once("Examples:\n")
        .unwrap_or_else(|| panic!("savme {path} --help has no Examples"));
    text.lines()
        .map(str::trim)
        .filter(|l| l.starts_with("savme "))
        .map(str::to_owned)
        .collect()
}

/// Runs each example of `savme PATH --help` in turn in a new empty directory, through the
/// shell (for `>`), with this build's savme first on PATH; panics naming the first that fails.
fn run_examples(path: &str) {
    let dir = temp_dir(&path.replace(' ', "-"));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let bin = Path::new(EXE).parent().expect("the binary's directory");
    let search = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let lines = examples(path);
    assert!(!lines.is_empty(), "{path}: no examples");
    for line in &lines {
        let out = Command::new("sh")
            .arg("-c")
            .arg(line)
            .current_dir(&dir)
            .env("PATH", &search)
            .stdin(Stdio::null())
            .output()
            .expect("sh");
        assert!(
            out.status.success(),
            "`savme {path} --help`'s example `{line}` failed after {:?} in {}:\n{}",
            lines.iter().take_while(|l| *l != line).collect::<Vec<_>>(),
            dir.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn estimate_examples_run_as_printed_in_sequence() {
    run_examples("estimate");
}

#[test]
fn failures_examples_run_as_printed_in_sequence() {
    run_examples("failures");
}

#[test]
fn fmu_examples_run_as_printed_in_sequence() {
    for path in ["fmu pack", "fmu info", "fmu validate"] {
        run_examples(path);
    }
}

/// The quick ones. Not run here: `reproduce` (its examples run the whole protocol, minutes
/// each), `run` (reads examples/fmu/campaign.toml of a checkout), `worker` (needs PostgreSQL),
/// `completions` (writes into the user's home).
#[test]
fn other_examples_run_as_printed_in_sequence() {
    for path in [
        "scenarios",
        "fidelity",
        "simulate",
        "example-config",
        "serve",
        "toy",
        "man",
    ] {
        run_examples(path);
    }
}

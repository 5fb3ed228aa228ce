//! `savme failures DIR` end to end: the failures it lists are exactly the HF failures of the
//! campaign's trial lines, its replay command reproduces a failure in `savme simulate`, the
//! filters keep what they name, and bad input is refused naming the stage, scenario or
//! directory.
use crate::common;

use common::{run, temp_dir, trial_lines, TINY_PROTOCOL};
use serde_json::Value;
use std::path::Path;

/// A tiny protocol on the camera + lidar simulator (what `savme simulate` runs), work cost.
fn campaign(dir: &Path) {
    let out = dir.display().to_string();
    let (code, _, err) = run(&[&["reproduce", "--out", &out][..], TINY_PROTOCOL].concat());
    assert_eq!(code, Some(0), "{err}");
}

fn failures(dir: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let d = dir.display().to_string();
    run(&[&["failures", &d][..], extra].concat())
}

fn json_lines(text: &str) -> Vec<Value> {
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

// Long because one campaign serves every check (listing, replay, filters, bad input).
#[test]
fn failures_lists_every_hf_failure_and_its_replay_reproduces_it() {
    let dir = temp_dir("campaign");
    campaign(&dir);
    let lines = trial_lines(&dir);
    let expected: Vec<&Value> = lines
        .iter()
        .filter(|l| l["hf"]["failure"] == true)
        .collect();
    assert!(!expected.is_empty(), "the tiny campaign found no failure");
    let (code, out, err) = failures(&dir, &["--json"]);
    assert_eq!(code, Some(0), "{err}");
    let found = json_lines(&out);
    assert_eq!(found.len(), expected.len());
    for (f, l) in found.iter().zip(&expected) {
        for key in ["stage", "index", "id", "scenario", "phi", "theta_lf"] {
            assert_eq!(f[key], l[key], "{key} of {f}");
        }
        let lf = l["lf"].get("failure").cloned().unwrap_or(Value::Null);
        assert_eq!(f["lf_failure"], lf, "{f}");
        assert_eq!(f["hf_runtime"], l["hf"]["runtime"], "{f}");
    }
    // The replay command, run as printed, fails again (the simulator is deterministic in φ).
    let replay = found[0]["replay"]
        .as_str()
        .expect("a camera + lidar campaign replays");
    let args: Vec<&str> = replay.split(' ').skip(1).chain(["--json"]).collect();
    let (code, out, err) = run(&args);
    assert_eq!(code, Some(0), "{replay}: {err}");
    let sim: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(sim["failure"], true, "{replay}: {sim}");
    assert_eq!(sim["phi"], found[0]["phi"]);

    // The table: a count line, then a line per failure with its replay.
    let (code, table, _) = failures(&dir, &[]);
    assert_eq!(code, Some(0));
    assert!(table.starts_with(&format!(
        "{} HF failures in {} (of {} HF runs",
        expected.len(),
        dir.display(),
        lines.len()
    )));
    assert_eq!(
        table.matches("savme simulate --scenario").count(),
        expected.len()
    );

    // Filters keep what they name, and nothing else.
    let stage = expected[0]["stage"].as_str().unwrap();
    let scenario = expected[0]["scenario"].as_str().unwrap();
    let (code, out, _) = failures(&dir, &["--json", "--stage", stage, "--scenario", scenario]);
    assert_eq!(code, Some(0));
    let kept = json_lines(&out);
    let want = expected
        .iter()
        .filter(|l| l["stage"] == stage && l["scenario"] == scenario)
        .count();
    assert_eq!(kept.len(), want);
    assert!(kept
        .iter()
        .all(|f| f["stage"] == stage && f["scenario"] == scenario));

    // Bad input names what is wrong.
    let (code, _, err) = failures(&dir, &["--stage", "train@0.7"]);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("--stage `train@0.7`: the campaign has no such stage (its stages: baseline-train, train@0.3"),
        "{err}"
    );
    let (code, _, err) = failures(&dir, &["--scenario", "nowhere"]);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("--scenario `nowhere`: the campaign has no such scenario"),
        "{err}"
    );
    let empty = temp_dir("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let (code, _, err) = failures(&empty, &[]);
    assert_eq!(code, Some(1));
    assert!(err.contains("no protocol.json"), "{err}");
    for d in [dir, empty] {
        let _ = std::fs::remove_dir_all(d);
    }
}

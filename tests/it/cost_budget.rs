//! Budgets in cost (`--search-budget`, `--deploy-budget`): a stage runs until its runs have
//! cost its budget, a campaign killed with SIGKILL mid-stage resumes to exactly the trials of
//! an uninterrupted one, progress speaks in the budget, and bad budgets are named.
use crate::common;

use common::{kill_once_written, made_dir, run, temp_dir, trial_lines, without_wall, EXE};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

/// A tuned campaign on the bundled simulator with ideal perception (≈ 160 work units a
/// trial): the search stages get 40,000 wu (≈ 250 trials), the deployed search 20,000.
fn args(out: &Path) -> Vec<String> {
    let mut a: Vec<String> = [
        "reproduce",
        "--perception",
        "ideal",
        "--method",
        "tuned",
        "--budgets",
        "0.3",
        "--search-budget",
        "40000",
        "--deploy-budget",
        "20000",
        "--eval-iterations",
        "4",
        "--baseline-iterations",
        "4",
        "--baseline-test-iterations",
        "4",
        "--cost",
        "work",
        "--seed",
        "5",
        "--window",
        "3",
        "--out",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    a.push(out.display().to_string());
    a
}

/// What a line's runs cost.
fn cost(line: &Value) -> f64 {
    ["hf", "lf"]
        .iter()
        .map(|r| line[r]["runtime"].as_f64().unwrap_or(0.0))
        .sum()
}

fn stage_lines<'a>(lines: &'a [Value], stage: &str) -> Vec<&'a Value> {
    lines.iter().filter(|l| l["stage"] == stage).collect()
}

#[test]
fn a_cost_budget_ends_each_stage_once_spent_and_a_killed_campaign_resumes_identically() {
    let whole = temp_dir("whole");
    let mut a = args(&whole);
    a.push("--quiet".into());
    let (code, _, err) = run(&a);
    assert_eq!(code, Some(0), "{err}");
    let lines = trial_lines(&whole);
    // Every search and deployed stage spent its budget, and stopped asking once it had (the
    // runs in flight — at most the window of 3 — finish and count).
    for (stage, budget) in [
        ("train@0.3", 40000.0),
        ("screen@0.3", 20000.0),
        ("test-learned@0.3", 40000.0),
        ("test-uniform@0.3", 40000.0),
    ] {
        let stage_lines = stage_lines(&lines, stage);
        let spent: f64 = stage_lines.iter().map(|l| cost(l)).sum();
        assert!(spent >= budget, "{stage}: {spent} < {budget}");
        let n = stage_lines.len();
        let last3: f64 = stage_lines[n.saturating_sub(3)..]
            .iter()
            .map(|l| cost(l))
            .sum();
        assert!(
            spent - last3 < budget,
            "{stage}: overshot: {spent} ({n} trials)"
        );
        assert!(n >= 5, "{stage}: {n} trials");
    }
    assert_eq!(stage_lines(&lines, "evaluate@0.3").len(), 4);

    // Killed (SIGKILL) in its meta-training stage, and once more after it (a spent stage is
    // complete on resume, not short of its cap), then resumed: the same trials.
    let killed = made_dir("killed");
    for (stage, n) in [("train@0.3", 8), ("test-learned@0.3", 1)] {
        kill_after(&killed, stage, n);
    }
    let (code, _, err) = run(&["reproduce", "--quiet", "--resume", killed.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(without_wall(trial_lines(&killed)), without_wall(lines));
    // The stored protocol keeps the budgets, so the resume needed no flag.
    let protocol: Value =
        serde_json::from_str(&std::fs::read_to_string(killed.join("protocol.json")).unwrap())
            .unwrap();
    assert_eq!(protocol["search_budget"], 40000.0);
    assert_eq!(protocol["deploy_budget"], 20000.0);
    assert_eq!(protocol["allocation"], "cost-rate-scout");
    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&killed);
}

/// Starts (or resumes) the campaign in `dir` and kills it with SIGKILL once `trials.jsonl`
/// holds `n` lines of `stage`.
fn kill_after(dir: &Path, stage: &str, n: usize) {
    let mut cmd = Command::new(EXE);
    if dir.join("protocol.json").exists() {
        cmd.args(["reproduce", "--quiet", "--resume", dir.to_str().unwrap()]);
    } else {
        let _ = std::fs::remove_dir_all(dir);
        cmd.args(args(dir)).arg("--quiet");
    }
    kill_once_written(cmd, &dir.join("trials.jsonl"), stage, n);
}

#[test]
fn progress_lines_speak_in_the_cost_budget() {
    let out = temp_dir("progress");
    let (code, _, err) = run(&args(&out));
    assert_eq!(code, Some(0), "{err}");
    // Not a terminal: plain lines. A cost stage counts its cost, the campaign its trials.
    let started = err
        .lines()
        .find(|l| l.starts_with("train@0.3 started: "))
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        started.contains("0 trials, 0 of 40000 work units (campaign: "),
        "{started}"
    );
    assert!(!started.contains("100000000"), "{started}");
    let done = err
        .lines()
        .find(|l| l.starts_with("train@0.3 done: "))
        .unwrap_or_else(|| panic!("{err}"));
    assert!(done.contains(" of 40000 work units, "), "{done}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn bad_cost_budgets_and_floors_are_named_before_anything_runs() {
    let out = temp_dir("bad");
    for (flag, value, says) in [
        ("--search-budget", "0", "search_budget"),
        ("--search-budget", "-5", "search_budget"),
        ("--deploy-budget", "inf", "deploy_budget"),
        ("--search-budget", "nan", "search_budget"),
        ("--coverage-floor", "1.5", "coverage_floor"),
    ] {
        let (code, _, err) = run(&[
            "reproduce",
            "--perception",
            "ideal",
            flag,
            value,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, Some(2), "{flag} {value}: {err}");
        assert!(err.contains(says), "{flag} {value}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists(), "{flag} {value}: wrote {}", out.display());
    }
}

//! A fidelity ladder end to end (`savme reproduce --ladder`): HF plus two cheaper levels, each
//! meta-trained at its own budget with its own θ_LF; the screening stage at the top budget runs
//! the cheapest level first, a failure is confirmed at the next level up and HF last; the
//! report has a row per level; a campaign killed with SIGKILL resumes to the same trials; an
//! edited ladder line and bad ladders are refused, naming what is wrong.
use crate::common;

use common::{
    kill_once_written, made_dir, resume, run, savme, temp_dir, trial_lines, without_wall, EXE,
};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Stdio};

/// A three-level campaign on the bundled simulator with ideal perception: HF, C = 0.5 and
/// C = 0.2, each LF level meta-trained for 60 trials.
fn args(out: &Path) -> Vec<String> {
    let mut a: Vec<String> = [
        "reproduce",
        "--perception",
        "ideal",
        "--budgets",
        "0.2,0.5",
        "--ladder",
        "0.2,0.5",
        "--iterations",
        "60",
        "--eval-iterations",
        "20",
        "--test-iterations",
        "4",
        "--baseline-iterations",
        "20",
        "--baseline-test-iterations",
        "4",
        "--screen-iterations",
        "120",
        "--audit-fraction",
        "0.2",
        "--cost",
        "work",
        "--seed",
        "11",
        "--quiet",
        "--out",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    a.push(out.display().to_string());
    a
}

fn stage<'a>(lines: &'a [Value], label: &str) -> Vec<&'a Value> {
    lines.iter().filter(|l| l["stage"] == label).collect()
}

/// The LF runs of a screened line, cheapest level first (Null where none was made).
fn level_runs(l: &Value) -> Vec<Value> {
    let mut runs: Vec<Value> = (l["ladder"].as_array().into_iter().flatten())
        .map(|r| r["lf"].clone())
        .collect();
    runs.push(l["lf"].clone());
    runs
}

#[test]
fn a_three_level_ladder_learns_a_theta_per_level_and_screens_down_it_in_order() {
    let dir = temp_dir("three");
    let (ok, stdout, err) = savme(&args(&dir));
    assert!(ok, "{err}");
    let lines = trial_lines(&dir);
    // Each LF level is meta-trained at its own budget: its own θ draws, its own θ_LF*.
    let theta_star = |b: &str| stage(&lines, &format!("evaluate@{b}"))[0]["theta_lf"].clone();
    let (low, top) = (theta_star("0.2"), theta_star("0.5"));
    assert_ne!(low, top, "the levels learnt the same θ_LF*");
    for b in ["0.2", "0.5"] {
        let train = stage(&lines, &format!("train@{b}"));
        assert_eq!(train.len(), 60);
        assert!(train
            .iter()
            .all(|l| l["budget"].as_f64().unwrap().to_string() == b));
    }
    // The two-level screening at 0.2 has no ladder; the one at the top screens down it.
    assert!(stage(&lines, "screen@0.2")
        .iter()
        .all(|l| l.get("ladder").is_none()));
    let screened = stage(&lines, "screen@0.5");
    assert_eq!(screened.len(), 120);
    let (mut low_runs, mut top_runs, mut hf_runs) = (0, 0, 0);
    for l in &screened {
        let rung = &l["ladder"][0];
        assert_eq!(
            (rung["budget"].as_f64(), &rung["theta_lf"]),
            (Some(0.2), &low)
        );
        assert_eq!(l["theta_lf"], top);
        // In order: the cheapest level always; the next only after a failure below; HF after
        // the top level's failure, or to audit a pass.
        let runs = level_runs(l);
        assert!(runs[0].is_object(), "{l}");
        let low_failed = runs[0]["failure"] == true;
        assert_eq!(runs[1].is_object(), low_failed, "{l}");
        let last_failed = runs.iter().rev().find(|r| r.is_object()).unwrap()["failure"] == true;
        let hf = l["hf"].is_object();
        let expected = if last_failed {
            "confirm"
        } else if hf {
            "audit"
        } else {
            "pass"
        };
        assert_eq!(l["screen"], expected, "{l}");
        assert!(!last_failed || hf, "{l}");
        low_runs += 1;
        top_runs += usize::from(runs[1].is_object());
        hf_runs += usize::from(hf);
    }
    // Each level filters: fewer runs at each level up.
    assert!(
        top_runs < low_runs && hf_runs < low_runs,
        "{top_runs} {hf_runs}"
    );
    assert!(top_runs > 0 && hf_runs > 0);
    // The report: a row per level, counted from the lines.
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let budgets = summary["report"]["budgets"].as_array().unwrap();
    let at = |b: f64| budgets.iter().find(|x| x["budget"] == b).unwrap();
    let levels = at(0.5)["screening"]["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 2);
    assert_eq!(levels[0]["budget"], 0.2);
    assert_eq!(levels[0]["runs"], low_runs);
    assert_eq!(levels[1]["runs"], top_runs);
    assert_eq!(at(0.2)["screening"]["levels"].as_array().unwrap().len(), 1);
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(
        table.contains("## Fidelity ladder C = 0.2 → C = 0.5 → HF (120 screened trials)"),
        "{table}"
    );
    assert!(
        table.contains(&format!("| C = 0.2 | {low_runs} |")),
        "{table}"
    );
    assert!(
        table.contains("- two-level screening at C_budget = 0.2:"),
        "{table}"
    );
    assert!(
        stdout.contains("C_budget = 0.5 (ladder C = 0.2 → C = 0.5 → HF)"),
        "{stdout}"
    );
    let protocol: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("protocol.json")).unwrap()).unwrap();
    assert_eq!(protocol["ladder"], serde_json::json!([0.2, 0.5]));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Starts (or resumes) the campaign in `dir` and kills it with SIGKILL once `trials.jsonl`
/// holds `n` lines of `stage`.
fn kill_after(dir: &Path, extra: &[&str], stage: &str, n: usize) {
    let mut cmd = Command::new(EXE);
    if dir.join("protocol.json").exists() {
        cmd.args(["reproduce", "--quiet", "--resume", dir.to_str().unwrap()]);
    } else {
        let _ = std::fs::remove_dir_all(dir);
        cmd.args(args(dir)).args(extra);
    }
    let label = format!("\"stage\":\"{stage}\"");
    kill_once_written(cmd, &dir.join("trials.jsonl"), &label, n);
}

#[test]
fn a_ladder_killed_mid_screening_resumes_to_the_same_trials_and_refuses_an_edited_rung() {
    // Where-it-pays: each level runs only where it pays, decided from the lines told so far,
    // so a resume must decide the same (an exploiting elite search makes failures frequent
    // enough that some levels do not pay).
    let extra = [
        "--screen-lf",
        "where-it-pays",
        "--search",
        "elite",
        "--deployment",
        "exploit",
    ];
    let whole = temp_dir("whole");
    let mut a = args(&whole);
    a.extend(extra.iter().map(|s| s.to_string()));
    let (code, _, err) = run(&a);
    assert_eq!(code, Some(0), "{err}");
    let lines = trial_lines(&whole);
    let screened = stage(&lines, "screen@0.5");
    let skipped_low = screened
        .iter()
        .filter(|l| l["ladder"][0].get("lf").is_none())
        .count();
    let skipped_top = screened
        .iter()
        .filter(|l| l["ladder"][0]["lf"]["failure"] != false && l.get("lf").is_none())
        .count();
    assert!(
        skipped_low > 0 && skipped_top > 0,
        "{skipped_low} {skipped_top}"
    );
    let killed = made_dir("killed");
    for (label, n) in [("screen@0.5", 30), ("screen@0.5", 70)] {
        kill_after(&killed, &extra, label, n);
    }
    let (ok, _, err) = resume(&killed);
    assert!(ok, "{err}");
    assert_eq!(without_wall(trial_lines(&killed)), without_wall(lines));
    // A lower level's verdict edited: refused, naming the line and the field.
    let text = std::fs::read_to_string(killed.join("trials.jsonl")).unwrap();
    let mut rows: Vec<String> = text.lines().map(String::from).collect();
    let k = rows
        .iter()
        .position(|l| l.contains("\"stage\":\"screen@0.5\"") && l.contains("\"budget\":0.2,"))
        .unwrap();
    let edited = rows[k].replacen("\"budget\":0.2,", "\"budget\":0.25,", 1);
    assert_ne!(edited, rows[k]);
    rows[k] = edited;
    std::fs::write(killed.join("trials.jsonl"), rows.join("\n") + "\n").unwrap();
    let (ok, _, err) = resume(&killed);
    assert!(!ok);
    assert!(
        err.contains(&format!("line {}", k + 1)) && err.contains("field `ladder[0].budget`"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&killed);
}

#[test]
fn bad_ladders_are_refused_naming_the_flag_and_why() {
    let out = temp_dir("bad");
    let o = out.display().to_string();
    let base = ["reproduce", "--perception", "ideal", "--quiet", "--out", &o];
    for (extra, why) in [
        (
            &["--budgets", "0.2,0.5", "--ladder", "0.5"][..],
            "one level",
        ),
        (
            &[
                "--budgets",
                "0.2,0.5",
                "--ladder",
                "0.2,0.4",
                "--screen-iterations",
                "5",
            ][..],
            "0.4 is not one of budgets (0.2, 0.5)",
        ),
        (
            &[
                "--budgets",
                "0.2,0.5",
                "--ladder",
                "0.5,0.2",
                "--screen-iterations",
                "5",
            ][..],
            "cheapest first",
        ),
        (
            &[
                "--budgets",
                "0.5,0.2",
                "--ladder",
                "0.2,0.5",
                "--screen-iterations",
                "5",
            ][..],
            "budgets lists 0.5 before 0.2",
        ),
        (
            &["--budgets", "0.2,0.5", "--ladder", "0.2,0.5"][..],
            "screen_iterations is 0",
        ),
    ] {
        let mut a: Vec<&str> = base.to_vec();
        a.extend(extra);
        let (code, _, err) = run(&a);
        assert_eq!(code, Some(2), "{extra:?}: {err}");
        assert!(
            err.contains("ladder") && err.contains(why),
            "{extra:?}: {err}"
        );
        assert!(!out.exists(), "{extra:?}: a campaign started");
    }
}

/// The MAP arm of `simulation_rate_hz` (2, 4, 6, 8, 10 Hz) over `train`'s paired trials
/// re-credited at `level` (Table I: HF and LF agree and t_LF / t_HF ≤ level), from the uniform
/// prior: the kernel's rule (highest mode, then highest mean, then the lower arm), written out.
fn recredited_map_rate(train: &[&Value], level: f64) -> u64 {
    let rates = [2u64, 4, 6, 8, 10];
    let mut counts = [(1.0f64, 1.0f64); 5];
    for l in train.iter().filter(|l| !l["credit"]["fidelity"].is_null()) {
        let rate = l["theta_lf"]["simulation_rate_hz"].as_u64().unwrap();
        let k = rates.iter().position(|&r| r == rate).unwrap();
        let agree = matches!(l["outcome"].as_str(), Some("TP" | "TN"));
        let success = agree && l["cost_ratio"].as_f64().unwrap() <= level;
        if success {
            counts[k].0 += 1.0;
        } else {
            counts[k].1 += 1.0;
        }
    }
    let mode = |(a, b): (f64, f64)| match (a, b) {
        (a, b) if a == 1.0 && b == 1.0 => 0.5,
        (a, b) => (a - 1.0) / (a + b - 2.0),
    };
    let mean = |(a, b): (f64, f64)| a / (a + b);
    let mut best = 0;
    for k in 1..5 {
        let (m, mb) = (mode(counts[k]), mode(counts[best]));
        if m > mb || (m == mb && mean(counts[k]) > mean(counts[best])) {
            best = k;
        }
    }
    rates[best]
}

#[test]
fn a_shared_ladder_meta_trains_the_top_level_only_and_resumes_to_the_same_trials() {
    // `--ladder-training shared`: only C = 0.5 is a budget and meta-trains; the 0.2 level reads
    // its θ_LF* off train@0.5's trials re-credited at 0.2 — no train@0.2 or evaluate@0.2 stage.
    let shared = |dir: &Path| {
        let mut a = args(dir);
        let i = a.iter().position(|x| x == "--budgets").unwrap();
        a[i + 1] = "0.5".into();
        a.extend(["--ladder-training".to_string(), "shared".to_string()]);
        a
    };
    let whole = temp_dir("shared");
    let (code, _, err) = run(&shared(&whole));
    assert_eq!(code, Some(0), "{err}");
    let lines = trial_lines(&whole);
    assert!(stage(&lines, "train@0.2").is_empty() && stage(&lines, "evaluate@0.2").is_empty());
    let train = stage(&lines, "train@0.5");
    assert_eq!(train.len(), 60);
    let screened = stage(&lines, "screen@0.5");
    assert_eq!(screened.len(), 120);
    let low = screened[0]["ladder"][0]["theta_lf"].clone();
    let rate = recredited_map_rate(&train, 0.2);
    assert_eq!(low["simulation_rate_hz"], rate, "{low}");
    assert_ne!(
        rate,
        recredited_map_rate(&train, 0.5),
        "the test needs the levels to choose differently"
    );
    for l in &screened {
        assert_eq!(l["ladder"][0]["budget"], 0.2);
        assert_eq!(l["ladder"][0]["theta_lf"], low);
    }
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(whole.join("summary.json")).unwrap())
            .unwrap();
    let levels = &summary["report"]["budgets"][0]["screening"]["levels"];
    assert_eq!(levels.as_array().unwrap().len(), 2, "{levels}");
    // Table IV's column of the level below, as the report computes it from the lines.
    let shared_levels = &summary["report"]["budgets"][0]["fidelity"]["shared_levels"];
    assert_eq!(shared_levels[0]["budget"], 0.2, "{shared_levels}");
    assert_eq!(shared_levels[0]["theta_lf"], low, "{shared_levels}");
    let md = std::fs::read_to_string(whole.join("fidelity.md")).unwrap();
    assert!(
        md.contains("## The ladder's levels below C_budget = 0.5 (shared meta-training)"),
        "{md}"
    );
    // Killed twice mid-screening (the rung's θ_LF* recomputed from the replayed lines).
    let killed = made_dir("shared-killed");
    let _ = std::fs::remove_dir_all(&killed);
    for n in [20, 70] {
        if killed.join("protocol.json").exists() {
            kill_after(&killed, &[], "screen@0.5", n);
        } else {
            let mut cmd = Command::new(EXE);
            let mut child = cmd
                .args(shared(&killed))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap();
            let trials = killed.join("trials.jsonl");
            let start = std::time::Instant::now();
            while std::fs::read_to_string(&trials)
                .map_or(0, |s| s.matches("\"stage\":\"screen@0.5\"").count())
                < n
            {
                assert!(start.elapsed().as_secs() < 120, "no progress");
                assert!(
                    child.try_wait().unwrap().is_none(),
                    "finished before the kill"
                );
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            child.kill().unwrap();
            child.wait().unwrap();
        }
    }
    let (ok, _, err) = resume(&killed);
    assert!(ok, "{err}");
    assert_eq!(without_wall(trial_lines(&killed)), without_wall(lines));
    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&killed);
}

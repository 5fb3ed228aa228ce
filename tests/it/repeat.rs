//! `savme reproduce --repeat N` end to end: each seed's campaign is the single campaign of that
//! seed, the results over the seeds agree with the seeds' own summaries, a killed repeated run
//! resumes to the same trials, and bad input is refused before any simulation.
use crate::common;

use common::campaign::file_trials;
use common::{resume, savme, temp_dir, EXE};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A tiny protocol on the idealised-perception simulator (fast), work-unit cost.
const TINY: &[&str] = &[
    "--perception",
    "ideal",
    "--budgets",
    "0.3",
    "--iterations",
    "30",
    "--eval-iterations",
    "12",
    "--test-iterations",
    "14",
    "--baseline-iterations",
    "24",
    "--baseline-test-iterations",
    "14",
    "--cost",
    "work",
    "--quiet",
];

/// TINY, with seed 7 unless `extra` gives one.
fn args(extra: &[&str]) -> Vec<String> {
    let mut a: Vec<String> = TINY.iter().chain(extra).map(|s| s.to_string()).collect();
    if !extra.contains(&"--seed") {
        a.extend(["--seed".into(), "7".into()]);
    }
    a
}

fn reproduce(out: &Path, extra: &[&str]) -> (bool, String, String) {
    let mut a = vec![
        "reproduce".to_string(),
        "--out".into(),
        out.display().to_string(),
    ];
    a.extend(args(extra));
    savme(&a)
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

// Long because it checks every aggregate against the seeds' own outputs: one run, many checks.
#[test]
fn a_repeated_reproduction_aggregates_its_seeds_and_each_seed_is_the_single_campaign() {
    let dir = temp_dir("agg");
    let strengths = ["--prior-strengths", "0,0.3,1"];
    let (ok, out, err) = reproduce(
        &dir,
        &[&["--repeat", "3", "--jobs", "2"], &strengths[..]].concat(),
    );
    assert!(ok, "{err}");
    assert!(out.contains("3 seeds"), "{out}");
    // Seed 8's directory holds exactly the campaign `--seed 8` gives alone.
    let single = temp_dir("agg-single");
    assert!(reproduce(&single, &[&["--seed", "8"], &strengths[..]].concat()).0);
    assert_eq!(file_trials(&dir.join("seed-8")), file_trials(&single));

    let summary = json(&dir.join("summary.json"));
    let rep = &summary["repeated"];
    assert_eq!(rep["seeds"], serde_json::json!([7, 8, 9]));
    let seeds: Vec<Value> = (7..10)
        .map(|s| json(&dir.join(format!("seed-{s}/summary.json")))["report"].clone())
        .collect();
    // Per-seed TP-rates are the seeds' own; the mean is their mean, inside its interval.
    let tp = &rep["budgets"][0]["tp_rate"];
    let own: Vec<f64> = seeds
        .iter()
        .map(|s| s["budgets"][0]["evaluation"]["tp_rate"].as_f64().unwrap())
        .collect();
    let per_seed: Vec<f64> = tp["over_seeds"]["per_seed"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(per_seed, own);
    let mean = tp["over_seeds"]["mean"]["mean"].as_f64().unwrap();
    assert!((mean - own.iter().sum::<f64>() / 3.0).abs() < 1e-12);
    let (lo, hi) = (
        tp["over_seeds"]["mean"]["lo"].as_f64().unwrap(),
        tp["over_seeds"]["mean"]["hi"].as_f64().unwrap(),
    );
    assert!(lo <= mean && mean <= hi && lo >= 0.0 && hi <= 1.0, "{tp}");
    // The pooled Wilson interval counts every seed's evaluation trials.
    assert_eq!(tp["pooled"]["n"], 36);
    let pooled_tp: u64 = seeds
        .iter()
        .map(|s| s["budgets"][0]["evaluation"]["tp"].as_u64().unwrap())
        .sum();
    assert!((tp["pooled"]["mean"].as_f64().unwrap() - pooled_tp as f64 / 36.0).abs() < 1e-12);
    let base = &rep["baseline_train"]["pooled"];
    assert_eq!(base["n"], 72);
    assert!(base["lo"].as_f64().unwrap() < base["hi"].as_f64().unwrap());

    // The ablation: strength 0 is the uniform prior (gain 0 in every seed), strength 1 the
    // learned prior's stage; 0.3 ran its own stage in every seed.
    let ab = rep["budgets"][0]["ablation"].as_array().unwrap();
    assert_eq!(ab.len(), 3);
    // (undefined in a seed where the uniform prior found no failure by the horizon).
    for (gain, found) in ab[0]["gain_all_runs"]["per_seed"]
        .as_array()
        .unwrap()
        .iter()
        .zip(ab[0]["found"]["per_seed"].as_array().unwrap())
    {
        match gain.as_f64() {
            Some(g) => assert_eq!(g, 0.0),
            None => assert_eq!(found.as_f64(), Some(0.0)),
        }
    }
    let s8 = file_trials(&dir.join("seed-8"));
    let stage = |label: &str| s8.iter().filter(|t| t["stage"] == label).count();
    assert_eq!(stage("test-learned-s0.3@0.3"), 14);
    assert_eq!(stage("test-learned-s1@0.3"), 0);
    // The tables and figures of the aggregate.
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(table.contains("over 3 seeds"), "{table}");
    assert!(table.contains("| 0.3 | 0.3 |"), "{table}");
    for png in ["breakeven.png", "meta_testing.png"] {
        let b = std::fs::read(dir.join(png)).unwrap();
        assert_eq!(&b[..4], b"\x89PNG", "{png}");
    }
    for d in [dir, single] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_killed_repeated_campaign_resumes_to_the_same_trials() {
    let full = temp_dir("full");
    assert!(reproduce(&full, &["--repeat", "2", "--jobs", "1"]).0);
    let dir = temp_dir("killed");
    let mut child = Command::new(EXE)
        .arg("reproduce")
        .arg("--out")
        .arg(&dir)
        .args(args(&["--repeat", "2", "--jobs", "1"]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // jobs 1: the seeds run one after the other; kill during the first.
    let log = dir.join("seed-7/trials.jsonl");
    let start = Instant::now();
    while std::fs::read_to_string(&log).map_or(0, |s| s.lines().count()) < 20 {
        assert!(start.elapsed() < Duration::from_secs(120), "no progress");
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before the kill"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert!(!dir.join("summary.json").exists());
    let (ok, out, err) = resume(&dir);
    assert!(ok, "{err}");
    assert!(out.contains("replayed"), "{out}");
    for seed in ["seed-7", "seed-8"] {
        assert_eq!(
            file_trials(&dir.join(seed)),
            file_trials(&full.join(seed)),
            "{seed}"
        );
    }
    let table = |d: &Path| std::fs::read_to_string(d.join("table.md")).unwrap();
    assert_eq!(table(&dir), table(&full));
    for d in [full, dir] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn bad_repeat_input_is_refused_before_any_simulation() {
    let dir = temp_dir("bad");
    let cases: &[(&[&str], &str)] = &[
        (&["--repeat", "0"], "`repeat`: 0 is not between 1 and 1000"),
        (&["--repeat", "1001"], "`repeat`"),
        (
            &["--repeat", "2", "--prior-strengths", "0,-1"],
            "`prior_strengths`: -1",
        ),
        (
            &["--repeat", "2", "--prior-strengths", "0.3,0.3"],
            "0.3 is given twice",
        ),
        (&["--repeat", "2", "--record", "x.rrd"], "cannot record"),
        (
            &["--repeat", "2", "--seed", "18446744073709551615"],
            "`seed`",
        ),
    ];
    for (extra, message) in cases {
        let (ok, _, err) = reproduce(&dir, extra);
        assert!(!ok, "{extra:?} was accepted");
        assert!(err.contains(message), "{extra:?}: {err}");
        assert!(!dir.join("seed-7").exists(), "{extra:?} ran a campaign");
    }
    // A directory that holds a repeated campaign is not started again, and a resume keeps
    // the protocol.
    assert!(reproduce(&dir, &["--repeat", "1"]).0);
    let (ok, _, err) = reproduce(&dir, &["--repeat", "1"]);
    assert!(!ok && err.contains("already holds a campaign"), "{err}");
    let o = Command::new(EXE)
        .args(["reproduce", "--repeat", "3", "--resume"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("keeps its protocol"));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_toy_runs_repeat_seeds_too_and_resumes_them() {
    // `savme toy --repeat N` ran one campaign and ignored N (even 0).
    let dir = temp_dir("toy");
    let d = dir.to_str().unwrap();
    let toy = |args: &[&str]| {
        let o = Command::new(EXE).arg("toy").args(args).output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (code, err) = toy(&["--out", d, "--repeat", "0", "--quiet"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("`repeat`: 0 is not between 1 and"), "{err}");
    assert!(!dir.exists());
    let (code, err) = toy(&["--out", d, "--repeat", "2", "--iterations", "20", "--quiet"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(json(&dir.join("repeat.json"))["repeat"], 2);
    let seeds = [dir.join("seed-1"), dir.join("seed-2")];
    let before: Vec<Vec<Value>> = seeds.iter().map(|s| file_trials(s)).collect();
    assert!(before.iter().all(|t| !t.is_empty()) && before[0] != before[1]);
    // A resume keeps the count and replays every seed's trials.
    let (code, err) = toy(&["--resume", d, "--quiet"]);
    assert_eq!(code, Some(0), "{err}");
    let after: Vec<Vec<Value>> = seeds.iter().map(|s| file_trials(s)).collect();
    assert_eq!(before, after);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_resumed_elite_campaign_keeps_its_stored_search_and_pairing_parameters() {
    // protocol.json stores the elite parameters and the pairing, so a resume draws the same
    // trials even if the defaults change meanwhile (explore 0.3 is not the default: a resume
    // with the defaults would ask other trials).
    let dir = temp_dir("elite");
    let search = [
        "--search",
        "elite",
        "--elite",
        "explore=0.3,tries=4",
        "--pair-fraction",
        "0.5",
        "--pair-settle",
        "1",
    ];
    let (ok, _, err) = reproduce(&dir, &search);
    assert!(ok, "{err}");
    let protocol = json(&dir.join("protocol.json"));
    assert_eq!(protocol["elite"]["explore"], 0.3);
    assert_eq!(protocol["elite"]["tries"], 4);
    assert_eq!(
        protocol["elite"]["bandwidth"], 0.06,
        "the defaults of the day are stored"
    );
    assert_eq!(
        (
            protocol["pair_fraction"].clone(),
            protocol["pair_settle"].clone()
        ),
        (0.5.into(), 1.into())
    );
    let full = file_trials(&dir);
    let train: Vec<&Value> = full.iter().filter(|t| t["stage"] == "train@0.3").collect();
    let unpaired = train.iter().filter(|t| t["theta_lf"].is_null()).count();
    assert!(
        unpaired > 0 && unpaired < train.len(),
        "{unpaired} of {}",
        train.len()
    );
    assert!(train
        .iter()
        .all(|t| t["theta_lf"].is_null() == t["lf"].is_null()));
    // Cut the store to its first 20 lines (a killed campaign) and resume.
    let text = std::fs::read_to_string(dir.join("trials.jsonl")).unwrap();
    let head: String = text.lines().take(20).map(|l| format!("{l}\n")).collect();
    std::fs::write(dir.join("trials.jsonl"), head).unwrap();
    let (ok, _, err) = resume(&dir);
    assert!(ok, "{err}");
    assert_eq!(file_trials(&dir), full);
    // Idle or bad values are refused naming the flag's value.
    let bad = temp_dir("elite-bad");
    let (ok, _, err) = reproduce(&bad, &["--elite", "explore=0.3"]);
    assert!(
        !ok && err.contains("`elite`") && err.contains("search = elite"),
        "{err}"
    );
    let (ok, _, err) = reproduce(&bad, &["--pair-fraction", "1.5"]);
    assert!(
        !ok && err.contains("`pair_fraction`: 1.5 is outside (0, 1]"),
        "{err}"
    );
    assert!(!bad.exists());
    let _ = std::fs::remove_dir_all(dir);
}

//! `savme reproduce` end to end: outputs agree with trials.jsonl, runs are reproducible and
//! independent of the number of jobs, a killed run resumes without losing or repeating a trial,
//! and bad input is refused before any simulation.
use crate::common;

use common::{resume, run, temp_dir, trial_lines, without_wall, EXE, TINY_PROTOCOL};
use serde_json::{json, Value};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A tiny protocol on the camera + lidar simulator, work-unit cost.
const TINY: &[&str] = TINY_PROTOCOL;
const TINY_TRIALS: usize = 14 + 16 + 6 + 8 + 2 * 8;

/// TINY with the flags of `extra` added or replaced.
fn args(extra: &[&str]) -> Vec<String> {
    let mut a: Vec<String> = TINY.iter().map(|s| s.to_string()).collect();
    let mut i = 0;
    while i < extra.len() {
        let flag = extra[i];
        let value = extra.get(i + 1).filter(|v| !v.starts_with("--"));
        match (a.iter().position(|x| x == flag), value) {
            (Some(k), Some(v)) => a[k + 1] = v.to_string(),
            (None, Some(v)) => a.extend([flag.to_string(), v.to_string()]),
            (_, None) => a.push(flag.to_string()),
        }
        i += 1 + usize::from(value.is_some());
    }
    a
}

fn reproduce(out: &Path, extra: &[&str]) -> (bool, String, String) {
    let (code, out, err) = reproduce_status(out, extra);
    (code == Some(0), out, err)
}

/// `reproduce` with its exit status.
fn reproduce_status(out: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let mut a = vec![
        "reproduce".to_string(),
        "--out".into(),
        out.display().to_string(),
    ];
    a.extend(args(extra));
    run(&a)
}

fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(
        &b[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

/// The numbers of a table row `| key | a | b | c |`.
fn row(table: &str, key: &str) -> Vec<String> {
    let line = table
        .lines()
        .find(|l| l.starts_with(&format!("| {key} |")))
        .unwrap_or_else(|| panic!("no row {key} in\n{table}"));
    line.split('|')
        .map(str::trim)
        .filter(|c| !c.is_empty())
        .skip(1)
        .map(String::from)
        .collect()
}

// Long because it recomputes every output (both tables, the summary, the figures) from the
// trial lines of one run, which is slow to produce: one run, many checks.
#[test]
fn a_tiny_reproduction_writes_outputs_that_agree_with_its_trials() {
    let dir = temp_dir("e2e");
    let (ok, out, err) = reproduce(&dir, &["--jobs", "2"]);
    assert!(ok, "{err}");
    let t = trial_lines(&dir);
    assert_eq!(t.len(), TINY_TRIALS);
    // Every stage, in the protocol's order, with consecutive indices.
    let stages: Vec<&str> = t.iter().map(|v| v["stage"].as_str().unwrap()).collect();
    let mut order = stages.clone();
    order.dedup();
    assert_eq!(
        order,
        [
            "baseline-train",
            "train@0.3",
            "evaluate@0.3",
            "baseline-test",
            "test-learned@0.3",
            "test-uniform@0.3"
        ]
    );
    for s in &order {
        let idx: Vec<u64> = t
            .iter()
            .filter(|v| v["stage"] == *s)
            .map(|v| v["index"].as_u64().unwrap())
            .collect();
        assert_eq!(idx, (0..idx.len() as u64).collect::<Vec<_>>(), "{s}");
    }
    // Paired trials have both runs; baselines only HF; train scenarios are 1–8, test 9–10.
    for v in &t {
        let baseline = v["stage"].as_str().unwrap().starts_with("baseline");
        assert_eq!(v["lf"].is_null(), baseline, "{v}");
        assert_eq!(v["theta_lf"].is_null(), baseline);
        let test = v["stage"].as_str().unwrap().contains("test");
        let scenario = v["scenario"].as_str().unwrap();
        assert_eq!(
            ["lead_vehicle_two_way", "on_ramp_merge"].contains(&scenario),
            test,
            "{scenario} in {}",
            v["stage"]
        );
    }

    // table.md recomputed from the trials.
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    let base: Vec<&Value> = t
        .iter()
        .filter(|v| v["stage"] == "baseline-train")
        .collect();
    let base_rate =
        base.iter().filter(|v| v["hf"]["failure"] == true).count() as f64 / base.len() as f64;
    let eval: Vec<&Value> = t.iter().filter(|v| v["stage"] == "evaluate@0.3").collect();
    let tp = eval
        .iter()
        .filter(|v| v["hf"]["failure"] == true && v["lf"]["failure"] == true)
        .count() as f64
        / eval.len() as f64;
    let cost = eval
        .iter()
        .map(|v| v["lf"]["runtime"].as_f64().unwrap() / v["hf"]["runtime"].as_f64().unwrap())
        .sum::<f64>()
        / eval.len() as f64;
    let base_row = row(&table, "baseline");
    assert_eq!(
        base_row[..3],
        [format!("{base_rate:.2}"), "1.00".into(), "1.00".into()]
    );
    // The rates carry their Wilson 95 % interval: p̃ ± z·√(p(1−p)/n + z²/4n²) / (1 + z²/n).
    let wilson = |p: f64, n: f64| {
        let z = 1.959964f64;
        let c = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
        let h = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
        format!("[{:.2}, {:.2}]", (c - h).max(0.0), (c + h).min(1.0))
    };
    assert_eq!(base_row[3], wilson(base_rate, base.len() as f64), "{table}");
    let r = row(&table, "0.3");
    assert_eq!(r[0], format!("{tp:.2}"), "{table}");
    assert_eq!(r[3], wilson(tp, eval.len() as f64), "{table}");
    assert_eq!(r[1], format!("{cost:.2}"), "{table}");
    if tp > 0.0 && base_rate > 0.0 {
        assert_eq!(r[2], format!("{:.2}", tp / cost / base_rate), "{table}");
    } else {
        assert_eq!(r[2], "–");
    }
    // The evaluation ran one θ_LF (the MAP), and fidelity.md shows it.
    let theta = &eval[0]["theta_lf"];
    assert!(eval.iter().all(|v| v["theta_lf"] == *theta));
    let fidelity = std::fs::read_to_string(dir.join("fidelity.md")).unwrap();
    for name in [
        "simulation_rate_hz",
        "lidar_subsample_count",
        "camera_disable_shadows",
    ] {
        assert_eq!(
            row(&fidelity, name)[1],
            theta[name].to_string(),
            "{fidelity}"
        );
    }
    // summary.json parses and agrees.
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["trials"], TINY_TRIALS);
    assert_eq!(summary["format_version"], 1);
    let e = &summary["report"]["budgets"][0]["evaluation"];
    // The four classes under their own names (not `fn_`), adding up to the evaluation.
    let classes: Vec<u64> = ["tp", "tn", "fp", "fn"]
        .iter()
        .map(|k| e[*k].as_u64().unwrap_or_else(|| panic!("{k}: {e}")))
        .collect();
    assert_eq!(classes.iter().sum::<u64>(), 6, "{e}");
    assert!(e.get("fn_").is_none(), "{e}");
    let protocol: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("protocol.json")).unwrap()).unwrap();
    assert_eq!(protocol["format_version"], 1);
    for md in ["table.md", "fidelity.md"] {
        let text = std::fs::read_to_string(dir.join(md)).unwrap();
        assert!(
            text.ends_with("<!-- savme format_version 1 -->\n"),
            "{md}: {text}"
        );
    }
    assert!((e["tp_rate"].as_f64().unwrap() - tp).abs() < 1e-12);
    assert!((e["mean_lf_cost"].as_f64().unwrap() - cost).abs() < 1e-9);
    let m = &summary["report"]["budgets"][0]["meta_testing"];
    for accounting in ["all_runs", "lf_only"] {
        let f = &m[accounting];
        assert!(
            f["learned"].as_u64().is_some() && f["horizon"].as_f64().unwrap() > 0.0,
            "{m}"
        );
    }
    // The figures exist.
    assert_eq!(png_size(&dir.join("breakeven.png")), (900, 560));
    assert_eq!(png_size(&dir.join("meta_testing.png")), (620, 520));
    // The printed summary shows both tables and the findings.
    assert!(
        out.contains("| C_budget | TP-rate | mean LF cost | speedup |"),
        "{out}"
    );
    assert!(out.contains("| simulation_rate_hz |") && out.contains("Break-even"));
    assert!(out.contains("Meta-testing"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn same_seed_and_work_cost_give_the_same_campaign_whatever_the_jobs() {
    let (a, b) = (temp_dir("same-a"), temp_dir("same-b"));
    assert!(reproduce(&a, &["--jobs", "1"]).0);
    assert!(reproduce(&b, &["--jobs", "2"]).0);
    let read = |d: &Path, f: &str| std::fs::read_to_string(d.join(f)).unwrap();
    assert_eq!(read(&a, "table.md"), read(&b, "table.md"));
    assert_eq!(read(&a, "fidelity.md"), read(&b, "fidelity.md"));
    assert_eq!(without_wall(trial_lines(&a)), without_wall(trial_lines(&b)));
    // Another seed gives another campaign.
    let c = temp_dir("same-c");
    assert!(reproduce(&c, &["--jobs", "2", "--seed", "8"]).0);
    assert_ne!(without_wall(trial_lines(&a)), without_wall(trial_lines(&c)));
    for d in [a, b, c] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// Starts the TINY campaign (2 jobs) into `dir` and returns once `lines` trials are stored.
fn start_and_wait_for_lines(dir: &Path, lines: usize) -> std::process::Child {
    start_with(dir, lines, &[])
}

/// [`start_and_wait_for_lines`] with `extra` flags.
fn start_with(dir: &Path, lines: usize, extra: &[&str]) -> std::process::Child {
    let mut child = Command::new(EXE)
        .arg("reproduce")
        .arg("--out")
        .arg(dir)
        .args(args(&[&["--jobs", "2"], extra].concat()))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let log = dir.join("trials.jsonl");
    let start = Instant::now();
    while std::fs::read_to_string(&log).map_or(0, |s| s.lines().count()) < lines {
        assert!(start.elapsed() < Duration::from_secs(120), "no progress");
        assert!(child.try_wait().unwrap().is_none(), "finished too early");
        std::thread::sleep(Duration::from_millis(5));
    }
    child
}

/// Ctrl-C (a real SIGINT): the campaign stops between trials, exits 130 saying how to resume,
/// and the resumed campaign equals the uninterrupted one.
fn ctrl_c_then_resume(expected: &[Value]) {
    let dir = temp_dir("interrupted");
    let child = start_and_wait_for_lines(&dir, 20);
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("stopping after the runs in flight"), "{err}");
    assert!(err.contains("error: interrupted: stopped in "), "{err}");
    let hint = format!(
        "trials (every told trial is stored); continue with --resume {}",
        dir.display()
    );
    assert!(err.contains(&hint), "{err}");
    let before = trial_lines(&dir).len();
    assert!(
        before < TINY_TRIALS,
        "the run finished before Ctrl-C took effect"
    );
    let (ok, out, err) = resume(&dir);
    assert!(ok, "{err}");
    let replayed = format!("({before} replayed from the trial store");
    assert!(out.contains(&replayed), "{out}");
    assert_eq!(without_wall(trial_lines(&dir)), expected);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_killed_or_interrupted_campaign_resumes_without_losing_or_repeating_a_trial() {
    let full = temp_dir("resume-full");
    assert!(reproduce(&full, &["--jobs", "2"]).0);
    let expected = without_wall(trial_lines(&full));

    // kill -9 midway through, then resume.
    let dir = temp_dir("resume-killed");
    let mut child = start_and_wait_for_lines(&dir, 20);
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    // Lines, not parsed trials: the kill may have torn the last one.
    let log = std::fs::read_to_string(dir.join("trials.jsonl")).unwrap();
    assert!(
        log.lines().count() < TINY_TRIALS,
        "the run finished before the kill"
    );
    let (ok, out, err) = resume(&dir);
    assert!(ok, "{err}");
    assert!(out.contains("replayed from the trial store"), "{out}");
    assert_eq!(without_wall(trial_lines(&dir)), expected);

    ctrl_c_then_resume(&expected);

    // A torn last line (a write cut short) is dropped and its trial run again.
    let torn = temp_dir("resume-torn");
    std::fs::create_dir_all(&torn).unwrap();
    std::fs::copy(full.join("protocol.json"), torn.join("protocol.json")).unwrap();
    let text = std::fs::read_to_string(full.join("trials.jsonl")).unwrap();
    let cut = text.len() * 3 / 5;
    let cut = (cut..text.len())
        .find(|&i| text.is_char_boundary(i) && &text[i - 1..i] != "\n")
        .unwrap();
    std::fs::write(torn.join("trials.jsonl"), &text[..cut]).unwrap();
    let (ok, _, err) = resume(&torn);
    assert!(ok, "{err}");
    assert_eq!(without_wall(trial_lines(&torn)), expected);

    // Resuming a finished campaign runs nothing and rewrites the same outputs.
    let table = std::fs::read_to_string(full.join("table.md")).unwrap();
    let (ok, out, _) = resume(&full);
    assert!(ok);
    assert!(
        out.contains(&format!(
            "({TINY_TRIALS} replayed from the trial store, 0 run)"
        )),
        "{out}"
    );
    assert_eq!(
        std::fs::read_to_string(full.join("table.md")).unwrap(),
        table
    );
    for d in [full, dir, torn] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// Method tuned: θ_LF* from evidence and the transfer chosen by leave-one-scenario-out are
/// reported in fidelity.md and summary.json (per setting: the arm, its tries, false-alarm and
/// miss rates; per candidate strength: the held-out likelihood), the learned prior uses the
/// strengths reported, and a campaign killed during meta-testing resumes to the same trials.
#[test]
fn a_tuned_campaign_reports_its_evidence_and_transfer_and_resumes_identically() {
    let tuned = ["--method", "tuned"];
    let full = temp_dir("tuned-full");
    let (ok, _, err) = reproduce(&full, &tuned);
    assert!(ok, "{err}");
    let expected = without_wall(trial_lines(&full));
    let md = std::fs::read_to_string(full.join("fidelity.md")).unwrap();
    for says in [
        "chosen from evidence",
        "## θ_LF* at C_budget = 0.3: the evidence per setting",
        "| setting | arm | tried | successes | false alarms | misses | mean LF cost |",
        "## Transfer to meta-testing at C_budget = 0.3 (auto: per setting, leave-one-scenario-out)",
        "| (all settings) |",
        // The bundled simulator's test scenarios share no φ variable's domain with a training
        // scenario: p_ψ is not transferred, and the report says why.
        "## φ (p_ψ) transfer to meta-testing at C_budget = 0.3",
        "No meta-testing scenario shares a φ variable",
    ] {
        assert!(md.contains(says), "fidelity.md lacks {says:?}:\n{md}");
    }
    let table = std::fs::read_to_string(full.join("table.md")).unwrap();
    assert!(
        table.contains("with θ_LF* chosen from evidence (fidelity.md) and φ ~ p_ψ"),
        "{table}"
    );
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(full.join("summary.json")).unwrap()).unwrap();
    let f = &summary["report"]["budgets"][0]["fidelity"];
    assert_eq!(f["choice"], "evidence", "{f}");
    let settings = f["settings"].as_array().unwrap();
    assert_eq!(settings.len(), 16, "{f}");
    for s in settings {
        for key in [
            "variable",
            "arm",
            "tried",
            "fp",
            "fn",
            "false_alarm_rate",
            "miss_rate",
        ] {
            assert!(s.get(key).is_some(), "{key} missing: {s}");
        }
    }
    // Each setting's tries are meta-training trials: at most the 16 of TINY.
    assert!(settings.iter().all(|s| s["tried"].as_u64().unwrap() <= 16));
    let t = &f["transfer"];
    assert_eq!(t["mode"], "auto", "{t}");
    let strengths = t["strengths"].as_array().unwrap();
    assert_eq!(strengths.len(), 16);
    let choice = &t["choice"];
    assert_eq!(choice["candidates"].as_array().unwrap().len(), 6, "{t}");
    for (v, s) in choice["variables"]
        .as_array()
        .unwrap()
        .iter()
        .zip(strengths)
    {
        assert_eq!(&v["strength"], s, "the campaign used what the report says");
        assert_eq!(v["log_likelihood"].as_array().unwrap().len(), 6);
    }
    assert!(f["evaluation"]["trials"] == 6, "{f}");
    for phi in t["phi"].as_array().unwrap() {
        assert_eq!(phi["used"], false, "{phi}");
        for v in phi["variables"].as_array().unwrap() {
            assert_eq!(v["scenarios"], json!([]), "{v}");
            assert_eq!(v["strength"], 0.0, "{v}");
        }
    }

    // kill -9 during meta-testing (after training's 14 + 16 and evaluation's 6 lines).
    let dir = temp_dir("tuned-killed");
    let mut child = start_with(&dir, 40, &tuned);
    child.kill().unwrap();
    child.wait().unwrap();
    let (ok, _, err) = resume(&dir);
    assert!(ok, "{err}");
    assert_eq!(without_wall(trial_lines(&dir)), expected);
    assert_eq!(
        std::fs::read_to_string(dir.join("fidelity.md")).unwrap(),
        md
    );
    // The paper's method keeps the MAP and the fixed strength, and says so.
    let paper = temp_dir("tuned-paper");
    assert!(reproduce(&paper, &[]).0);
    let md = std::fs::read_to_string(paper.join("fidelity.md")).unwrap();
    assert!(md.contains("θ_LF* = MAP of p_ω"), "{md}");
    let table = std::fs::read_to_string(paper.join("table.md")).unwrap();
    assert!(
        table.contains("with θ_LF = MAP of p_ω and φ ~ p_ψ"),
        "{table}"
    );
    assert!(
        md.contains("(fixed: `prior_strength` for every setting)"),
        "{md}"
    );
    for d in [full, dir, paper] {
        let _ = std::fs::remove_dir_all(d);
    }
}

// Long because it is one table of bad inputs, each checked the same way.
#[test]
fn bad_input_is_refused_before_any_simulation() {
    let dir = temp_dir("bad");
    // A flag's value savme refuses is a usage error: exit status 2, as for clap's own.
    let bad = |extra: &[&str], needle: &str| {
        let (code, _, err) = reproduce_status(&dir, extra);
        assert_eq!(code, Some(2), "{extra:?}: {err}");
        assert!(
            err.contains(needle),
            "{extra:?}: expected `{needle}` in: {err}"
        );
        assert!(!dir.exists(), "{extra:?} created the output directory");
    };
    bad(&["--train-scenarios", "1,42"], "unknown scenario `42`");
    bad(
        &["--test-scenarios", "no_such_scenario"],
        "unknown scenario `no_such_scenario`",
    );
    bad(&["--budgets", "0"], "`budgets`: 0 is outside (0, 1]");
    bad(&["--budgets", "1.5"], "1.5 is outside (0, 1]");
    bad(
        &["--iterations", "0"],
        "`train_iterations`: must be at least 1",
    );
    bad(&["--eval-iterations", "0"], "`eval_iterations`");
    bad(
        &["--iterations", "10000000000"],
        "`train_iterations`: 10000000000 is more than savme runs in one stage",
    );
    bad(
        &["--test-iterations", "18446744073709551615"],
        "`test_iterations`: 18446744073709551615 is more",
    );
    bad(&["--window", "0"], "`window`: 0 is not between 1 and");
    bad(
        &["--jobs", "0"],
        "'0' for '--jobs <JOBS>': must be at least 1",
    );

    // An output directory that cannot be created.
    let file = temp_dir("bad-file");
    std::fs::write(&file, "not a directory").unwrap();
    // ... while a failure running the command is a runtime error: exit status 1.
    let (code, _, err) = reproduce_status(&file.join("out"), &[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(&file.join("out").display().to_string()),
        "{err}"
    );
    // An output directory that is a file: named, and said to be one (not "File exists").
    let (ok, _, err) = reproduce(&file, &[]);
    assert!(!ok);
    assert!(
        err.contains(&format!("{} is a file, not a directory", file.display())),
        "{err}"
    );
    assert!(!err.contains("os error"), "{err}");
    // For --resume the file is named as what it is not: a campaign directory to continue.
    let (ok, _, err) = resume(&file);
    assert!(!ok);
    assert!(
        err.contains(&format!(
            "{} is a file, not a campaign directory",
            file.display()
        )),
        "{err}"
    );
    // A file further up an output path.
    let (ok, _, err) = reproduce(&file.join("out").join("deeper"), &[]);
    assert!(!ok);
    assert!(
        err.contains(&format!("{} is a file, not a directory", file.display())),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a directory");
    let _ = std::fs::remove_file(&file);

    // A directory that holds a campaign is not overwritten.
    let done = temp_dir("bad-done");
    std::fs::create_dir_all(&done).unwrap();
    std::fs::write(done.join("trials.jsonl"), "").unwrap();
    let (ok, _, err) = reproduce(&done, &[]);
    assert!(!ok && err.contains("already holds a campaign"), "{err}");

    // Resume: nothing to resume, changed protocol, corrupt trials file.
    let (ok, _, err) = resume(&dir);
    assert!(!ok && err.contains("no protocol.json"), "{err}");
    let o = Command::new(EXE)
        .args(["reproduce", "--seed", "3", "--resume"])
        .arg(&done)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("keeps its protocol"));

    let good = temp_dir("bad-corrupt");
    assert!(reproduce(&good, &[]).0);
    let text = std::fs::read_to_string(good.join("trials.jsonl")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[4] = "{\"stage\": \"train@0.3\", garbage";
    std::fs::write(good.join("trials.jsonl"), lines.join("\n") + "\n").unwrap();
    let (ok, _, err) = resume(&good);
    assert!(!ok);
    assert!(err.contains("trials.jsonl, line 5"), "{err}");
    // A trial edited into another one does not match what the protocol asks.
    let mut edited: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    edited[20]["scenario"] = Value::from("parking_pull_out_edited");
    let body: String = edited.iter().map(|v| v.to_string() + "\n").collect();
    std::fs::write(good.join("trials.jsonl"), body).unwrap();
    let (ok, _, err) = resume(&good);
    assert!(!ok);
    assert!(
        err.contains("trials.jsonl, line 21: field `scenario` is parking_pull_out_edited"),
        "{err}"
    );
    // A φ edited: named by file, line and variable.
    let mut edited: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let (name, x) = edited[20]["phi"]
        .as_object()
        .and_then(|o| o.iter().find(|(_, v)| v.is_f64()))
        .map(|(k, v)| (k.clone(), v.as_f64().unwrap()))
        .unwrap();
    edited[20]["phi"][&name] = Value::from(x + 0.5);
    let body: String = edited.iter().map(|v| v.to_string() + "\n").collect();
    std::fs::write(good.join("trials.jsonl"), body).unwrap();
    let (ok, _, err) = resume(&good);
    assert!(!ok);
    assert!(
        err.contains(&format!(
            "trials.jsonl, line 21: field `phi.{name}` is {}",
            x + 0.5
        )),
        "{err}"
    );
    for d in [dir, done, good] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn the_same_seed_gives_the_trials_savme_gave_before_the_campaign_core_moved() {
    // tests/fixtures/README.md: written by savme b27244b with exactly TINY and --jobs 2.
    let dir = temp_dir("fixture");
    let (ok, _, err) = reproduce(&dir, &["--jobs", "2"]);
    assert!(ok, "{err}");
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/reproduce-tiny-seed7-work.trials.jsonl"
    );
    let before: Vec<Value> = std::fs::read_to_string(fixture)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(before.len(), TINY_TRIALS);
    // Today's runs also report their robustness (the bundled simulator's smallest clearance,
    // 0 at a collision); the fixture predates it. Every run has one, and apart from it the
    // trials are the same.
    let mut now = trial_lines(&dir);
    for line in &mut now {
        let text = line.to_string();
        for run in ["hf", "lf"] {
            let Some(r) = line[run].as_object_mut() else {
                continue;
            };
            let rho = r.remove("robustness").and_then(|v| v.as_f64());
            let rho = rho.unwrap_or_else(|| panic!("a {run} run without robustness: {text}"));
            let failed = r["failure"].as_bool().unwrap();
            assert!(rho >= 0.0 && (rho == 0.0) == failed, "{run}: {rho} {text}");
        }
    }
    assert_eq!(without_wall(now), without_wall(before));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_second_process_on_a_running_campaign_is_refused_and_changes_nothing() {
    let dir = temp_dir("second");
    let mut first = Command::new(EXE)
        .arg("reproduce")
        .arg("--out")
        .arg(&dir)
        .args(args(&["--jobs", "1", "--iterations", "120"]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let log = dir.join("trials.jsonl");
    let start = Instant::now();
    while std::fs::read_to_string(&log).map_or(0, |s| s.lines().count()) < 3 {
        assert!(start.elapsed() < Duration::from_secs(120), "no progress");
        std::thread::sleep(Duration::from_millis(5));
    }
    let holder = format!("pid {}", first.id());
    // A resume, and a new campaign into the same directory, while the first one runs.
    for extra in [None, Some("new")] {
        let mut cmd = Command::new(EXE);
        match extra {
            None => cmd.args(["reproduce", "--quiet", "--resume"]).arg(&dir),
            Some(_) => cmd.arg("reproduce").arg("--out").arg(&dir).args(args(&[])),
        };
        let before = std::fs::read(dir.join("protocol.json")).unwrap();
        let o = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{err}");
        assert!(
            err.contains(&log.display().to_string()) && err.contains(&holder),
            "{err}"
        );
        assert_eq!(std::fs::read(dir.join("protocol.json")).unwrap(), before);
    }
    assert!(
        first.try_wait().unwrap().is_none(),
        "the first process died"
    );
    first.kill().unwrap();
    first.wait().unwrap();
    // With the holder gone (kill -9: the OS released the lock) the campaign resumes.
    let o = Command::new(EXE)
        .args(["reproduce", "--quiet", "--resume"])
        .arg(&dir)
        .arg("--jobs")
        .arg("2")
        .stdout(Stdio::null())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_resume_refuses_any_edited_field_the_reports_use_naming_line_and_field() {
    let dir = temp_dir("tampered");
    assert!(reproduce(&dir, &["--jobs", "2"]).0);
    let path = dir.join("trials.jsonl");
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    // Line 21 is a meta-training trial (after 14 baseline trials).
    let k = 20;
    assert!(lines[k]["stage"].as_str().unwrap().starts_with("train@"));
    type Edit = Box<dyn Fn(&mut Value)>;
    let flip_outcome = |v: &mut Value| {
        let o = if v["outcome"] == "TP" { "FN" } else { "TP" };
        v["outcome"] = Value::from(o);
    };
    let edits: Vec<(Edit, &str)> = vec![
        (Box::new(flip_outcome), "field `outcome`"),
        (
            Box::new(|v: &mut Value| {
                let r = v["hf"]["runtime"].as_f64().unwrap();
                v["hf"]["runtime"] = Value::from(r / 2.0);
            }),
            "field `hf.runtime`",
        ),
        (
            Box::new(|v: &mut Value| {
                let f = v["hf"]["failure"].as_bool().unwrap();
                v["hf"]["failure"] = Value::from(!f);
            }),
            "field `outcome`",
        ),
        (
            Box::new(|v: &mut Value| {
                let r = v["cost_ratio"].as_f64().unwrap();
                v["cost_ratio"] = Value::from(r * 1.5);
            }),
            "field `cost_ratio`",
        ),
        (
            Box::new(|v: &mut Value| v["budget"] = Value::from(0.2)),
            "field `budget`",
        ),
    ];
    for (edit, field) in edits {
        let mut edited = lines.clone();
        edit(&mut edited[k]);
        let body: String = edited.iter().map(|v| v.to_string() + "\n").collect();
        std::fs::write(&path, &body).unwrap();
        let (ok, _, err) = resume(&dir);
        assert!(!ok, "{field}: accepted");
        assert!(
            err.contains("trials.jsonl, line 21") && err.contains(field),
            "{field}: {err}"
        );
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            body,
            "{field}: changed"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn without_a_terminal_progress_comes_as_plain_lines_per_stage() {
    let dir = temp_dir("lines");
    let flags: Vec<&str> = TINY.iter().copied().filter(|f| *f != "--quiet").collect();
    let o = Command::new(EXE)
        .arg("reproduce")
        .arg("--out")
        .arg(&dir)
        .args(&flags)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.lines()
            .next()
            .is_some_and(|l| l.starts_with("baseline-train started: 0/14 trials")),
        "{err}"
    );
    assert!(
        err.contains("train@0.3 done: 16/16 trials,") && err.contains("failure"),
        "{err}"
    );
    // No bar drawing characters when stderr is not a terminal.
    assert!(!err.contains('\r') && !err.contains("\u{1b}["), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_edited_protocol_json_is_checked_naming_its_line_and_field_not_a_panic() {
    // A protocol.json edited to a size savme refuses for a new campaign (0 or 100,000 bins of
    // the paper's fidelity space) is refused on --resume the same way, not a panic.
    for bins in [0, 100_000] {
        let dir = temp_dir(&format!("edited-protocol-{bins}"));
        std::fs::create_dir_all(&dir).unwrap();
        let mut p = savme::campaign::Protocol::quick(
            savme::compose::SENSORS,
            vec!["lead_vehicle_brakes".into()],
            vec!["on_ramp_merge".into()],
        );
        p.fidelity_bins = bins;
        let text = serde_json::to_string_pretty(&p).unwrap();
        let line = 1 + text
            .lines()
            .position(|l| l.contains("\"fidelity_bins\""))
            .unwrap();
        std::fs::write(dir.join("protocol.json"), text).unwrap();
        std::fs::write(dir.join("trials.jsonl"), "").unwrap();
        let o = Command::new(EXE)
            .args(["reproduce", "--quiet", "--resume"])
            .arg(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{bins}: {err}");
        assert!(!err.contains("panicked"), "{bins}: {err}");
        let at = format!("protocol.json, line {line}: `fidelity_bins`: {bins} is not between 1");
        assert!(err.contains(&at), "{bins}: expected `{at}` in: {err}");
        assert_eq!(
            std::fs::read_to_string(dir.join("trials.jsonl")).unwrap(),
            ""
        );
        let _ = std::fs::remove_dir_all(dir);
    }
}

#[test]
fn the_protocol_is_the_stores_first_record_and_old_stores_without_it_still_resume() {
    let full = temp_dir("record-full");
    assert!(reproduce(&full, &["--jobs", "2"]).0);
    let expected = without_wall(trial_lines(&full));
    let text = std::fs::read_to_string(full.join("trials.jsonl")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // Line 1 is the protocol, sealed into the checksum chain; protocol.json is its copy.
    let first: Value = serde_json::from_str(lines[0]).unwrap();
    let copy: Value =
        serde_json::from_str(&std::fs::read_to_string(full.join("protocol.json")).unwrap())
            .unwrap();
    assert_eq!((&first["v"], &first["protocol"]), (&Value::from(1), &copy));
    assert!(first["c"].is_string(), "{first}");
    assert_eq!(lines.len(), 1 + TINY_TRIALS);

    // Without protocol.json, a campaign cut after 20 trials resumes from its store alone.
    let cut = temp_dir("record-cut");
    std::fs::create_dir_all(&cut).unwrap();
    std::fs::write(cut.join("trials.jsonl"), lines[..21].join("\n") + "\n").unwrap();
    let (ok, out, err) = resume(&cut);
    assert!(ok, "{err}");
    assert!(out.contains("(20 replayed from the trial store"), "{out}");
    assert_eq!(without_wall(trial_lines(&cut)), expected);
    assert!(!cut.join("protocol.json").exists());

    // A store written before the protocol was kept in it (no protocol record, no checksums)
    // resumes with its protocol.json, and stays without the record.
    let old = temp_dir("record-old");
    std::fs::create_dir_all(&old).unwrap();
    std::fs::copy(full.join("protocol.json"), old.join("protocol.json")).unwrap();
    let unsealed: String = lines[1..21]
        .iter()
        .map(|l| {
            let mut v: Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().remove("c");
            v.to_string() + "\n"
        })
        .collect();
    std::fs::write(old.join("trials.jsonl"), &unsealed).unwrap();
    let (ok, out, err) = resume(&old);
    assert!(ok, "{err}");
    assert!(out.contains("(20 replayed from the trial store"), "{out}");
    assert_eq!(without_wall(trial_lines(&old)), expected);
    let resumed = std::fs::read_to_string(old.join("trials.jsonl")).unwrap();
    assert!(resumed.starts_with(&unsealed), "the old lines changed");

    // An edited protocol record is refused, naming the line and the field.
    let bad = temp_dir("record-bad");
    std::fs::create_dir_all(&bad).unwrap();
    let mut edited: Value = first.clone();
    edited["protocol"]["fidelity_bins"] = Value::from(0);
    edited.as_object_mut().unwrap().remove("c");
    let body = std::iter::once(edited.to_string())
        .chain(lines[1..5].iter().map(|l| l.to_string()))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(bad.join("trials.jsonl"), body + "\n").unwrap();
    let (ok, _, err) = resume(&bad);
    assert!(!ok);
    assert!(
        err.contains("trials.jsonl, line 1: `protocol.fidelity_bins`: 0 is not between 1"),
        "{err}"
    );
    for d in [full, cut, old, bad] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// `--log-bins paper` (issue 39 item 4): the bundled simulator's log-scaled settings are binned
/// as the authors' code bins them — every θ of a continuous log-scaled setting in trials.jsonl
/// lies in a bin `[lo − 1 + (hi − lo + 1)^(k/n), …]`, and fidelity.md shows those bins — the
/// choice is stored in protocol.json (so a resume keeps it), and savme's bins stay the default.
#[test]
fn log_bins_paper_bins_log_settings_as_the_authors_code() {
    let dir = temp_dir("log-bins");
    let (ok, _, err) = reproduce(&dir, &["--log-bins", "paper", "--fidelity-bins", "4"]);
    assert!(ok, "{err}");
    let protocol: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("protocol.json")).unwrap()).unwrap();
    assert_eq!(protocol["log_bins"], "paper");
    // camera_near_clipping_m on [0.2, 20] in 4 bins: the authors' edges.
    let edges: Vec<f64> = (0..=4)
        .map(|k| 0.2 - 1.0 + 20.8f64.powf(f64::from(k) / 4.0))
        .collect();
    let fidelity = std::fs::read_to_string(dir.join("fidelity.md")).unwrap();
    let row = fidelity
        .lines()
        .find(|l| l.starts_with("| camera_near_clipping_m"))
        .unwrap();
    assert!(
        edges
            .windows(2)
            .any(|w| row.contains(&format!("[{}, {}]", shown(w[0]), shown(w[1])))),
        "{row} names none of the authors' bins {edges:?}"
    );
    let mut seen = 0;
    for line in trial_lines(&dir) {
        let Some(x) = line["theta_lf"]["camera_near_clipping_m"].as_f64() else {
            continue;
        };
        assert!((0.2..=20.0).contains(&x), "{x}");
        seen += 1;
    }
    assert!(seen > 0, "no θ with camera_near_clipping_m in trials.jsonl");
    // The default: savme's bins (equal ratios), not written into protocol.json.
    let plain = temp_dir("log-bins-savme");
    assert!(reproduce(&plain, &["--fidelity-bins", "4"]).0);
    let text = std::fs::read_to_string(plain.join("protocol.json")).unwrap();
    assert!(!text.contains("log_bins"), "{text}");
    for d in [dir, plain] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// A bin edge as fidelity.md prints it (three significant digits).
fn shown(x: f64) -> String {
    let digits = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}

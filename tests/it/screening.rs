//! LF screening with HF confirmation end to end (`savme reproduce --screen-iterations`): HF runs
//! exactly for LF failures and the audit sample, the report agrees with the trial lines, the
//! stage is independent of the jobs and resumes, and an edited screening line is refused.
use crate::common;

use common::{resume, savme, temp_dir, trial_lines, without_wall};
use serde_json::Value;
use std::path::Path;

const ARGS: &[&str] = &[
    "--perception",
    "ideal",
    "--budgets",
    "0.3",
    "--iterations",
    "60",
    "--eval-iterations",
    "30",
    "--test-iterations",
    "10",
    "--baseline-iterations",
    "60",
    "--baseline-test-iterations",
    "10",
    "--screen-iterations",
    "150",
    "--audit-fraction",
    "0.25",
    "--cost",
    "work",
    "--seed",
    "3",
    "--quiet",
];

fn reproduce(out: &Path, jobs: &str) -> (bool, String, String) {
    let out = out.display().to_string();
    let mut a = vec!["reproduce", "--out", &out, "--jobs", jobs];
    a.extend(ARGS);
    savme(&a)
}

// Long because it recomputes the screening report from the trial lines: one run, many checks.
#[test]
fn screening_confirms_every_lf_failure_audits_a_fraction_and_reports_what_it_ran() {
    let dir = temp_dir("e2e");
    let (ok, out, err) = reproduce(&dir, "2");
    assert!(ok, "{err}");
    let all = trial_lines(&dir);
    let screen: Vec<&Value> = all.iter().filter(|v| v["stage"] == "screen@0.3").collect();
    assert_eq!(screen.len(), 150);
    // θ_LF is the evaluation's θ*.
    let eval: Vec<&Value> = all
        .iter()
        .filter(|v| v["stage"] == "evaluate@0.3")
        .collect();
    assert!(screen.iter().all(|v| v["theta_lf"] == eval[0]["theta_lf"]));
    let (mut confirmed, mut lf_failures, mut audited, mut misses, mut cost) = (0, 0, 0, 0, 0.0);
    for v in &screen {
        let lf_failed = v["lf"]["failure"] == true;
        let kind = v["screen"].as_str().unwrap();
        // HF ran exactly for LF failures (confirm) and audited passes.
        assert_eq!(v["hf"].is_null(), kind == "pass", "{v}");
        assert_eq!(lf_failed, kind == "confirm", "{v}");
        cost += v["lf"]["runtime"].as_f64().unwrap() + v["hf"]["runtime"].as_f64().unwrap_or(0.0);
        let hf_failed = v["hf"]["failure"] == true;
        match kind {
            "confirm" => {
                lf_failures += 1;
                confirmed += u64::from(hf_failed);
            }
            "audit" => {
                audited += 1;
                misses += u64::from(hf_failed);
            }
            _ => {}
        }
    }
    // α = 0.25 of the LF passes, within a binomial margin (± 4 standard deviations).
    let passes = 150 - lf_failures;
    let expected = 0.25 * passes as f64;
    let sd = (passes as f64 * 0.25 * 0.75).sqrt();
    assert!(
        (audited as f64 - expected).abs() < 4.0 * sd,
        "{audited} audited of {passes} passes"
    );
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let s = &summary["report"]["budgets"][0]["screening"];
    assert_eq!(s["counts"]["confirmed"], confirmed);
    assert_eq!(s["counts"]["lf_failures"], lf_failures);
    assert_eq!(s["counts"]["audited"], audited);
    assert_eq!(s["counts"]["audit_misses"], misses);
    let per = s["confirmed_per_runtime"].as_f64().unwrap();
    assert!((per - confirmed as f64 / cost).abs() < 1e-12 * per.max(1.0));
    // Against the paired evaluation: HF failures per (HF + LF) cost.
    let eval_cost: f64 = eval
        .iter()
        .map(|v| v["hf"]["runtime"].as_f64().unwrap() + v["lf"]["runtime"].as_f64().unwrap())
        .sum();
    let eval_failures = eval.iter().filter(|v| v["hf"]["failure"] == true).count();
    let paired = eval_failures as f64 / eval_cost;
    let vs = s["vs_paired"].as_f64().unwrap();
    assert!((vs - per / paired).abs() < 1e-9 * vs, "{vs}");
    // The miss rate carries its Wilson interval, around the observed rate.
    let miss = &s["miss_rate"];
    assert_eq!(miss["n"], audited);
    assert!(miss["lo"].as_f64().unwrap() <= miss["mean"].as_f64().unwrap());
    assert!(miss["hi"].as_f64().unwrap() >= miss["mean"].as_f64().unwrap());
    assert!(
        out.contains("LF screening with HF confirmation, C_budget = 0.3"),
        "{out}"
    );
    assert!(out.contains("LF screening, HF confirms (TP)"), "{out}");
    // `savme failures` lists the stage's HF failures: confirmed ones and audit misses.
    let d = dir.display().to_string();
    let (ok, listed, err) = savme(&["failures", &d, "--stage", "screen@0.3", "--json"]);
    assert!(ok, "{err}");
    let listed: Vec<Value> = listed
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(listed.len() as u64, confirmed + misses);
    let hf_failed: Vec<&&Value> = screen
        .iter()
        .filter(|v| v["hf"]["failure"] == true)
        .collect();
    for (f, v) in listed.iter().zip(hf_failed) {
        assert_eq!((&f["index"], &f["phi"]), (&v["index"], &v["phi"]));
        assert_eq!(f["lf_failure"], v["lf"]["failure"]);
        // Idealised perception: replayed by `savme simulate --perception ideal`.
        let replay = f["replay"].as_str().unwrap_or_default();
        assert!(replay.ends_with(" --perception ideal"), "{f}");
    }

    // The same campaign with one job, and a resumed one cut inside the screening stage.
    let one = temp_dir("one");
    assert!(reproduce(&one, "1").0);
    assert_eq!(without_wall(trial_lines(&one)), without_wall(all.clone()));
    let cut = temp_dir("cut");
    std::fs::create_dir_all(&cut).unwrap();
    std::fs::copy(dir.join("protocol.json"), cut.join("protocol.json")).unwrap();
    let first = all.iter().position(|v| v["stage"] == "screen@0.3").unwrap();
    let text: Vec<&str> = std::fs::read_to_string(dir.join("trials.jsonl"))
        .unwrap()
        .leak()
        .lines()
        .collect();
    std::fs::write(
        cut.join("trials.jsonl"),
        text[..first + 40].join("\n") + "\n",
    )
    .unwrap();
    // Without --quiet, progress lines go to the (piped) standard error: the screening stage's
    // trials, replayed and run, count as done, their HF failures (confirmed failures and
    // audit misses) as failures.
    let (ok, _, err) = savme(&["reproduce", "--resume", &cut.display().to_string()]);
    assert!(ok, "{err}");
    let done = format!(
        "screen@0.3 done: 150/150 trials, {} failures (HF)",
        confirmed + misses
    );
    assert!(err.contains(&done), "{done} not in {err}");
    assert_eq!(without_wall(trial_lines(&cut)), without_wall(all.clone()));

    // A screening line edited to skip its HF run is refused, naming the line and field.
    let edited = temp_dir("edited");
    std::fs::create_dir_all(&edited).unwrap();
    std::fs::copy(dir.join("protocol.json"), edited.join("protocol.json")).unwrap();
    let k = all
        .iter()
        .position(|v| v["screen"] == "audit")
        .expect("an audited trial");
    let mut bad: Vec<String> = text.iter().map(|s| s.to_string()).collect();
    // Trial k is on line k + 2: the store begins with the protocol record.
    let k = k + 1;
    let mut v: Value = serde_json::from_str(&bad[k]).unwrap();
    assert_eq!(v["screen"], "audit");
    v["screen"] = "pass".into();
    v["hf"] = Value::Null;
    v["outcome"] = Value::Null;
    bad[k] = v.to_string();
    std::fs::write(edited.join("trials.jsonl"), bad.join("\n") + "\n").unwrap();
    let (ok, _, err) = resume(&edited);
    assert!(!ok);
    assert!(
        err.contains(&format!("line {}", k + 1)) && err.contains("field `screen`"),
        "{err}"
    );
    for d in [dir, one, cut, edited] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn bad_screening_values_are_refused_naming_the_flag() {
    let dir = temp_dir("bad");
    for (flag, value, message) in [
        (
            "--audit-fraction",
            "1.5",
            "`audit_fraction`: 1.5 is outside [0, 1]",
        ),
        ("--audit-fraction", "NaN", "`audit_fraction`"),
        ("--screen-iterations", "200000000", "`screen_iterations`"),
    ] {
        let d = dir.display().to_string();
        let (ok, _, err) = savme(&["reproduce", "--out", &d, "--quiet", flag, value]);
        assert!(!ok, "{flag} {value} accepted");
        assert!(err.contains(message), "{flag} {value}: {err}");
        assert!(!dir.exists());
    }
}

/// `--deployment adaptive`: the search is the same trials as a frozen deployment's, the
/// evaluation credits the φ search and the screening draws other φ; the protocol stores it,
/// a cut store resumes to the same lines, and an exploiting deployment without the elite
/// search is refused naming the value.
#[test]
fn an_adaptive_deployment_keeps_the_search_learns_from_its_results_and_resumes() {
    let elite = ["--search", "elite", "--window", "1"];
    let run = |name: &str, deployment: &str| {
        let dir = temp_dir(name);
        let out = dir.display().to_string();
        let mut a = vec!["reproduce", "--out", &out, "--jobs", "2"];
        a.extend(ARGS);
        a.extend(elite);
        a.extend(["--deployment", deployment]);
        let (ok, _, err) = savme(&a);
        assert!(ok, "{deployment}: {err}");
        dir
    };
    let (frozen, adaptive) = (run("frozen", "frozen"), run("adaptive", "adaptive"));
    let protocol = |d: &Path| -> Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("protocol.json")).unwrap()).unwrap()
    };
    assert_eq!(protocol(&adaptive)["deployment"], "adaptive");
    assert!(
        protocol(&frozen).get("deployment").is_none(),
        "frozen is the default"
    );
    let stage = |lines: &[Value], s: &str| -> Vec<Value> {
        lines.iter().filter(|v| v["stage"] == s).cloned().collect()
    };
    let (f, a) = (trial_lines(&frozen), trial_lines(&adaptive));
    assert_eq!(
        without_wall(stage(&f, "train@0.3")),
        without_wall(stage(&a, "train@0.3")),
        "the deployment changed the search"
    );
    let credited = |lines: &[Value]| {
        stage(lines, "evaluate@0.3")
            .iter()
            .filter(|v| !v["credit"]["scenario"].is_null())
            .count()
    };
    assert_eq!(credited(&f), 0);
    assert_eq!(credited(&a), 30);
    let phis = |lines: &[Value]| -> Vec<Value> {
        stage(lines, "screen@0.3")
            .iter()
            .map(|v| v["phi"].clone())
            .collect()
    };
    assert_ne!(phis(&f), phis(&a));
    // Cut inside the screening stage and resume: the same lines.
    let text = std::fs::read_to_string(adaptive.join("trials.jsonl")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let cut = lines.len() - 60;
    std::fs::write(
        adaptive.join("trials.jsonl"),
        lines[..cut].join("\n") + "\n",
    )
    .unwrap();
    let (ok, _, err) = resume(&adaptive);
    assert!(ok, "{err}");
    assert_eq!(without_wall(trial_lines(&adaptive)), without_wall(a));
    // Exploiting needs the elite search.
    let bad = temp_dir("exploit-bins");
    let out = bad.display().to_string();
    let (ok, _, err) = savme(&[
        "reproduce",
        "--out",
        &out,
        "--quiet",
        "--deployment",
        "exploit",
    ]);
    assert!(
        !ok && err.contains("`deployment`") && err.contains("search = elite"),
        "{err}"
    );
    assert!(!bad.exists());
    for d in [frozen, adaptive] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// `--screen-lf where-it-pays`: where the deployed proposal fails so often that an LF run
/// saves less than it costs, trials run HF directly (a `direct` line without an LF run); the
/// decisions replay exactly on resume, an edited decision is refused naming the field, and the
/// value is refused without a screening stage.
#[test]
fn screening_runs_hf_directly_where_the_lf_run_does_not_pay_and_resumes() {
    let dir = temp_dir("direct");
    let out = dir.display().to_string();
    let mut a = vec!["reproduce", "--out", &out, "--jobs", "2"];
    a.extend(ARGS);
    a.extend(["--search", "elite", "--deployment", "exploit"]);
    a.extend(["--screen-lf", "where-it-pays"]);
    let (ok, _, err) = savme(&a);
    assert!(ok, "{err}");
    let all = trial_lines(&dir);
    let screen: Vec<&Value> = all.iter().filter(|v| v["stage"] == "screen@0.3").collect();
    assert_eq!(screen.len(), 150);
    let direct: Vec<&&Value> = screen.iter().filter(|v| v["screen"] == "direct").collect();
    assert!(
        !direct.is_empty() && direct.len() < 150,
        "{} direct",
        direct.len()
    );
    for v in &direct {
        assert!(v.get("lf").is_none() && v["hf"].is_object(), "{v}");
    }
    // Each scenario screens its first trials (the warm-up measures the LF run).
    let first = |name: &Value| screen.iter().position(|v| v["scenario"] == *name).unwrap();
    for v in &direct {
        assert!(screen.iter().position(|w| *w == **v).unwrap() > first(&v["scenario"]) + 9);
    }
    // The report counts the direct trials' failures with the confirmed ones (and the audit's
    // misses apart).
    let found = screen.iter().filter(|v| v["hf"]["failure"] == true).count();
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let text = report.to_string();
    assert!(text.contains("\"direct_found\""), "{text}");
    let counts = &report["report"]["budgets"][0]["screening"]["counts"];
    let reported = ["confirmed", "direct_found", "margin_found", "audit_misses"]
        .iter()
        .map(|k| counts[k].as_u64().unwrap())
        .sum::<u64>();
    assert_eq!(reported as usize, found);
    // Cut inside the screening stage and resume: the same decisions and lines.
    let text = std::fs::read_to_string(dir.join("trials.jsonl")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    std::fs::write(
        dir.join("trials.jsonl"),
        lines[..lines.len() - 50].join("\n") + "\n",
    )
    .unwrap();
    let (ok, _, err) = resume(&dir);
    assert!(ok, "{err}");
    assert_eq!(without_wall(trial_lines(&dir)), without_wall(all.clone()));
    // A direct line edited into a screened confirmation is refused, naming its line and field.
    let k = lines
        .iter()
        .position(|l| l.contains(r#""screen":"direct""#))
        .unwrap();
    let mut bad: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    bad[k] = bad[k].replace(r#""screen":"direct""#, r#""screen":"confirm""#);
    std::fs::write(dir.join("trials.jsonl"), bad.join("\n") + "\n").unwrap();
    let (ok, _, err) = resume(&dir);
    assert!(!ok);
    assert!(
        err.contains(&format!("line {}", k + 1)) && err.contains("field `screen`"),
        "{err}"
    );
    // Without a screening stage the value would do nothing.
    let none = temp_dir("direct-none");
    let out = none.display().to_string();
    let (ok, _, err) = savme(&[
        "reproduce",
        "--out",
        &out,
        "--quiet",
        "--screen-lf",
        "where-it-pays",
    ]);
    assert!(
        !ok && err.contains("`screen_lf`") && err.contains("screen_iterations"),
        "{err}"
    );
    assert!(!none.exists());
    let _ = std::fs::remove_dir_all(dir);
}

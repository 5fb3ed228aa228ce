//! What savme promises a user whose directory holds links, and whose input holds extreme
//! values, checked on the real binary (docs/RELIABILITY.md).
use crate::common;

use common::{made_dir, run, send, temp_dir, trial_lines, TINY_PROTOCOL};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// A decoy file holding text no savme process writes.
fn decoy(dir: &Path) -> PathBuf {
    let path = dir.join("decoy.txt");
    std::fs::write(&path, "someone else's file\n").unwrap();
    path
}

fn assert_untouched(decoy: &Path) {
    assert_eq!(
        std::fs::read_to_string(decoy).unwrap(),
        "someone else's file\n",
        "{} was written through a link",
        decoy.display()
    );
}

#[cfg(unix)]
fn link(target: &Path, at: &Path) {
    let _ = std::fs::remove_file(at);
    std::os::unix::fs::symlink(target, at).unwrap();
}

fn example_config(dir: &Path) -> PathBuf {
    let out = Command::new(common::EXE)
        .arg("example-config")
        .output()
        .unwrap();
    assert!(out.status.success());
    let path = dir.join("kernel.json");
    std::fs::write(&path, out.stdout).unwrap();
    path
}

/// `savme serve ARGS` with stdin closed at once: exit code and stderr.
fn serve(args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(common::EXE)
        .arg("serve")
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[cfg(unix)]
#[test]
fn a_served_journal_or_its_lock_that_is_a_link_is_refused_and_the_target_unchanged() {
    let dir = made_dir("serve-links");
    let config = example_config(&dir);
    let config = config.to_str().unwrap();
    let decoy = decoy(&dir);
    let journal = dir.join("jj");
    let j = journal.to_str().unwrap();
    // The lock file beside the journal is a link onto the decoy.
    let lock = dir.join("jj.lock");
    link(&decoy, &lock);
    let (code, err) = serve(&["--config", config, "--journal", j]);
    assert_ne!(code, Some(0), "{err}");
    assert!(
        err.contains(&lock.display().to_string()) && err.contains("symbolic link"),
        "{err}"
    );
    assert_untouched(&decoy);
    assert!(!journal.exists(), "nothing was created");
    // The journal itself a link (onto the decoy, or dangling).
    std::fs::remove_file(&lock).unwrap();
    for target in [decoy.clone(), dir.join("elsewhere.jsonl")] {
        link(&target, &journal);
        let (code, err) = serve(&["--config", config, "--journal", j]);
        assert_ne!(code, Some(0), "{err}");
        assert!(err.contains(j) && err.contains("symbolic link"), "{err}");
        assert_untouched(&decoy);
        assert!(!dir.join("elsewhere.jsonl").exists());
    }
    // A lock file or a journal of someone else's (not written by savme) is not truncated.
    std::fs::remove_file(&journal).unwrap();
    std::fs::copy(&decoy, &lock).unwrap();
    let (code, err) = serve(&["--config", config, "--journal", j]);
    assert!(code != Some(0) && err.contains("did not write"), "{err}");
    assert_untouched(&lock);
    std::fs::remove_file(&lock).unwrap();
    std::fs::write(&journal, "notes without a newline").unwrap();
    let (code, err) = serve(&["--config", config, "--journal", j]);
    assert!(code != Some(0) && err.contains("did not write"), "{err}");
    assert_eq!(
        std::fs::read_to_string(&journal).unwrap(),
        "notes without a newline"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

fn reproduce(dir: &Path) -> (Option<i32>, String) {
    let mut args = vec!["reproduce".to_string(), "--out".into()];
    args.push(dir.display().to_string());
    args.extend(TINY_PROTOCOL.iter().map(|s| s.to_string()));
    let (code, _, err) = run(&args);
    (code, err)
}

fn resume(dir: &Path) -> (Option<i32>, String) {
    let (code, _, err) = run(&[
        "reproduce".as_ref(),
        "--quiet".as_ref(),
        "--resume".as_ref(),
        dir.as_os_str(),
    ]);
    (code, err)
}

#[cfg(unix)]
#[test]
fn a_campaign_never_writes_through_a_link_in_its_directory() {
    let home = made_dir("campaign-links");
    let decoy = decoy(&home);
    // A new campaign into a directory whose lock file is a planted link.
    let fresh = home.join("fresh");
    std::fs::create_dir_all(&fresh).unwrap();
    link(&decoy, &fresh.join("trials.jsonl.lock"));
    let (code, err) = reproduce(&fresh);
    assert_ne!(code, Some(0), "{err}");
    assert!(
        err.contains("trials.jsonl.lock") && err.contains("symbolic link"),
        "{err}"
    );
    assert_untouched(&decoy);
    // A finished campaign, then each file it writes replaced by a link onto the decoy: the
    // resume is refused naming the file, and the decoy is unchanged.
    let dir = temp_dir("campaign-links-done");
    let (code, err) = reproduce(&dir);
    assert_eq!(code, Some(0), "{err}");
    for name in [
        "trials.jsonl.lock",
        "trials.jsonl",
        "table.md",
        "summary.json",
        "breakeven.png",
    ] {
        let path = dir.join(name);
        let kept = dir.join(format!("{name}.kept"));
        std::fs::rename(&path, &kept).unwrap();
        let copy = home.join(name);
        std::fs::copy(&kept, &copy).unwrap();
        link(
            if name == "trials.jsonl" {
                &copy
            } else {
                &decoy
            },
            &path,
        );
        let (code, err) = resume(&dir);
        assert_ne!(code, Some(0), "{name}: {err}");
        assert!(
            err.contains(&path.display().to_string()) && err.contains("symbolic link"),
            "{name}: {err}"
        );
        assert_untouched(&decoy);
        assert_eq!(std::fs::read(&copy).unwrap(), std::fs::read(&kept).unwrap());
        std::fs::remove_file(&path).unwrap();
        std::fs::rename(&kept, &path).unwrap();
    }
    let (code, err) = resume(&dir);
    assert_eq!(code, Some(0), "{err}");
    let _ = std::fs::remove_dir_all(&home);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Asserts that a command was refused (exit status 1, a runtime refusal as for a campaign's
/// files) with a message naming `path` and `why`.
fn assert_refused(code: Option<i32>, err: &str, path: &Path, why: &str) {
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(&path.display().to_string()) && err.contains(why),
        "the error names {} and says it {why}: {err}",
        path.display()
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[cfg(unix)]
#[test]
fn fmu_pack_never_writes_through_a_symbolic_or_hard_link() {
    let dir = made_dir("pack-links");
    let decoy = decoy(&dir);
    let out = dir.join("savme-sim.fmu");
    let pack = |out: &Path| {
        let (code, _, err) = run(&["fmu", "pack", "--out", out.to_str().unwrap()]);
        (code, err)
    };
    // A symbolic link at --out onto the decoy.
    link(&decoy, &out);
    let (code, err) = pack(&out);
    assert_refused(code, &err, &out, "symbolic link");
    assert_untouched(&decoy);
    // A hard link: the decoy under a second name.
    std::fs::remove_file(&out).unwrap();
    std::fs::hard_link(&decoy, &out).unwrap();
    let (code, err) = pack(&out);
    assert_refused(code, &err, &out, "has 2 names (hard links)");
    assert_untouched(&decoy);
    // A regular file of its own is replaced by the archive, as before.
    std::fs::remove_file(&out).unwrap();
    std::fs::write(&out, "an older pack").unwrap();
    let (code, err) = pack(&out);
    assert_eq!(code, Some(0), "{err}");
    assert!(std::fs::read(&out).unwrap().starts_with(b"PK"), "a zip");
    assert_untouched(&decoy);
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(unix)]
#[test]
fn man_out_never_writes_a_page_through_a_link() {
    let dir = made_dir("man-links");
    let decoy = decoy(&dir);
    let pages = dir.join("man1");
    std::fs::create_dir_all(&pages).unwrap();
    let man = || {
        let (code, _, err) = run(&["man", "--out", pages.to_str().unwrap()]);
        (code, err)
    };
    // A subcommand's page is a symbolic link onto the decoy, then a hard link to it.
    let page = pages.join("savme-fmu-pack.1");
    link(&decoy, &page);
    let (code, err) = man();
    assert_refused(code, &err, &page, "symbolic link");
    assert_untouched(&decoy);
    std::fs::remove_file(&page).unwrap();
    std::fs::hard_link(&decoy, &page).unwrap();
    let (code, err) = man();
    assert_refused(code, &err, &page, "has 2 names (hard links)");
    assert_untouched(&decoy);
    // Without the link every page is written, savme.1 among them.
    std::fs::remove_file(&page).unwrap();
    let (code, err) = man();
    assert_eq!(code, Some(0), "{err}");
    for name in ["savme.1", "savme-fmu-pack.1", "savme-run.1"] {
        let text = std::fs::read_to_string(pages.join(name)).unwrap();
        assert!(text.starts_with(".ie"), "{name}: a man page");
    }
    // The directory itself a dangling link: named, nothing created where it points.
    let gone = dir.join("gone");
    let dangling = dir.join("pages");
    link(&gone, &dangling);
    let (code, _, err) = run(&["man", "--out", dangling.to_str().unwrap()]);
    assert_refused(code, &err, &dangling, "which does not exist");
    assert!(!gone.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Sets `lo`/`hi` of every variable named `name` in a JSON document.
fn set_range(v: &mut Value, name: &str, lo: f64, hi: f64) -> usize {
    match v {
        Value::Object(m) if m.get("name").and_then(Value::as_str) == Some(name) => {
            let mut set = 0;
            for (key, x) in [("lo", lo), ("hi", hi)] {
                if let Some(slot) = find_key(m, key) {
                    *slot = x.into();
                    set += 1;
                }
            }
            usize::from(set == 2)
        }
        Value::Object(m) => m.values_mut().map(|x| set_range(x, name, lo, hi)).sum(),
        Value::Array(a) => a.iter_mut().map(|x| set_range(x, name, lo, hi)).sum(),
        _ => 0,
    }
}

fn find_key<'a>(m: &'a mut serde_json::Map<String, Value>, key: &str) -> Option<&'a mut Value> {
    if m.contains_key(key) {
        return m.get_mut(key);
    }
    m.values_mut()
        .filter_map(Value::as_object_mut)
        .find_map(|inner| find_key(inner, key))
}

#[test]
fn an_extreme_but_finite_range_is_refused_by_serve_naming_the_variable() {
    let dir = made_dir("serve-extreme");
    let config = example_config(&dir);
    let mut json: Value = serde_json::from_slice(&std::fs::read(&config).unwrap()).unwrap();
    assert!(
        set_range(&mut json, "ego_speed", -1e308, 1e308) > 0,
        "{json}"
    );
    std::fs::write(&config, json.to_string()).unwrap();
    let journal = dir.join("j.jsonl");
    let (code, err) = serve(&[
        "--config",
        config.to_str().unwrap(),
        "--journal",
        journal.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("kernel.json") && err.contains("`ego_speed`") && err.contains("too wide"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Starts `savme ARGS` with stderr captured and waits until `file` has `lines` lines.
fn start_and_wait(args: &[String], file: &Path, lines: usize) -> std::process::Child {
    let mut child = Command::new(common::EXE)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while std::fs::read_to_string(file).map_or(0, |s| s.lines().count()) < lines {
        assert!(
            start.elapsed() < std::time::Duration::from_secs(120),
            "no progress"
        );
        assert!(child.try_wait().unwrap().is_none(), "finished too early");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child
}

fn stopped(child: std::process::Child) -> (Option<i32>, String) {
    let o = child.wait_with_output().unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn line_count(file: &Path) -> usize {
    std::fs::read_to_string(file).unwrap().lines().count()
}

#[cfg(unix)]
#[test]
fn sigint_and_sigterm_stop_a_campaign_and_an_estimate_between_runs_and_say_how_to_resume() {
    let dir = temp_dir("signals-campaign");
    let mut args = vec!["reproduce".to_string(), "--out".into()];
    args.push(dir.display().to_string());
    // Not --quiet: the progress lines say the stage stopped.
    let tiny = TINY_PROTOCOL.iter().filter(|&&s| s != "--quiet");
    args.extend(tiny.map(|s| s.to_string()));
    args.extend(["--jobs".to_string(), "2".into()]);
    let trials = dir.join("trials.jsonl");
    // SIGTERM (SIGINT: tests/it/reproduce.rs): stops between runs, exit 143, the resume command.
    let child = start_and_wait(&args, &trials, 10);
    send(&child, "TERM");
    let (code, err) = stopped(child);
    assert_eq!(code, Some(143), "{err}");
    assert!(
        err.contains("SIGTERM: stopping after the runs in flight"),
        "{err}"
    );
    let hint = format!("continue with --resume {}", dir.display());
    assert!(err.contains(&hint), "{err}");
    let stopped_stage = err
        .lines()
        .any(|l| l.contains(" stopped: ") && l.contains(" trials, "));
    assert!(stopped_stage, "a stage cut short says so: {err}");
    let before = line_count(&trials);
    assert!(before < 60, "the campaign finished before the signal");
    let (code, err) = resume(&dir);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(line_count(&trials), 1 + 60, "no trial lost or repeated");
    // The estimate on the finished campaign, stopped by each signal, then resumed.
    for (signal, status) in [("INT", 130), ("TERM", 143)] {
        let out = dir.join(format!("estimate-{signal}"));
        let o = out.display().to_string();
        let c = dir.display().to_string();
        let mut args = vec![
            "estimate",
            &c,
            "--out",
            &o,
            "--no-target",
            "--max-runs",
            "40",
        ];
        args.extend(["--jobs", "1"]);
        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        let lines = out.join("trials.jsonl");
        let child = start_and_wait(&args, &lines, 3);
        send(&child, signal);
        let (code, err) = stopped(child);
        assert_eq!(code, Some(status), "{signal}: {err}");
        let hint = format!("continue with savme estimate {c} --out {o} --resume");
        assert!(
            err.contains(&hint) && err.contains("every one stored"),
            "{signal}: {err}"
        );
        let told = line_count(&lines);
        assert!(
            told < 40,
            "{signal}: the estimate finished before the signal"
        );
        let (code, _, err) = run(&["estimate", &c, "--out", &o, "--resume", "--quiet"]);
        assert_eq!(code, Some(0), "{signal}: {err}");
        assert_eq!(line_count(&lines), 40, "{signal}: no run lost or repeated");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The command after `continue with ` at the end of a line of `err`, as words.
fn printed_command(err: &str) -> Vec<String> {
    let line = err
        .lines()
        .find_map(|l| l.split_once("continue with ").map(|(_, c)| c.to_string()))
        .unwrap_or_else(|| panic!("no `continue with` in: {err}"));
    line.split_whitespace().map(str::to_string).collect()
}

#[cfg(unix)]
#[test]
fn a_run_stopped_in_its_campaign_prints_the_whole_command_that_resumes_it() {
    let dir = made_dir("run-hint");
    let fmu = dir.join("savme-sim.fmu");
    let (code, _, err) = run(&["fmu", "pack", "--out", fmu.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    let config = dir.join("campaign.toml");
    let body = include_str!("../fixtures/fmu-tiny-campaign.toml");
    std::fs::write(&config, body.replace("FMU", fmu.to_str().unwrap())).unwrap();
    let out = dir.join("out");
    let args: Vec<String> = [
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--method",
        "paper",
        "--jobs",
        "1",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let trials = out.join("trials.jsonl");
    let child = start_and_wait(&args, &trials, 3);
    send(&child, "INT");
    let (code, err) = stopped(child);
    assert_eq!(code, Some(130), "{err}");
    let told = line_count(&trials);
    let all = 1 + 6 + 8 + 4 + 4 + 2 * 4;
    assert!(told < all, "the campaign finished before the signal");
    // The printed command, run as printed, resumes the campaign to its end.
    let words = printed_command(&err);
    assert_eq!(words[..2], ["savme", "run"], "a whole command: {err}");
    let (code, _, resumed) = run(&words[1..]);
    assert_eq!(code, Some(0), "{words:?}: {resumed}");
    assert_eq!(line_count(&trials), all, "no trial lost or repeated");
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(unix)]
#[test]
fn a_second_signal_quits_at_once_and_still_prints_the_resume_command() {
    let dir = temp_dir("signals-twice");
    let d = dir.display().to_string();
    let args: Vec<String> = ["toy", "--out", &d, "--sleep-ms", "4000", "--jobs", "1"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    // The protocol exists once the campaign runs; its first run then sleeps 4 s.
    let child = start_and_wait(&args, &dir.join("protocol.json"), 1);
    std::thread::sleep(std::time::Duration::from_millis(300));
    send(&child, "INT");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let started = std::time::Instant::now();
    send(&child, "TERM");
    let (code, err) = stopped(child);
    assert!(
        started.elapsed() < std::time::Duration::from_secs(3),
        "{err}"
    );
    assert_eq!(code, Some(143), "{err}");
    assert!(
        err.contains("quit at once") && err.contains(&format!("continue with --resume {d}")),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_that_would_never_end_is_refused_naming_the_flag_and_its_maximum() {
    let dir = temp_dir("never-ends");
    let d = dir.display().to_string();
    let (code, _, err) = run(&["toy", "--out", &d, "--sleep-ms", "18446744073709551615"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--sleep-ms") && err.contains("3600000 ms (one hour)"),
        "{err}"
    );
    assert!(!dir.exists(), "nothing created");
}

#[test]
fn jobs_zero_is_the_same_usage_error_for_every_command() {
    let dir = temp_dir("jobs-zero");
    let d = dir.display().to_string();
    for args in [
        vec!["estimate", &d, "--jobs", "0"],
        vec!["reproduce", "--out", &d, "--jobs", "0"],
        vec!["toy", "--out", &d, "--jobs", "0"],
        vec![
            "worker",
            "--storage",
            "postgresql://localhost/x",
            "--jobs",
            "0",
        ],
    ] {
        let (code, _, err) = run(&args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(
            err.contains("'0' for '--jobs <JOBS>': must be at least 1"),
            "{args:?}: {err}"
        );
    }
    assert!(!dir.exists());
}

#[test]
fn a_value_that_is_no_number_is_named_as_such_not_as_outside_the_variable() {
    let phi = "ego_speed=abc,intruder_speed=10,time_offset=0";
    let (code, _, err) = run(&["simulate", "--scenario", "1", "--phi", phi]);
    assert_ne!(code, Some(0), "{err}");
    assert!(
        err.contains("value abc of variable `ego_speed` is not a number")
            && !err.contains("outside"),
        "{err}"
    );
}

#[cfg(unix)]
#[test]
fn a_dangling_output_link_and_a_missing_journal_directory_are_named() {
    let home = made_dir("dangling");
    let out = home.join("out");
    let gone = home.join("gone");
    link(&gone, &out);
    let (code, err) = reproduce(&out);
    assert_ne!(code, Some(0), "{err}");
    assert!(
        err.contains(&out.display().to_string())
            && err.contains(&format!(
                "is a symbolic link to {}, which does not exist",
                gone.display()
            )),
        "{err}"
    );
    assert!(!err.contains("os error 17") && !gone.exists(), "{err}");
    let journal = home.join("missing").join("j");
    let (code, err) = serve(&["--journal", journal.to_str().unwrap()]);
    assert_ne!(code, Some(0), "{err}");
    let dir = home.join("missing").display().to_string();
    assert!(
        err.contains(&format!("its directory {dir} does not exist")) && !err.contains("j.lock"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&home);
}

#[test]
fn an_audit_fraction_without_screening_is_refused_before_anything_runs() {
    let dir = temp_dir("audit-alone");
    let d = dir.display().to_string();
    let (code, _, err) = run(&["toy", "--out", &d, "--audit-fraction", "0.5"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("`audit_fraction`: 0.5 would do nothing") && err.contains("screen_iterations"),
        "{err}"
    );
    assert!(!dir.exists(), "nothing created");
}

#[test]
fn extreme_budgets_and_strengths_make_compact_stage_names() {
    let dir = temp_dir("tiny-budget");
    let d = dir.display().to_string();
    let mut args = vec!["toy", "--out", &d, "--jobs", "1"];
    args.extend(TINY_PROTOCOL.iter().filter(|&&s| s != "0.3"));
    let budgets = args.iter().position(|&s| s == "--budgets").unwrap();
    args.insert(budgets + 1, "1e-300");
    args.extend(["--prior-strengths", "0,1e300"]);
    let (code, _, err) = run(&args);
    assert_eq!(code, Some(0), "{err}");
    let stages: std::collections::BTreeSet<String> = trial_lines(&dir)
        .iter()
        .map(|t| t["stage"].as_str().unwrap().to_string())
        .collect();
    assert!(stages.contains("train@1e-300"), "{stages:?}");
    assert!(stages.contains("test-learned-s1e300@1e-300"), "{stages:?}");
    assert!(stages.iter().all(|s| s.len() < 40), "{stages:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Line `n` (1-based) of `file` with `from` replaced by `to` (the rest of the file as is).
fn edit_line(file: &Path, n: usize, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    assert!(lines[n - 1].contains(from), "line {n}: {}", lines[n - 1]);
    lines[n - 1] = lines[n - 1].replacen(from, to, 1);
    let edited = lines.join("\n") + "\n";
    std::fs::write(file, &edited).unwrap();
    edited
}

#[test]
fn an_edited_told_line_is_refused_on_resume_naming_it_and_a_torn_tail_still_recovers() {
    let dir = temp_dir("edited-store");
    let (code, err) = reproduce(&dir);
    assert_eq!(code, Some(0), "{err}");
    let trials = dir.join("trials.jsonl");
    let good = std::fs::read_to_string(&trials).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    // A baseline trial's HF failure flag, flipped in place (its line keeps its checksum): no
    // field tells it apart from a real trial, the checksum does.
    // (Not line 1: without its checksum, a first line reads as one an earlier savme wrote, and
    // the chain then fails at line 2, which says so.)
    let n = 2 + lines[1..]
        .iter()
        .position(|l| l.contains("\"stage\":\"baseline-train\"") && l.contains("\"failure\":false"))
        .unwrap();
    let edited = edit_line(&trials, n, "\"failure\":false", "\"failure\":true");
    let (code, err) = resume(&dir);
    assert_ne!(code, Some(0), "an edited failure flag was accepted");
    let at = format!("{}, line {n}: its checksum", trials.display());
    assert!(
        err.contains(&at) && err.contains("was changed after savme wrote it"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&trials).unwrap(), edited, "changed");
    // The checksum removed from the edited line: refused too.
    let cut = edited.lines().nth(n - 1).unwrap();
    let without = format!("{}}}", &cut[..cut.find(",\"c\":").unwrap()]);
    edit_line(&trials, n, cut, &without);
    let (code, err) = resume(&dir);
    assert_ne!(code, Some(0));
    assert!(
        err.contains(&format!("line {n}: this line has no checksum")),
        "{err}"
    );
    // Restored, with a torn tail (a process killed mid-write): resumes, the tail dropped.
    std::fs::write(&trials, good.clone() + "{\"v\":1,\"stage\":\"test-le").unwrap();
    let (code, err) = resume(&dir);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(std::fs::read_to_string(&trials).unwrap(), good);
    // A store written before the checksums (every `"c"` gone): still resumes (compatibility).
    let old: String = good
        .lines()
        .map(|l| format!("{}}}\n", &l[..l.find(",\"c\":").unwrap()]))
        .collect();
    std::fs::write(&trials, &old).unwrap();
    let (code, err) = resume(&dir);
    assert_eq!(code, Some(0), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_given_as_a_campaign_and_a_negative_seed_are_named_as_such() {
    let home = made_dir("not-a-campaign");
    let file = home.join("afile");
    std::fs::write(&file, "notes\n").unwrap();
    let journal = home.join("j.jsonl");
    std::fs::write(&journal, "{\"v\":1,\"event\":\"start\"}\n").unwrap();
    let f = file.display().to_string();
    let j = journal.display().to_string();
    for (args, extra) in [
        (vec!["estimate", &f], ""),
        (vec!["failures", &f], ""),
        (vec!["failures", &j], "this file is a savme serve journal"),
        (vec!["reproduce", "--resume", &f], ""),
    ] {
        let (code, _, err) = run(&args);
        assert_ne!(code, Some(0), "{args:?}");
        let named = format!(
            "{} is a file, not a campaign directory",
            args[args.len() - 1]
        );
        assert!(
            err.contains(&named) && err.contains(extra),
            "{args:?}: {err}"
        );
        assert!(
            !err.contains("choose another output directory"),
            "{args:?}: {err}"
        );
    }
    let (code, _, err) = run(&[
        "toy",
        "--out",
        &home.join("x").display().to_string(),
        "--seed",
        "-1",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("invalid value '-1' for '--seed <SEED>': a seed is a whole number from 0 to 18446744073709551615 (not negative)")
            && !err.contains("-- -1"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&home);
}

/// `good` with its lines changed by `edit` (0-based lines), written to `file`.
fn rewrite_lines(file: &Path, good: &str, edit: impl FnOnce(&mut Vec<String>)) {
    let mut lines: Vec<String> = good.lines().map(String::from).collect();
    edit(&mut lines);
    std::fs::write(file, lines.join("\n") + "\n").unwrap();
}

/// The refusal of a resume (it must fail), its first line.
fn refused(dir: &Path) -> String {
    let (code, err) = resume(dir);
    assert_ne!(code, Some(0), "an edited store was accepted: {err}");
    err.lines().next().unwrap_or_default().to_string()
}

#[test]
fn an_edited_store_is_refused_saying_what_happened_at_the_line_it_happened() {
    let dir = temp_dir("edited-kinds");
    let (code, err) = reproduce(&dir);
    assert_eq!(code, Some(0), "{err}");
    let trials = dir.join("trials.jsonl");
    let good = std::fs::read_to_string(&trials).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    let at = |n: usize| format!("{}, line {n}: ", trials.display());
    // The 5th line of the first paired stage (its trial index 4).
    let first = lines
        .iter()
        .position(|l| l.contains("\"stage\":\"train@0.3\""))
        .unwrap();
    let (n, index) = (first + 5, 4);
    assert!(lines[n - 1].contains(&format!("\"index\":{index},")));

    // Re-serialised by another JSON writer: the same values, keys sorted, spaces added, the
    // checksum kept. Refused (savme checks the bytes it wrote), as a rewritten line.
    rewrite_lines(&trials, &good, |l| {
        let v: serde_json::Map<String, Value> = serde_json::from_str(&l[n - 1]).unwrap();
        let sorted: std::collections::BTreeMap<_, _> = v.into_iter().collect();
        l[n - 1] = serde_json::to_string(&sorted)
            .unwrap()
            .replace(",\"", ", \"");
    });
    let e = refused(&dir);
    assert!(
        e.contains(&at(n))
            && e.contains("was rewritten after savme wrote it")
            && e.contains("no longer matches")
            && !e.contains("unknown field"),
        "{e}"
    );

    // A deleted line: named where the gap is (the chain breaks there too).
    rewrite_lines(&trials, &good, |l| {
        l.remove(n - 1);
    });
    let e = refused(&dir);
    assert!(
        e.contains(&at(n))
            && e.contains(&format!(
                "trial index {} of stage `train@0.3` follows index {} (line {}): a line is missing",
                index + 1,
                index - 1,
                n - 1
            )),
        "{e}"
    );

    // A duplicated line: named as a copy of the line before it.
    rewrite_lines(&trials, &good, |l| {
        let copy = l[n - 1].clone();
        l.insert(n, copy);
    });
    let e = refused(&dir);
    assert!(
        e.contains(&at(n + 1))
            && e.contains(&format!("this line repeats line {n}"))
            && e.contains(&format!(
                "trial index {index} of stage `train@0.3` appears twice"
            )),
        "{e}"
    );

    // A field edited: its values as the line has them, never Rust's debug text.
    let m = 1 + lines
        .iter()
        .position(|l| l.contains("\"outcome\":\"TN\""))
        .unwrap();
    for (to, shown) in [("\"FP\"", "is FP but"), ("null", "is absent but")] {
        rewrite_lines(&trials, &good, |l| {
            l[m - 1] = l[m - 1].replacen("\"outcome\":\"TN\"", &format!("\"outcome\":{to}"), 1);
        });
        let e = refused(&dir);
        assert!(
            e.contains(&at(m))
                && e.contains(&format!(
                    "field `outcome` {shown} replaying the trial gives TN"
                )),
            "{e}"
        );
        assert!(!e.contains("Some(") && !e.contains("None"), "{e}");
    }

    // Numbers compactly: 1e308, not 309 digits.
    rewrite_lines(&trials, &good, |l| {
        let i = l[1].find("\"runtime\":").unwrap() + 10;
        let end = i + l[1][i..].find(',').unwrap();
        l[1].replace_range(i..end, "1e308");
    });
    let e = refused(&dir);
    assert!(
        e.contains(&at(2)) && e.contains("field `hf.runtime` is 1e308 but") && e.len() < 300,
        "{e}"
    );
    rewrite_lines(&trials, &good, |l| {
        let i = l[1].find("\"ego_speed\":").unwrap() + 12;
        let end = i + l[1][i..].find(',').unwrap();
        l[1].replace_range(i..end, "1e308");
    });
    let e = refused(&dir);
    assert!(
        e.contains(&at(2)) && e.contains("field `phi.ego_speed` is 1e308,") && e.len() < 300,
        "{e}"
    );

    // Restored: resumes.
    std::fs::write(&trials, &good).unwrap();
    let (code, err) = resume(&dir);
    assert_eq!(code, Some(0), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

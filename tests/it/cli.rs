//! `savme scenarios` and `savme simulate` as a user runs them.
use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_savme");

fn savme(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(EXE).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn scenarios_lists_all_ten_with_their_spaces() {
    let (ok, out, _) = savme(&["scenarios"]);
    assert!(ok);
    for n in 1..=10 {
        assert!(
            out.contains(&format!("{n:>2}  ")),
            "scenario {n} missing:\n{out}"
        );
    }
    assert!(out.contains("meta-testing") && out.contains("lead_decel"));
}

#[test]
fn scenarios_and_fidelity_print_json_with_units() {
    let (ok, out, err) = savme(&["scenarios", "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["format_version"], 1);
    let s = v["scenarios"].as_array().unwrap();
    assert_eq!(s.len(), 10);
    assert_eq!(s[6]["name"], "lead_vehicle_brakes");
    assert_eq!(s[8]["role"], "meta-testing");
    let gap = &s[6]["parameters"][2];
    assert_eq!((&gap["name"], &gap["unit"]), (&"gap".into(), &"m".into()));
    assert_eq!(
        (&gap["lo"], &gap["hi"], &gap["bins"]),
        (&8.0.into(), &28.0.into(), &10.into())
    );

    let (ok, out, err) = savme(&["fidelity", "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["format_version"], 1);
    let settings = v["settings"].as_array().unwrap();
    assert_eq!(settings.len(), 16);
    assert_eq!(settings[0]["name"], "simulation_rate_hz");
    assert_eq!(
        (&settings[0]["unit"], &settings[0]["hf"]),
        (&"Hz".into(), &10.into())
    );
    let clip = settings
        .iter()
        .find(|s| s["name"] == "lidar_near_clipping_m")
        .unwrap();
    assert_eq!(
        (&clip["scale"], &clip["unit"], &clip["hf"]),
        (&"log".into(), &"m".into(), &0.2.into())
    );
}

#[test]
fn fidelity_lists_table_ii_with_hf_values() {
    let (ok, out, _) = savme(&["fidelity"]);
    assert!(ok);
    assert_eq!(out.lines().count(), 17, "{out}");
    assert!(out.contains("simulation_rate_hz") && out.contains("{2, 4, 6, 8, 10}"));
    assert!(out.contains("camera_view_distance_m") && out.contains("[10, 5000]"));
    assert!(out
        .lines()
        .any(|l| l.starts_with("lidar_subsample_count") && l.ends_with('5')));
}

#[test]
fn simulate_reports_outcome_distance_and_cost() {
    let crash = "ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";
    let (ok, out, err) = savme(&["simulate", "--scenario", "7", "--phi", crash]);
    assert!(ok, "{err}");
    assert!(
        out.contains("COLLISION at") && out.contains("work units"),
        "{out}"
    );
    let safe = "ego_speed=10,lead_speed=10,gap=28,lead_decel=4,brake_time=4";
    let (ok, out, _) = savme(&[
        "simulate",
        "--scenario",
        "lead_vehicle_brakes",
        "--phi",
        safe,
        "--json",
    ]);
    assert!(ok);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["failure"], false);
    assert!(v["min_distance_m"].as_f64().unwrap() > 0.0);
    assert_eq!(v["steps"], 100); // 10 s at 10 Hz
    let (ok, out, _) = savme(&[
        "simulate",
        "--scenario",
        "7",
        "--phi",
        safe,
        "--json",
        "--fidelity",
        "simulation_rate_hz=2",
    ]);
    assert!(ok);
    let low: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(low["steps"], 20);
    assert!(low["work"].as_u64() < v["work"].as_u64());
}

#[test]
fn bad_inputs_are_named() {
    let phi = "ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";
    let cases: [(&[&str], &str); 6] = [
        (
            &["simulate", "--scenario", "11", "--phi", phi],
            "unknown scenario `11`",
        ),
        (
            &["simulate", "--scenario", "7", "--phi", "ego_speed"],
            "expected name=value",
        ),
        (
            &["simulate", "--scenario", "7", "--phi", "ego_speed=20"],
            "lead_speed",
        ),
        (
            &[
                "simulate",
                "--scenario",
                "7",
                "--phi",
                &phi.replace("gap=8", "gap=99"),
            ],
            "gap",
        ),
        (
            &[
                "simulate",
                "--scenario",
                "7",
                "--phi",
                phi,
                "--fidelity",
                "rate=3",
            ],
            "unknown fidelity setting `rate`",
        ),
        (
            &[
                "simulate",
                "--scenario",
                "7",
                "--phi",
                phi,
                "--fidelity",
                "simulation_rate_hz=3",
            ],
            "simulation_rate_hz",
        ),
    ];
    for (args, expected) in cases {
        let out = Command::new(EXE).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        // Wrong flag values are usage errors: exit status 2, as for clap's own errors.
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(expected), "{args:?}: {err}");
    }
    let (ok, help, _) = savme(&["--help"]);
    assert!(
        ok && help.contains("Exit status: 0 on success; 1 when running failed"),
        "{help}"
    );
}

#[cfg(not(feature = "rerun"))]
#[test]
fn recording_without_the_rerun_feature_says_how_to_get_it() {
    let phi = "ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";
    for flags in [
        &["--record", "x.rrd"][..],
        &["--spawn"][..],
        &["--connect"][..],
    ] {
        let mut args = vec!["simulate", "--scenario", "7", "--phi", phi];
        args.extend_from_slice(flags);
        let (ok, out, err) = savme(&args);
        assert!(!ok, "{flags:?}");
        assert!(err.contains("--features rerun"), "{err}");
        // Refused before running: no result, neither printed nor inside the error.
        assert!(out.is_empty(), "{out}");
        assert!(
            !err.contains("COLLISION") && err.lines().count() == 1,
            "{err}"
        );
    }
    // The flags a build cannot use are hidden from the help.
    for cmd in ["simulate", "reproduce", "run"] {
        let (ok, help, _) = savme(&[cmd, "--help"]);
        assert!(ok);
        assert!(
            !help.contains("--record") && !help.contains("--spawn"),
            "{help}"
        );
    }
    let (ok, _, err) = savme(&["reproduce", "--quick", "--spawn", "--out", "/nonexistent/x"]);
    assert!(!ok && err.contains("--features rerun"), "{err}");
}

#[test]
fn simulate_has_no_campaign_recording_flags() {
    let phi = "ego_speed=20,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";
    for flag in ["--record-every", "--record-failures"] {
        let (ok, out, err) = savme(&["simulate", "--scenario", "7", "--phi", phi, flag, "3"]);
        assert!(!ok && out.is_empty(), "{flag}: {out}");
        assert!(err.contains(flag), "{flag}: {err}");
    }
}

#[test]
fn more_jobs_than_savme_starts_are_a_usage_error_not_an_abort() {
    // 100,000 threads could not be started: savme aborted (exit 134) after the output
    // directory was created.
    let out = std::env::temp_dir().join(format!("savme-cli-{}-jobs", std::process::id()));
    let o = out.to_str().unwrap();
    for args in [
        &["toy", "--out", o, "--jobs", "100000"][..],
        &["reproduce", "--out", o, "--jobs", "100000"][..],
        &["estimate", o, "--jobs", "100000"][..],
        &["worker", "--jobs", "100000"][..],
    ] {
        let r = Command::new(EXE).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("--jobs") && err.contains("at most 1024 worker threads"),
            "{args:?}: {err}"
        );
        assert!(!out.exists(), "{args:?} created {o}");
    }
}

/// `savme completions bash` completes the subcommands and their flags in a real bash; the zsh
/// and fish scripts name them too (no zsh or fish on the test machine to run them in).
#[test]
fn shell_completions_complete_subcommands_and_flags() {
    let (ok, bash, err) = savme(&["completions", "bash"]);
    assert!(ok, "{err}");
    let complete = |words: &str, cword: usize| -> String {
        let script = format!(
            "{bash}\nCOMP_WORDS=({words}); COMP_CWORD={cword}\n\
             _savme savme \"${{COMP_WORDS[COMP_CWORD]}}\" \"${{COMP_WORDS[COMP_CWORD-1]}}\"\n\
             printf '%s\\n' \"${{COMPREPLY[@]}}\""
        );
        let out = Command::new("bash")
            .args(["--norc", "-c", &script])
            .output()
            .expect("bash");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let subcommands = complete("savme re", 1);
    assert!(
        subcommands.lines().any(|l| l == "reproduce"),
        "{subcommands}"
    );
    let flags = complete("savme estimate --", 2);
    for flag in ["--json", "--quiet", "--target-width", "--storage"] {
        assert!(flags.lines().any(|l| l == flag), "{flag} not in {flags}");
    }
    for shell in ["zsh", "fish", "elvish", "powershell"] {
        let (ok, script, err) = savme(&["completions", shell]);
        assert!(ok, "{shell}: {err}");
        for word in ["reproduce", "estimate", "target-width", "completions"] {
            assert!(script.contains(word), "{shell}: no {word}");
        }
    }
    let (ok, _, err) = savme(&["completions", "tcsh"]);
    assert!(!ok && err.contains("tcsh"), "{err}");
}

/// `savme man` prints savme(1); `--out DIR` writes a page per subcommand, each with its
/// Examples.
#[test]
fn man_pages_are_written_for_every_subcommand() {
    let (ok, page, err) = savme(&["man"]);
    assert!(ok, "{err}");
    assert!(page.contains(".TH savme 1"), "{page}");
    assert!(page.contains("reproduce") && page.contains("completions"));
    let dir = std::env::temp_dir().join(format!("savme-man-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (ok, _, err) = savme(&["man", "--out", dir.to_str().unwrap()]);
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    let (estimate, pack) = (read("savme-estimate.1"), read("savme-fmu-pack.1"));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(ok, "{err}");
    assert!(estimate.contains("target\\-width"), "{estimate}");
    assert!(estimate.contains("Examples:"), "{estimate}");
    assert!(pack.contains("savme fmu pack"), "{pack}");
}

/// `--version` names the commit it was built from and the enabled features.
#[test]
fn version_names_commit_and_features() {
    let (ok, out, err) = savme(&["--version"]);
    assert!(ok, "{err}");
    assert!(out.starts_with("savme 0."), "{out}");
    assert!(out.contains("(commit "), "{out}");
    let features = if cfg!(feature = "postgres") {
        "features: postgres"
    } else {
        "features: none"
    };
    assert!(out.contains(features), "{out}");
}

#[test]
fn a_campaign_file_no_adapter_reads_is_refused_naming_the_adapters() {
    let dir = std::env::temp_dir().join(format!("savme-cli-no-adapter-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("campaign.toml");
    let text = "[fidelity]\npaper = true\n[[scenario]]\nname = \"a\"\nrole = \"train\"\n\
                [[scenario.phi]]\nname = \"x\"\nrange = [0.0, 1.0]\n";
    std::fs::write(&file, text).unwrap();
    let (ok, _, err) = savme(&["run", "--config", file.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        err.contains(&format!(
            "{}: no simulator adapter reads this file",
            file.display()
        )) && err.contains("fmu ([fmu], [failure])"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn more_jobs_than_the_window_keeps_busy_are_warned_about() {
    let dir = std::env::temp_dir().join(format!("savme-cli-window-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let tiny = [
        "toy",
        "--null",
        "--cost",
        "work",
        "--iterations",
        "2",
        "--eval-iterations",
        "1",
        "--test-iterations",
        "1",
        "--baseline-iterations",
        "2",
        "--baseline-test-iterations",
        "1",
        "--window",
        "2",
    ];
    let out = dir.to_str().unwrap();
    let (ok, _, err) = savme(&[&tiny[..], &["--jobs", "5", "--out", out]].concat());
    assert!(ok, "{err}");
    assert!(
        err.contains("--jobs 5 but a window of 2 trials keeps at most 4 runs in flight: 1 threads will be idle; --window 5"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    let (ok, _, err) = savme(&[&tiny[..], &["--jobs", "4", "--out", out]].concat());
    assert!(ok, "{err}");
    assert!(!err.contains("WARNING"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every error says `error: …`, whoever found it (clap while parsing, or savme before or while
/// running), and the exit status says which kind: 2 for the command line, 1 for running.
#[test]
fn every_error_has_one_prefix_and_its_exit_status() {
    let missing = std::env::temp_dir().join(format!("savme-cli-{}-none", std::process::id()));
    let m = missing.to_str().unwrap();
    for (args, code) in [
        // clap: an unknown flag.
        (&["simulate", "--no-such-flag"][..], 2),
        // savme, before running: a value it refuses.
        (&["simulate", "--scenario", "99", "--phi", "gap=8"][..], 2),
        (&["serve"][..], 2),
        // savme, running: a file that is not there.
        (&["fmu", "info", m][..], 1),
        (&["failures", m][..], 1),
    ] {
        let r = Command::new(EXE).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(!err.contains("savme: "), "{args:?}: {err}");
    }
}

/// `--color auto|always|never` (any position) decides whether clap's help and errors are
/// coloured; `auto` colours a terminal unless NO_COLOR is set (CLICOLOR_FORCE stands in for the
/// terminal here).
#[test]
fn color_flag_and_no_color_decide_the_escapes() {
    let run = |args: &[&str], env: &[(&str, &str)]| {
        let mut c = Command::new(EXE);
        c.args(args)
            .env_remove("NO_COLOR")
            .env_remove("CLICOLOR_FORCE");
        for (k, v) in env {
            c.env(k, v);
        }
        let o = c.output().unwrap();
        let text =
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
        (o.status.code(), text.contains('\x1b'))
    };
    let force = [("CLICOLOR_FORCE", "1")];
    let both = [("CLICOLOR_FORCE", "1"), ("NO_COLOR", "1")];
    for help in [&["--help"][..], &["estimate", "--help"][..]] {
        let with = |flag: &[&'static str]| -> Vec<&'static str> { [flag, help].concat() };
        assert_eq!(
            run(&with(&["--color", "always"]), &[]),
            (Some(0), true),
            "{help:?}"
        );
        assert_eq!(
            run(&with(&["--color=never"]), &force),
            (Some(0), false),
            "{help:?}"
        );
        assert_eq!(run(help, &force), (Some(0), true), "{help:?}");
        assert_eq!(run(help, &both), (Some(0), false), "{help:?}");
        assert_eq!(run(help, &[]), (Some(0), false), "{help:?}: not a terminal");
    }
    // After the subcommand too, and for an error.
    assert_eq!(
        run(&["estimate", "--help", "--color", "never"], &force),
        (Some(0), false)
    );
    assert_eq!(
        run(&["simulate", "--bogus", "--color", "always"], &[]),
        (Some(2), true)
    );
    assert_eq!(
        run(&["simulate", "--bogus", "--color", "never"], &force),
        (Some(2), false)
    );
    // A wrong value is a usage error.
    assert_eq!(run(&["--color", "sometimes", "scenarios"], &[]).0, Some(2));
}

// Issue 40 item 5: a number like 1e308 was echoed as its 309 digits.
#[test]
fn a_huge_number_is_echoed_in_exponent_form() {
    let phi = "ego_speed=1e308,lead_speed=10,gap=8,lead_decel=9,brake_time=0.5";
    let (ok, _, err) = savme(&["simulate", "--scenario", "7", "--phi", phi]);
    assert!(!ok);
    assert!(
        err.contains("value 1e308 is outside variable `ego_speed`"),
        "{err}"
    );
    assert!(err.len() < 300, "{err}");
}

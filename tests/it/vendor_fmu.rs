//! `savme` on an FMU as vendors ship them: the `braking` example (`examples/fmu/braking`, C
//! against the FMI 2.0 C API), compiled here with the system C compiler and packed with its
//! resources — its example campaign (the step size as the only fidelity), `--fmu-log`, and
//! `savme fmu info` / `validate`.
use crate::common;

use common::braking::{braking3_library, example, model_description, pack, pack3};
use common::{fmpy_python, made_dir, savme};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The packed FMU of FMI version `fmi` in `dir`.
fn pack_version(dir: &Path, fmi: u8) -> PathBuf {
    if fmi == 3 {
        pack3(dir)
    } else {
        pack(dir, &model_description())
    }
}

/// `dir` with the packed FMU and the example campaign file.
fn example_dir(name: &str) -> (PathBuf, PathBuf) {
    let dir = made_dir(name);
    pack(&dir, &model_description());
    let config = dir.join("campaign.toml");
    std::fs::copy(example().join("campaign.toml"), &config).unwrap();
    (dir, config)
}

/// Item 2: the example campaign, whose only fidelity is the communication step size, runs the
/// whole protocol; every trial's θ is a step size of the list.
#[test]
fn the_step_size_example_campaign_runs() {
    for fmi in [2, 3] {
        step_size_campaign(fmi);
    }
}

/// The example campaign on the FMU of FMI version `fmi` (item 7: the same campaign runs the
/// FMI 3.0 build of the model, its step size still the fidelity).
fn step_size_campaign(fmi: u8) {
    let (dir, config) = example_dir(&format!("example{fmi}"));
    if fmi == 3 {
        pack3(&dir);
        let text = std::fs::read_to_string(&config).unwrap();
        let text = text.replace("hf = \"braking.fmu\"", "hf = \"braking3.fmu\"");
        assert!(text.contains("braking3.fmu"));
        std::fs::write(&config, text).unwrap();
    }
    let out = dir.join("out");
    let (ok, stdout, err) = savme(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{err}");
    assert!(stdout.contains("| step | 0.01 |"), "{stdout}");
    let trials = std::fs::read_to_string(out.join("trials.jsonl")).unwrap();
    // The protocol record, then the trials.
    let (_, trials) = trials.split_once('\n').unwrap();
    assert_eq!(trials.lines().count(), 120 + 120 + 40 + 3 * 60);
    let mut steps = std::collections::BTreeSet::new();
    for line in trials.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        assert!(v.get("error").is_none(), "a withdrawn trial: {line}");
        // θ_LF of the LF runs (HF runs use θ_HF = 0.01).
        if let Some(h) = v["theta_lf"]["step"].as_f64() {
            assert!([0.4, 0.2, 0.1, 0.05, 0.02, 0.01].contains(&h), "{line}");
            steps.insert(h.to_bits());
        }
    }
    assert!(steps.len() > 1, "the LF runs explore the step sizes");
}

/// `savme run` on `text` (a campaign file written next to the packed braking FMU in `dir` as
/// `name.toml`), shortened to 60 + 60 + 20 + 3 × 30 trials: the trial lines of its store,
/// without their wall times and checksums.
fn braking_trials(dir: &Path, name: &str, text: &str, args: &[&str]) -> Vec<serde_json::Value> {
    let shorter = text
        .replace("train_iterations = 120", "train_iterations = 60")
        .replace("eval_iterations = 40", "eval_iterations = 20")
        .replace("test_iterations = 60", "test_iterations = 30");
    assert_eq!(shorter.matches("iterations = ").count(), 5, "{name}");
    let config = dir.join(format!("{name}.toml"));
    std::fs::write(&config, shorter).unwrap();
    let out = dir.join(name);
    let config = config.to_str().unwrap();
    let mut all = vec![
        "run",
        "--config",
        config,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    all.extend(args);
    let (ok, _, err) = savme(&all);
    assert!(ok, "{name}: {err}");
    let trials = std::fs::read_to_string(out.join("trials.jsonl")).unwrap();
    // Without what differs between two runs of one campaign: wall times, the line checksum.
    let lines: Vec<serde_json::Value> = trials
        .lines()
        .skip(1)
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            for run in ["hf", "lf"] {
                if let Some(r) = v[run].as_object_mut() {
                    r.remove("wall_seconds");
                }
            }
            v.as_object_mut().unwrap().remove("c");
            v
        })
        .collect();
    assert_eq!(lines.len(), 60 + 60 + 20 + 3 * 30, "{name}");
    lines
}

/// The HF and LF runs of a stored trial: (failure, robustness).
fn runs(trial: &serde_json::Value) -> Vec<(bool, Option<f64>)> {
    ["hf", "lf"]
        .iter()
        .filter_map(|k| trial.get(*k).filter(|r| !r.is_null()))
        .map(|r| (r["failure"].as_bool().unwrap(), r["robustness"].as_f64()))
        .collect()
}

/// Issue 42: the braking example names `distance` as the robustness beside its Boolean
/// `collision`. With the paper's search (which ignores ρ, so both campaigns ask the same
/// trials) every run's verdict equals the Boolean-only file's, and every run now carries ρ =
/// its smallest clearance (≤ 0 exactly on a collision), in process and through `savme
/// fmu-worker` processes alike; with the default (tuned) search, whose
/// ρ model learns from it, the campaign asks, judges and stores exactly what the threshold form
/// of the same campaign (`benches/peers/braking-threshold.toml`: `distance` below 0) does.
#[test]
fn the_braking_examples_robustness_keeps_its_verdicts_and_reaches_the_search() {
    let dir = made_dir("robustness");
    pack(&dir, &model_description());
    let example = std::fs::read_to_string(example().join("campaign.toml")).unwrap();
    let flag = "boolean = \"collision\"\n";
    let rho = "robustness = \"distance\"\n";
    assert!(example.contains(&format!("{flag}# ")) && example.contains(rho));
    let boolean_only = example.replace(rho, "");
    let paper = ["--method", "paper"];
    let with = braking_trials(&dir, "with", &example, &paper);
    let without = braking_trials(&dir, "without", &boolean_only, &paper);
    let mut failures = 0;
    for (a, b) in with.iter().zip(&without) {
        assert_eq!((&a["phi"], &a["theta_lf"]), (&b["phi"], &b["theta_lf"]));
        let (ra, rb) = (runs(a), runs(b));
        assert_eq!(ra.len(), rb.len());
        for ((fa, rho), (fb, none)) in ra.into_iter().zip(rb) {
            assert_eq!(fa, fb, "{a}");
            assert_eq!(none, None, "{b}");
            let rho = rho.unwrap_or_else(|| panic!("no robustness: {a}"));
            assert_eq!(rho <= 0.0, fa, "{a}");
            failures += usize::from(fa);
        }
    }
    assert!(failures > 20, "{failures} failing runs");
    // Through `savme fmu-worker` processes (isolation) the runs carry the same ρ.
    let isolated = example.replacen("[fmu]\n", "[fmu]\nisolate = true\n", 1);
    assert_ne!(isolated, example);
    assert_eq!(braking_trials(&dir, "isolated", &isolated, &paper), with);
    // The tuned search (the default) learns from ρ: the threshold form asks the same.
    let threshold = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/peers/braking-threshold.toml"),
    )
    .unwrap()
    .replace("../../examples/fmu/braking/braking.fmu", "braking.fmu");
    let tuned = braking_trials(&dir, "tuned", &example, &[]);
    let margin = braking_trials(&dir, "margin", &threshold, &[]);
    assert_eq!(tuned, margin);
    // ... and ρ reaches it: without the robustness output it asks other trials.
    let blind = braking_trials(&dir, "blind", &boolean_only, &[]);
    let same_asks = tuned.iter().zip(&blind).all(|(a, b)| a["phi"] == b["phi"]);
    assert!(
        !same_asks,
        "the tuned search asked the same trials without ρ"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Item 4 on the command line: `--fmu-log` prints every message of the FMU, also the
/// informational ones it sends only with `loggingOn`.
#[test]
fn fmu_log_prints_the_fmus_messages() {
    let (dir, config) = example_dir("fmu-log");
    let small = [
        "--cost",
        "wall",
        "--iterations",
        "2",
        "--eval-iterations",
        "1",
        "--test-iterations",
        "1",
        "--baseline-iterations",
        "1",
        "--baseline-test-iterations",
        "1",
    ];
    for flag in [true, false] {
        let out = dir.join(format!("out-{flag}"));
        let mut args = vec![
            "run",
            "--config",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ];
        args.extend(small);
        if flag {
            args.push("--fmu-log");
        }
        let (ok, stdout, err) = savme(&args);
        assert!(ok, "{err}");
        // Item 9: times below a second in ms or µs, never "0.0 s".
        assert!(!stdout.contains(" 0.0 s"), "{stdout}");
        assert!(stdout.contains(" ms") || stdout.contains(" µs"), "{stdout}");
        assert_eq!(
            err.contains("[savme-hf] ok logAll: friction 0.80 for the dry road from /"),
            flag,
            "--fmu-log {flag}: {err}"
        );
    }
}

/// The row of variable `name` in `savme fmu info`'s table, its cells joined by one space.
fn row(text: &str, name: &str) -> String {
    text.lines()
        .find(|l| l.starts_with(&format!("{name} ")))
        .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

/// Item 8: `savme fmu info` shows what `fmpy info` shows — version, kinds, platforms,
/// capabilities, variables with causality, type, start, min/max, unit (and items) — as text
/// or JSON.
#[test]
fn fmu_info_shows_the_model_and_its_variables() {
    let dir = made_dir("info");
    let fmu = pack(&dir, &model_description());
    let (ok, text, err) = savme(&["fmu", "info", fmu.to_str().unwrap()]);
    assert!(ok, "{err}");
    for needle in [
        "FMI version      2.0",
        "Kinds            co-simulation",
        "Model name       braking",
        &format!("Platforms        {}", savme_fmi_export::platform_folder()),
        "Default run      start 0, stop 8, step 0.1, tolerance -",
        "Co-simulation    model identifier braking; canHandleVariableCommunicationStepSize",
    ] {
        assert!(text.contains(needle), "{needle}: {text}");
    }
    let row = |name: &str| row(&text, name);
    assert_eq!(
        row("speed0"),
        "speed0 parameter Real 15.0 4 25 m/s initial speed"
    );
    assert_eq!(
        row("road"),
        "road parameter Enumeration 1 dry=1 wet=2 ice=3"
    );
    assert_eq!(
        row("friction"),
        "friction calculatedParameter Real from resources/friction.txt"
    );
    let (ok, json, err) = savme(&["fmu", "info", fmu.to_str().unwrap(), "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["model"]["fmi_version"], "2.0");
    assert_eq!(v["model"]["co_simulation"]["model_identifier"], "braking");
    let vars = v["model"]["variables"].as_array().unwrap();
    assert_eq!(vars.len(), 10);
    assert_eq!(vars[0]["name"], "speed0");
    assert_eq!(
        (vars[0]["min"].as_f64(), vars[0]["max"].as_f64()),
        (Some(4.0), Some(25.0))
    );
    assert_eq!(vars[0]["unit"], "m/s");
    assert_eq!(vars[2]["items"][2]["name"], "ice");
    assert_eq!(vars[2]["items"][2]["value"], 3);
    // A file that is no FMU is named.
    let (ok, _, err) = savme(&["fmu", "info", dir.join("none.fmu").to_str().unwrap()]);
    assert!(!ok && err.contains("none.fmu"), "{err}");
}

/// Item 8: `savme fmu validate` makes every check savme makes before a campaign (the library
/// in a child process): exit status 0, or 1 with the list of problems — as text or JSON.
#[test]
fn fmu_validate_lists_every_problem() {
    let dir = made_dir("validate");
    let good = pack(&dir, &model_description());
    let (ok, text, err) = savme(&["fmu", "validate", good.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(
        text.ends_with(": valid — every check savme makes before a campaign passes\n"),
        "{text}"
    );
    // Two bad declarations: both are listed.
    let bad = dir.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    let xml = model_description()
        .replacen(
            "min=\"4.0\" max=\"25.0\" start=\"15.0\"",
            "min=\"4.0\" max=\"25.0\" start=\"30.0\"",
            1,
        )
        .replacen(
            "<Enumeration declaredType=\"Road\" start=\"1\"/>",
            "<Enumeration declaredType=\"Road\" start=\"7\"/>",
            1,
        );
    let fmu = pack(&bad, &xml);
    let (ok, json, err) = savme(&["fmu", "validate", fmu.to_str().unwrap(), "--json"]);
    assert!(!ok && err.contains("not valid (2 problem(s))"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["valid"], false);
    // Each problem names the line of the variable's declaration (as FMPy's validation does).
    let line_of = |name: &str| {
        1 + xml
            .lines()
            .position(|l| l.contains(&format!("name=\"{name}\"")))
            .unwrap()
    };
    assert_eq!(
        v["problems"],
        serde_json::json!([
            format!(
                "modelDescription.xml, line {}, column 5: variable `speed0`: start 30.0 lies outside [min, max]",
                line_of("speed0")
            ),
            format!(
                "modelDescription.xml, line {}, column 5: variable `road`: start 7 is none of its enumeration's items",
                line_of("road")
            )
        ])
    );
    // A GUID the library does not know: found by instantiating it.
    let guid = dir.join("guid");
    std::fs::create_dir_all(&guid).unwrap();
    let fmu = pack(
        &guid,
        &model_description().replacen("{b7a1e000", "{00000000", 1),
    );
    let (ok, text, _) = savme(&["fmu", "validate", fmu.to_str().unwrap()]);
    assert!(!ok);
    assert!(text.contains(": 1 problem(s)\n  - "), "{text}");
    assert!(
        text.contains("fmi2Instantiate failed (returned no instance)"),
        "{text}"
    );
    // A library that crashes while loading is a problem, not the end of savme; the child's
    // unpacked copy of the FMU does not stay behind in the temporary directory (issue 40).
    let crash = dir.join("crash");
    std::fs::create_dir_all(&crash).unwrap();
    let fmu = crashing_fmu(&crash);
    let tmp = made_dir("validate-tmp");
    let o = Command::new(common::EXE)
        .args(["fmu", "validate", fmu.to_str().unwrap()])
        .env("TMPDIR", &tmp)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains(
            "the library crashed while it was loaded or instantiated (killed by signal 7)"
        ),
        "{text}"
    );
    assert_nothing_left_in(&tmp);
}

/// `braking.fmu` in `dir` whose library dies of SIGBUS while it is loaded (its constructor:
/// `fmu-adapter/testkit/c/crash_on_load.c`).
fn crashing_fmu(dir: &Path) -> PathBuf {
    let lib = dir.join("crash.so");
    let status = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
        .args(["-shared", "-fPIC", "-o"])
        .arg(&lib)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu-adapter/testkit/c/crash_on_load.c"))
        .status()
        .unwrap();
    assert!(status.success());
    let fmu = dir.join("braking.fmu");
    savme_fmi_export::pack(&model_description(), "braking", &lib, &fmu).unwrap();
    fmu
}

/// Issue 40 item 10: a campaign that runs its FMU in this process (no `isolate`) on a library
/// that crashes while it is loaded ends with a message naming the FMU, the signal and that
/// `isolate = true` contains it (exit status 1) — it died of the signal without a word (exit
/// 135) — and leaves nothing in $TMPDIR.
#[test]
fn an_fmu_that_crashes_on_load_is_named_before_an_in_process_campaign() {
    let (dir, config) = example_dir("crash-on-load");
    crashing_fmu(&dir);
    let tmp = dir.join("tmp");
    std::fs::create_dir_all(&tmp).unwrap();
    let o = Command::new(common::EXE)
        .args([
            "run",
            "--config",
            config.to_str().unwrap(),
            "--quiet",
            "--out",
        ])
        .arg(dir.join("out"))
        .env("TMPDIR", &tmp)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("campaign.toml, line 14, key `fmu.hf / fmu.lf`")
            && err.contains("braking.fmu: the FMU's library crashed while it was loaded and instantiated in a test process (killed by signal 7 (SIGBUS: the FMU crashed))")
            && err.contains("`isolate = true` in [fmu] runs the FMU in worker processes"),
        "{err}"
    );
    assert_nothing_left_in(&tmp);
    let _ = std::fs::remove_dir_all(&dir);
}

/// FMPy, the independent FMI client, and savme give the braking FMU the same outcomes: its
/// resources found the same way, the enumeration and the String parameter set alike.
/// Item 7: on the FMI 3.0 build too (FMPy allowed to return early, as savme is: the FMU then
/// stops at the collision inside a step in both).
#[test]
fn fmpy_runs_the_braking_fmu_like_savme() {
    let Some(python) = fmpy_python() else { return };
    for fmi in [2, 3] {
        fmpy_compare(&python, fmi);
    }
}

fn fmpy_compare(python: &str, fmi: u8) {
    use savme::kernel::{Assignment, Role, Scale, Space, Value, Variable};
    use savme_fmu::{Binding, CostSource, Failure, Fixed, FmuFile, FmuSimulator, RunSpec};
    let dir = made_dir(&format!("fmpy{fmi}"));
    let fmu = pack_version(&dir, fmi);
    let file = std::sync::Arc::new(FmuFile::open(&fmu).unwrap());
    let phi = Space::new(vec![Variable::continuous("v", 4.0, 25.0, 4, Scale::Linear)]).unwrap();
    let cases = [
        (12.0, "dry", 1, "alert"),
        (16.0, "dry", 1, "distracted"),
        (10.0, "ice", 3, "alert"),
        (20.0, "wet", 2, "alert"),
    ];
    let mut failures = 0;
    for (v, road, value, driver) in cases {
        let spec = RunSpec {
            stop_time: 8.0,
            // Exact in binary: both clients reach the same communication points.
            step: savme_fmu::StepSize::Fixed(0.125),
            tolerance: None,
            failure: Failure::Boolean {
                variable: "collision".into(),
                robustness: None,
            },
            stop_on_failure: false,
            cost: CostSource::Output("steps".into()),
            fidelity: Vec::new(),
            fmu_log: false,
            scenarios: vec![savme_fmu::ScenarioSpec {
                name: "s".into(),
                phi: vec![Binding {
                    variable: "v".into(),
                    fmu_variable: "speed0".into(),
                    labels: None,
                }],
                fixed: vec![
                    Fixed {
                        fmu_variable: "road".into(),
                        value: Value::from(road),
                    },
                    Fixed {
                        fmu_variable: "driver".into(),
                        value: Value::from(driver),
                    },
                ],
            }],
        };
        let mut sim = FmuSimulator::new(file.clone(), file.clone(), spec, None, &|_| {
            Some(phi.clone())
        })
        .unwrap();
        let local = sim
            .run(
                Role::High,
                "s",
                &Assignment::new().with("v", v),
                &Assignment::new(),
            )
            .unwrap();
        let script = format!(
            "import fmpy\n\
             r = fmpy.simulate_fmu(r'{}', start_values={{'speed0': {v:?}, 'road': {value}, 'driver': '{driver}'}}, \
             stop_time=8.0, output_interval=0.125, output=['collision', 'steps'], early_return_allowed={})\n\
             print(bool(r['collision'][-1]), int(r['steps'][-1]))\n",
            fmu.display(),
            if fmi == 3 { "True" } else { "False" }
        );
        let o = Command::new(python)
            .arg("-c")
            .arg(&script)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout);
        let f: Vec<&str> = out.split_whitespace().collect();
        assert_eq!(f.len(), 2, "{out}");
        assert_eq!(
            f[0] == "True",
            local.failure,
            "FMI {fmi} {v} {road} {driver}: {out}"
        );
        assert_eq!(
            f[1].parse::<u64>().ok(),
            local.work,
            "{v} {road} {driver}: {out}"
        );
        failures += usize::from(local.failure);
    }
    assert!(
        failures > 0 && failures < cases.len(),
        "the cases differ in outcome"
    );
}

/// Item 7 with item 8: `savme fmu info` and `validate` read an FMI 3.0 FMU — its platform
/// tuple, its types (UInt32, Enumeration, the independent time) — and validate instantiates it
/// through `fmi3InstantiateCoSimulation`.
#[test]
fn fmu_info_and_validate_read_fmi3() {
    let dir = made_dir("info3");
    let fmu = pack3(&dir);
    let (ok, text, err) = savme(&["fmu", "info", fmu.to_str().unwrap()]);
    assert!(ok, "{err}");
    for needle in [
        "FMI version      3.0",
        &format!("Platforms        {}", savme_fmi_export::platform_tuple()),
        "GUID             {b7a1e000-5a4e-4b1c-9e11-b7a1c0ffee03}",
    ] {
        assert!(text.contains(needle), "{needle}: {text}");
    }
    let row = |name: &str| row(&text, name);
    assert_eq!(row("steps"), "steps output UInt32 Euler steps taken");
    assert_eq!(
        row("road"),
        "road parameter Enumeration 1 dry=1 wet=2 ice=3"
    );
    assert_eq!(
        row("driver"),
        "driver parameter String alert alert or distracted"
    );
    let (ok, text, err) = savme(&["fmu", "validate", fmu.to_str().unwrap()]);
    assert!(ok, "{text} {err}");
    // A wrong instantiation token is found by instantiating it.
    let bad = dir.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    let xml = std::fs::read_to_string(example().join("modelDescription3.xml"))
        .unwrap()
        .replacen("{b7a1e000", "{00000000", 1);
    let wrong = bad.join("braking3.fmu");
    savme_fmi_export::pack(&xml, "braking", braking3_library(), &wrong).unwrap();
    let (ok, text, _) = savme(&["fmu", "validate", wrong.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        text.contains("fmi3InstantiateCoSimulation failed (returned no instance); the FMU logged: [error] fmi3InstantiateCoSimulation: wrong instantiationToken"),
        "{text}"
    );
}

/// The FMI 3.0 `stairs` test FMU (`fmu-adapter/testkit/c/stairs.c`, compiled here) in `dir`:
/// `failed` holds when its Int64 parameter `ticket` is odd (or x reaches `threshold`).
fn stairs3(dir: &Path) -> PathBuf {
    let testkit = Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu-adapter/testkit/c");
    let lib = dir.join("stairs.so");
    let status = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
        .args(["-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-o"])
        .arg(&lib)
        .arg(testkit.join("stairs.c"))
        .arg("-lm")
        .status()
        .unwrap();
    assert!(status.success());
    let xml = std::fs::read_to_string(testkit.join("stairs3.xml")).unwrap();
    let fmu = dir.join("stairs3.fmu");
    savme_fmi_export::pack(&xml, "stairs", &lib, &fmu).unwrap();
    fmu
}

/// Issue 40 item 10: a library that crashes in its instantiate (the `stairs` FMU with
/// SAVME_STAIRS_CRASH set: SIGSEGV) in an in-process campaign is named with its signal before
/// the campaign starts (it died at the first run: exit 139); with `isolate = true` each run
/// fails in its worker and the campaign stops naming the trial, not the process.
#[test]
fn an_fmu_that_crashes_in_instantiate_is_named_before_an_in_process_campaign() {
    let dir = made_dir("crash-instantiate");
    stairs3(&dir);
    let config = dir.join("campaign.toml");
    let body = "[fmu]\nhf = \"stairs3.fmu\"\nstop_time = 1.0\nstep = 0.5\n\n[failure]\nboolean = \"failed\"\n\n\
                [campaign]\nbudgets = [0.5]\n\n[fidelity]\n[[fidelity.variable]]\nname = \"min_step\"\n\
                values = [1e-9, 1e-8]\nhf = 1e-9\n\n[[scenario]]\nname = \"s\"\nrole = \"train\"\n\
                [[scenario.phi]]\nname = \"x0\"\nrange = [0.0, 1.0]\n\n[[scenario]]\nname = \"t\"\n\
                role = \"test\"\n[[scenario.phi]]\nname = \"x0\"\nrange = [0.0, 1.0]\n";
    std::fs::write(&config, body).unwrap();
    let run = |out: &str| {
        let o = Command::new(common::EXE)
            .args([
                "run",
                "--config",
                config.to_str().unwrap(),
                "--quiet",
                "--out",
            ])
            .arg(dir.join(out))
            .env("SAVME_STAIRS_CRASH", "1")
            .output()
            .unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (code, err) = run("in-process");
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("stairs3.fmu: the FMU's library crashed while it was loaded and instantiated in a test process (killed by signal 11 (SIGSEGV: the FMU crashed))")
            && err.contains("`isolate = true` in [fmu]"),
        "{err}"
    );
    std::fs::write(
        &config,
        body.replace("step = 0.5\n", "step = 0.5\nisolate = true\n"),
    )
    .unwrap();
    let (code, err) = run("isolated");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("signal 11"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 40 item 7, end to end: a campaign over Int64 values next to 2⁵³ keeps them exact in
/// its trial store and the FMU gets each exactly — every verdict is the parity of the value the
/// store holds (9007199254740993 was set as 9007199254740992: verdicts differed from FMPy's).
#[test]
fn a_campaigns_int64_values_are_exact_in_the_store_and_the_fmu() {
    let dir = made_dir("int64-campaign");
    stairs3(&dir);
    let config = dir.join("campaign.toml");
    let scenario = |name: &str, role: &str| {
        format!(
            "[[scenario]]\nname = \"{name}\"\nrole = \"{role}\"\nfixed = {{ threshold = 100.0 }}\n\
             [[scenario.phi]]\nname = \"ticket\"\n\
             values = [9007199254740993, 9007199254740992, 9223372036854775807, -9223372036854775808]\n"
        )
    };
    std::fs::write(
        &config,
        format!(
            "[fmu]\nhf = \"stairs3.fmu\"\nstop_time = 1.0\nstep = 0.5\n\n[failure]\nboolean = \"failed\"\n\n\
             [campaign]\nbudgets = [0.5]\ntrain_iterations = 6\neval_iterations = 3\ntest_iterations = 3\n\
             baseline_train_iterations = 3\nbaseline_test_iterations = 3\ncost = \"work\"\n\n\
             [fidelity]\n[[fidelity.variable]]\nname = \"min_step\"\nvalues = [1e-9, 1e-8]\nhf = 1e-9\n\n{}\n{}",
            scenario("s", "train"),
            scenario("t", "test")
        ),
    )
    .unwrap();
    for isolate in [false, true] {
        let out = dir.join(format!("out-{isolate}"));
        let mut args = vec![
            "run",
            "--config",
            config.to_str().unwrap(),
            "--quiet",
            "--out",
        ];
        args.push(out.to_str().unwrap());
        if isolate {
            let text = std::fs::read_to_string(&config).unwrap();
            std::fs::write(
                &config,
                text.replace("step = 0.5\n", "step = 0.5\nisolate = true\n"),
            )
            .unwrap();
        }
        let (ok, _, err) = savme(&args);
        assert!(ok, "{err}");
        let text = std::fs::read_to_string(out.join("trials.jsonl")).unwrap();
        let (mut seen, mut judged) = (std::collections::BTreeSet::new(), 0);
        for line in text.lines().skip(1) {
            let v: serde_json::Value = serde_json::from_str(line).unwrap();
            let Some(ticket) = v["phi"]["ticket"].as_i64() else {
                continue;
            };
            // The stored value as written: an integer, not a float near it.
            assert!(v["phi"]["ticket"].is_i64(), "{line}");
            for run in ["hf", "lf"] {
                if let Some(failure) = v[run]["failure"].as_bool() {
                    assert_eq!(failure, ticket % 2 != 0, "ticket {ticket}, {run}: {line}");
                    judged += 1;
                }
            }
            seen.insert(ticket);
        }
        assert!(
            seen.contains(&9_007_199_254_740_993) && seen.contains(&9_007_199_254_740_992),
            "{seen:?}"
        );
        assert!(judged > 10, "{judged} runs judged: {text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The private `$TMPDIR` of a test holds nothing (no unpacked FMU left behind).
fn assert_nothing_left_in(tmp: &std::path::Path) {
    let left: Vec<_> = std::fs::read_dir(tmp)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert!(left.is_empty(), "left in $TMPDIR: {left:?}");
}

//! The adapter on FMUs as vendors ship them: the `braking` FMU written in C against the FMI 2.0
//! C API and the same model against the FMI 3.0 C API (`braking3`; both compiled by the test
//! kit's build script from `examples/fmu/braking`), which read a resource file during
//! initialisation, ask to end the simulation, log through the environment's logger, and
//! declare bounds, an enumeration and a String parameter. The tests run on both versions
//! (`for fmi in BOTH`): the campaign features are the same for FMI 2.0 and 3.0.
mod common;
use savme_fmu::instance::Instance;
use savme_fmu::{
    Binding, CostSource, Failure, Fixed, FmuError, FmuFile, FmuSimulator, RunSpec, ScenarioSpec,
    StepSize,
};
use savme_kernel::{Assignment, Role, Scale, Space, Value, Variable};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn temp_dir(name: &str) -> PathBuf {
    common::temp_dir("savme-vendor", name)
}

/// The FMI versions of the braking FMU.
const BOTH: [u8; 2] = [2, 3];

/// The `braking` FMU of FMI version `fmi` (2 or 3) packed into `dir` (with its resources
/// unless `with_resources` is false).
fn braking(dir: &Path, fmi: u8, with_resources: bool) -> PathBuf {
    let out = dir.join(format!("braking{fmi}.fmu"));
    if fmi == 3 {
        savme_fmu_testkit::pack_braking3(&out, with_resources).unwrap();
    } else {
        savme_fmu_testkit::pack_braking(
            &out,
            savme_fmu_testkit::BRAKING_MODEL_DESCRIPTION,
            with_resources,
        )
        .unwrap();
    }
    out
}

/// A scenario searching the initial speed on a fixed gap, with `fixed` added.
fn spec(fixed: Vec<Fixed>) -> RunSpec {
    let mut all = vec![Fixed {
        fmu_variable: "gap".into(),
        value: Value::Real(40.0),
    }];
    all.extend(fixed);
    RunSpec {
        fmu_log: false,
        tolerance: None,
        stop_time: 8.0,
        step: StepSize::Fixed(0.05),
        failure: Failure::Boolean {
            variable: "collision".into(),
            robustness: None,
        },
        stop_on_failure: false,
        cost: CostSource::Output("steps".into()),
        fidelity: Vec::new(),
        scenarios: vec![ScenarioSpec {
            name: "brake".into(),
            phi: vec![Binding {
                variable: "v".into(),
                fmu_variable: "speed0".into(),
                labels: None,
            }],
            fixed: all,
        }],
    }
}

fn phi_space() -> Space {
    Space::new(vec![Variable::continuous("v", 5.0, 25.0, 4, Scale::Linear)]).unwrap()
}

fn simulator(fmu: &Path, spec: RunSpec) -> Result<FmuSimulator, FmuError> {
    let file = Arc::new(FmuFile::open(fmu)?);
    let phi = phi_space();
    FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(phi.clone()))
}

fn run(sim: &mut FmuSimulator, v: f64) -> Result<savme_kernel::SimResult, FmuError> {
    sim.run(
        Role::High,
        "brake",
        &Assignment::new().with("v", v),
        &Assignment::new(),
    )
}

/// Item 1: the FMU gets the `file://` URI of its unpacked `resources/` directory and reads
/// `friction.txt` from it while it initialises.
#[test]
fn the_fmu_reads_its_resources_during_initialisation() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("resources{fmi}"));
        let fmu = braking(&dir, fmi, true);
        let file = Arc::new(FmuFile::open(&fmu).unwrap());
        // FMI 2.0: a file:// URI; FMI 3.0: a plain path with a trailing separator.
        let uri = file.resource_uri.to_str().unwrap().to_string();
        if fmi == 2 {
            assert!(
                uri.starts_with("file:///") && uri.ends_with("/resources"),
                "{uri}"
            );
        } else {
            assert!(
                uri.starts_with('/') && uri.ends_with("/resources/"),
                "{uri}"
            );
        }
        let friction = file.variable("friction").unwrap().vr;
        let road = file.variable("road").unwrap().clone();
        for (surface, mu) in [(1, 0.8), (2, 0.5), (3, 0.15)] {
            let mut inst = Instance::new(file.clone(), "resources").unwrap();
            inst.setup(0.0, Some(1.0), None).unwrap();
            inst.set_int(&road, surface).unwrap();
            inst.initialize().unwrap();
            assert_eq!(inst.real(friction).unwrap(), mu, "road {surface}");
        }
        // And the friction read decides the outcome: 10 m/s stops in time on a dry road, not on ice.
        let mut dry = simulator(&fmu, spec(Vec::new())).unwrap();
        assert!(!run(&mut dry, 10.0).unwrap().failure);
        let ice = Fixed {
            fmu_variable: "road".into(),
            value: Value::Int(3),
        };
        let mut icy = simulator(&fmu, spec(vec![ice])).unwrap();
        assert!(run(&mut icy, 10.0).unwrap().failure);
    }
}

/// Without its resources the FMU cannot initialise: the error names the FMU and the call.
#[test]
fn an_fmu_without_its_resources_fails_to_initialise_naming_the_call() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("no-resources{fmi}"));
        let fmu = braking(&dir, fmi, false);
        let mut sim = simulator(&fmu, spec(Vec::new())).unwrap();
        let e = run(&mut sim, 10.0).unwrap_err().to_string();
        assert!(e.contains(&fmu.display().to_string()), "{e}");
        assert!(
            e.contains(&format!("fmi{fmi}ExitInitializationMode failed")),
            "{e}"
        );
    }
}

/// Item 3: `fmi2Discard` with `fmi2Terminated` (the car left the map) ends the run at the last
/// completed communication point, judged on the signals seen so far — not an error.
#[test]
fn a_stop_request_ends_the_run_at_the_last_completed_point() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("stop{fmi}"));
        let fmu = braking(&dir, fmi, true);
        // 20 m/s towards an obstacle 40 m ahead collides when the map is long enough …
        let mut full = simulator(&fmu, spec(Vec::new())).unwrap();
        let r = run(&mut full, 20.0).unwrap();
        assert!(r.failure);
        // … but the map ends after 10 m: at 1 m per step of 0.05 s, 10 steps complete, the 11th is
        // discarded and the run ends there, before any collision. The instance is reused after it.
        let map = Fixed {
            fmu_variable: "map_length".into(),
            value: Value::Real(10.0),
        };
        let mut short = simulator(&fmu, spec(vec![map])).unwrap();
        for _ in 0..3 {
            let r = run(&mut short, 20.0).unwrap();
            assert!(!r.failure, "judged on the signals before the stop request");
            assert_eq!(r.work, Some(10), "ten completed steps");
        }
        // Through the kernel's Simulator interface too (what a campaign calls): a result, no error.
        let r = savme_kernel::Simulator::simulate_as(
            &mut short,
            Role::High,
            "brake",
            &Assignment::new().with("v", 20.0),
            &Assignment::new(),
        )
        .unwrap();
        assert!(!r.failure);
    }
}

/// Item 4: the FMU's log messages (printf-style, formatted by savme's logger) come with the
/// error of the failed call — and so with the trial's log line.
#[test]
fn a_failed_call_carries_the_fmus_log_messages() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("log{fmi}"));
        let fmu = braking(&dir, fmi, false);
        let mut sim = simulator(&fmu, spec(Vec::new())).unwrap();
        for _ in 0..2 {
            let e = run(&mut sim, 10.0).unwrap_err().to_string();
            assert!(
                e.contains(&format!(
                    "fmi{fmi}ExitInitializationMode failed (fmi{fmi}Error)"
                )),
                "{e}"
            );
            // "cannot open %s: %s" with the path and strerror, formatted.
            assert!(
                e.contains("; the FMU logged: [error] cannot open /")
                    && e.contains("/resources/friction.txt: No such file or directory"),
                "{e}"
            );
            // Each run starts with an empty log: the message appears once.
            assert_eq!(e.matches("cannot open").count(), 1, "{e}");
        }
    }
}

/// With `fmu_log` every message (also the informational ones the FMU only sends with
/// `loggingOn`) is printed to standard error as it comes: here through a real worker process
/// (`savme-fmu-worker`, what `savme run` starts with `isolate = true`), whose standard error
/// the test reads.
#[test]
fn fmu_log_prints_every_message() {
    use std::io::Write;
    for fmi in BOTH {
        let dir = temp_dir(&format!("log-all{fmi}"));
        let fmu = braking(&dir, fmi, true);
        for fmu_log in [true, false] {
            let init = savme_fmu::worker::WorkerInit {
                hf: fmu.clone(),
                lf: fmu.clone(),
                spec: RunSpec {
                    fmu_log,
                    ..spec(Vec::new())
                },
                fidelity: None,
                phi: [("brake".to_string(), phi_space())].into_iter().collect(),
            };
            let request = savme_fmu::worker::WorkerRequest {
                role: savme_kernel::Role::High,
                scenario: "brake".into(),
                phi: Assignment::new().with("v", 10.0),
                fidelity: Assignment::new(),
                record: Vec::new(),
            };
            let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_savme-fmu-worker"))
                .stdin(std::process::Stdio::piped())
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap();
            let mut stdin = child.stdin.take().unwrap();
            writeln!(stdin, "{}", serde_json::to_string(&init).unwrap()).unwrap();
            writeln!(stdin, "{}", serde_json::to_string(&request).unwrap()).unwrap();
            drop(stdin);
            let out = child.wait_with_output().unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(stdout.contains("\"done\""), "{stdout}");
            let line = format!(
                "{} [savme-hf] ok logAll: friction 0.80 for the dry road from /",
                fmu.display()
            );
            assert_eq!(
                stderr.contains(&line),
                fmu_log,
                "fmu_log {fmu_log}: {stderr}"
            );
        }
    }
}

/// Item 2: the communication step size and the tolerance handed to `fmi2SetupExperiment` are
/// fidelity variables of their own, bound to no FMU variable — for an FMU (like `braking`)
/// without a fidelity parameter.
#[test]
fn the_step_size_and_the_tolerance_can_be_the_fidelity() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("step-fidelity{fmi}"));
        let fmu = braking(&dir, fmi, true);
        let theta_space = Space::new(vec![
            Variable::discrete("h", [0.4, 0.1, 0.02]),
            Variable::discrete("tol", [1.0, 0.01]),
        ])
        .unwrap();
        let file = Arc::new(FmuFile::open(&fmu).unwrap());
        let phi = phi_space();
        let mut sim = FmuSimulator::new(
            file.clone(),
            file,
            RunSpec {
                step: StepSize::Of("h".into()),
                tolerance: Some(savme_fmu::Tolerance::Of("tol".into())),
                ..spec(Vec::new())
            },
            Some(&theta_space),
            &|_| Some(phi.clone()),
        )
        .unwrap();
        let mut at = |v: f64, h: f64, tol: f64| {
            let theta = Assignment::new().with("h", h).with("tol", tol);
            sim.run(
                Role::Learned,
                "brake",
                &Assignment::new().with("v", v),
                &theta,
            )
            .unwrap()
        };
        // The work is the FMU's Euler steps: one per communication step over 8 s, or sub-steps of
        // at most `tolerance` seconds when the tolerance is smaller than the step.
        assert_eq!(at(10.0, 0.1, 1.0).work, Some(80));
        assert_eq!(at(10.0, 0.4, 1.0).work, Some(20));
        // On the grid n·h some steps are 0.1 s plus a few ulps, which this FMU splits into 11
        // sub-steps of at most 0.01 s: 840, as FMPy 0.3 counts too (`simulate_fmu(…,
        // output_interval=0.1, relative_tolerance=0.01)` ends with steps = 840).
        assert_eq!(at(10.0, 0.1, 0.01).work, Some(840));
        // And the fidelity changes the verdict: at 19 m/s the car stops about 2 m short of the
        // obstacle, which explicit Euler at 0.4 s overshoots (by about v·h/2 = 3.8 m).
        assert!(at(19.0, 0.4, 1.0).failure);
        assert!(!at(19.0, 0.02, 1.0).failure);
        assert!(!at(19.0, 0.4, 0.01).failure, "sub-steps of 0.01 s");
    }
}

fn fixed(name: &str, value: Value) -> Fixed {
    Fixed {
        fmu_variable: name.into(),
        value,
    }
}

/// Item 6: φ ranges, fixed values and θ values are checked against the `min` / `max` the
/// model description declares, before any run, naming the variable and its bounds.
#[test]
fn values_outside_the_declared_bounds_are_refused_before_any_run() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("bounds{fmi}"));
        let fmu = braking(&dir, fmi, true);
        let file = Arc::new(FmuFile::open(&fmu).unwrap());
        let build = |spec: RunSpec, phi: Space, theta: Option<Space>| {
            FmuSimulator::new(file.clone(), file.clone(), spec, theta.as_ref(), &|_| {
                Some(phi.clone())
            })
            .map(|_| ())
            .unwrap_err()
            .to_string()
        };
        let wide = Space::new(vec![Variable::continuous(
            "v",
            0.0,
            100.0,
            4,
            Scale::Linear,
        )])
        .unwrap();
        let e = build(spec(Vec::new()), wide, None);
        assert_eq!(
        e,
        format!(
            "{}: variable `speed0` is declared in [4, 25] (min/max); φ `v` ranges over [0, 100], outside it",
            fmu.display()
        )
    );
        let e = build(
            spec(vec![fixed("gap", Value::Real(500.0))]),
            phi_space(),
            None,
        );
        assert!(
        e.ends_with(
            "variable `gap` is declared in [1, 200] (min/max); the fixed value 500 lies outside"
        ),
        "{e}"
    );
        let theta = Space::new(vec![Variable::discrete("m", [-1.0, 5.0])]).unwrap();
        let e = build(
            RunSpec {
                fidelity: vec![Binding {
                    variable: "m".into(),
                    fmu_variable: "map_length".into(),
                    labels: None,
                }],
                ..spec(Vec::new())
            },
            phi_space(),
            Some(theta),
        );
        assert!(
        e.ends_with(
            "variable `map_length` is declared in [0, inf] (min/max); θ `m` value -1 lies outside"
        ),
        "{e}"
    );
    }
}

/// Item 6: an enumeration is set through `fmi2SetInteger`, by item name or value — fixed or
/// searched (φ labels are item names); a value that is no item is refused before any run.
#[test]
fn enumerations_are_set_by_item_name_or_value() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("enum{fmi}"));
        let fmu = braking(&dir, fmi, true);
        // 10 m/s on a 40 m gap: stops in time on a dry or wet road, not on ice.
        let verdict = |road: Value| {
            let mut sim = simulator(&fmu, spec(vec![fixed("road", road)])).unwrap();
            run(&mut sim, 10.0).unwrap().failure
        };
        assert!(!verdict(Value::from("dry")));
        assert!(!verdict(Value::from("wet")));
        assert!(verdict(Value::from("ice")));
        assert!(verdict(Value::Int(3)));
        for (bad, shown) in [(Value::from("snow"), "snow"), (Value::Int(4), "4")] {
            let e = simulator(&fmu, spec(vec![fixed("road", bad)]))
                .unwrap_err()
                .to_string();
            assert!(
            e.ends_with(&format!(
                "variable `road` is an enumeration (dry = 1, wet = 2, ice = 3); the fixed value {shown} is none of its items (give an item's name or value)"
            )),
            "{e}"
        );
        }
        // Searched: φ with the item names as labels.
        let file = Arc::new(FmuFile::open(&fmu).unwrap());
        let phi = Space::new(vec![
            Variable::continuous("v", 5.0, 25.0, 4, Scale::Linear),
            Variable::discrete("surface", ["dry", "ice"]),
        ])
        .unwrap();
        let mut s = spec(Vec::new());
        s.scenarios[0].phi.push(Binding {
            variable: "surface".into(),
            fmu_variable: "road".into(),
            labels: Some(vec!["dry".into(), "ice".into()]),
        });
        let mut sim =
            FmuSimulator::new(file.clone(), file, s, None, &|_| Some(phi.clone())).unwrap();
        for (surface, failure) in [("dry", false), ("ice", true)] {
            let phi = Assignment::new().with("v", 10.0).with("surface", surface);
            let r = sim
                .run(Role::High, "brake", &phi, &Assignment::new())
                .unwrap();
            assert_eq!(r.failure, failure, "{surface}");
        }
    }
}

/// Item 6: a String parameter can be fixed (`fmi2SetString`); a value the FMU rejects fails in
/// initialisation with its message.
#[test]
fn string_parameters_can_be_fixed() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("string{fmi}"));
        let fmu = braking(&dir, fmi, true);
        // 16 m/s on 40 m: an alert driver (0.8 s) stops in time, a distracted one (1.6 s) does not.
        for (driver, failure) in [("alert", false), ("distracted", true)] {
            let mut sim =
                simulator(&fmu, spec(vec![fixed("driver", Value::from(driver))])).unwrap();
            assert_eq!(run(&mut sim, 16.0).unwrap().failure, failure, "{driver}");
        }
        let mut sim = simulator(&fmu, spec(vec![fixed("driver", Value::from("sleepy"))])).unwrap();
        let e = run(&mut sim, 15.0).unwrap_err().to_string();
        assert!(
            e.ends_with("unknown driver profile 'sleepy' (expected alert or distracted)"),
            "{e}"
        );
        // A number is not a string.
        let e = simulator(&fmu, spec(vec![fixed("driver", Value::Int(1))]))
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("variable `driver` is String, expected a variable that takes the value 1"),
            "{e}"
        );
    }
}

/// The braking FMU declaring `canBeInstantiatedOnlyOncePerProcess="true"`, built to refuse a
/// second live instance.
fn braking_once(dir: &Path) -> PathBuf {
    let out = dir.join("braking-once.fmu");
    let xml = savme_fmu_testkit::BRAKING_MODEL_DESCRIPTION.replacen(
        "canNotUseMemoryManagementFunctions=\"true\"",
        "canNotUseMemoryManagementFunctions=\"true\" canBeInstantiatedOnlyOncePerProcess=\"true\"",
        1,
    );
    savme_fmu_testkit::pack_braking_library(
        &out,
        &xml,
        true,
        &savme_fmu_testkit::braking_once_library(),
    )
    .unwrap();
    out
}

/// Item 6: `canBeInstantiatedOnlyOncePerProcess="true"` is refused in-process (a campaign runs
/// several instances) and runs isolated, where the worker keeps one instance at a time even
/// when the HF and LF runs alternate on the same FMU.
#[test]
fn an_fmu_instantiable_once_per_process_runs_isolated_only() {
    use savme_fmu::worker::WorkerInit;
    use savme_fmu::FmuBackend;
    use savme_kernel::Simulator;
    let dir = temp_dir("once");
    let fmu = braking_once(&dir);
    // The library really refuses a second instance.
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    assert!(file.only_once_per_process());
    let first = Instance::new(file.clone(), "first").unwrap();
    let e = Instance::new(file.clone(), "second")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("fmi2Instantiate failed (returned no instance); the FMU logged: [error] an instance is alive"),
        "{e}"
    );
    drop(first);
    let init = WorkerInit {
        hf: fmu.clone(),
        lf: fmu.clone(),
        spec: spec(Vec::new()),
        fidelity: None,
        phi: [("brake".to_string(), phi_space())].into_iter().collect(),
    };
    let e = FmuBackend::new(&init, None, std::time::Duration::from_secs(30)).unwrap_err();
    assert!(
        e.to_string().ends_with("the FMU declares canBeInstantiatedOnlyOncePerProcess=\"true\": savme runs it in worker processes only (set [fmu] isolate = true)"),
        "{e}"
    );
    let worker = vec![env!("CARGO_BIN_EXE_savme-fmu-worker").to_string()];
    let mut backend =
        FmuBackend::new(&init, Some(worker), std::time::Duration::from_secs(30)).unwrap();
    for k in 0..4 {
        let role = if k % 2 == 0 {
            Role::High
        } else {
            Role::Learned
        };
        let phi = Assignment::new().with("v", 10.0);
        let r = backend.simulate_as(role, "brake", &phi, &Assignment::new());
        assert!(!r.unwrap().failure, "run {k}");
    }
}

/// Item 6 in a campaign file: an FMU instantiable once per process forces isolation, and its
/// library is not loaded by the check (the workers load it). (And `[fmu] log = true` is item 4's
/// config key.)
#[test]
fn a_campaign_on_an_fmu_instantiable_once_is_isolated() {
    let dir = temp_dir("once-campaign");
    braking_once(&dir);
    let path = dir.join("campaign.toml");
    std::fs::write(
        &path,
        r#"
[fmu]
hf = "braking-once.fmu"
stop_time = 8.0
cost = "steps"
isolate = false
log = true

[failure]
boolean = "collision"

[fidelity]
[[fidelity.variable]]
name = "step"
drives = "step_size"
values = [0.1, 0.01]
hf = 0.01

[[scenario]]
name = "ice"
role = "train"
fixed = { road = "ice", driver = "alert" }
[[scenario.phi]]
name = "speed0"
range = [5.0, 20.0]
"#,
    )
    .unwrap();
    let f = savme_fmu::campaign_file::FmuCampaignFile::load(&path, &|_| unreachable!()).unwrap();
    assert!(f.isolate, "forced by canBeInstantiatedOnlyOncePerProcess");
    assert!(f.init.spec.fmu_log, "[fmu] log = true");
}

/// Item 5: with isolation the FMU's library is loaded in the worker only — one that crashes
/// while loading (SIGBUS in its constructor) is reported naming the FMU, before any run, and
/// neither the campaign-file check nor the backend loads it in this process (which would kill
/// this test).
#[test]
fn a_library_crashing_while_loading_is_reported_naming_the_fmu() {
    use savme_fmu::FmuBackend;
    let dir = temp_dir("crash-on-load");
    let fmu = dir.join("braking.fmu");
    savme_fmu_testkit::pack_braking_library(
        &fmu,
        savme_fmu_testkit::BRAKING_MODEL_DESCRIPTION,
        true,
        &savme_fmu_testkit::crash_on_load_library(),
    )
    .unwrap();
    let path = dir.join("campaign.toml");
    std::fs::write(
        &path,
        r#"
[fmu]
hf = "braking.fmu"
stop_time = 8.0
step = 0.1
isolate = true

[failure]
boolean = "collision"

[fidelity]
[[fidelity.variable]]
name = "road"
values = ["dry", "ice"]
hf = "dry"

[[scenario]]
name = "s"
role = "train"
[[scenario.phi]]
name = "speed0"
range = [5.0, 20.0]
"#,
    )
    .unwrap();
    let f = savme_fmu::campaign_file::FmuCampaignFile::load(&path, &|_| unreachable!()).unwrap();
    let worker = vec![env!("CARGO_BIN_EXE_savme-fmu-worker").to_string()];
    let e = FmuBackend::new(&f.init, Some(worker), std::time::Duration::from_secs(30))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "{}: the FMU worker died while loading this FMU (killed by signal 7 (SIGBUS: the FMU crashed))",
            fmu.display()
        )
    );
}

/// Item 7: FMI 3.0's `fmi3DoStep` outputs. Allowed to return early (savme instantiates with
/// `earlyReturnAllowed`), `braking3` stops at the instant the car reaches the obstacle:
/// [`Step::EarlyReturn`] at `lastSuccessfulTime`, signals read there; `terminateSimulation`
/// after a completed step is a stop request whose signals count.
#[test]
fn fmi3_early_return_and_terminate_simulation() {
    use savme_fmu::instance::Step;
    let dir = temp_dir("fmi3-step");
    let fmu = braking(&dir, 3, true);
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    let var = |n: &str| file.variable(n).unwrap().clone();
    let mut inst = Instance::new(file.clone(), "early").unwrap();
    inst.setup(0.0, Some(8.0), None).unwrap();
    // 20 m/s, 10 m ahead: reached at 0.5 s, before the driver reacts (0.8 s).
    inst.set_real(var("speed0").vr, 20.0).unwrap();
    inst.set_real(var("gap").vr, 10.0).unwrap();
    inst.initialize().unwrap();
    assert_eq!(
        inst.step(0.0, 1.0).unwrap(),
        Step::EarlyReturn { time: 0.5 }
    );
    assert!(inst.boolean(var("collision").vr).unwrap());
    assert_eq!(inst.real(var("distance").vr).unwrap(), 0.0);
    assert_eq!(inst.number(&var("steps")).unwrap(), 1.0, "fmi3GetUInt32");
    assert_eq!(inst.step(0.5, 0.5).unwrap(), Step::Completed);
    // terminateSimulation: the map ends after 5 m, 2 m per step of 0.1 s.
    inst.reset().unwrap();
    inst.setup(0.0, Some(8.0), None).unwrap();
    inst.set_real(var("speed0").vr, 20.0).unwrap();
    inst.set_real(var("map_length").vr, 5.0).unwrap();
    inst.initialize().unwrap();
    assert_eq!(inst.step(0.0, 0.1).unwrap(), Step::Completed);
    assert_eq!(inst.step(0.1, 0.1).unwrap(), Step::Completed);
    let Step::StopRequested {
        terminated: Some(true),
        reached: Some(t),
    } = inst.step(0.2, 0.1).unwrap()
    else {
        panic!("no stop request")
    };
    assert!((t - 0.3).abs() < 1e-12, "{t}");
    // Through the simulator: the run with stop_on_failure ends at the early return (one
    // partial Euler step, on the failure), and the run on the short map after three steps.
    let mut s = spec(vec![fixed("gap", Value::Real(10.0))]);
    s.stop_on_failure = true;
    s.step = StepSize::Fixed(1.0);
    let mut sim = simulator(&fmu, s).unwrap();
    let r = run(&mut sim, 20.0).unwrap();
    assert!(r.failure);
    assert_eq!(r.work, Some(1));
    let mut s = spec(vec![fixed("map_length", Value::Real(5.0))]);
    s.step = StepSize::Fixed(0.1);
    let mut sim = simulator(&fmu, s).unwrap();
    let r = run(&mut sim, 20.0).unwrap();
    assert_eq!((r.failure, r.work), (false, Some(3)));
}

/// Item 7: the FMI 3.0 model description — its types (Float64, UInt32, Enumeration with
/// Int64 access, String with a `<Start>` element), the independent variable and
/// `ModelStructure` — read into the same variables as FMI 2.0's.
#[test]
fn the_fmi3_model_description_reads_like_fmi2() {
    use savme_fmu::{Repr, VarCausality, VarType};
    let dir = temp_dir("fmi3-md");
    let two = FmuFile::open(&braking(&dir, 2, true)).unwrap();
    let three = FmuFile::open(&braking(&dir, 3, true)).unwrap();
    assert!(three.model.is_fmi3() && !two.model.is_fmi3());
    for name in [
        "speed0",
        "gap",
        "road",
        "driver",
        "map_length",
        "distance",
        "collision",
    ] {
        let (a, b) = (two.variable(name).unwrap(), three.variable(name).unwrap());
        assert_eq!(
            (
                a.kind,
                a.causality,
                &a.start,
                a.min,
                a.max,
                &a.unit,
                &a.items
            ),
            (
                b.kind,
                b.causality,
                &b.start,
                b.min,
                b.max,
                &b.unit,
                &b.items
            ),
            "{name}"
        );
    }
    assert_eq!(
        three.variable("driver").unwrap().start.as_deref(),
        Some("alert")
    );
    assert_eq!(three.variable("road").unwrap().repr, Repr::Int64);
    assert_eq!(two.variable("road").unwrap().repr, Repr::Int32);
    let steps = three.variable("steps").unwrap();
    assert_eq!((steps.kind, steps.repr), (VarType::Integer, Repr::UInt32));
    let time = three.variable("time").unwrap();
    assert_eq!(time.causality, VarCausality::Independent);
    assert_eq!(two.model.structure_outputs, vec![5, 6, 7, 8]);
    assert_eq!(three.model.structure_outputs, vec![5, 6, 7, 8]);
    // A value outside an FMI 3.0 integer type's range is refused before any run.
    let phi = Space::new(vec![Variable::discrete("surface", [1i64, 300])]).unwrap();
    let mut s = spec(Vec::new());
    s.scenarios[0].phi = vec![Binding {
        variable: "surface".into(),
        fmu_variable: "road".into(),
        labels: None,
    }];
    let file = Arc::new(three);
    let e = FmuSimulator::new(file.clone(), file, s, None, &|_| Some(phi.clone()))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("variable `road` is an enumeration"), "{e}");
}

/// Issue 42: `robustness` beside the Boolean `collision` — every run keeps the flag's verdict
/// and reports the output's smallest value over its communication points as ρ (FMI 2.0 and
/// 3.0): the clearance `distance`, ≤ 0 exactly on a collision here. A robustness output that
/// disagrees with the flag (`speed`: 0 on a pass that stops in time, above 0 at a collision)
/// does not change the verdict: ρ is passed on as the output reports it.
#[test]
fn a_boolean_failures_robustness_output_is_its_smallest_value() {
    for fmi in BOTH {
        let dir = temp_dir(&format!("robustness{fmi}"));
        let fmu = braking(&dir, fmi, true);
        // As the example campaign runs: stopped at the collision.
        let stopping = || RunSpec {
            stop_on_failure: true,
            ..spec(Vec::new())
        };
        let with = |output: &str| {
            let mut s = stopping();
            s.failure = Failure::Boolean {
                variable: "collision".into(),
                robustness: Some(output.into()),
            };
            simulator(&fmu, s).unwrap()
        };
        let mut flag = simulator(&fmu, stopping()).unwrap();
        let (mut distance, mut speed) = (with("distance"), with("speed"));
        let mut failures = 0;
        for v in [5.0, 10.0, 15.0, 20.0, 22.5, 25.0] {
            let alone = run(&mut flag, v).unwrap();
            assert_eq!(alone.robustness, None);
            let d = run(&mut distance, v).unwrap();
            let s = run(&mut speed, v).unwrap();
            assert_eq!(
                (d.failure, s.failure),
                (alone.failure, alone.failure),
                "v = {v}"
            );
            assert_eq!((d.work, s.work), (alone.work, alone.work), "v = {v}");
            let rho = d.robustness.unwrap();
            assert_eq!(rho <= 0.0, d.failure, "v = {v}: ρ {rho}");
            // The gap is 40 m: a pass's smallest clearance is below it, above 0.
            assert!(rho < 40.0, "v = {v}: ρ {rho}");
            // Speed falls to 0 while braking (a pass stops: ρ = 0 with no failure), and a
            // collision keeps some speed (ρ > 0 with a failure): both kept as reported.
            let s_rho = s.robustness.unwrap();
            assert!(
                s_rho >= 0.0 && (s_rho > 0.0) == s.failure,
                "v = {v}: {s_rho}"
            );
            failures += usize::from(d.failure);
        }
        assert!((1..6).contains(&failures), "{failures} of 6 failed");
        // The same output twice in a row does not leak between runs (instances are reused).
        let again = run(&mut distance, 5.0).unwrap();
        assert_eq!(
            again.robustness,
            run(&mut distance, 5.0).unwrap().robustness
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// What one braking run costs in process (the peer benchmark's braking family: HF at the
/// 0.01 s step, LF down to 0.4 s; 8 s simulated, stopped at a collision): run with
/// `cargo test --profile bench -p savme-fmu --test vendor print_braking_run_times -- --ignored`.
#[test]
#[ignore = "a timing, printed"]
fn print_braking_run_times() {
    let dir = temp_dir("timing");
    let fmu = braking(&dir, 2, true);
    for (h, stop_on_failure) in [(0.01, true), (0.01, false), (0.4, true), (0.4, false)] {
        let mut s = spec(Vec::new());
        s.step = StepSize::Fixed(h);
        s.stop_on_failure = stop_on_failure;
        let mut sim = simulator(&fmu, s).unwrap();
        let speeds: Vec<f64> = (0..200)
            .map(|i| 5.0 + 20.0 * f64::from(i) / 199.0)
            .collect();
        for &v in &speeds {
            run(&mut sim, v).unwrap();
        }
        let start = std::time::Instant::now();
        let mut work = 0;
        for _ in 0..10 {
            for &v in &speeds {
                work += run(&mut sim, v).unwrap().work.unwrap_or(0);
            }
        }
        let per = start.elapsed().as_secs_f64() / 2000.0 * 1e6;
        println!(
            "step {h} s, stop_on_failure {stop_on_failure}: {per:.2} µs per run, {:.1} steps",
            work as f64 / 2000.0
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

//! The adapter on FMUs as vendors ship them: the `braking` FMU written in C against the FMI 2.0
//! C API (compiled by the test kit's build script from `examples/fmu/braking`), which reads a
//! resource file during initialisation, asks to end the simulation, logs through the
//! environment's logger, and declares bounds, an enumeration and a String parameter.
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

/// The `braking` FMU packed into `dir` (with its resources unless `with_resources` is false).
fn braking(dir: &Path, with_resources: bool) -> PathBuf {
    let out = dir.join("braking.fmu");
    savme_fmu_testkit::pack_braking(
        &out,
        savme_fmu_testkit::BRAKING_MODEL_DESCRIPTION,
        with_resources,
    )
    .unwrap();
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
    FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(phi.clone()), None)
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
    let dir = temp_dir("resources");
    let fmu = braking(&dir, true);
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    let uri = file.resource_uri.to_str().unwrap().to_string();
    assert!(
        uri.starts_with("file:///") && uri.ends_with("/resources"),
        "{uri}"
    );
    let friction = file.variable("friction").unwrap().vr;
    let road = file.variable("road").unwrap().vr;
    for (surface, mu) in [(1, 0.8), (2, 0.5), (3, 0.15)] {
        let mut inst = Instance::new(file.clone(), "resources").unwrap();
        inst.setup(0.0, Some(1.0), None).unwrap();
        inst.set_integer(road, surface).unwrap();
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

/// Without its resources the FMU cannot initialise: the error names the FMU and the call.
#[test]
fn an_fmu_without_its_resources_fails_to_initialise_naming_the_call() {
    let dir = temp_dir("no-resources");
    let fmu = braking(&dir, false);
    let mut sim = simulator(&fmu, spec(Vec::new())).unwrap();
    let e = run(&mut sim, 10.0).unwrap_err().to_string();
    assert!(e.contains(&fmu.display().to_string()), "{e}");
    assert!(e.contains("fmi2ExitInitializationMode failed"), "{e}");
}

/// Item 3: `fmi2Discard` with `fmi2Terminated` (the car left the map) ends the run at the last
/// completed communication point, judged on the signals seen so far — not an error.
#[test]
fn a_stop_request_ends_the_run_at_the_last_completed_point() {
    let dir = temp_dir("stop");
    let fmu = braking(&dir, true);
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
    let r = savme_kernel::Simulator::simulate(
        &mut short,
        "brake",
        &Assignment::new().with("v", 20.0),
        &Assignment::new(),
    )
    .unwrap();
    assert!(!r.failure);
}

/// Item 4: the FMU's log messages (printf-style, formatted by savme's logger) come with the
/// error of the failed call — and so with the trial's log line.
#[test]
fn a_failed_call_carries_the_fmus_log_messages() {
    let dir = temp_dir("log");
    let fmu = braking(&dir, false);
    let mut sim = simulator(&fmu, spec(Vec::new())).unwrap();
    for _ in 0..2 {
        let e = run(&mut sim, 10.0).unwrap_err().to_string();
        assert!(
            e.contains("fmi2ExitInitializationMode failed (fmi2Error)"),
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

/// With `fmu_log` every message (also the informational ones the FMU only sends with
/// `loggingOn`) is printed to standard error as it comes: here through a real worker process
/// (`savme-fmu-worker`, what `savme run` starts with `isolate = true`), whose standard error
/// the test reads.
#[test]
fn fmu_log_prints_every_message() {
    use std::io::Write;
    let dir = temp_dir("log-all");
    let fmu = braking(&dir, true);
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
            theta_hf: None,
        };
        let request = savme_fmu::worker::WorkerRequest {
            learned: false,
            scenario: "brake".into(),
            phi: Assignment::new().with("v", 10.0),
            fidelity: Assignment::new(),
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

/// Item 2: the communication step size and the tolerance handed to `fmi2SetupExperiment` are
/// fidelity variables of their own, bound to no FMU variable — for an FMU (like `braking`)
/// without a fidelity parameter.
#[test]
fn the_step_size_and_the_tolerance_can_be_the_fidelity() {
    let dir = temp_dir("step-fidelity");
    let fmu = braking(&dir, true);
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
        None,
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
    assert_eq!(at(10.0, 0.1, 0.01).work, Some(800));
    // And the fidelity changes the verdict: at 19 m/s the car stops about 2 m short of the
    // obstacle, which explicit Euler at 0.4 s overshoots (by about v·h/2 = 3.8 m).
    assert!(at(19.0, 0.4, 1.0).failure);
    assert!(!at(19.0, 0.02, 1.0).failure);
    assert!(!at(19.0, 0.4, 0.01).failure, "sub-steps of 0.01 s");
}

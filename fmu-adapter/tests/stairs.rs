//! Issue 26: verdicts exactly FMPy's on FMUs with the behaviours of third-party FMUs — the
//! `stairs` test FMU (`testkit/c/stairs.c`, FMI 2.0 and 3.0): a failure that holds at t = 0,
//! FMI 3.0 early returns at events a few ulps before a communication point (with a minimum
//! step), an FMU that ends the simulation at the failure (`fmi2Discard` + `fmi2Terminated`,
//! `terminateSimulation`) and whose reset keeps that stop request. Every run is compared with
//! FMPy 0.3 (verdict and the FMU's count of `doStep` calls) when SAVME_FMPY_PYTHON is set, in
//! this process and in an isolated worker.
mod common;
use savme_fmu::worker::WorkerInit;
use savme_fmu::{
    Binding, CostSource, Failure, Fixed, FmuBackend, FmuFile, FmuSimulator, RunSpec, ScenarioSpec,
    StepSize,
};
use savme_kernel::{Assignment, CostMeasure, Role, Scale, SimResult, Simulator, Space, Value};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

const BOTH: [u8; 2] = [2, 3];

fn stairs(dir: &Path, fmi: u8) -> PathBuf {
    let out = dir.join(format!("stairs{fmi}.fmu"));
    savme_fmu_testkit::pack_stairs(&out, fmi, str::to_string).unwrap();
    out
}

/// One case: the fixed values, the step and the stop time.
#[derive(Clone)]
struct Case {
    fixed: Vec<(&'static str, Value)>,
    h: f64,
    stop: f64,
    stop_on_failure: bool,
}

impl Case {
    fn new(fixed: &[(&'static str, Value)], h: f64, stop: f64) -> Case {
        Case {
            fixed: fixed.to_vec(),
            h,
            stop,
            stop_on_failure: false,
        }
    }

    fn spec(&self, cost: CostSource) -> RunSpec {
        RunSpec {
            stop_time: self.stop,
            step: StepSize::Fixed(self.h),
            tolerance: None,
            failure: Failure::Boolean {
                variable: "failed".into(),
            },
            stop_on_failure: self.stop_on_failure,
            cost,
            fidelity: Vec::new(),
            fmu_log: false,
            scenarios: vec![ScenarioSpec {
                name: "s".into(),
                phi: vec![Binding {
                    variable: "threshold".into(),
                    fmu_variable: "threshold".into(),
                    labels: None,
                }],
                fixed: self
                    .fixed
                    .iter()
                    .map(|(n, v)| Fixed {
                        fmu_variable: (*n).into(),
                        value: v.clone(),
                    })
                    .collect(),
            }],
        }
    }
}

fn phi_space() -> Space {
    Space::new(vec![savme_kernel::Variable::continuous(
        "threshold",
        0.1,
        100.0,
        4,
        Scale::Linear,
    )])
    .unwrap()
}

fn in_process(fmu: &Path, spec: RunSpec) -> FmuBackend {
    let file = Arc::new(FmuFile::open(fmu).unwrap());
    let phi = phi_space();
    FmuBackend::InProcess(
        FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(phi.clone()), None).unwrap(),
    )
}

fn isolated(fmu: &Path, spec: RunSpec) -> FmuBackend {
    let init = WorkerInit {
        hf: fmu.to_path_buf(),
        lf: fmu.to_path_buf(),
        spec,
        fidelity: None,
        phi: [("s".to_string(), phi_space())].into_iter().collect(),
        theta_hf: None,
    };
    let worker = vec![env!("CARGO_BIN_EXE_savme-fmu-worker").to_string()];
    FmuBackend::new(&init, Some(worker), Duration::from_secs(60)).unwrap()
}

fn run(sim: &mut FmuBackend, threshold: f64) -> SimResult {
    let phi = Assignment::new().with("threshold", threshold);
    sim.simulate_as(Role::High, "s", &phi, &Assignment::new())
        .unwrap_or_else(|e| panic!("threshold {threshold}: {e}"))
}

/// FMPy's verdict (the failure signal at the end: it only grows) and the FMU's `doStep` count,
/// for each threshold.
fn fmpy(python: &str, fmu: &Path, case: &Case, thresholds: &[f64]) -> Vec<(bool, u64)> {
    let start: Vec<String> = case
        .fixed
        .iter()
        .map(|(n, v)| {
            let v = match v {
                Value::Bool(b) => if *b { "True" } else { "False" }.to_string(),
                other => other.as_f64().unwrap().to_string(),
            };
            format!("'{n}': {v}")
        })
        .collect();
    let script = format!(
        "import fmpy\n\
         for th in {thresholds:?}:\n    \
         r = fmpy.simulate_fmu(r'{}', start_values={{{} 'threshold': th}}, stop_time={:?}, \
         output_interval={:?}, output=['failed', 'steps'], early_return_allowed=True)\n    \
         print(bool(r['failed'][-1]), int(r['steps'][-1]))\n",
        fmu.display(),
        start.iter().map(|s| format!("{s},")).collect::<String>(),
        case.stop,
        case.h,
    );
    let o = std::process::Command::new(python)
        .arg("-c")
        .arg(&script)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| {
            let (f, n) = l.split_once(' ').unwrap();
            (f == "True", n.parse().unwrap())
        })
        .collect()
}

/// Runs `case` at each threshold on both versions, in this process and isolated, with the
/// work counted by savme and read from the FMU's `steps`: the verdicts and work are
/// `expected` (a run is at least one unit of work), and FMPy's when it is there.
fn check(name: &str, case: &Case, thresholds: &[f64], expected: &[[(bool, u64); 2]]) {
    let python = common::fmpy_python();
    for fmi in BOTH {
        let dir = common::temp_dir("savme-stairs", &format!("{name}{fmi}"));
        let fmu = stairs(&dir, fmi);
        let want: Vec<(bool, u64)> = expected.iter().map(|e| e[usize::from(fmi == 3)]).collect();
        if let Some(python) = &python {
            let theirs = fmpy(python, &fmu, case, thresholds);
            let theirs: Vec<(bool, u64)> = theirs.into_iter().map(|(f, n)| (f, n.max(1))).collect();
            assert_eq!(theirs, want, "FMPy, FMI {fmi}, {name}");
        }
        for cost in [CostSource::Wall, CostSource::Output("steps".into())] {
            for (how, mut sim) in [
                ("in-process", in_process(&fmu, case.spec(cost.clone()))),
                ("isolated", isolated(&fmu, case.spec(cost.clone()))),
            ] {
                // Twice over: an instance reused after a stop request must not change a verdict.
                for round in 0..2 {
                    let ours: Vec<(bool, u64)> = thresholds
                        .iter()
                        .map(|th| {
                            let r = run(&mut sim, *th);
                            (r.failure, r.work.unwrap())
                        })
                        .collect();
                    assert_eq!(ours, want, "FMI {fmi} {name} {how} {cost:?} round {round}");
                }
            }
        }
    }
}

/// Item 1: a failure that holds at t = 0 (x0 above the threshold) is a verdict like any other:
/// the run goes on to the stop time as in FMPy, or — stopping on the failure — ends at
/// initialisation with one unit of work, which the kernel takes (a zero cost aborted the
/// campaign).
#[test]
fn a_failure_at_time_zero_is_told() {
    let case = Case::new(&[("x0", Value::Real(6.0))], 0.5, 5.0);
    check(
        "t0",
        &case,
        &[5.0, 20.0],
        &[[(true, 10); 2], [(false, 10); 2]],
    );
    let stopping = Case {
        stop_on_failure: true,
        ..case
    };
    for fmi in BOTH {
        let dir = common::temp_dir("savme-stairs", &format!("t0-stop{fmi}"));
        let fmu = stairs(&dir, fmi);
        for cost in [CostSource::Wall, CostSource::Output("steps".into())] {
            let mut sim = in_process(&fmu, stopping.spec(cost));
            let r = run(&mut sim, 5.0);
            assert_eq!((r.failure, r.work), (true, Some(1)));
            let told = r.run(CostMeasure::Work).unwrap();
            assert!(told.runtime >= 1.0, "{}", told.runtime);
            assert!(r.run(CostMeasure::Wall).unwrap().runtime > 0.0);
        }
    }
}

/// Item 2: FMI 3.0 early returns at events k·period computed by the FMU. With a period of
/// 0.3 s on a 0.1 s grid, each event lands a few ulps before a communication point: it counts
/// as reached (no near-zero step, which this FMU refuses below 1e-9 s), so the `doStep` count
/// is FMPy's 100; with 0.25 s, half the events fall inside a step: 20 early returns more.
/// FMI 2.0 has no early return: 100 steps either way.
#[test]
fn fmi3_early_returns_keep_fmpys_grid() {
    for (period, fmi3_steps) in [(0.3, 100), (0.25, 120), (0.1, 100)] {
        let case = Case::new(
            &[
                ("period", Value::Real(period)),
                ("jump", Value::Real(1.0)),
                ("rate", Value::Real(0.0)),
            ],
            0.1,
            10.0,
        );
        // 33 (or 40, 100) jumps of 1: a failure above, not below.
        let events = (10.0 / period + 1e-9).floor();
        check(
            &format!("early{period}"),
            &case,
            &[events - 0.5, events + 0.5],
            &[
                [(true, 100), (true, fmi3_steps)],
                [(false, 100), (false, fmi3_steps)],
            ],
        );
    }
}

/// Items 3 and 4: the FMU ends the simulation at the instant x reaches the threshold —
/// `fmi2Discard` with `fmi2Terminated` and `fmi2LastSuccessfulTime` there (FMI 2.0),
/// `terminateSimulation` with an early return there (FMI 3.0) — and its reset keeps that stop
/// request. Judged at the last successful time, both versions say "failure" where FMPy does,
/// with FMPy's step count; and a fresh instance after every stop keeps the later runs right
/// (a reused one would refuse every step and be judged "no failure" on its initial state).
#[test]
fn a_stop_at_the_failure_is_a_failure_and_the_instance_is_not_reused() {
    let case = Case::new(&[("stop_at_failure", Value::Bool(true))], 0.1, 10.0);
    check(
        "stop",
        &case,
        &[2.05, 7.05, 50.0, 0.55, 99.0],
        &[
            [(true, 21); 2],
            [(true, 71); 2],
            [(false, 100); 2],
            [(true, 6); 2],
            [(false, 100); 2],
        ],
    );
}

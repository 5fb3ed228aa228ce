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
                robustness: None,
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
        FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(phi.clone())).unwrap(),
    )
}

fn isolated(fmu: &Path, spec: RunSpec) -> FmuBackend {
    let init = WorkerInit {
        hf: fmu.to_path_buf(),
        lf: fmu.to_path_buf(),
        spec,
        fidelity: None,
        phi: [("s".to_string(), phi_space())].into_iter().collect(),
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
    fmpy_verdicts(python, &script)
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

/// Item 7: an FMU declaring `canHandleVariableCommunicationStepSize="false"` takes one step
/// size: a step that does not divide the stop time is refused before any run, naming the FMU,
/// the step and the stop time (FMPy would silently stop one step short); one that divides it
/// runs as FMPy runs it. A fidelity variable as the step size is checked value by value.
#[test]
fn a_fixed_step_fmu_refuses_a_step_that_does_not_divide_the_stop_time() {
    for fmi in BOTH {
        let dir = common::temp_dir("savme-stairs", &format!("fixed-step{fmi}"));
        let fmu = dir.join(format!("fixed{fmi}.fmu"));
        savme_fmu_testkit::pack_stairs(&fmu, fmi, |xml| {
            xml.replacen(
                "canHandleVariableCommunicationStepSize=\"true\"",
                "canHandleVariableCommunicationStepSize=\"false\"",
                1,
            )
        })
        .unwrap();
        let file = Arc::new(FmuFile::open(&fmu).unwrap());
        let phi = phi_space();
        let build = |spec: RunSpec, theta: Option<&Space>| {
            FmuSimulator::new(file.clone(), file.clone(), spec, theta, &|_| {
                Some(phi.clone())
            })
        };
        let e = build(Case::new(&[], 0.3, 10.0).spec(CostSource::Wall), None)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            format!(
                "run specification: {}: the FMU declares canHandleVariableCommunicationStepSize=\"false\" (one step size only), \
                 but the stop time 10 s is not a whole number of steps of 0.3 s: choose a step that divides the stop time \
                 (e.g. 0.294117647059) or a stop time that is a multiple of it (e.g. 9.9)",
                fmu.display()
            )
        );
        // A step size from a fidelity variable: each listed value is checked.
        let theta = Space::new(vec![savme_kernel::Variable::discrete("h", [0.5, 0.3])]).unwrap();
        let mut spec = Case::new(&[], 0.1, 10.0).spec(CostSource::Wall);
        spec.step = StepSize::Of("h".into());
        let e = build(spec.clone(), Some(&theta)).map(|_| ()).unwrap_err();
        assert!(e.to_string().contains("steps of 0.3 s"), "{e}");
        let theta = Space::new(vec![savme_kernel::Variable::discrete("h", [0.5, 0.1])]).unwrap();
        assert!(build(spec, Some(&theta)).is_ok());
        // 0.1 s divides 10 s (within FMPy's 1e-9): runs, as in FMPy.
        let case = Case::new(&[], 0.1, 10.0);
        let mut sim = FmuBackend::InProcess(build(case.spec(CostSource::Wall), None).unwrap());
        let ours = run(&mut sim, 7.05);
        assert_eq!((ours.failure, ours.work), (true, Some(100)));
        if let Some(python) = common::fmpy_python() {
            assert_eq!(fmpy(&python, &fmu, &case, &[7.05]), vec![(true, 100)]);
        }
    }
}

/// The FMI 3.0 `stairs` FMU with `edit` applied to its model description.
fn stairs3_edited(dir: &Path, name: &str, edit: impl FnOnce(&str) -> String) -> PathBuf {
    let out = dir.join(name);
    savme_fmu_testkit::pack_stairs(&out, 3, edit).unwrap();
    out
}

/// Item 6: FMI 3.0 `<Alias>` names are variables of their own — shown by `fmu info` as
/// aliases, bindable as φ, failure signal or cost, with the verdicts of the names they alias
/// (and FMPy's, which is run with the aliased names).
#[test]
fn fmi3_aliases_are_shown_and_bindable() {
    let dir = common::temp_dir("savme-stairs", "alias");
    let fmu = stairs3_edited(&dir, "alias.fmu", |xml| {
        xml.replacen(
            r#"<Float64 name="x" valueReference="7" causality="output" variability="continuous" initial="calculated"/>"#,
            r#"<Float64 name="x" valueReference="7" causality="output" variability="continuous" initial="calculated"><Alias name="h_ft" description="x, in feet"/></Float64>"#,
            1,
        )
        .replacen(
            r#"initial="exact" start="5"/>"#,
            r#"initial="exact" start="5"><Alias name="limit"/></Float64>"#,
            1,
        )
    });
    let text = savme_fmu::inspect::Info::read(&fmu).unwrap().text();
    let row = |name: &str| {
        text.lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
            .unwrap_or_else(|| panic!("no row {name}: {text}"))
    };
    assert_eq!(row("h_ft"), "h_ft output Float64 alias of x: x, in feet");
    assert_eq!(row("limit"), "limit parameter Float64 5 alias of threshold");
    assert!(savme_fmu::inspect::problems(&fmu).is_empty());
    let file = FmuFile::open(&fmu).unwrap();
    assert_eq!(
        file.variable("h_ft").unwrap().vr,
        file.variable("x").unwrap().vr
    );
    // Bound through the aliases: φ → `limit`, failure: `h_ft` ≥ 7.05, cost: `steps`.
    let case = Case::new(&[], 0.1, 10.0);
    let mut spec = case.spec(CostSource::Output("steps".into()));
    spec.scenarios[0].phi[0].fmu_variable = "limit".into();
    spec.failure = Failure::Threshold {
        variable: "h_ft".into(),
        when: savme_fmu::Crossing::Above,
        value: 7.05,
    };
    let mut sim = in_process(&fmu, spec.clone());
    let mut iso = isolated(&fmu, spec);
    // The threshold parameter (`limit`) decides `failed`, not the verdict here: h_ft = x = t.
    for (limit, failure) in [(2.0, true), (50.0, true)] {
        for s in [&mut sim, &mut iso] {
            let r = run(s, limit);
            assert_eq!((r.failure, r.work), (failure, Some(100)), "limit {limit}");
        }
    }
    let mut short = Case::new(&[], 0.1, 5.0).spec(CostSource::Wall);
    short.scenarios[0].phi[0].fmu_variable = "limit".into();
    let mut sim = in_process(&fmu, short);
    for (limit, failure) in [(2.0, true), (50.0, false)] {
        let r = run(&mut sim, limit);
        assert_eq!((r.failure, r.work), (failure, Some(50)), "limit {limit}");
        if let Some(python) = common::fmpy_python() {
            let theirs = fmpy(&python, &fmu, &Case::new(&[], 0.1, 5.0), &[limit]);
            assert_eq!(theirs, vec![(failure, 50)]);
        }
    }
    // An alias name taken twice is refused like any duplicate name.
    let dup = stairs3_edited(&dir, "dup.fmu", |xml| {
        xml.replacen(
            r#"initial="exact" start="5"/>"#,
            r#"initial="exact" start="5"><Alias name="rate"/></Float64>"#,
            1,
        )
    });
    let e = FmuFile::open(&dup).unwrap_err().to_string();
    assert!(
        e.contains("modelDescription.xml: line ")
            && e.ends_with(": variable `rate` is declared twice (first at line 11, column 5)"),
        "{e}"
    );
}

/// Item 5 and 6: an FMI 3.0 FMU with an array (its start a list), a Binary and a Clock is
/// valid — `fmu validate` finds no problem, as FMPy — and `fmu info` names their types; an
/// array is refused as a binding, naming it; a ScheduledExecution-only FMU is named as such;
/// a model description that ends before its closing tag is refused, with line and column.
#[test]
fn fmi3_arrays_binaries_clocks_and_broken_descriptions() {
    let dir = common::temp_dir("savme-stairs", "types3");
    let extra = r#"<Float64 name="m" valueReference="20" causality="parameter" variability="fixed" initial="exact" start="1 0 0 0 1 0 0 0 1"><Dimension start="3"/><Dimension start="3"/></Float64>
    <Binary name="blob" valueReference="21" causality="parameter" variability="fixed" initial="exact"><Start value="00ff"/></Binary>
    <Clock name="tick" valueReference="22" causality="input" intervalVariability="constant" intervalDecimal="0.1"/>
  </ModelVariables>"#;
    let fmu = stairs3_edited(&dir, "types.fmu", |xml| {
        xml.replacen("  </ModelVariables>", extra, 1)
    });
    assert_eq!(savme_fmu::inspect::problems(&fmu), Vec::<String>::new());
    let text = savme_fmu::inspect::Info::read(&fmu).unwrap().text();
    for (name, shown) in [("m", "Float64[]"), ("blob", "Binary"), ("tick", "Clock")] {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("{name}: {text}"));
        assert_eq!(line.split_whitespace().nth(2), Some(shown), "{line}");
    }
    let bad_array = stairs3_edited(&dir, "bad-array.fmu", |xml| {
        xml.replacen(
            "  </ModelVariables>",
            &extra.replace("1 0 0 0 1", "1 0 x 0 1"),
            1,
        )
    });
    let problems = savme_fmu::inspect::problems(&bad_array);
    assert_eq!(problems.len(), 1, "{problems:?}");
    let line: usize = problems[0]
        .strip_prefix("modelDescription.xml, line ")
        .and_then(|r| r.split(',').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no line: {problems:?}"));
    assert!(line > 1, "{problems:?}");
    assert!(
        problems[0].ends_with(": variable `m`: element start \"x\" is not a Real"),
        "{problems:?}"
    );
    let mut spec = Case::new(&[], 0.1, 10.0).spec(CostSource::Wall);
    spec.scenarios[0].phi[0].fmu_variable = "m".into();
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    let phi = phi_space();
    let e = FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(phi.clone()))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with(
            "variable `m` is an array (it has Dimension elements), expected a scalar variable"
        ),
        "{e}"
    );
    // ScheduledExecution only.
    let scheduled = stairs3_edited(&dir, "scheduled.fmu", |xml| {
        xml.replacen("<CoSimulation", "<ScheduledExecution", 1)
            .replacen(" canHandleVariableCommunicationStepSize=\"true\"\n    canReturnEarlyAfterIntermediateUpdate=\"false\" hasEventMode=\"false\"", "", 1)
    });
    let e = savme_fmu::FmuDescription::read(&scheduled)
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with("no CoSimulation element; savme runs co-simulation FMUs only (this one is scheduled execution (clocked model partitions))"),
        "{e}"
    );
    let text = savme_fmu::inspect::Info::read(&scheduled).unwrap().text();
    assert!(
        text.contains("Kinds            scheduled execution\n"),
        "{text}"
    );
    // Premature end of data.
    let cut = stairs3_edited(&dir, "cut.fmu", |xml| {
        xml.replacen("</fmiModelDescription>", "", 1)
    });
    let e = savme_fmu::FmuDescription::read(&cut)
        .unwrap_err()
        .to_string();
    let lines = savme_fmu_testkit::STAIRS3_MODEL_DESCRIPTION.lines().count();
    assert!(
        e.ends_with(&format!(
            "modelDescription.xml: line {}, column 1: premature end of data: the element `fmiModelDescription` is not closed",
            lines + 1
        )),
        "{e}"
    );
    // FMPy's validation agrees on each: no problem, the array element, the premature end (at
    // the same line and column).
    if let Some(python) = common::fmpy_python() {
        let script = format!(
            "import fmpy.validation as v\nfor f in {:?}:\n    print(len(v.validate_fmu(f)), ' '.join(v.validate_fmu(f)))\n",
            [&fmu, &bad_array, &cut].map(|p| p.display().to_string())
        );
        let o = std::process::Command::new(python)
            .arg("-c")
            .arg(&script)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout);
        let lines_out: Vec<&str> = out.lines().collect();
        assert_eq!(lines_out.len(), 3, "{out}");
        assert_eq!(lines_out[0], "0 ", "{out}");
        assert!(lines_out[1].contains("'x' is not a valid value"), "{out}");
        assert!(
            lines_out[2].contains(&format!(
                "Premature end of data in tag fmiModelDescription line 2, line {}, column 1",
                lines + 1
            )),
            "{out}"
        );
    }
}

/// Item 10: an Enumeration output can be the failure signal (a threshold on its value: read
/// through `fmi2GetInteger` / `fmi3GetInt64`), with the verdicts of the same output declared
/// as an Integer.
#[test]
fn an_enumeration_output_can_be_the_failure_signal() {
    for fmi in BOTH {
        let dir = common::temp_dir("savme-stairs", &format!("enum-out{fmi}"));
        let plain = stairs(&dir, fmi);
        let enumerated = dir.join(format!("enum{fmi}.fmu"));
        savme_fmu_testkit::pack_stairs(&enumerated, fmi, |xml| {
            let items = r#"<Item name="none" value="0"/><Item name="many" value="100"/>"#;
            if fmi == 3 {
                xml.replacen(
                    "<DefaultExperiment",
                    &format!("<TypeDefinitions><EnumerationType name=\"Count\">{items}</EnumerationType></TypeDefinitions>\n  <DefaultExperiment"),
                    1,
                )
                .replacen(r#"<Int32 name="events""#, r#"<Enumeration declaredType="Count" name="events""#, 1)
            } else {
                xml.replacen(
                    "<DefaultExperiment",
                    &format!("<TypeDefinitions><SimpleType name=\"Count\"><Enumeration>{items}</Enumeration></SimpleType></TypeDefinitions>\n  <DefaultExperiment"),
                    1,
                )
                .replacen(
                    "<ScalarVariable name=\"events\" valueReference=\"10\" causality=\"output\" variability=\"discrete\" initial=\"calculated\">\n      <Integer/>",
                    "<ScalarVariable name=\"events\" valueReference=\"10\" causality=\"output\" variability=\"discrete\" initial=\"calculated\">\n      <Enumeration declaredType=\"Count\"/>",
                    1,
                )
            }
        })
        .unwrap();
        let kind = FmuFile::open(&enumerated)
            .unwrap()
            .variable("events")
            .unwrap()
            .kind;
        assert_eq!(kind, savme_fmu::VarType::Enumeration);
        for stop in [3.0, 5.0] {
            let case = Case::new(&[("period", Value::Real(1.0))], 0.5, stop);
            let mut spec = case.spec(CostSource::Wall);
            spec.failure = Failure::Threshold {
                variable: "events".into(),
                when: savme_fmu::Crossing::Above,
                value: 3.5,
            };
            let verdicts: Vec<bool> = [&plain, &enumerated]
                .into_iter()
                .map(|f| run(&mut in_process(f, spec.clone()), 99.0).failure)
                .collect();
            assert_eq!(verdicts, [stop > 4.0; 2], "FMI {fmi}, stop {stop}");
        }
    }
}

/// Item 10: an FMI 3.0 UInt64 above 2⁶³ − 1 — as a start value (valid), set and read back,
/// and as a φ value listed — and a continuous φ bound to an integer variable, refused naming
/// the variable and what to write instead.
#[test]
fn uint64_values_above_i64_and_integer_variables_from_ranges() {
    let dir = common::temp_dir("savme-stairs", "uint64");
    let fmu = stairs3_edited(&dir, "seed.fmu", |xml| {
        xml.replacen(
            "  </ModelVariables>",
            r#"<UInt64 name="seed" valueReference="12" causality="parameter" variability="fixed" initial="exact" start="18446744073709551615"/>
  </ModelVariables>"#,
            1,
        )
    });
    assert_eq!(savme_fmu::inspect::problems(&fmu), Vec::<String>::new());
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    let seed = file.variable("seed").unwrap().clone();
    let mut inst = savme_fmu::instance::Instance::new(file.clone(), "seed").unwrap();
    inst.setup(0.0, Some(1.0), None).unwrap();
    inst.set_number(&seed, 1.5e19).unwrap();
    assert_eq!(inst.number(&seed).unwrap(), 1.5e19);
    assert!(inst.set_number(&seed, 2e19).is_err(), "beyond UInt64");
    drop(inst);
    // Listed φ values above 2⁶³ − 1 are set as such.
    let mut spec = Case::new(&[], 0.5, 5.0).spec(CostSource::Wall);
    spec.scenarios[0].phi.push(Binding {
        variable: "seed".into(),
        fmu_variable: "seed".into(),
        labels: None,
    });
    let phi = Space::new(vec![
        savme_kernel::Variable::continuous("threshold", 0.1, 100.0, 4, Scale::Linear),
        savme_kernel::Variable::discrete("seed", [1e19, 1.2e19]),
    ])
    .unwrap();
    let mut sim = FmuSimulator::new(file.clone(), file.clone(), spec.clone(), None, &|_| {
        Some(phi.clone())
    })
    .unwrap();
    let values = Assignment::new()
        .with("threshold", 2.0)
        .with("seed", 1.2e19);
    assert!(
        sim.run(Role::High, "s", &values, &Assignment::new())
            .unwrap()
            .failure
    );
    // A continuous φ cannot set an integer.
    let ranged = Space::new(vec![
        savme_kernel::Variable::continuous("threshold", 0.1, 100.0, 4, Scale::Linear),
        savme_kernel::Variable::continuous("seed", 0.0, 100.0, 4, Scale::Linear),
    ])
    .unwrap();
    let e = FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(ranged.clone()))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with("variable `seed` is Integer, expected a Real for `seed`, which ranges continuously: give an Integer variable its values as a list (`values = [1, 2, 3]`, not `range`)"),
        "{e}"
    );
}

/// The `stairs` FMU of version `fmi` whose output `x` declares a start value savme may set
/// (`initial="exact"`), its `DefaultExperiment startTime` set to `start`.
fn stairs_with_start(dir: &Path, fmi: u8, start: f64) -> PathBuf {
    let out = dir.join(format!("start{fmi}-{start}.fmu"));
    savme_fmu_testkit::pack_stairs(&out, fmi, |xml| {
        let xml = xml.replacen(
            "startTime=\"0.0\"",
            &format!("startTime=\"{start:?}\""),
            1,
        );
        if fmi == 3 {
            xml.replacen(
                r#"<Float64 name="x" valueReference="7" causality="output" variability="continuous" initial="calculated"/>"#,
                r#"<Float64 name="x" valueReference="7" causality="output" variability="continuous" initial="exact" start="0"/>"#,
                1,
            )
        } else {
            xml.replacen(
                "<ScalarVariable name=\"x\" valueReference=\"7\" causality=\"output\" variability=\"continuous\" initial=\"calculated\">\n      <Real/>",
                "<ScalarVariable name=\"x\" valueReference=\"7\" causality=\"output\" variability=\"continuous\" initial=\"exact\">\n      <Real start=\"0\"/>",
                1,
            )
        }
    })
    .unwrap();
    out
}

/// Item 8: φ, fixed values and θ can set the start value of a state or an output declared with
/// `initial="exact"` / `"approx"` (as FMPy does: set before initialisation) — here `x`'s;
/// a calculated output is still refused, naming what is settable. And the model
/// description's `DefaultExperiment startTime` is honoured: the run starts there, its grid is
/// startTime + n·h. Verdicts and steps equal FMPy's, in-process and isolated.
#[test]
fn start_values_of_outputs_and_the_default_start_time() {
    for fmi in BOTH {
        let dir = common::temp_dir("savme-stairs", &format!("start-values{fmi}"));
        for start in [0.0, 2.0] {
            let fmu = stairs_with_start(&dir, fmi, start);
            // φ binds `x` (its start value); the threshold is fixed at 5.
            let mut case = Case::new(&[("threshold", Value::Real(5.0))], 0.1, 4.0);
            let mut spec = case.spec(CostSource::Wall);
            spec.scenarios[0].phi[0].fmu_variable = "x".into();
            let steps = ((4.0 - start) / 0.1_f64).round() as u64;
            // x = x0 + t up to t = 4: from x0 = 0.5 it never reaches 5, from 1.5 at t = 3.5,
            // from 6 at once; the start time changes the number of steps (40 or 20).
            let expected = [(0.5, false), (1.5, true), (6.0, true)];
            for (how, mut sim) in [
                ("in-process", in_process(&fmu, spec.clone())),
                ("isolated", isolated(&fmu, spec.clone())),
            ] {
                for (x0, failure) in expected {
                    let r = run(&mut sim, x0);
                    assert_eq!(
                        (r.failure, r.work),
                        (failure, Some(steps)),
                        "FMI {fmi} start {start} {how} x0 {x0}"
                    );
                }
            }
            if let Some(python) = common::fmpy_python() {
                // FMPy sets `x` by name: the helper's φ is called threshold, so fix `x` instead.
                for (x0, failure) in expected {
                    case.fixed = vec![("x", Value::Real(x0))];
                    let theirs = fmpy(&python, &fmu, &case, &[5.0]);
                    assert_eq!(
                        theirs,
                        vec![(failure, steps)],
                        "FMPy, FMI {fmi} start {start} x0 {x0}"
                    );
                }
            }
        }
        // A calculated output's start cannot be set.
        let fmu = stairs(&dir, fmi);
        let mut spec = Case::new(&[], 0.1, 4.0).spec(CostSource::Wall);
        spec.scenarios[0].phi[0].fmu_variable = "steps".into();
        let file = Arc::new(FmuFile::open(&fmu).unwrap());
        let phi = phi_space();
        let e = FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(phi.clone()))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.ends_with("variable `steps` cannot be used here: expected a parameter, a structural parameter, an input, or a variable whose start value can be set (initial=\"exact\" or \"approx\")"), "{e}");
        // A stop time not after the start time is refused naming both.
        let late = stairs_with_start(&dir, fmi, 5.0);
        let file = Arc::new(FmuFile::open(&late).unwrap());
        let e = FmuSimulator::new(
            file.clone(),
            file,
            Case::new(&[], 0.1, 4.0).spec(CostSource::Wall),
            None,
            &|_| Some(phi.clone()),
        )
        .map(|_| ())
        .unwrap_err()
        .to_string();
        assert!(e.ends_with("the stop time 4 s is not after the FMU's start time (DefaultExperiment startTime = 5 s)"), "{e}");
    }
}

/// Item 1 as a campaign meets it: a kernel whose cost is the work, on HF and LF runs of the
/// stairs FMU (the step size is the fidelity) that fail at initialisation for every threshold
/// below x0 = 6 and stop there. Every trial is told — none is refused for a zero runtime
/// (`HF runtime must be finite and > 0, got 0` aborted such a campaign) — in this process and
/// isolated, FMI 2.0 and 3.0.
#[test]
fn a_kernel_on_work_takes_runs_that_fail_at_initialisation() {
    use savme_kernel::{Kernel, Observation};
    let fidelity = Space::new(vec![savme_kernel::Variable::discrete("h", [0.5, 0.25])]).unwrap();
    let theta_hf = Assignment::new().with("h", 0.25);
    let mut spec = Case {
        stop_on_failure: true,
        ..Case::new(&[("x0", Value::Real(6.0))], 0.25, 5.0)
    }
    .spec(CostSource::Wall);
    spec.step = StepSize::Of("h".into());
    for fmi in BOTH {
        let dir = common::temp_dir("savme-stairs", &format!("kernel{fmi}"));
        let fmu = stairs(&dir, fmi);
        let file = Arc::new(FmuFile::open(&fmu).unwrap());
        let phi = phi_space();
        let local = FmuSimulator::new(file.clone(), file, spec.clone(), Some(&fidelity), &|_| {
            Some(phi.clone())
        })
        .unwrap();
        let init = WorkerInit {
            hf: fmu.clone(),
            lf: fmu.clone(),
            spec: spec.clone(),
            fidelity: Some(fidelity.clone()),
            phi: [("s".to_string(), phi_space())].into_iter().collect(),
        };
        let worker = vec![env!("CARGO_BIN_EXE_savme-fmu-worker").to_string()];
        let iso = FmuBackend::new(&init, Some(worker), Duration::from_secs(60)).unwrap();
        for (how, mut sim) in [
            ("in-process", FmuBackend::InProcess(local)),
            ("isolated", iso),
        ] {
            let mut kernel = Kernel::builder(fidelity.clone(), theta_hf.clone())
                .scenario("s", phi_space(), 1.0)
                .seed(11)
                .build()
                .unwrap();
            let (mut at_start, mut later) = (0, 0);
            for _ in 0..40 {
                let trial = kernel.ask();
                let theta_lf = trial.theta_lf.clone().unwrap_or_else(|| theta_hf.clone());
                let mut go = |role, theta: &Assignment| {
                    let r = sim
                        .simulate_as(role, &trial.scenario, &trial.phi, theta)
                        .unwrap();
                    r.run(CostMeasure::Work).unwrap()
                };
                let hf = go(Role::High, &theta_hf);
                let lf = go(Role::Learned, &theta_lf);
                // x = 6 + t up to t = 5: a failure at once below 6, later below 11.
                let threshold = trial.phi.get_f64("threshold").unwrap();
                let failed_at_start = threshold <= 6.0;
                assert_eq!(hf.failure, threshold <= 11.0, "{how} {}", trial.phi);
                if failed_at_start {
                    assert_eq!((hf.runtime, lf.runtime), (1.0, 1.0), "{how}");
                    at_start += 1;
                } else {
                    later += 1;
                }
                kernel
                    .tell(trial.id, Observation::Paired { hf, lf })
                    .unwrap_or_else(|e| panic!("FMI {fmi} {how}: {e}"));
            }
            assert!(at_start > 0 && later > 0, "{how}: {at_start} / {later}");
        }
    }
}

/// The FMI 3.0 `stairs` FMU with a UInt64 parameter `seed` (odd fails, as an odd `ticket`).
fn stairs3_with_seed(dir: &Path) -> PathBuf {
    stairs3_edited(dir, "exact.fmu", |xml| {
        xml.replacen(
            "  </ModelVariables>",
            r#"<UInt64 name="seed" valueReference="12" causality="parameter" variability="fixed" initial="exact" start="0"/>
  </ModelVariables>"#,
            1,
        )
    })
}

/// FMPy's verdict of one run of `fmu` with `start` values (Python literals) up to `stop` in
/// steps of `h`, and the FMU's `steps` count.
fn fmpy_runs(python: &str, fmu: &Path, starts: &[String], stop: f64, h: f64) -> Vec<(bool, u64)> {
    let script = format!(
        "import fmpy\n\
         for s in [{}]:\n    \
         r = fmpy.simulate_fmu(r'{}', start_values=s, stop_time={stop:?}, output_interval={h:?}, \
         output=['failed', 'steps'], early_return_allowed=True)\n    \
         print(bool(r['failed'][-1]), int(r['steps'][-1]))\n",
        starts.join(", "),
        fmu.display(),
    );
    fmpy_verdicts(python, &script)
}

/// A spec whose one scenario binds φ `name` to the FMU variable of that name, with the
/// threshold fixed at `threshold`.
fn bound_spec(name: &str, threshold: f64, h: f64, stop: f64) -> RunSpec {
    let mut spec =
        Case::new(&[("threshold", Value::Real(threshold))], h, stop).spec(CostSource::Wall);
    spec.scenarios[0].phi = vec![Binding {
        variable: name.into(),
        fmu_variable: name.into(),
        labels: None,
    }];
    spec
}

/// Runs every value of φ `name` (listed in `values`) on `fmu` in this process and in a worker:
/// each run's verdict and `doStep` count.
fn run_values(fmu: &Path, spec: &RunSpec, name: &str, values: &[Value]) -> Vec<Vec<(bool, u64)>> {
    let space = Space::new(vec![savme_kernel::Variable::discrete(
        name,
        values.to_vec(),
    )])
    .unwrap();
    let file = Arc::new(FmuFile::open(fmu).unwrap());
    let in_process = FmuBackend::InProcess(
        FmuSimulator::new(file.clone(), file, spec.clone(), None, &|_| {
            Some(space.clone())
        })
        .unwrap(),
    );
    let init = WorkerInit {
        hf: fmu.to_path_buf(),
        lf: fmu.to_path_buf(),
        spec: spec.clone(),
        fidelity: None,
        phi: [("s".to_string(), space.clone())].into_iter().collect(),
    };
    let worker = vec![env!("CARGO_BIN_EXE_savme-fmu-worker").to_string()];
    let isolated = FmuBackend::new(&init, Some(worker), Duration::from_secs(60)).unwrap();
    [in_process, isolated]
        .into_iter()
        .map(|mut sim| {
            values
                .iter()
                .map(|v| {
                    let phi = Assignment::new().with(name, v.clone());
                    let r = sim
                        .simulate_as(Role::High, "s", &phi, &Assignment::new())
                        .unwrap_or_else(|e| panic!("{name} = {v}: {e}"));
                    (r.failure, r.work.unwrap())
                })
                .collect()
        })
        .collect()
}

/// Issue 40 item 7: Int64 and UInt64 values reach the FMU exactly — 2⁵³ + 1 stays odd (it was
/// rounded to 2⁵³ through a double), the Int64 extremes are set (i64::MAX was accepted by the
/// checks and then refused by the first run), a UInt64 above 2⁶³ − 1 written as the number it is
/// is set as that integer — with FMPy's verdicts; a value outside the type is refused before
/// any run, naming the variable.
#[test]
fn int64_and_uint64_values_are_set_exactly_as_fmpy_sets_them() {
    let dir = common::temp_dir("savme-stairs", "exact");
    let fmu = stairs3_with_seed(&dir);
    let (h, stop) = (0.5, 2.0);
    // x stays below the threshold: only an odd ticket or seed fails.
    let tickets = [
        (9_007_199_254_740_993_i64, true),
        (9_007_199_254_740_992, false),
        (i64::MAX, true),
        (i64::MIN, false),
        (-3, true),
    ];
    let seeds: [(Value, &str, bool); 4] = [
        (Value::Int(9_007_199_254_740_993), "9007199254740993", true),
        (Value::Int(i64::MAX), "9223372036854775807", true),
        // 2⁶⁴ − 2048, the largest double below 2⁶⁴: even.
        (
            Value::Real(18_446_744_073_709_549_568.0),
            "18446744073709549568",
            false,
        ),
        (Value::Int(0), "0", false),
    ];
    let want_t: Vec<(bool, u64)> = tickets.iter().map(|(_, f)| (*f, 4)).collect();
    let want_s: Vec<(bool, u64)> = seeds.iter().map(|(_, _, f)| (*f, 4)).collect();
    let spec = |name| bound_spec(name, 100.0, h, stop);
    let values: Vec<Value> = tickets.iter().map(|(t, _)| Value::Int(*t)).collect();
    for (how, ours) in
        ["in-process", "isolated"]
            .iter()
            .zip(run_values(&fmu, &spec("ticket"), "ticket", &values))
    {
        assert_eq!(ours, want_t, "ticket, {how}");
    }
    let values: Vec<Value> = seeds.iter().map(|(v, _, _)| v.clone()).collect();
    for (how, ours) in
        ["in-process", "isolated"]
            .iter()
            .zip(run_values(&fmu, &spec("seed"), "seed", &values))
    {
        assert_eq!(ours, want_s, "seed, {how}");
    }
    if let Some(python) = common::fmpy_python() {
        let starts: Vec<String> = tickets
            .iter()
            .map(|(t, _)| format!("{{'threshold': 100.0, 'ticket': {t}}}"))
            .collect();
        assert_eq!(
            fmpy_runs(&python, &fmu, &starts, stop, h),
            want_t,
            "FMPy, ticket"
        );
        let starts: Vec<String> = seeds
            .iter()
            .map(|(_, s, _)| format!("{{'threshold': 100.0, 'seed': {s}}}"))
            .collect();
        assert_eq!(
            fmpy_runs(&python, &fmu, &starts, stop, h),
            want_s,
            "FMPy, seed"
        );
    }
    // Outside the C type: refused when the simulator is built, before any run.
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    for (name, bad) in [
        ("seed", Value::Int(-1)),
        ("seed", Value::Real(18_446_744_073_709_551_616.0)),
        ("ticket", Value::Real(9_223_372_036_854_775_808.0)),
    ] {
        let space =
            Space::new(vec![savme_kernel::Variable::discrete(name, [bad.clone()])]).unwrap();
        let e = FmuSimulator::new(file.clone(), file.clone(), spec(name), None, &|_| {
            Some(space.clone())
        })
        .map(|_| ())
        .unwrap_err()
        .to_string();
        assert!(
            e.contains(&format!("variable `{name}`")) && e.contains("lies outside"),
            "{name} = {bad}: {e}"
        );
    }
    let e = FmuSimulator::new(file.clone(), file, spec("seed"), None, &|_| {
        Some(Space::new(vec![savme_kernel::Variable::discrete("seed", [-1])]).unwrap())
    })
    .map(|_| ())
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("is declared in [0, 18446744073709551615]"),
        "{e}"
    );
}

/// Issue 40 item 8: an FMI 3.0 structural parameter (`stages`, no `initial` attribute) can be
/// bound; savme sets it in configuration mode (the FMU counts one), before the other values,
/// and the verdicts and step counts are FMPy's (which sets it in the Instantiated state).
#[test]
fn structural_parameters_are_set_in_configuration_mode() {
    let dir = common::temp_dir("savme-stairs", "structural");
    let fmu = stairs(&dir, 3);
    let (h, stop) = (0.5, 2.0);
    // x(2) = 2 · stages: fails from stages = 3 on (threshold 5), stopping at the failure.
    let stages = [1_i64, 2, 3, 7];
    let mut spec = bound_spec("stages", 5.0, h, stop);
    spec.stop_on_failure = false;
    let want: Vec<(bool, u64)> = stages.iter().map(|s| (*s >= 3, 4)).collect();
    let values: Vec<Value> = stages.iter().map(|s| Value::Int(*s)).collect();
    for (how, ours) in ["in-process", "isolated"]
        .iter()
        .zip(run_values(&fmu, &spec, "stages", &values))
    {
        assert_eq!(ours, want, "{how}");
    }
    if let Some(python) = common::fmpy_python() {
        let starts: Vec<String> = stages
            .iter()
            .map(|s| format!("{{'threshold': 5.0, 'stages': {s}}}"))
            .collect();
        assert_eq!(fmpy_runs(&python, &fmu, &starts, stop, h), want, "FMPy");
    }
    // Once per run, in configuration mode: the FMU counted it (reset clears the count).
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    let space = Space::new(vec![savme_kernel::Variable::discrete("stages", values)]).unwrap();
    let mut sim =
        FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(space.clone())).unwrap();
    for s in stages {
        let phi = Assignment::new().with("stages", s);
        let record = ["configurations".to_string(), "x".to_string()];
        let (_, trace) = sim
            .run_traced(Role::High, "s", &phi, &Assignment::new(), &record)
            .unwrap();
        assert_eq!(
            trace.series("configurations").unwrap()[0],
            1.0,
            "stages {s}"
        );
        assert_eq!(trace.series("x").unwrap().last(), Some(&(2.0 * s as f64)));
    }
}

/// FMPy's `validate_fmu` problems of `fmu`, one per line.
fn fmpy_validate(python: &str, fmu: &Path) -> Vec<String> {
    let script = format!(
        "import fmpy.validation\nfor p in fmpy.validation.validate_fmu(r'{}'):\n    print(' '.join(str(p).split()))\n",
        fmu.display()
    );
    let o = std::process::Command::new(python)
        .arg("-c")
        .arg(&script)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(String::from)
        .collect()
}

/// Issue 40 item 9: `fmu validate` (`inspect::problems`) finds what FMPy's validation flags —
/// a parameter with continuous variability (FMI 2.0 and 3.0), a value reference shared by two
/// FMI 3.0 variables, a ModelStructure output naming no variable — and lists every problem
/// of a description (five here, one before), each with its line, and a column where the
/// problem is an element (a name declared twice with both places).
#[test]
fn validate_lists_every_problem_fmpy_flags_with_lines_and_columns() {
    let dir = common::temp_dir("savme-stairs", "validate");
    let faults: [(&str, &str, &str); 5] = [
        (
            "continuous",
            r#"name="rate" valueReference="1" causality="parameter" variability="fixed""#,
            r#"name="rate" valueReference="1" causality="parameter" variability="continuous""#,
        ),
        (
            "reference",
            r#"name="period" valueReference="3""#,
            r#"name="period" valueReference="1""#,
        ),
        (
            "output",
            r#"<Output valueReference="10"/>"#,
            r#"<Output valueReference="10"/><Output valueReference="99"/>"#,
        ),
        (
            "twice",
            "  </ModelVariables>",
            "    <Float64 name=\"x0\" valueReference=\"20\" causality=\"parameter\" variability=\"fixed\" initial=\"exact\" start=\"0\"/>\n  </ModelVariables>",
        ),
        (
            "start",
            r#"initial="exact" start="5"/>"#,
            r#"initial="exact" start="5" min="0" max="1"/>"#,
        ),
    ];
    let xml3 = savme_fmu_testkit::STAIRS3_MODEL_DESCRIPTION;
    let line_of =
        |xml: &str, needle: &str| 1 + xml.lines().position(|l| l.contains(needle)).unwrap();
    let all = faults
        .iter()
        .fold(xml3.to_string(), |x, (_, from, to)| x.replacen(from, to, 1));
    let fmu = stairs3_edited(&dir, "all.fmu", |_| all.clone());
    let ours = savme_fmu::inspect::problems(&fmu);
    let shown = fmu.display().to_string();
    let twice = line_of(&all, r#"name="x0" valueReference="20""#);
    let expected = vec![
        format!("{shown}: modelDescription.xml: line {}, column 34: ModelStructure: Output valueReference=\"99\" names no variable", line_of(&all, "valueReference=\"99\"")),
        format!("{shown}: modelDescription.xml: line {twice}, column 5: variable `x0` is declared twice (first at line {}, column 5)", line_of(&all, r#"name="x0" valueReference="0""#)),
        format!("modelDescription.xml, line {}, column 5: variable `rate`: a parameter cannot have variability=\"continuous\" (only \"fixed\" or \"tunable\")", line_of(&all, "name=\"rate\"")),
        format!("modelDescription.xml, line {}, column 5: variable `threshold`: start 5 lies outside [min, max]", line_of(&all, "name=\"threshold\"")),
        format!("modelDescription.xml, line {}, column 5: variable `period`: value reference 1 is that of variable `rate` (line {}) too", line_of(&all, "name=\"period\""), line_of(&all, "name=\"rate\"")),
    ];
    assert_eq!(ours, expected);
    // FMI 2.0: a continuous parameter; an output Unknown naming no variable, at its line.
    let xml2 = savme_fmu_testkit::STAIRS_MODEL_DESCRIPTION
        .replacen(
            r#"name="rate" valueReference="1" causality="parameter" variability="fixed""#,
            r#"name="rate" valueReference="1" causality="parameter" variability="continuous""#,
            1,
        )
        .replacen(r#"<Unknown index="8"/>"#, r#"<Unknown index="99"/>"#, 1);
    let fmu2 = dir.join("all2.fmu");
    savme_fmu_testkit::pack_stairs(&fmu2, 2, |_| xml2.clone()).unwrap();
    let ours2 = savme_fmu::inspect::problems(&fmu2);
    assert_eq!(
        ours2,
        [
            format!("{}: modelDescription.xml: line {}, column 7: ModelStructure: output index 99 names no variable", fmu2.display(), line_of(&xml2, "index=\"99\"")),
            format!("modelDescription.xml, line {}, column 5: variable `rate`: a parameter cannot have variability=\"continuous\" (only \"fixed\" or \"tunable\")", line_of(&xml2, "name=\"rate\"")),
        ]
    );
    // Each fault alone: FMPy flags it, and so does savme.
    if let Some(python) = common::fmpy_python() {
        assert_eq!(
            fmpy_validate(&python, &stairs(&dir, 3)),
            Vec::<String>::new()
        );
        for (name, from, to) in faults {
            let one = stairs3_edited(&dir, &format!("{name}.fmu"), |x| x.replacen(from, to, 1));
            if name != "start" {
                // (FMPy does not check a start value against min / max.)
                assert!(
                    !fmpy_validate(&python, &one).is_empty(),
                    "FMPy misses {name}"
                );
            }
            assert_eq!(savme_fmu::inspect::problems(&one).len(), 1, "{name}");
        }
        let one = dir.join("continuous2.fmu");
        let xml = savme_fmu_testkit::STAIRS_MODEL_DESCRIPTION.replacen(faults[0].1, faults[0].2, 1);
        savme_fmu_testkit::pack_stairs(&one, 2, |_| xml.clone()).unwrap();
        assert!(!fmpy_validate(&python, &one).is_empty());
        assert_eq!(savme_fmu::inspect::problems(&one).len(), 1);
    }
}

/// A recorded FMI 3.0 Int64 output is read through `fmi3GetInt64` (it was read through
/// `fmi3GetInt32`, which the FMU refuses for it).
#[test]
fn an_int64_output_is_recorded_through_its_own_getter() {
    let dir = common::temp_dir("savme-stairs", "record-int64");
    let fmu = stairs3_edited(&dir, "int64-out.fmu", |xml| {
        xml.replacen(
            r#"name="ticket" valueReference="13" causality="parameter" variability="fixed" initial="exact" start="0""#,
            r#"name="ticket" valueReference="13" causality="output" variability="discrete" initial="calculated""#,
            1,
        )
    });
    let file = Arc::new(FmuFile::open(&fmu).unwrap());
    let spec = Case::new(&[], 0.5, 1.0).spec(CostSource::Wall);
    let phi = phi_space();
    let mut sim =
        FmuSimulator::new(file.clone(), file, spec, None, &|_| Some(phi.clone())).unwrap();
    let phi = Assignment::new().with("threshold", 50.0);
    let (_, trace) = sim
        .run_traced(
            Role::High,
            "s",
            &phi,
            &Assignment::new(),
            &["ticket".into()],
        )
        .unwrap();
    assert_eq!(trace.series("ticket"), Some(&[0.0, 0.0, 0.0][..]));
}

/// Runs `script` in FMPy's Python; each line it prints is `True|False STEPS`.
fn fmpy_verdicts(python: &str, script: &str) -> Vec<(bool, u64)> {
    let o = std::process::Command::new(python)
        .arg("-c")
        .arg(script)
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

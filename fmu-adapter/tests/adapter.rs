//! The adapter on small FMUs this test builds: the trivial test-kit FMU (packed from the
//! `savme-fmu-testkit` library built alongside the tests) and deliberately broken variants.
mod common;
use savme_fmu::{
    Binding, CostSource, Crossing, Failure, FmuError, FmuFile, FmuSimulator, RunSpec, ScenarioSpec,
    StepSize,
};
use savme_kernel::{Assignment, Role, Scale, Space, Variable};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn temp_dir(name: &str) -> PathBuf {
    common::temp_dir("savme-fmu", name)
}

use common::testkit_library;

fn pack_xml(dir: &Path, file: &str, xml: &str) -> PathBuf {
    let out = dir.join(file);
    savme_fmi_export::pack(xml, "savme_fmu_testkit", &testkit_library(), &out).unwrap();
    out
}

fn testkit(dir: &Path) -> PathBuf {
    pack_xml(dir, "testkit.fmu", &savme_fmu_testkit::model_description())
}

fn spaces() -> (Space, Space) {
    let fidelity = Space::new(vec![Variable::continuous(
        "rate",
        0.5,
        4.0,
        4,
        Scale::Linear,
    )])
    .unwrap();
    let phi = Space::new(vec![Variable::continuous(
        "start",
        0.0,
        1.0,
        4,
        Scale::Linear,
    )])
    .unwrap();
    (fidelity, phi)
}

fn spec(fixed_fault: i32, stop_on_failure: bool) -> RunSpec {
    RunSpec {
        fmu_log: false,
        tolerance: None,
        stop_time: 1.0,
        step: StepSize::Fixed(0.01),
        failure: Failure::Boolean {
            variable: "failed".into(),
            robustness: None,
        },
        stop_on_failure,
        cost: CostSource::Output("steps".into()),
        fidelity: vec![Binding {
            variable: "rate".into(),
            fmu_variable: "rate".into(),
            labels: None,
        }],
        scenarios: vec![ScenarioSpec {
            name: "grow".into(),
            phi: vec![Binding {
                variable: "start".into(),
                fmu_variable: "x0".into(),
                labels: None,
            }],
            fixed: vec![
                savme_fmu::Fixed {
                    fmu_variable: "fault".into(),
                    value: savme_kernel::Value::Int(i64::from(fixed_fault)),
                },
                savme_fmu::Fixed {
                    fmu_variable: "fault_time".into(),
                    value: savme_kernel::Value::Real(0.3),
                },
            ],
        }],
    }
}

fn simulator(fmu: &Path, spec: RunSpec) -> Result<FmuSimulator, FmuError> {
    let file = Arc::new(FmuFile::open(fmu)?);
    let (fidelity, phi) = spaces();
    FmuSimulator::new(file.clone(), file, spec, Some(&fidelity), &|_| {
        Some(phi.clone())
    })
}

fn args(start: f64, rate: f64) -> (Assignment, Assignment) {
    (
        Assignment::new().with("start", start),
        Assignment::new().with("rate", rate),
    )
}

#[test]
fn runs_until_the_failure_signal_and_reuses_its_instance() {
    let dir = temp_dir("runs");
    let fmu = testkit(&dir);
    let mut sim = simulator(&fmu, spec(0, true)).unwrap();
    // x = start + rate·t reaches the threshold 0.5 at t = 0.4 with start 0.1, rate 1.
    let (phi, theta) = args(0.1, 1.0);
    let r = sim.run(Role::High, "grow", &phi, &theta).unwrap();
    assert!(r.failure);
    assert_eq!(
        r.work,
        Some(40),
        "stopped at the failure after 40 steps of 0.01"
    );
    // Without stopping early it runs to the stop time; the failure stays found.
    let mut full = simulator(&fmu, spec(0, false)).unwrap();
    let r = full.run(Role::High, "grow", &phi, &theta).unwrap();
    assert!(r.failure);
    assert_eq!(r.work, Some(100));
    // Never reaching the threshold: no failure, the whole run. Repeated runs on the reused
    // (reset) instance give the same answers.
    let (phi, theta) = args(0.0, 0.4);
    for _ in 0..3 {
        let r = sim.run(Role::Learned, "grow", &phi, &theta).unwrap();
        assert!(!r.failure);
        assert_eq!(r.work, Some(100));
        assert!(r.wall_seconds > 0.0);
    }
}

#[test]
fn a_threshold_on_a_real_output_and_a_step_size_from_a_rate() {
    let dir = temp_dir("threshold");
    let fmu = testkit(&dir);
    let mut s = spec(0, true);
    s.failure = Failure::Threshold {
        variable: "x".into(),
        when: Crossing::Above,
        value: 0.75,
    };
    // The step is 1 / (the fidelity variable `rate`), here 1/4 s.
    s.step = StepSize::RateOf("rate".into());
    let mut sim = simulator(&fmu, s).unwrap();
    let (phi, theta) = args(0.0, 4.0);
    let r = sim.run(Role::High, "grow", &phi, &theta).unwrap();
    // x = 4·t ≥ 0.75 first at the step ending t = 0.25 (x = 1.0).
    assert!(r.failure);
    assert_eq!(r.work, Some(1));
    // The robustness is the smallest margin to the threshold: 0.75 − 1.0 at the failure.
    assert_eq!(r.robustness, Some(-0.25));
    let mut below = spec(0, true);
    below.failure = Failure::Threshold {
        variable: "x".into(),
        when: Crossing::Below,
        value: -1.0,
    };
    let mut sim = simulator(&fmu, below).unwrap();
    let r = sim.run(Role::High, "grow", &phi, &theta).unwrap();
    assert!(!r.failure);
    // x ≥ 0 throughout: the closest it came to −1 was x = 0 at the start.
    assert_eq!(r.robustness, Some(1.0));
    // A Boolean failure signal has no margin.
    let mut boolean = simulator(&fmu, spec(0, true)).unwrap();
    assert_eq!(
        boolean
            .run(Role::High, "grow", &phi, &theta)
            .unwrap()
            .robustness,
        None
    );
}

#[test]
fn a_do_step_error_is_an_error_naming_the_fmu_and_the_call() {
    let dir = temp_dir("dostep");
    let fmu = testkit(&dir);
    let mut sim = simulator(&fmu, spec(1, true)).unwrap();
    let (phi, theta) = args(0.0, 0.1);
    let e = sim
        .run(Role::High, "grow", &phi, &theta)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("fmi2DoStep failed") && e.contains("testkit.fmu"),
        "{e}"
    );
    // The failed instance is not reused: the next run (no fault) works.
    let mut ok = simulator(&fmu, spec(0, true)).unwrap();
    assert!(ok.run(Role::High, "grow", &phi, &theta).is_ok());
}

fn zip_with(path: &Path, files: &[(&str, &[u8])]) {
    let f = std::fs::File::create(path).unwrap();
    let mut z = zip::ZipWriter::new(f);
    for (name, data) in files {
        z.start_file(*name, zip::write::FileOptions::default())
            .unwrap();
        z.write_all(data).unwrap();
    }
    z.finish().unwrap();
}

#[test]
fn broken_fmus_are_refused_with_an_error_naming_them() {
    let dir = temp_dir("broken");
    let expect = |path: &Path, needle: &str| {
        let e = FmuFile::open(path).unwrap_err().to_string();
        assert!(e.contains(&path.display().to_string()), "{e}");
        assert!(e.contains(needle), "expected `{needle}` in: {e}");
    };
    expect(&dir.join("missing.fmu"), "No such file");
    let text = dir.join("text.fmu");
    std::fs::write(&text, "not a zip").unwrap();
    expect(&text, "not a zip archive");
    let empty = dir.join("no-md.fmu");
    zip_with(&empty, &[("binaries/readme.txt", b"nothing")]);
    expect(&empty, "no modelDescription.xml");
    let md = savme_fmu_testkit::model_description();
    let v4 = pack_xml(
        &dir,
        "fmi4.fmu",
        &md.replace("fmiVersion=\"2.0\"", "fmiVersion=\"4.0\""),
    );
    expect(&v4, "fmiVersion is \"4.0\"");
    // FMI 3.0 read with the 3.0 schema: a 2.0 description relabelled is no valid 3.0 one …
    let v3 = pack_xml(
        &dir,
        "fmi3.fmu",
        &md.replace("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\""),
    );
    expect(
        &v3,
        "modelDescription.xml: line 22, column 7: variable #1: no name",
    );
    // `savme fmu validate` lists every problem of the description, each at its line and
    // column (as FMPy's validation does), not only the first.
    let all = savme_fmu::inspect::problems(&v3);
    assert!(all.len() > 1, "{all:?}");
    for p in &all {
        assert!(
            p.contains("fmi3.fmu: modelDescription.xml: line ") && p.contains(", column "),
            "{all:?}"
        );
    }
    // … and an FMI 3.0 description over a library of FMI 2.0 functions only (the C braking
    // FMU) is refused on loading.
    let v3 = dir.join("fmi3-lib2.fmu");
    savme_fmu_testkit::pack_braking_library(
        &v3,
        savme_fmu_testkit::BRAKING3_MODEL_DESCRIPTION,
        true,
        &savme_fmu_testkit::braking_library(),
    )
    .unwrap();
    expect(&v3, "does not export fmi3InstantiateCoSimulation");
    let me = md
        .replace("<CoSimulation ", "<ModelExchange ")
        .replace("canHandleVariableCommunicationStepSize=\"true\" ", "");
    let me = pack_xml(&dir, "me.fmu", &me);
    expect(&me, "no CoSimulation element");
    let garbled = pack_xml(&dir, "garbled.fmu", &md.replace("</ModelVariables>", ""));
    expect(&garbled, "modelDescription.xml");
    let wrong_id = pack_xml(
        &dir,
        "wrong-id.fmu",
        &md.replace(
            "modelIdentifier=\"savme_fmu_testkit\"",
            "modelIdentifier=\"other\"",
        ),
    );
    expect(&wrong_id, "no binary for this platform");
    // `fmu validate` on an FMU savme cannot run still lists its declarations' problems.
    let mut bad = md.replace(
        "modelIdentifier=\"savme_fmu_testkit\"",
        "modelIdentifier=\"other\"",
    );
    let first = bad
        .find("causality=\"parameter\" variability=\"fixed\"")
        .unwrap();
    bad.replace_range(
        first..first + "causality=\"parameter\" variability=\"fixed\"".len(),
        "causality=\"parameter\" variability=\"continuous\"",
    );
    let bad = pack_xml(&dir, "wrong-id-continuous.fmu", &bad);
    let all = savme_fmu::inspect::problems(&bad);
    assert_eq!(all.len(), 2, "{all:?}");
    assert!(all[0].contains("no binary for this platform"), "{all:?}");
    assert!(
        all[1].ends_with(
            "a parameter cannot have variability=\"continuous\" (only \"fixed\" or \"tunable\")"
        ),
        "{all:?}"
    );
}

#[test]
fn unknown_variables_wrong_types_and_causalities_are_named() {
    let dir = temp_dir("mapping");
    let fmu = testkit(&dir);
    let check = |change: &dyn Fn(&mut RunSpec), needle: &str| {
        let mut s = spec(0, true);
        change(&mut s);
        let e = simulator(&fmu, s).unwrap_err().to_string();
        assert!(
            e.contains("testkit.fmu") && e.contains(needle),
            "expected `{needle}` in: {e}"
        );
    };
    check(
        &|s| s.scenarios[0].phi[0].fmu_variable = "nope".into(),
        "no variable `nope`",
    );
    // A continuous savme variable needs a Real; `fault` is an Integer (issue 26 item 10: the
    // error says what to write instead).
    check(
        &|s| s.scenarios[0].phi[0].fmu_variable = "fault".into(),
        "variable `fault` is Integer, expected a Real for `start`, which ranges continuously: give an Integer variable its values as a list (`values = [1, 2, 3]`, not `range`)",
    );
    check(
        &|s| s.fidelity[0].fmu_variable = "enabled".into(),
        "variable `enabled` is Boolean",
    );
    // Outputs cannot be set; parameters are no failure signal.
    check(
        &|s| s.scenarios[0].phi[0].fmu_variable = "x".into(),
        "variable `x` cannot be used here: expected a parameter, a structural parameter, an input, or a variable whose start value can be set (initial=\"exact\" or \"approx\")",
    );
    check(
        &|s| {
            s.failure = Failure::Boolean {
                variable: "enabled".into(),
                robustness: None,
            }
        },
        "variable `enabled` cannot be used here: expected an output",
    );
    check(
        &|s| {
            s.failure = Failure::Boolean {
                variable: "x".into(),
                robustness: None,
            }
        },
        "variable `x` is Real, expected Boolean",
    );
    check(
        &|s| s.cost = CostSource::Output("failed".into()),
        "variable `failed` is Boolean",
    );
}

#[test]
fn the_export_layer_checks_calls_like_an_fmu_should() {
    // Setting an output, or a parameter after initialisation, is refused by the FMU itself.
    let dir = temp_dir("export");
    let file = Arc::new(FmuFile::open(&testkit(&dir)).unwrap());
    let mut i = savme_fmu::instance::Instance::new(file, "t").unwrap();
    i.setup(0.0, Some(1.0), None).unwrap();
    let x = savme_fmu_testkit::vr::X;
    assert!(i.set_real(x, 1.0).is_err(), "an output was settable");
    i.set_real(savme_fmu_testkit::vr::RATE, 2.0).unwrap();
    i.initialize().unwrap();
    assert!(i.set_real(savme_fmu_testkit::vr::RATE, 3.0).is_err());
    i.step(0.0, 0.5).unwrap();
    assert_eq!(i.real(x).unwrap(), 1.0);
    assert_eq!(i.integer(savme_fmu_testkit::vr::STEPS).unwrap(), 1);
    assert!(i.boolean(savme_fmu_testkit::vr::FAILED).unwrap());
    // A communication point that is not the current time is an error.
    assert!(i.step(0.7, 0.1).is_err());
    // Reset restores the start values.
    i.reset().unwrap();
    i.setup(0.0, None, None).unwrap();
    i.initialize().unwrap();
    i.step(0.0, 0.5).unwrap();
    assert_eq!(i.real(x).unwrap(), 0.5);
}

mod isolation {
    use super::*;
    use savme_fmu::worker::{IsolatedSimulator, WorkerInit};
    use savme_kernel::Simulator;
    use std::time::{Duration, Instant};

    fn isolated(fmu: &Path, fault: i32, timeout: Duration) -> IsolatedSimulator {
        let (fidelity, phi) = spaces();
        let init = WorkerInit {
            hf: fmu.to_path_buf(),
            lf: fmu.to_path_buf(),
            spec: spec(fault, true),
            fidelity: Some(fidelity),
            phi: [("grow".to_string(), phi)].into_iter().collect(),
        };
        IsolatedSimulator::new(
            vec![env!("CARGO_BIN_EXE_savme-fmu-worker").to_string()],
            &init,
            timeout,
        )
        .unwrap()
    }

    #[test]
    fn a_worker_gives_the_in_process_answers() {
        let dir = temp_dir("iso-ok");
        let fmu = testkit(&dir);
        let mut local = simulator(&fmu, spec(0, true)).unwrap();
        let mut iso = isolated(&fmu, 0, Duration::from_secs(20));
        for (start, rate) in [(0.1, 1.0), (0.0, 0.4), (0.45, 0.2)] {
            let (phi, theta) = args(start, rate);
            let a = local.run(Role::High, "grow", &phi, &theta).unwrap();
            let b = iso.simulate_as(Role::High, "grow", &phi, &theta).unwrap();
            assert_eq!((a.failure, a.work), (b.failure, b.work));
        }
    }

    /// The test-kit FMU whose description swaps the names of `x0` and `threshold`: setting
    /// `x0` sets its threshold, so the same φ and θ give another outcome than the test kit's.
    fn swapped(dir: &Path) -> PathBuf {
        let xml = savme_fmu_testkit::model_description()
            .replace("name=\"x0\"", "name=\"@\"")
            .replace("name=\"threshold\"", "name=\"x0\"")
            .replace("name=\"@\"", "name=\"threshold\"");
        pack_xml(dir, "swapped.fmu", &xml)
    }

    /// Issue 24 item 4: a pair whose HF and LF FMU files differ runs each run on its role's
    /// file, in this process and in a worker alike — with the same θ for both runs, so that
    /// nothing but the role can tell them apart.
    #[test]
    fn in_process_and_isolated_pairs_run_each_role_on_its_own_fmu() {
        let dir = temp_dir("iso-roles");
        let (hf, lf) = (testkit(&dir), swapped(&dir));
        let (fidelity, phi) = spaces();
        let open = |p: &Path| Arc::new(FmuFile::open(p).unwrap());
        let pair = FmuSimulator::new(
            open(&hf),
            open(&lf),
            spec(0, true),
            Some(&fidelity),
            &|_| Some(phi.clone()),
        )
        .unwrap();
        let init = WorkerInit {
            hf: hf.clone(),
            lf: lf.clone(),
            spec: spec(0, true),
            fidelity: Some(fidelity.clone()),
            phi: [("grow".to_string(), phi.clone())].into_iter().collect(),
        };
        let worker = vec![env!("CARGO_BIN_EXE_savme-fmu-worker").to_string()];
        let isolated = IsolatedSimulator::new(worker, &init, Duration::from_secs(20)).unwrap();
        let mut backends = [
            savme_fmu::FmuBackend::InProcess(pair),
            savme_fmu::FmuBackend::Isolated(isolated),
        ];
        // Each file alone, as the HF FMU of a one-file simulator: what each role must give.
        let mut hf_alone = simulator(&hf, spec(0, true)).unwrap();
        let mut lf_alone = simulator(&lf, spec(0, true)).unwrap();
        for (start, rate) in [(0.1, 1.0), (0.3, 0.5), (0.05, 2.0)] {
            let (phi, theta) = args(start, rate);
            let want_hf = hf_alone.run(Role::High, "grow", &phi, &theta).unwrap();
            let want_lf = lf_alone.run(Role::High, "grow", &phi, &theta).unwrap();
            assert_ne!(
                want_hf.work, want_lf.work,
                "the two files differ at {start}, {rate}"
            );
            for backend in &mut backends {
                let got_hf = backend
                    .simulate_as(Role::High, "grow", &phi, &theta)
                    .unwrap();
                let got_lf = backend
                    .simulate_as(Role::Learned, "grow", &phi, &theta)
                    .unwrap();
                let what = format!("{backend:?} at {start}, {rate}");
                assert_eq!(
                    (got_hf.failure, got_hf.work),
                    (want_hf.failure, want_hf.work),
                    "HF: {what}"
                );
                assert_eq!(
                    (got_lf.failure, got_lf.work),
                    (want_lf.failure, want_lf.work),
                    "LF: {what}"
                );
            }
        }
    }

    #[test]
    fn a_crash_or_an_abort_costs_one_run_not_the_process() {
        let dir = temp_dir("iso-crash");
        let fmu = testkit(&dir);
        for (fault, signal) in [(2, "SIGABRT"), (4, "SIGSEGV")] {
            let mut iso = isolated(&fmu, fault, Duration::from_secs(20));
            let (phi, theta) = args(0.0, 0.1);
            let e = iso
                .simulate_as(Role::High, "grow", &phi, &theta)
                .unwrap_err()
                .to_string();
            assert!(e.contains("worker died") && e.contains(signal), "{e}");
            assert!(e.contains("testkit.fmu"), "{e}");
            // The next run gets a fresh worker (and crashes again, being the same fault).
            assert!(iso.simulate_as(Role::High, "grow", &phi, &theta).is_err());
        }
        // A doStep error in the worker is the run's error; the worker lives on.
        let mut iso = isolated(&fmu, 1, Duration::from_secs(20));
        let (phi, theta) = args(0.0, 0.1);
        let e = iso
            .simulate_as(Role::High, "grow", &phi, &theta)
            .unwrap_err()
            .to_string();
        assert!(e.contains("fmi2DoStep failed"), "{e}");
    }

    /// The directories `savme-fmu-<pid>-*` in the temporary directory: what process `pid`
    /// unpacked.
    fn unpacked_by(pid: u32) -> Vec<PathBuf> {
        let prefix = format!("savme-fmu-{pid}-");
        std::fs::read_dir(std::env::temp_dir())
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
            .map(|e| e.path())
            .collect()
    }

    /// Issue 26 item 9: a worker that crashes (abort, segfault) or hangs (killed at the
    /// timeout) leaves no unpacked FMU behind; nor does one that ends normally. The workers are
    /// started through `sh -c 'echo $$ >> pids; exec savme-fmu-worker'` to learn their pids.
    #[test]
    fn a_crashed_or_hung_worker_leaves_no_unpacked_fmu() {
        let dir = temp_dir("iso-clean");
        let fmu = testkit(&dir);
        let pids = dir.join("pids");
        let (fidelity, phi) = spaces();
        for (fault, timeout) in [(2, 20_000), (4, 20_000), (3, 1_500), (0, 20_000)] {
            let init = WorkerInit {
                hf: fmu.clone(),
                lf: fmu.clone(),
                spec: spec(fault, true),
                fidelity: Some(fidelity.clone()),
                phi: [("grow".to_string(), phi.clone())].into_iter().collect(),
            };
            let script = format!(
                "echo $$ >> '{}'; exec '{}'",
                pids.display(),
                env!("CARGO_BIN_EXE_savme-fmu-worker")
            );
            let command = vec!["sh".into(), "-c".into(), script];
            let mut iso =
                IsolatedSimulator::new(command, &init, Duration::from_millis(timeout)).unwrap();
            let (p, theta) = args(0.0, 0.1);
            let r = iso.simulate_as(Role::High, "grow", &p, &theta);
            assert_eq!(r.is_ok(), fault == 0, "fault {fault}: {r:?}");
            drop(iso);
        }
        let pids: Vec<u32> = std::fs::read_to_string(&pids)
            .unwrap()
            .lines()
            .map(|l| l.parse().unwrap())
            .collect();
        assert_eq!(pids.len(), 4, "{pids:?}");
        for pid in pids {
            assert_eq!(unpacked_by(pid), Vec::<PathBuf>::new(), "worker {pid}");
        }
    }

    #[test]
    fn a_hang_is_cut_off_by_the_timeout() {
        let dir = temp_dir("iso-hang");
        let fmu = testkit(&dir);
        let mut iso = isolated(&fmu, 3, Duration::from_millis(1500));
        let (phi, theta) = args(0.0, 0.1);
        let t = Instant::now();
        let e = iso
            .simulate_as(Role::High, "grow", &phi, &theta)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no answer within 1.5s") && e.contains("hung"),
            "{e}"
        );
        assert!(t.elapsed() < Duration::from_secs(30));
    }

    #[test]
    fn a_bad_worker_set_up_is_reported() {
        let dir = temp_dir("iso-bad");
        let mut iso = isolated(&dir.join("absent.fmu"), 0, Duration::from_secs(20));
        let (phi, theta) = args(0.0, 0.1);
        let e = iso
            .simulate_as(Role::High, "grow", &phi, &theta)
            .unwrap_err()
            .to_string();
        assert!(e.contains("absent.fmu"), "{e}");
    }

    /// Not a test on its own: the parent process of `a_worker_dies_with_the_process_that_started_it`
    /// (run as a child of the test with SAVME_TEST_HANG_FMU set): starts a worker that hangs.
    #[test]
    fn helper_parent_of_a_hanging_worker() {
        let Some(fmu) = std::env::var_os("SAVME_TEST_HANG_FMU") else {
            return;
        };
        let mut iso = isolated(Path::new(&fmu), 3, Duration::from_secs(3600));
        let (phi, theta) = args(0.0, 0.1);
        let _ = iso.simulate_as(Role::High, "grow", &phi, &theta);
    }

    /// The pids of the processes whose parent is `pid` (Linux /proc).
    fn children(pid: u32) -> Vec<u32> {
        let mut out = Vec::new();
        for e in std::fs::read_dir("/proc").unwrap().flatten() {
            let Ok(child) = e.file_name().to_string_lossy().parse::<u32>() else {
                continue;
            };
            let stat = std::fs::read_to_string(e.path().join("stat")).unwrap_or_default();
            // pid (comm) state ppid …; comm may hold spaces, so split after the last ')'.
            let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
            if rest.split_whitespace().nth(1) == Some(&pid.to_string()) {
                out.push(child);
            }
        }
        out
    }

    /// Alive: exists and is not a zombie.
    fn alive(pid: u32) -> bool {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
        let state = stat
            .rsplit_once(')')
            .and_then(|(_, r)| r.split_whitespace().next());
        matches!(state, Some(s) if s != "Z" && s != "X")
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_worker_dies_with_the_process_that_started_it() {
        let dir = temp_dir("iso-orphan");
        let fmu = testkit(&dir);
        let mut parent = std::process::Command::new(std::env::current_exe().unwrap())
            .args([
                "--exact",
                "isolation::helper_parent_of_a_hanging_worker",
                "--nocapture",
            ])
            .env("SAVME_TEST_HANG_FMU", &fmu)
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let t = Instant::now();
        let worker = loop {
            if let Some(&w) = children(parent.id()).first() {
                let cmd = std::fs::read_to_string(format!("/proc/{w}/cmdline")).unwrap_or_default();
                if cmd.contains("savme-fmu-worker") {
                    break w;
                }
            }
            assert!(t.elapsed() < Duration::from_secs(60), "no worker started");
            std::thread::sleep(Duration::from_millis(20));
        };
        // Let it reach the hang, then kill its parent with SIGKILL.
        std::thread::sleep(Duration::from_millis(500));
        assert!(alive(worker));
        parent.kill().unwrap();
        parent.wait().unwrap();
        let t = Instant::now();
        while alive(worker) {
            if t.elapsed() > Duration::from_secs(10) {
                // Kill it, or it would hold the test's output open forever.
                let _ = std::process::Command::new("kill")
                    .args(["-9", &worker.to_string()])
                    .status();
                panic!("worker {worker} outlived its parent");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        // Issue 26 item 9: killed with SIGKILL, the worker left its unpacked FMU; the next
        // start (any process that unpacks an FMU) removes it, and only what dead processes left.
        let left = unpacked_by(worker);
        assert_eq!(left.len(), 1, "{left:?}");
        // (This process's first unpacking sweeps; the explicit sweep is for when it has
        // unpacked before.)
        let mine = FmuFile::open(&fmu).unwrap();
        let swept = savme_fmu::file::sweep_stale_unpacked();
        assert!(!left[0].exists(), "{left:?}");
        assert_eq!(unpacked_by(worker), Vec::<PathBuf>::new());
        // What a live process (this one) unpacked stays.
        let own = format!("savme-fmu-{}-", std::process::id());
        assert!(
            swept.iter().all(|p| !p.to_string_lossy().contains(&own)),
            "{swept:?}"
        );
        let uri = mine.resource_uri.to_string_lossy().into_owned();
        let resources = uri.strip_prefix("file://").unwrap();
        assert!(Path::new(resources).parent().unwrap().is_dir(), "{uri}");
    }
}

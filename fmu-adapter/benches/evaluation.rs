//! Per-evaluation cost of the adapter on the trivial test-kit FMU: `fmi2Reset` (the instance is
//! reused) + set-up + initialisation + 100 `fmi2DoStep`s, reading the failure signal after
//! each step, + reading the cost output — as FMI 2.0 and as FMI 3.0 (the same library exports
//! both APIs; `fmi3Reset`, `fmi3EnterInitializationMode`, … `fmi3DoStep`).
//!
//! `cargo bench -p savme-fmu --bench evaluation`
//! (FMPy on the same FMUs, for scale: `python3 fmu-adapter/benches/fmpy_evaluation.py
//! target/savme-fmu-testkit.fmu target/savme-fmu-testkit3.fmu`.)
use criterion::{criterion_group, criterion_main, Criterion};
use savme_fmu::{
    Binding, CostSource, Failure, FmuFile, FmuSimulator, RunSpec, ScenarioSpec, StepSize,
};
use savme_kernel::{Assignment, Role, Scale, Space, Variable};
use std::hint::black_box;
use std::path::PathBuf;
use std::sync::Arc;

/// The test kit's library packed as an FMU of FMI version `fmi` (2 or 3).
fn testkit_fmu(fmi: u8) -> PathBuf {
    let exe = std::env::current_exe().expect("bench executable");
    let deps = exe.parent().expect("deps dir");
    let name = format!(
        "{}savme_fmu_testkit{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    let lib = [deps.join(&name), deps.join("..").join(&name)]
        .into_iter()
        .find(|p| p.exists())
        .expect("the test-kit library next to the bench");
    // target/savme-fmu-testkit.fmu and …testkit3.fmu, kept for the FMPy comparison.
    let (name, xml) = if fmi == 3 {
        (
            "savme-fmu-testkit3.fmu",
            savme_fmu_testkit::model_description3(),
        )
    } else {
        (
            "savme-fmu-testkit.fmu",
            savme_fmu_testkit::model_description(),
        )
    };
    let out = deps
        .parent()
        .and_then(|p| p.parent())
        .unwrap_or(deps)
        .join(name);
    savme_fmi_export::pack(&xml, "savme_fmu_testkit", &lib, &out).expect("pack");
    println!("trivial FMU (FMI {fmi}.0): {}", out.display());
    out
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("fmu");
    for fmi in [2, 3] {
        bench_version(&mut g, fmi);
    }
    g.finish();
}

fn bench_version(g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>, fmi: u8) {
    let fmu = testkit_fmu(fmi);
    let file = Arc::new(FmuFile::open(&fmu).expect("open"));
    let fidelity = Space::new(vec![Variable::continuous(
        "rate",
        0.5,
        4.0,
        4,
        Scale::Linear,
    )])
    .expect("space");
    let phi = Space::new(vec![Variable::continuous(
        "start",
        0.0,
        1.0,
        4,
        Scale::Linear,
    )])
    .expect("space");
    let spec = RunSpec {
        fmu_log: false,
        tolerance: None,
        stop_time: 1.0,
        step: StepSize::Fixed(0.01),
        failure: Failure::Boolean {
            variable: "failed".into(),
        },
        stop_on_failure: false,
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
            fixed: vec![],
        }],
    };
    let mut sim = FmuSimulator::new(file.clone(), file, spec, Some(&fidelity), &|_| {
        Some(phi.clone())
    })
    .expect("simulator");
    let p = Assignment::new().with("start", 0.0);
    let t = Assignment::new().with("rate", 0.1);
    let r = sim.run(Role::High, "grow", &p, &t).expect("run");
    assert_eq!(r.work, Some(100));
    // Timed like fmu-adapter/benches/fmpy_evaluation.py times FMPy: each evaluation on its
    // own, the median of many — on a busy machine a median of single evaluations leaves out
    // the pre-emptions a criterion sample of many iterations includes, so this is the figure
    // to set against FMPy's.
    let mut times: Vec<f64> = (0..20_000)
        .map(|_| {
            let t0 = std::time::Instant::now();
            black_box(sim.run(Role::High, "grow", &p, &t).expect("run"));
            t0.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    println!(
        "savme-fmu, FMI {fmi}.0, single evaluations timed like fmpy_evaluation.py: median {:.2} µs (20000 runs)",
        times[times.len() / 2] * 1e6
    );
    let name = if fmi == 3 {
        "evaluation_100_steps_fmi3"
    } else {
        "evaluation_100_steps"
    };
    g.bench_function(name, |b| {
        b.iter(|| black_box(sim.run(Role::High, "grow", &p, &t).expect("run")))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);

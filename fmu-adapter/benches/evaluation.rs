//! Per-evaluation cost of the adapter on the trivial test-kit FMU: `fmi2Reset` (the instance is
//! reused) + set-up + initialisation + 100 `fmi2DoStep`s, reading the failure signal after
//! each step, + reading the cost output.
//!
//! `cargo bench -p savme-fmu --bench evaluation`
//! (FMPy on the same FMU, for scale: `python3 fmu-adapter/benches/fmpy_evaluation.py
//! target/savme-fmu-testkit.fmu`.)
use criterion::{criterion_group, criterion_main, Criterion};
use savme_fmu::{
    Binding, CostSource, Failure, FmuFile, FmuSimulator, RunSpec, ScenarioSpec, StepSize,
};
use savme_kernel::{Assignment, Role, Scale, Space, Variable};
use std::hint::black_box;
use std::path::PathBuf;
use std::sync::Arc;

fn testkit_fmu() -> PathBuf {
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
    // target/savme-fmu-testkit.fmu, kept for the FMPy comparison.
    let out = deps
        .parent()
        .and_then(|p| p.parent())
        .unwrap_or(deps)
        .join("savme-fmu-testkit.fmu");
    savme_fmi_export::pack(
        &savme_fmu_testkit::model_description(),
        "savme_fmu_testkit",
        &lib,
        &out,
    )
    .expect("pack");
    println!("trivial FMU: {}", out.display());
    out
}

fn bench(c: &mut Criterion) {
    let fmu = testkit_fmu();
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
    let mut sim = FmuSimulator::new(
        file.clone(),
        file,
        spec,
        Some(&fidelity),
        &|_| Some(phi.clone()),
        None,
    )
    .expect("simulator");
    let p = Assignment::new().with("start", 0.0);
    let t = Assignment::new().with("rate", 0.1);
    let r = sim.run(Role::High, "grow", &p, &t).expect("run");
    assert_eq!(r.work, Some(100));
    let mut g = c.benchmark_group("fmu");
    g.bench_function("evaluation_100_steps", |b| {
        b.iter(|| black_box(sim.run(Role::High, "grow", &p, &t).expect("run")))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

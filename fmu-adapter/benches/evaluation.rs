//! Per-evaluation cost of the adapter on the trivial test-kit FMU: `fmi2Reset` (the instance is
//! reused) + set-up + initialisation + 100 `fmi2DoStep`s, reading the failure signal after
//! each step, + reading the cost output — as FMI 2.0 and as FMI 3.0 (the same library exports
//! both APIs; `fmi3Reset`, `fmi3EnterInitializationMode`, … `fmi3DoStep`).
//!
//! `cargo bench -p savme-fmu --bench evaluation`
//! (FMPy on the same FMUs, for scale: `python3 fmu-adapter/benches/fmpy_evaluation.py
//! target/savme-fmu-testkit.fmu target/savme-fmu-testkit3.fmu`.)
mod testkit;

use criterion::{criterion_group, criterion_main, Criterion};
use savme_kernel::{Assignment, Role};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("fmu");
    for fmi in [2, 3] {
        bench_version(&mut g, fmi);
    }
    g.finish();
}

fn bench_version(g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>, fmi: u8) {
    let mut sim = testkit::simulator(fmi);
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

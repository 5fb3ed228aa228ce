//! One HF run per scenario with camera + lidar perception, and with the idealised perception
//! (occlusion + noise), release, one thread. φ cycles through 16 uniform samples.
//!
//! `cargo bench -p savme-sim --bench hf_run`
use criterion::{criterion_group, criterion_main, Criterion};
use savme_kernel::{Assignment, Kernel, Phase};
use savme_sim::fidelity;
use savme_sim::scenario::{phi_space, SCENARIOS};
use savme_sim::sim::DrivingSimulator;
use std::hint::black_box;
use std::time::Duration;

fn phis(info: &savme_sim::scenario::ScenarioInfo) -> Vec<Assignment> {
    let mut k = Kernel::builder(fidelity::space(10), fidelity::theta_hf())
        .scenario(info.name, phi_space(info), 1.0)
        .seed(3)
        .build()
        .expect("valid config");
    k.set_phase(Phase::Baseline);
    (0..16).map(|_| k.ask().phi).collect()
}

fn bench(c: &mut Criterion) {
    let sim = DrivingSimulator::default();
    let ideal = DrivingSimulator::ideal();
    let hf = fidelity::theta_hf();
    let mut g = c.benchmark_group("hf_run");
    for (prefix, simulator) in [("", &sim), ("ideal_", &ideal)] {
        for info in &SCENARIOS {
            let phis = phis(info);
            let mut i = 0;
            g.bench_function(format!("{prefix}{:02}_{}", info.id, info.name), |b| {
                b.iter(|| {
                    i = (i + 1) % phis.len();
                    let run = simulator.run(info.name, &phis[i], &hf, false);
                    black_box(run.expect("valid run"))
                })
            });
        }
    }
    g.finish();

    // What each setting buys: scenario 7 with θ_HF, with every setting at its cheapest value,
    // and with one setting at a time at its cheapest value.
    let mut s = c.benchmark_group("settings");
    let info = &SCENARIOS[6];
    let phis = phis(info);
    let space = fidelity::space(10);
    let mut cheapest_all = hf.clone();
    let mut variants: Vec<(String, Assignment)> = vec![("hf".into(), hf.clone())];
    for v in space.variables() {
        let value = savme_sim::settings::cheapest_value(v);
        cheapest_all.set(&v.name, value.clone());
        variants.push((format!("only_{}", v.name), hf.clone().with(&v.name, value)));
    }
    variants.insert(1, ("all_cheapest".into(), cheapest_all));
    for (name, theta) in &variants {
        let mut i = 0;
        s.bench_function(name.as_str(), |b| {
            b.iter(|| {
                i = (i + 1) % phis.len();
                black_box(
                    sim.run(info.name, &phis[i], theta, false)
                        .expect("valid run"),
                )
            })
        });
    }
    s.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(20)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    targets = bench
}
criterion_main!(benches);

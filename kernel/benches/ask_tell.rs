//! Ask+tell cost on the paper's space: Table I's 16 fidelity settings (continuous ones in 10 log
//! bins) and one scenario of 4 continuous parameters with 10 bins each.
//!
//! `cargo bench -p savme-kernel --bench ask_tell`
use criterion::{criterion_group, criterion_main, Criterion};
use savme_kernel::journal::Journaled;
use savme_kernel::{paper, Kernel, KernelConfig, Observation, Run, Scale, Space, Trial, Variable};
use std::hint::black_box;
use std::time::{Duration, Instant};

fn config() -> KernelConfig {
    let phi = Space::new(
        ["ego_speed", "intruder_speed", "gap", "intruder_decel"]
            .iter()
            .map(|n| Variable::continuous(n, 1.0, 30.0, 10, Scale::Linear))
            .collect(),
    )
    .expect("valid φ-space");
    Kernel::builder(paper::fidelity_space(10), paper::theta_hf())
        .scenario("lead_vehicle", phi, 1.0)
        .budget(0.3)
        .seed(1)
        .build()
        .expect("valid config")
        .config()
        .clone()
}

/// A cheap synthetic outcome so that only the kernel is measured.
fn observe(t: &Trial) -> Observation {
    let hf = t.phi.get_f64("gap").unwrap_or(0.0) < 8.0;
    let theta = t.theta_lf.as_ref().expect("paired trial");
    let rate = theta.get_f64("simulation_rate_hz").unwrap_or(10.0);
    let lf = hf ^ (rate < 4.0);
    Observation::Paired {
        hf: Run::new(hf, 1.0),
        lf: Run::new(lf, rate / 10.0),
    }
}

fn warmed(told: usize) -> Kernel {
    let mut k = Kernel::new(config()).expect("valid config");
    for _ in 0..told {
        let t = k.ask();
        let o = observe(&t);
        k.tell(t.id, o).expect("valid tell");
    }
    k
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("ask_tell");
    for told in [1_000usize, 1_000_000] {
        let mut k = warmed(told);
        g.bench_function(format!("after_{told}_told"), |b| {
            b.iter(|| {
                let t = k.ask();
                let o = observe(&t);
                black_box(k.tell(t.id, o).expect("valid tell"));
            })
        });
    }
    // The journal's own cost (the event sink in memory; writing lines to a file is the trial
    // store's, benchmarked in the `savme` package).
    g.bench_function("journaled_in_memory", |b| {
        b.iter_custom(|iters| {
            let mut log = Journaled::start(config(), Vec::new()).expect("start");
            let start = Instant::now();
            for _ in 0..iters {
                let t = log.ask().expect("in memory");
                let o = observe(&t);
                black_box(log.tell(t.id, o).expect("tell"));
            }
            start.elapsed()
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(30)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    targets = bench
}
criterion_main!(benches);

//! Ask+tell cost on the paper's space: Table II's 16 fidelity settings (continuous ones in 10 log
//! bins) and one scenario of 4 continuous parameters with 10 bins each.
//!
//! `cargo bench -p savme-kernel --bench ask_tell`
use criterion::{criterion_group, criterion_main, Criterion};
mod setup;

use savme_kernel::journal::Journaled;
use setup::{config, observe, tuned_config, warmed, warmed_with};
use std::hint::black_box;
use std::time::{Duration, Instant};

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
    // The tuned kernel with every scenario's archive full (4,096 trials each): the elite
    // proposal's Parzen scores dominate; ranking per cost adds one more kernel sum per candidate.
    for (name, per_cost) in [
        ("tuned_after_40000_told", true),
        ("elite_odds_after_40000_told", false),
    ] {
        let mut k = warmed_with(tuned_config(per_cost), 40_000);
        g.bench_function(name, |b| {
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

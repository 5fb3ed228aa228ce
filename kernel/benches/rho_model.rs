//! The ρ model's price per ask + tell (`EliteMixture::rho_model`, issue 42): the thin band of
//! `kernel/tests/rho_model.rs` (two φ variables, a robustness on every run, most told trials
//! failures near the band), the archive full (5,000 told, 4,096 kept), with the ρ model and
//! without it; and 10 asks + tells after 300 told (the peer benchmark's lengths).
//!
//! `cargo bench -p savme-kernel --bench rho_model`
use criterion::{criterion_group, criterion_main, Criterion};
use savme_kernel::{
    Assignment, EliteMixture, Kernel, Observation, Run, Scale, SearchModel, Space, Trial, Variable,
};
use std::hint::black_box;
use std::time::Duration;

fn kernel(m: EliteMixture) -> Kernel {
    let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 5, 10])]).expect("space");
    let phi = Space::new(vec![
        Variable::continuous("h", 0.0, 1.0, 10, Scale::Linear),
        Variable::continuous("v", 0.0, 1.0, 10, Scale::Linear),
    ])
    .expect("space");
    let config = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
        .scenario("band", phi, 1.0)
        .search(SearchModel::EliteMixture(m))
        .seed(3)
        .build()
        .expect("config")
        .config()
        .clone();
    Kernel::new(config).expect("kernel")
}

/// The band: a failure for `v < 0.08 + 0.04·h`, ρ = `v − 0.08 − 0.04·h`, a failure costing 1
/// and a pass 40.
fn observe(t: &Trial) -> Observation {
    let h = t.phi.get_f64("h").unwrap_or(0.0);
    let v = t.phi.get_f64("v").unwrap_or(0.0);
    let rho = v - 0.08 - 0.04 * h;
    let failure = rho < 0.0;
    let hf = Run::new(failure, if failure { 1.0 } else { 40.0 }).with_robustness(rho);
    match &t.theta_lf {
        Some(_) => Observation::Paired {
            hf,
            lf: Run::new(failure, 0.5),
        },
        None => Observation::HfOnly(hf),
    }
}

fn step(k: &mut Kernel) {
    let t = k.ask();
    let o = observe(&t);
    black_box(k.tell(t.id, o).expect("valid tell"));
}

/// The same kernel, its configuration's `rho_model` switched (through a snapshot): the same
/// archive, elites and in-flight state, so that the difference is the process's own cost.
fn switched(k: &Kernel, rho_model: bool) -> Kernel {
    // Text, not a `serde_json::Value`: the snapshot's generator state is a 128-bit integer.
    let json = k.to_json();
    let (from, to) = ("\"rho_model\":true", "\"rho_model\":false");
    assert!(
        json.contains(from) || json.contains(to),
        "no rho_model in the snapshot"
    );
    let json = if rho_model {
        json.replace(to, from)
    } else {
        json.replace(from, to)
    };
    Kernel::from_json(&json).expect("restores")
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("rho_model");
    let mut with = kernel(EliteMixture::default());
    for _ in 0..5000 {
        step(&mut with);
    }
    let mut same = switched(&with, false);
    let mut without = kernel(EliteMixture {
        rho_model: false,
        ..EliteMixture::default()
    });
    for _ in 0..5000 {
        step(&mut without);
    }
    // With the ρ model; the same archive without it (the process's own price is the
    // difference); and the search run without it from the start (another archive).
    g.bench_function("full_archive", |b| b.iter(|| step(&mut with)));
    g.bench_function("same_archive_without", |b| b.iter(|| step(&mut same)));
    g.bench_function("full_archive_without", |b| b.iter(|| step(&mut without)));
    // At the peer benchmark's lengths (200–300 search trials per family): 300 told. Each
    // sample restarts from a clone of the warmed kernel, so the archive stays at that size.
    let mut short = kernel(EliteMixture::default());
    for _ in 0..300 {
        step(&mut short);
    }
    let short_without = switched(&short, false);
    for (name, warmed) in [("after_300", &short), ("after_300_without", &short_without)] {
        g.bench_function(name, |b| {
            b.iter_batched_ref(
                || warmed.clone(),
                |k| {
                    for _ in 0..10 {
                        step(k);
                    }
                },
                criterion::BatchSize::SmallInput,
            )
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(20)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    targets = bench
}
criterion_main!(benches);

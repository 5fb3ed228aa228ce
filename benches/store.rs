//! The trial store's cost on the serve path: an ask and a tell of the toy kernel, each journaled
//! as a line of a locked JSON-lines file (`savme serve --journal`), against the same kernel
//! journaled in memory.
//!
//! `cargo bench --bench store`
use criterion::{criterion_group, criterion_main, Criterion};
use savme::campaign::store::{journal, JsonlStore};
use savme::kernel::journal::Journaled;
use savme::kernel::{Observation, Run, Trial};
use std::hint::black_box;
use std::time::{Duration, Instant};

fn observe(t: &Trial) -> Observation {
    let fails = t.phi.get_f64("ego_speed").unwrap_or(0.0) > 28.0;
    Observation::Paired {
        hf: Run::new(fails, 1.0),
        lf: Run::new(fails, 0.25),
    }
}

fn bench(c: &mut Criterion) {
    let config = savme::toy::kernel_builder()
        .seed(1)
        .build()
        .expect("the toy kernel")
        .config()
        .clone();
    let mut g = c.benchmark_group("store");
    g.bench_function("journaled_in_memory", |b| {
        b.iter_custom(|iters| {
            let mut log = Journaled::start(config.clone(), Vec::new()).expect("start");
            let start = Instant::now();
            for _ in 0..iters {
                let t = log.ask().expect("in memory");
                black_box(log.tell(t.id, observe(&t)).expect("tell"));
            }
            start.elapsed()
        })
    });
    let dir = std::env::temp_dir().join(format!("savme-bench-store-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    g.bench_function("journaled_to_jsonl_store", |b| {
        b.iter_custom(|iters| {
            let path = dir.join("j.jsonl");
            let _ = std::fs::remove_file(&path);
            let store = JsonlStore::open(&path).expect("store");
            let mut j = journal::open(Box::new(store), Some(config.clone())).expect("journal");
            let start = Instant::now();
            for _ in 0..iters {
                let t = j.kernel.ask().expect("write");
                black_box(j.kernel.tell(t.id, observe(&t)).expect("tell"));
            }
            start.elapsed()
        })
    });
    let _ = std::fs::remove_dir_all(&dir);
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

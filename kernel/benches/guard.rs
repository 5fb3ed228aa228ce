//! The per-call regression guard (issue 39 item 6): the kernel's ask+tell — the paper's method
//! after 10³ told trials, the tuned method with full archives after 40,000 — each timed as a
//! ratio to a reference loop measured in the same run (batches interleaved, so both see the same
//! machine), compared with the ratios recorded in `kernel/benches/guard.json`. Exits with status
//! 1 when a ratio is more than 10 % above its record: a shared, noisy machine moves absolute
//! times, but it moves the reference loop too.
//!
//! `cargo bench -p savme-kernel --bench guard` checks; `… --bench guard -- --record` rewrites
//! the record (after a change that is meant to cost more or less).
mod setup;

use rand::{RngExt, SeedableRng};
use savme_kernel::Kernel;
use setup::{config, observe, tuned_config, warmed_with};
use std::collections::BTreeMap;
use std::hint::black_box;
use std::time::Instant;

/// How far above its recorded ratio a measured one may be before it counts as a regression.
const TOLERANCE: f64 = 1.10;
/// Interleaved batches per measurement (the median is kept).
const BATCHES: usize = 15;

/// A fixed, kernel-like unit of work: draws, a small vector, `exp`, name look-ups.
fn reference_unit(rng: &mut rand_pcg::Pcg64, names: &BTreeMap<String, f64>) -> f64 {
    let draws: Vec<f64> = (0..20).map(|_| rng.random::<f64>()).collect();
    let mut acc: f64 = draws.iter().map(|x| (-x * x).exp()).sum();
    for key in [
        "gap",
        "ego_speed",
        "simulation_rate_hz",
        "camera_near_clipping_m",
    ] {
        acc += names.get(key).copied().unwrap_or(0.0);
    }
    acc
}

/// Seconds per call of `kernel` and of the reference unit: medians over interleaved batches of
/// `calls` and `units` each.
fn measure(kernel: &mut Kernel, calls: usize, units: usize) -> (f64, f64) {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    let names: BTreeMap<String, f64> = ["gap", "ego_speed", "simulation_rate_hz", "lane"]
        .iter()
        .enumerate()
        .map(|(i, n)| (n.to_string(), i as f64))
        .collect();
    let (mut k, mut r) = (Vec::new(), Vec::new());
    for _ in 0..BATCHES {
        let start = Instant::now();
        for _ in 0..units {
            black_box(reference_unit(&mut rng, &names));
        }
        r.push(start.elapsed().as_secs_f64() / units as f64);
        let start = Instant::now();
        for _ in 0..calls {
            let t = kernel.ask();
            let o = observe(&t);
            black_box(kernel.tell(t.id, o).expect("valid tell"));
        }
        k.push(start.elapsed().as_secs_f64() / calls as f64);
    }
    (median(k), median(r))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn record_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/guard.json")
}

fn main() {
    let record = std::env::args().any(|a| a == "--record");
    let cases: [(&str, Kernel, usize); 2] = [
        (
            "paper_after_1000_told",
            warmed_with(config(), 1_000),
            20_000,
        ),
        (
            "tuned_after_40000_told",
            warmed_with(tuned_config(true), 40_000),
            40,
        ),
    ];
    let mut ratios = BTreeMap::new();
    for (name, mut kernel, calls) in cases {
        let (per_call, per_unit) = measure(&mut kernel, calls, 20_000);
        let ratio = per_call / per_unit;
        println!(
            "{name}: {:.3} µs per ask+tell, reference {:.3} µs: ratio {ratio:.2}",
            per_call * 1e6,
            per_unit * 1e6
        );
        ratios.insert(name.to_string(), ratio);
    }
    let path = record_path();
    if record {
        let text = serde_json::to_string_pretty(&ratios).expect("ratios as JSON") + "\n";
        std::fs::write(&path, text).expect("write the record");
        println!("recorded in {}", path.display());
        return;
    }
    let recorded: BTreeMap<String, f64> = match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text).expect("a valid guard.json"),
        Err(e) => {
            eprintln!("{}: {e}; run with -- --record first", path.display());
            std::process::exit(2);
        }
    };
    let mut regressed = false;
    for (name, ratio) in &ratios {
        let Some(&was) = recorded.get(name) else {
            eprintln!("{name}: not in {}; run with -- --record", path.display());
            std::process::exit(2);
        };
        let verdict = if *ratio > was * TOLERANCE {
            regressed = true;
            "REGRESSION"
        } else {
            "ok"
        };
        println!("{name}: ratio {ratio:.2} against {was:.2} recorded: {verdict}");
    }
    if regressed {
        std::process::exit(1);
    }
}

//! Trial throughput of a campaign with 1 and 2 worker threads (the issue's `--jobs 2` ≥ 1.8 ×
//! `--jobs 1` target).
//!
//! `cargo bench --bench jobs -- [repetitions]`
//!
//! A reduced protocol (one budget, 60 meta-training iterations, 20 evaluations, 30 meta-testing
//! iterations per prior, 60 + 30 baseline trials: 230 trials, 370 simulator runs) on the
//! camera-and-lidar simulator with work-unit cost, so that every repetition runs exactly the same trials.
//! Each repetition runs the campaign once per job count, alternating; the median wall time per
//! job count and their ratio are printed.
use savme::campaign::{self, Campaign, Cost, Protocol};
use savme_sim::sim::DrivingSimulator;
use std::time::Instant;

fn protocol() -> Protocol {
    let (train, test) = savme_sim::scenario::train_test_names();
    Protocol {
        budgets: vec![0.3],
        train_iterations: 60,
        eval_iterations: 20,
        test_iterations: 30,
        baseline_train_iterations: 60,
        baseline_test_iterations: 30,
        cost: Cost::Work,
        ..Protocol::paper(savme::compose::SENSORS, train, test)
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `cargo bench` passes `--bench`; the first number given is the repetition count.
    let reps: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(5);
    let p = protocol();
    let problem = campaign::Problem::from(savme_sim::problem(10));
    let sim = DrivingSimulator::default();
    let dir = std::env::temp_dir().join(format!("savme-bench-jobs-{}", std::process::id()));
    let mut times: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    for rep in 0..reps {
        for (k, jobs) in [1usize, 2].into_iter().enumerate() {
            let _ = std::fs::remove_dir_all(&dir);
            let t = Instant::now();
            let out = Campaign::new(p.clone(), problem.clone())
                .out(&dir)
                .jobs(jobs)
                .run(&sim)?;
            let s = t.elapsed().as_secs_f64();
            assert_eq!(out.ran, p.total_trials());
            println!("rep {rep}: --jobs {jobs}: {s:.2} s");
            times[k].push(s);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    let trials = p.total_trials() as f64;
    let (t1, t2) = (median(times[0].clone()), median(times[1].clone()));
    println!(
        "{} trials; median --jobs 1: {t1:.2} s ({:.1} trials/s); --jobs 2: {t2:.2} s ({:.1} trials/s); throughput ratio {:.2}",
        p.total_trials(),
        trials / t1,
        trials / t2,
        t1 / t2
    );
    Ok(())
}

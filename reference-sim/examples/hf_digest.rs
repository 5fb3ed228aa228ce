//! A digest of many recorded sensor runs, to check that a change to the simulator leaves every
//! result bit-identical: every scenario, `runs` draws of φ, each run once with θ_HF and once
//! with a random θ (any setting, any rate), recording every step (trajectory, camera images,
//! lidar clouds, detections). Prints the digest of everything recorded (the `Debug` text of
//! each result, which writes every float exactly; wall-clock time left out), the total work
//! units and the CPU time the runs took.
//!
//! `cargo run --release -p savme-sim --example hf_digest -- [runs] [seed]` (defaults 8 1): run it
//! before and after a change; the digests must be equal.
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use savme_kernel::{Assignment, Kernel, Phase};
use savme_sim::fidelity;
use savme_sim::scenario::{phi_space, SCENARIOS};
use savme_sim::sim::DrivingSimulator;
use std::hash::{DefaultHasher, Hasher};
use std::time::Instant;

/// A random θ over Table II (continuous settings log-uniform over their ranges).
fn random_theta(rng: &mut Pcg64) -> Assignment {
    let log_uniform =
        |rng: &mut Pcg64, lo: f64, hi: f64| (lo.ln() + rng.random::<f64>() * (hi / lo).ln()).exp();
    let mut theta = Assignment::new()
        .with(
            "simulation_rate_hz",
            [2, 4, 6, 8, 10][rng.random_range(0..5usize)],
        )
        .with(
            "camera_bloom_level",
            if rng.random::<bool>() { "high" } else { "low" },
        )
        .with("camera_view_distance_m", log_uniform(rng, 10.0, 5000.0))
        .with("camera_near_clipping_m", log_uniform(rng, 0.2, 20.0))
        .with("lidar_subsample_count", rng.random_range(1..=5i64))
        .with("lidar_raytracing_bounces", rng.random_range(0..=4i64))
        .with("lidar_near_clipping_m", log_uniform(rng, 0.2, 20.0));
    for flag in [
        "camera_disable_bloom",
        "camera_disable_lighting",
        "camera_disable_shadows",
        "camera_disable_lens_model",
        "camera_disable_depth_of_field",
        "camera_disable_shot_noise",
        "lidar_disable_shot_noise",
        "lidar_disable_ambient_effects",
        "lidar_disable_translucency",
    ] {
        theta.set(flag, rng.random::<bool>());
    }
    theta
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let runs: usize = args.next().map_or(Ok(8), |a| a.parse())?;
    let seed: u64 = args.next().map_or(Ok(1), |a| a.parse())?;
    let sim = DrivingSimulator::default();
    let hf = fidelity::theta_hf();
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut digest = DefaultHasher::new();
    let (mut work, mut cpu) = (0u64, 0.0f64);
    for info in &SCENARIOS {
        let mut kernel = Kernel::builder(fidelity::space(10), hf.clone())
            .scenario(info.name, phi_space(info), 1.0)
            .seed(seed)
            .build()?;
        kernel.set_phase(Phase::Baseline);
        for _ in 0..runs {
            let phi = kernel.ask().phi;
            for theta in [hf.clone(), random_theta(&mut rng)] {
                let clock = Instant::now();
                let mut run = sim.run(info.name, &phi, &theta, true)?;
                cpu += clock.elapsed().as_secs_f64();
                run.wall_seconds = 0.0;
                work += run.work;
                // The images by their bits (their `Debug` text would take longer than the runs).
                for frame in run.sensor_frames.iter_mut().flatten() {
                    for p in frame.image.pixels.drain(..) {
                        for c in p {
                            digest.write_u32(c.to_bits());
                        }
                    }
                }
                digest.write(format!("{run:?}").as_bytes());
            }
        }
    }
    println!(
        "digest {:016x} work {work} seconds {cpu:.2}",
        digest.finish()
    );
    Ok(())
}

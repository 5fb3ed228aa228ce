//! Failure rate of every scenario under uniform φ and θ_HF (the paper's baseline), the figure
//! the scenario ranges are calibrated against (target: 5–35 % each).
//!
//! `cargo run --release -p savme-sim --example failure_rates -- [samples] [seed] [sensors|ideal] [scenario]`
use savme_kernel::{Kernel, Observation, Phase, Run};
use savme_sim::fidelity;
use savme_sim::scenario::{phi_space, SCENARIOS};
use savme_sim::sim::DrivingSimulator;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(Ok(500), |a| a.parse())?;
    let seed: u64 = args.next().map_or(Ok(1), |a| a.parse())?;
    let sim = match args.next().as_deref() {
        None | Some("sensors") => DrivingSimulator::default(),
        Some("ideal") => DrivingSimulator::ideal(),
        Some(other) => return Err(format!("perception `{other}`: use sensors or ideal").into()),
    };
    let only: Option<u8> = args.next().map(|a| a.parse()).transpose()?;
    println!(
        "{:>3}  {:<34} {:>8} {:>10} {:>12}",
        "id", "scenario", "failures", "rate", "HF run (ms)"
    );
    for info in SCENARIOS
        .iter()
        .filter(|s| only.is_none_or(|id| id == s.id))
    {
        let mut k = Kernel::builder(fidelity::space(10), fidelity::theta_hf())
            .scenario(info.name, phi_space(info), 1.0)
            .seed(seed)
            .build()?;
        k.set_phase(Phase::Baseline);
        let (mut fails, mut wall) = (0, 0.0);
        for _ in 0..n {
            let t = k.ask();
            let r = sim.run(info.name, &t.phi, k.theta_hf(), false)?;
            fails += usize::from(r.failure);
            wall += r.wall_seconds;
            k.tell(
                t.id,
                Observation::HfOnly(Run::new(r.failure, r.wall_seconds.max(1e-9))),
            )?;
        }
        println!(
            "{:>3}  {:<34} {:>8} {:>9.1}% {:>12.3}",
            info.id,
            info.name,
            fails,
            100.0 * fails as f64 / n as f64,
            1e3 * wall / n as f64
        );
    }
    Ok(())
}

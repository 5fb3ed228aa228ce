//! Whether LF runs can stand in for HF runs in a failure-probability estimate on the rare
//! setting A of docs/RESULTS.md ("Failure probability from cheap runs"): `lead_vehicle_brakes`,
//! idealised perception (0.1 m noise), ego speed ~ N(12, 2) truncated to [10, 25] — here
//! conditioned on ego speed ≥ `min-ego` (where the failures are), the other variables uniform.
//! Each draw runs HF (θ_HF, 10 Hz) and LF (θ_HF with `simulation_rate_hz` = `rate`: with
//! idealised perception the only setting that changes a run). Printed: both failure rates,
//! their agreement and correlation (what a control variate could remove: ρ²), the LF/HF cost
//! in work units, and for a gate "run HF when the LF's robustness ≤ r" the share of draws
//! gated and of HF failures caught (what a two-phase, LF-screened estimate would pay).
//!
//! `cargo run --release -p savme-sim --example mf_agreement -- [draws] [min-ego] [seed] [rate]`
//! (defaults 8000 13.5 7 2).
use rand::{RngExt, SeedableRng};
use savme_kernel::{Assignment, Domain};
use savme_sim::scenario::{find, phi_space};
use savme_sim::sim::DrivingSimulator;

/// One draw: (HF fails, LF fails, LF robustness, LF work, HF work).
type Pair = (bool, bool, f64, f64, f64);

/// Ego speed ~ N(12, 2) restricted to [lo, 25] (rejection, Box–Muller).
fn ego_speed(rng: &mut impl rand::Rng, lo: f64) -> f64 {
    loop {
        let (u1, u2): (f64, f64) = (rng.random(), rng.random());
        let z = (-2.0 * u1.max(1e-300).ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
        let x = 12.0 + 2.0 * z;
        if (lo..=25.0).contains(&x) {
            return x;
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let draws: usize = args.next().map_or(Ok(8000), |a| a.parse())?;
    let min_ego: f64 = args.next().map_or(Ok(13.5), |a| a.parse())?;
    let seed: u64 = args.next().map_or(Ok(7), |a| a.parse())?;
    let rate: i64 = args.next().map_or(Ok(2), |a| a.parse())?;
    let info = find("lead_vehicle_brakes").ok_or("no lead_vehicle_brakes")?;
    let space = phi_space(info);
    let sim = DrivingSimulator::ideal();
    let hf = savme_sim::fidelity::theta_hf();
    let lf = hf.clone().with("simulation_rate_hz", rate);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut pairs: Vec<Pair> = Vec::with_capacity(draws);
    for _ in 0..draws {
        let mut phi = Assignment::new();
        for v in space.variables() {
            let Domain::Continuous { lo, hi, .. } = v.domain else {
                return Err(format!("{} is not continuous", v.name).into());
            };
            let x = if &*v.name == "ego_speed" {
                ego_speed(&mut rng, min_ego)
            } else {
                lo + rng.random::<f64>() * (hi - lo)
            };
            phi.set(&v.name, x);
        }
        let h = sim.run(info.name, &phi, &hf, false)?;
        let l = sim.run(info.name, &phi, &lf, false)?;
        pairs.push((
            h.failure,
            l.failure,
            l.min_distance,
            l.work as f64,
            h.work as f64,
        ));
    }
    report(&pairs, rate, min_ego);
    Ok(())
}

fn report(pairs: &[Pair], rate: i64, min_ego: f64) {
    let n = pairs.len() as f64;
    let count = |f: &dyn Fn(&Pair) -> bool| pairs.iter().filter(|p| f(p)).count() as f64;
    let (h, l, both) = (count(&|p| p.0), count(&|p| p.1), count(&|p| p.0 && p.1));
    let (ph, pl) = (h / n, l / n);
    let rho = (both / n - ph * pl) / (ph * (1.0 - ph) * pl * (1.0 - pl)).sqrt();
    let work: (f64, f64) = pairs.iter().fold((0.0, 0.0), |a, p| (a.0 + p.3, a.1 + p.4));
    println!(
        "{} draws, ego speed ≥ {min_ego} m/s; LF = θ_HF at {rate} Hz",
        pairs.len()
    );
    println!(
        "HF failures {h} ({:.2} %), LF failures {l} ({:.2} %), both {both}",
        100.0 * ph,
        100.0 * pl
    );
    println!(
        "LF catches {:.0} % of the HF failures; false alarms {}; correlation ρ = {rho:.3} (a control variate removes ρ² = {:.1} % of the variance)",
        100.0 * both / h.max(1.0),
        l - both,
        100.0 * rho * rho
    );
    println!("LF/HF cost (work units): {:.3}", work.0 / work.1);
    for gate in [0.0, 0.5, 1.0, 2.0, 3.0, 4.0] {
        let gated = count(&|p| p.2 <= gate);
        let caught = count(&|p| p.0 && p.2 <= gate);
        println!(
            "gate LF robustness ≤ {gate} m: {:.1} % of draws gated, {:.0} % of HF failures caught",
            100.0 * gated / n,
            100.0 * caught / h.max(1.0)
        );
    }
}

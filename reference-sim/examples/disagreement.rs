//! How often the learned-fidelity run disagrees with the HF run, and what it costs.
//!
//! Part 1 — 200 uniform (scenario, φ, θ_LF) pairs: overall disagreement, and per setting the
//! disagreement and LF/HF work ratio among the pairs where that setting took its cheapest value
//! vs the others.
//! Part 2 — one setting at a time: from θ_HF, switch one setting to its cheapest value, over
//! the same φ samples: disagreement and work ratio attributable to that setting alone.
//!
//! `cargo run --release -p savme-sim --example disagreement -- [pairs] [per-setting] [seed]`
use savme_kernel::{Assignment, Domain, Kernel};
use savme_sim::fidelity;
use savme_sim::scenario::{phi_space, SCENARIOS};
use savme_sim::settings::cheapest_value;
use savme_sim::sim::DrivingSimulator;

// Long because it is a straight-line study script: sample, run, tabulate, print.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let pairs: usize = args.next().map_or(Ok(200), |a| a.parse())?;
    let per_setting: usize = args.next().map_or(Ok(40), |a| a.parse())?;
    let seed: u64 = args.next().map_or(Ok(1), |a| a.parse())?;
    let space = fidelity::space(10);
    let hf = fidelity::theta_hf();
    let sim = DrivingSimulator::default();
    // A kernel over all ten scenarios draws uniform φ (baseline) and uniform θ (untrained).
    let mut b = Kernel::builder(space.clone(), hf.clone()).seed(seed);
    for info in &SCENARIOS {
        b = b.scenario(info.name, phi_space(info), 1.0);
    }
    let mut k = b.build()?;
    let mut rows = Vec::new(); // (θ, disagree, work ratio)
    let mut samples = Vec::new();
    for _ in 0..pairs {
        let t = k.ask();
        let theta = t.theta_lf.clone().ok_or("paired trial")?;
        let h = sim.run(&t.scenario, &t.phi, &hf, false)?;
        let l = sim.run(&t.scenario, &t.phi, &theta, false)?;
        rows.push((theta, h.failure != l.failure, l.work as f64 / h.work as f64));
        samples.push((t.scenario.clone(), t.phi.clone(), h.failure, h.work));
        k.cancel(t.id)?;
    }
    let overall = rows.iter().filter(|r| r.1).count() as f64 / rows.len() as f64;
    let mean_ratio = rows.iter().map(|r| r.2).sum::<f64>() / rows.len() as f64;
    println!("Part 1: {pairs} uniform (scenario, φ, θ_LF) pairs");
    println!(
        "  overall disagreement {:.1} %, mean LF/HF work {mean_ratio:.3}",
        100.0 * overall
    );
    println!(
        "  {:<32} {:>22} {:>22}",
        "setting", "cheapest: dis. / work", "others: dis. / work"
    );
    for v in space.variables() {
        let cheap = cheapest_value(v);
        let is_cheap = |theta: &Assignment| match (&v.domain, theta.get(&v.name)) {
            (Domain::Continuous { lo, hi, .. }, Some(x)) => {
                let x = x.as_f64().unwrap_or(f64::NAN);
                let f = if v.name.contains("view") {
                    (x / lo).ln() / (hi / lo).ln()
                } else {
                    1.0 - (x / lo).ln() / (hi / lo).ln()
                };
                f < 0.3
            }
            (_, Some(x)) => x.same_as(&cheap),
            _ => false,
        };
        let stat = |sel: bool| {
            let g: Vec<_> = rows.iter().filter(|r| is_cheap(&r.0) == sel).collect();
            let n = g.len().max(1) as f64;
            (
                g.iter().filter(|r| r.1).count() as f64 / n,
                g.iter().map(|r| r.2).sum::<f64>() / n,
                g.len(),
            )
        };
        let (a, b) = (stat(true), stat(false));
        println!(
            "  {:<32} {:>6.1} % / {:.3} (n={:>3}) {:>6.1} % / {:.3} (n={:>3})",
            v.name,
            100.0 * a.0,
            a.1,
            a.2,
            100.0 * b.0,
            b.1,
            b.2
        );
    }
    println!(
        "\nPart 2: one setting at its cheapest value, the rest at θ_HF ({per_setting} φ samples)"
    );
    println!(
        "  {:<32} {:>10} {:>12} {:>10}",
        "setting", "cheapest", "disagree", "LF/HF work"
    );
    for v in space.variables() {
        let theta = hf.clone().with(&v.name, cheapest_value(v));
        let (mut dis, mut ratio) = (0usize, 0.0);
        for (s, phi, hf_fail, hf_work) in samples.iter().take(per_setting) {
            let l = sim.run(s, phi, &theta, false)?;
            dis += usize::from(l.failure != *hf_fail);
            ratio += l.work as f64 / *hf_work as f64;
        }
        let n = per_setting.min(samples.len()) as f64;
        println!(
            "  {:<32} {:>10} {:>10.1} % {:>10.3}",
            v.name,
            cheapest_value(v).to_string(),
            100.0 * dis as f64 / n,
            ratio / n
        );
    }
    Ok(())
}

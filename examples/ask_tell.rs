//! The savme kernel embedded in a hand-written harness, on the toy paired simulator.
//!
//! Runs the SAVME protocol in miniature — baseline, meta-training, evaluation — and prints what
//! the kernel learned: the fidelity settings θ_LF*, where each scenario fails, and the speedup
//! over the baseline.
//!
//! ```text
//! cargo run --release --example ask_tell -- [--iterations N] [--budget C] [--seed S] [--cost wall|work]
//! ```
use savme::kernel::metrics::{break_even, speedup, Accounting, FailureCurve, Summary};
use savme::kernel::{
    CostMeasure, Estimator, Kernel, Observation, Phase, Role, Simulator, Trial, TrialRecord,
};
use savme::toy::{self, ToySimulator};
use std::error::Error;
use std::process::ExitCode;

struct Options {
    iterations: usize,
    budget: f64,
    seed: u64,
    cost: CostMeasure,
}

fn parse() -> Result<Options, String> {
    let mut o = Options {
        iterations: 500,
        budget: 0.3,
        seed: 1,
        cost: CostMeasure::Wall,
    };
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or(format!("{flag} needs a value"));
        let bad = |v: &str| format!("{flag}: cannot use `{v}`");
        match flag.as_str() {
            "--iterations" => {
                let v = value()?;
                o.iterations = v.parse().ok().filter(|&n| n > 0).ok_or(bad(&v))?;
            }
            "--budget" => {
                let v = value()?;
                o.budget = v.parse().map_err(|_| bad(&v))?;
            }
            "--seed" => {
                let v = value()?;
                o.seed = v.parse().map_err(|_| bad(&v))?;
            }
            "--cost" => {
                let v = value()?;
                o.cost = match v.as_str() {
                    "wall" => CostMeasure::Wall,
                    "work" => CostMeasure::Work,
                    _ => return Err(bad(&v)),
                };
            }
            "-h" | "--help" => {
                return Err("usage: ask_tell [--iterations N] [--budget C] [--seed S] \
                     [--cost wall|work]"
                    .into())
            }
            other => return Err(format!("unknown option `{other}` (try --help)")),
        }
    }
    Ok(o)
}

/// Runs one trial: HF always, LF too for paired phases.
fn run(
    sim: &mut ToySimulator,
    kernel: &Kernel,
    t: &Trial,
    cost: CostMeasure,
) -> Result<Observation, Box<dyn Error>> {
    let hf = sim
        .simulate_as(Role::High, &t.scenario, &t.phi, kernel.theta_hf())?
        .run(cost)?;
    Ok(match &t.theta_lf {
        None => Observation::HfOnly(hf),
        Some(theta) => Observation::Paired {
            hf,
            lf: sim
                .simulate_as(Role::Learned, &t.scenario, &t.phi, theta)?
                .run(cost)?,
        },
    })
}

/// Asks, runs and tells `n` trials in the kernel's current phase. Asks go out in batches of
/// four and are told in reverse order, as an asynchronous harness would.
fn phase(
    kernel: &mut Kernel,
    sim: &mut ToySimulator,
    n: usize,
    cost: CostMeasure,
) -> Result<Vec<TrialRecord>, Box<dyn Error>> {
    let mut records = Vec::with_capacity(n);
    while records.len() < n {
        let batch: Vec<Trial> = (0..(n - records.len()).min(4))
            .map(|_| kernel.ask())
            .collect();
        for t in batch.iter().rev() {
            let obs = run(sim, kernel, t, cost)?;
            records.push(kernel.tell(t.id, obs)?);
        }
    }
    Ok(records)
}

fn main() -> ExitCode {
    let o = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    match demo(&o) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

// Long because it is the walk-through the README points to, read top to bottom.
fn demo(o: &Options) -> Result<(), Box<dyn Error>> {
    let unit = match o.cost {
        CostMeasure::Wall => "s",
        CostMeasure::Work => "work units",
    };
    let mut kernel = toy::kernel_builder()
        .budget(o.budget)
        .seed(o.seed)
        .build()?;
    let mut sim = ToySimulator;
    println!(
        "savme ask/tell on the toy simulator: {} iterations, C_budget = {}, seed {}, cost in {unit}",
        o.iterations, o.budget, o.seed
    );

    kernel.set_phase(Phase::Baseline);
    let baseline = phase(&mut kernel, &mut sim, o.iterations, o.cost)?;
    kernel.set_phase(Phase::Train);
    let training = phase(&mut kernel, &mut sim, o.iterations, o.cost)?;
    kernel.set_phase(Phase::Evaluate);
    let evaluation = phase(&mut kernel, &mut sim, 100.max(o.iterations / 10), o.cost)?;

    let base = Summary::of(&baseline);
    let train = Summary::of(&training);
    let eval = Summary::of(&evaluation);
    let base_rate = base.hf_failure_rate().unwrap_or(0.0);
    println!("\nlearned fidelity θ_LF* (MAP)          θ_HF");
    let theta_star = kernel.fidelity_estimate(Estimator::Map);
    for ((name, learned), (_, hf)) in theta_star.iter().zip(kernel.theta_hf().iter()) {
        println!("  {name:<22} {:<14} {hf}", learned.to_string());
    }
    println!("\nwhere the scenarios fail (MAP bins of p_ψ(φ | s))");
    for s in toy::SCENARIOS {
        let space = toy::phi_space(s).ok_or("unknown scenario")?;
        let post = kernel.scenario_posterior(s).ok_or("unknown scenario")?;
        let arms = post.best_arms(Estimator::Map);
        let bins: Vec<String> = space
            .variables()
            .iter()
            .zip(&arms)
            .map(|(v, &a)| match v.bin(a as usize) {
                Some((lo, hi)) => format!("{} ∈ [{lo:.1}, {hi:.1}]", v.name),
                None => format!("{} = {}", v.name, v.representative(a as usize)),
            })
            .collect();
        println!("  {s:<18} {}", bins.join(", "));
    }
    println!("\n              failure/TP rate  mean LF cost  speedup");
    println!(
        "  baseline    {base_rate:>15.2}  {:>12.2}  {:>7.2}",
        1.0, 1.0
    );
    let tp = eval.tp_rate().unwrap_or(0.0);
    let cost = eval.mean_lf_cost().unwrap_or(f64::NAN);
    let sp = speedup(tp, cost, base_rate).map_or("n/a".into(), |s| format!("{s:.2}"));
    println!("  evaluation  {tp:>15.2}  {cost:>12.2}  {sp:>7}");
    println!(
        "\ntraining: {} HF failures in {} trials, LF agreed in {:.0} % of them",
        train.hf_failures,
        train.trials,
        100.0 * train.agreement().unwrap_or(0.0)
    );
    let show = |c: f64| match o.cost {
        CostMeasure::Wall => format!("{:.1} ms", c * 1e3),
        CostMeasure::Work => format!("{c:.0} work units"),
    };
    let savme_curve = FailureCurve::from_records(&training, Accounting::AllRuns);
    let base_curve = FailureCurve::from_records(&baseline, Accounting::AllRuns);
    match break_even(&savme_curve, &base_curve) {
        Some(t) => println!(
            "break-even: training (HF + LF runs) is ahead of the baseline from {} on \
             (baseline: {} for {} trials)",
            show(t),
            show(base_curve.end()),
            baseline.len()
        ),
        None => println!(
            "break-even: not reached within the common horizon ({})",
            show(savme_curve.end().min(base_curve.end()))
        ),
    }
    Ok(())
}

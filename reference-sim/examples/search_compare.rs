//! The φ search models of the kernel side by side on the bundled simulator (issue 25): the
//! paper's independent bins against the elite mixture, at an equal budget of deterministic work
//! units, on the eight meta-training scenarios with camera + lidar.
//!
//! Each seed and model runs one meta-training search (train phase, C_budget = 0.3, every trial
//! paired: HF at θ_HF and LF at the drawn θ_LF, both charged) until the budget is spent, and
//! reports HF failures per 10⁹ work units and distinct failing joint cells (10 bins per
//! variable, the φ-spaces' own bins), with a per-scenario breakdown.
//!
//! `cargo run --release -p savme-sim --example search_compare -- [budget_gwu] [seeds] [threads] [models] [train|test]`
//!
//! `budget_gwu` in 10⁹ work units (default 15, about the paper's 500 iterations), `seeds` a
//! count (default 3, seeds 1..=n), `threads` (default 2), `models` a comma list of
//! `bins` and `elite[+key=value…][+binary]` (default `bins,elite`; `+binary` tells no
//! robustness, so the elites are failures only); `test` searches the meta-testing scenarios
//! (9–10) instead of the eight meta-training ones.
use savme_kernel::{EliteMixture, Kernel, Observation, Pairing, Run, SearchModel, Trial};
use savme_sim::fidelity;
use savme_sim::scenario::{phi_space, SCENARIOS};
use savme_sim::sim::DrivingSimulator;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Mutex};

/// What one search found.
#[derive(Debug, Default, Clone)]
struct Tally {
    trials: u64,
    /// Trials with an LF run.
    paired: u64,
    work: u64,
    failures: u64,
    /// Distinct failing (scenario, joint cell).
    cells: BTreeSet<(usize, Vec<usize>)>,
    /// Per scenario: trials, failures.
    per_scenario: BTreeMap<usize, (u64, u64)>,
}

/// How one row searches: the kernel's search model and pairing, and the campaign's window.
struct Spec {
    model: SearchModel,
    pairing: Pairing,
    window: usize,
}

/// `bins` or `elite`, with optional `+key=value` parameters of [`EliteMixture`], of the
/// [`Pairing`] (`pair=FRACTION`, `settle=N`), `window=N` (trials in flight, told in ask order,
/// as a campaign's window) and `+binary` (tell no robustness), e.g. `elite+tries=8+pair=0.25`.
fn model(spec: &str) -> Result<Spec, String> {
    let mut parts = spec.split('+');
    let elite = match parts.next() {
        Some("bins") => false,
        Some("elite") => true,
        _ => return Err(format!("model `{spec}`: use bins or elite[+key=value…]")),
    };
    let mut m = EliteMixture::default();
    let (mut pairing, mut window) = (Pairing::default(), 1usize);
    for p in parts.filter(|p| *p != "binary") {
        let (key, value) = p.split_once('=').ok_or(format!("`{p}`: use key=value"))?;
        let x: f64 = value.parse().map_err(|e| format!("`{p}`: {e}"))?;
        match key {
            "pair" => pairing.fraction = x,
            "settle" => pairing.settle = x as u64,
            "window" => window = (x as usize).max(1),
            "explore" => m.explore = x,
            "bandwidth" => m.bandwidth = x,
            "jump" => m.jump = x,
            "near_miss" => m.near_miss = x,
            "near_miss_weight" => m.near_miss_weight = x,
            "spread" => m.spread = x,
            "near_miss_until" => m.near_miss_until = x as u32,
            "tries" => m.tries = x as u32,
            other => return Err(format!("unknown parameter `{other}`")),
        }
    }
    m.validate().map_err(|e| e.to_string())?;
    pairing.validate().map_err(|e| e.to_string())?;
    let model = if elite {
        SearchModel::EliteMixture(m)
    } else {
        SearchModel::IndependentBins
    };
    Ok(Spec {
        model,
        pairing,
        window,
    })
}

fn search(
    name: &str,
    seed: u64,
    budget: u64,
    train: bool,
) -> Result<Tally, Box<dyn std::error::Error>> {
    let training: Vec<_> = SCENARIOS.iter().filter(|s| s.training() == train).collect();
    let spec = model(name)?;
    let mut b = Kernel::builder(fidelity::space(10), fidelity::theta_hf())
        .budget(0.3)
        .seed(seed)
        .search(spec.model)
        .pairing(spec.pairing);
    for info in &training {
        b = b.scenario(info.name, phi_space(info), 1.0);
    }
    let mut k = b.build()?;
    let sim = DrivingSimulator::default();
    let robust = !name.split('+').any(|p| p == "binary");
    let mut t = Tally::default();
    let mut window: std::collections::VecDeque<Trial> = (0..spec.window).map(|_| k.ask()).collect();
    while t.work < budget {
        let trial = window.pop_front().ok_or("empty window")?;
        let hf = sim.run(&trial.scenario, &trial.phi, k.theta_hf(), false)?;
        let lf = match &trial.theta_lf {
            Some(theta) => Some(sim.run(&trial.scenario, &trial.phi, theta, false)?),
            None => None,
        };
        let run = |r: &savme_sim::sim::RunResult| {
            let run = Run::new(r.failure, r.work.max(1) as f64);
            let rho = if r.failure { -1.0 } else { r.min_distance };
            if robust {
                run.with_robustness(rho)
            } else {
                run
            }
        };
        let observation = match &lf {
            Some(lf) => Observation::Paired {
                hf: run(&hf),
                lf: run(lf),
            },
            None => Observation::HfOnly(run(&hf)),
        };
        k.tell(trial.id, observation)?;
        window.push_back(k.ask());
        t.trials += 1;
        t.paired += u64::from(lf.is_some());
        t.work += hf.work + lf.map_or(0, |l| l.work);
        let e = t.per_scenario.entry(trial.scenario_index).or_default();
        e.0 += 1;
        if hf.failure {
            e.1 += 1;
            t.failures += 1;
            let space = &k.config().scenarios[trial.scenario_index].space;
            t.cells
                .insert((trial.scenario_index, space.arms_of(&trial.phi)?));
        }
    }
    Ok(t)
}

fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

type Results = Arc<Mutex<BTreeMap<(String, u64), Tally>>>;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let budget_gwu: f64 = args.next().map_or(Ok(15.0), |a| a.parse())?;
    let seeds: u64 = args.next().map_or(Ok(3), |a| a.parse())?;
    let threads: usize = args.next().map_or(Ok(2), |a| a.parse())?;
    let models: Vec<String> = args
        .next()
        .unwrap_or_else(|| "bins,elite".into())
        .split(',')
        .map(str::to_string)
        .collect();
    for m in &models {
        model(m)?;
    }
    let train = match args.next().as_deref() {
        None | Some("train") => true,
        Some("test") => false,
        Some(other) => return Err(format!("scenarios `{other}`: use train or test").into()),
    };
    let budget = (budget_gwu * 1e9) as u64;
    let jobs: Vec<(String, u64)> = models
        .iter()
        .flat_map(|m| (1..=seeds).map(move |s| (m.clone(), s)))
        .collect();
    let queue = Arc::new(Mutex::new(jobs));
    let results: Results = Arc::default();
    let workers: Vec<_> = (0..threads.max(1))
        .map(|_| {
            let (queue, results) = (queue.clone(), results.clone());
            std::thread::spawn(move || loop {
                let job = queue.lock().ok().and_then(|mut q| q.pop());
                let Some((m, seed)) = job else { break };
                match search(&m, seed, budget, train) {
                    Ok(t) => {
                        eprintln!(
                            "{m} seed {seed}: {} trials ({} paired), {} HF failures, {} cells",
                            t.trials,
                            t.paired,
                            t.failures,
                            t.cells.len()
                        );
                        if let Ok(mut r) = results.lock() {
                            r.insert((m, seed), t);
                        }
                    }
                    Err(e) => eprintln!("{m} seed {seed}: {e}"),
                }
            })
        })
        .collect();
    for w in workers {
        w.join().map_err(|_| "a worker panicked")?;
    }
    let results = results.lock().map_err(|_| "poisoned")?.clone();
    report(&models, &results, budget_gwu, train);
    Ok(())
}

fn report(
    models: &[String],
    results: &BTreeMap<(String, u64), Tally>,
    budget_gwu: f64,
    train: bool,
) {
    let set = if train {
        "8 meta-training"
    } else {
        "2 meta-testing"
    };
    println!("budget {budget_gwu} × 10⁹ wu per seed; {set} scenarios, camera + lidar\n");
    println!("| model | seeds | trials | HF failures per 10⁹ wu | distinct failing joint cells | failing cells per 10⁹ wu |");
    println!("|---|---|---|---|---|---|");
    for m in models {
        let runs: Vec<&Tally> = results
            .iter()
            .filter(|((n, _), _)| n == m)
            .map(|(_, t)| t)
            .collect();
        if runs.is_empty() {
            continue;
        }
        let per =
            |f: &dyn Fn(&Tally) -> f64| mean_sd(&runs.iter().map(|t| f(t)).collect::<Vec<_>>());
        let (fm, fs) = per(&|t| t.failures as f64 / (t.work as f64 / 1e9));
        let (cm, cs) = per(&|t| t.cells.len() as f64);
        let (pm, ps) = per(&|t| t.cells.len() as f64 / (t.work as f64 / 1e9));
        let (tm, _) = per(&|t| t.trials as f64);
        println!(
            "| {m} | {} | {tm:.0} | {fm:.1} ± {fs:.1} | {cm:.0} ± {cs:.0} | {pm:.1} ± {ps:.1} |",
            runs.len()
        );
    }
    println!("\nper scenario: HF failures / trials, summed over seeds\n");
    print!("| scenario |");
    models.iter().for_each(|m| print!(" {m} |"));
    println!();
    print!("|---|");
    models.iter().for_each(|_| print!("---|"));
    println!();
    for (i, info) in SCENARIOS
        .iter()
        .filter(|s| s.training() == train)
        .enumerate()
    {
        print!("| {} |", info.name);
        for m in models {
            let (n, f) = results
                .iter()
                .filter(|((name, _), _)| name == m)
                .filter_map(|(_, t)| t.per_scenario.get(&i))
                .fold((0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
            print!(" {f} / {n} |");
        }
        println!();
    }
}

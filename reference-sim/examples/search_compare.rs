//! The φ search models of the kernel side by side on the bundled simulator (issue 25): the
//! paper's independent bins against the elite mixture, at an equal budget of deterministic work
//! units, on the eight meta-training scenarios with camera + lidar.
//!
//! Each seed and model runs one meta-training search (train phase, C_budget = 0.3, every trial
//! paired: HF at θ_HF and LF at the drawn θ_LF, both charged) until the budget is spent, and
//! reports HF failures per 10⁹ work units and distinct failing joint cells (10 bins per
//! variable, the φ-spaces' own bins), with a per-scenario breakdown.
//!
//! `cargo run --release -p savme-sim --example search_compare -- [budget_gwu] [seeds] [threads] [models] [train|test] [deploy_gwu] [deployments]`
//!
//! `budget_gwu` in 10⁹ work units (default 15, about the paper's 500 iterations), `seeds` a
//! count (default 3, seeds 1..=n), `threads` (default 2), `models` a comma list of
//! `bins` and `elite[+key=value…][+binary]` (default `bins,elite`; `+binary` tells no
//! robustness, so the elites are failures only); `test` searches the meta-testing scenarios
//! (9–10) instead of the eight meta-training ones.
//!
//! With `deploy_gwu` > 0 every search is then deployed as LF screening with HF confirmation
//! (the campaign's `screen@B` stage: φ from the learned proposal, an LF run at θ_LF*, HF runs
//! as the screen decides, both charged) for that many 10⁹ wu, once per deployment in
//! `deployments` (a comma list, default `paper,margin,adaptive,adaptive+margin`), each from a
//! copy of the same searched kernel: `paper` (frozen proposal, only LF failures confirmed),
//! `learn`, `exploit`, `adaptive` (both; [`savme_kernel::Deployment`]) and `+margin` (LF
//! near-misses also checked on HF, the margin fitted per scenario on the search's trials at
//! θ_LF*: [`savme_kernel::screening::Rule::fit`]). It reports HF-confirmed failures per 10⁹ wu.
use savme_kernel::screening::{Economy, Rule, Screen};
use savme_kernel::{
    Deployment, EliteMixture, Estimator, Kernel, Observation, Pairing, Phase, Run, SearchModel,
    Trial,
};
use savme_sim::fidelity;
use savme_sim::scenario::{phi_space, SCENARIOS};
use savme_sim::sim::DrivingSimulator;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Mutex};

/// A search trial's LF and HF runs, for fitting the screen's margin.
struct Pair {
    scenario: usize,
    /// θ_LF's arms (its bins).
    theta_lf: Vec<usize>,
    lf: Run,
    hf: Run,
}

/// What one search found, and what its deployments found.
#[derive(Debug, Default, Clone)]
struct Tally {
    /// Per deployment: HF-confirmed failures, cost, distinct failing cells.
    deployed: BTreeMap<String, (u64, u64, usize)>,
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

/// The kernel run's result as told: its runtime in work units, and the robustness ρ (the run's
/// minimum distance, −1 on a collision) unless `robust` is false.
fn told(r: &savme_sim::sim::RunResult, robust: bool) -> Run {
    let run = Run::new(r.failure, r.work.max(1) as f64);
    let rho = if r.failure { -1.0 } else { r.min_distance };
    if robust {
        run.with_robustness(rho)
    } else {
        run
    }
}

/// A deployment by name (`paper`, `learn`, `exploit`, `adaptive`, each optionally
/// `+margin`; `margin` alone is `paper+margin`): the kernel's and whether the screen fits a
/// margin.
fn deployment(name: &str) -> Result<(Deployment, bool), String> {
    let name = name.strip_suffix("+direct").unwrap_or(name);
    let (base, margin) = match name.strip_suffix("+margin") {
        Some(b) => (b, true),
        None if name == "margin" => ("paper", true),
        None => (name, false),
    };
    let d = match base {
        "paper" => Deployment::FROZEN,
        "learn" => Deployment {
            learn: true,
            exploit: false,
        },
        "exploit" => Deployment {
            learn: false,
            exploit: true,
        },
        "adaptive" => Deployment::ADAPTIVE,
        other => {
            return Err(format!(
                "deployment `{other}`: use paper, learn, exploit or adaptive"
            ))
        }
    };
    Ok((d, margin))
}

/// Deploys the searched kernel `k` (built with its deployment) as LF screening for `budget`
/// wu; `margin` fits a margin per scenario on the search's trials at θ_LF*.
fn deploy(
    mut k: Kernel,
    pairs: &[Pair],
    (margin, direct): (bool, bool),
    budget: u64,
    robust: bool,
) -> Result<(u64, u64, usize), Box<dyn std::error::Error>> {
    // `+direct`: HF alone where screening does not pay (the campaign's `--screen-lf
    // where-it-pays`), the HF pass costs seeded from the search's paired trials.
    let mut economy = vec![Economy::default(); k.config().scenarios.len()];
    for p in pairs {
        economy[p.scenario].saw_hf(&p.hf);
    }
    k.set_phase(Phase::Evaluate);
    let theta = k
        .config()
        .fidelity
        .arms_of(&k.fidelity_estimate(Estimator::Map))?;
    let rules: Vec<Rule> = (0..k.config().scenarios.len())
        .map(|s| {
            let at: Vec<(Run, Run)> = pairs
                .iter()
                .filter(|p| p.scenario == s && p.theta_lf == theta)
                .map(|p| (p.lf, p.hf))
                .collect();
            if !margin {
                return Rule::PAPER;
            }
            let rule = Rule::fit(&at, 20);
            let missed = at.iter().filter(|(lf, hf)| hf.failure && !lf.failure).count();
            let all = pairs.iter().filter(|p| p.scenario == s).count();
            eprintln!(
                "scenario {s}: {} of {all} search trials at θ_LF*, {missed} HF failures the LF run passed; margin {:?}",
                at.len(),
                rule.margin
            );
            rule
        })
        .collect();
    let sim = DrivingSimulator::default();
    let (mut found, mut work, mut cells) = (0u64, 0u64, BTreeSet::new());
    // What the same φ would have given on HF alone (exact only when the deployment does not
    // learn: then φ does not depend on the outcomes), and the LF share of the cost.
    let (mut trials, mut lf_work, mut missed, mut alone) = (0u64, 0u64, 0u64, (0u64, 0u64));
    let counterfactual = std::env::var_os("SAVME_HF_DIRECT").is_some();
    while work < budget {
        let t = k.ask();
        let theta_lf = t
            .theta_lf
            .as_ref()
            .ok_or("an evaluate trial without θ_LF")?;
        if direct && !economy[t.scenario_index].screen_pays() {
            let hf = sim.run(&t.scenario, &t.phi, k.theta_hf(), false)?;
            work += hf.work;
            trials += 1;
            let hf_run = told(&hf, robust);
            economy[t.scenario_index].add_direct(&hf_run);
            if hf.failure {
                found += 1;
                let space = &k.config().scenarios[t.scenario_index].space;
                cells.insert((t.scenario_index, space.arms_of(&t.phi)?));
            }
            k.tell_direct(t.id, hf_run)?;
            continue;
        }
        let lf = sim.run(&t.scenario, &t.phi, theta_lf, false)?;
        work += lf.work;
        lf_work += lf.work;
        trials += 1;
        if counterfactual {
            let hf = sim.run(&t.scenario, &t.phi, k.theta_hf(), false)?;
            alone.0 += u64::from(hf.failure);
            alone.1 += hf.work;
            missed += u64::from(hf.failure && !lf.failure);
        }
        let lf_run = told(&lf, robust);
        if rules[t.scenario_index].decide(&lf_run, false) == Screen::Pass {
            economy[t.scenario_index].add_screened(&lf_run, None);
            k.tell_unconfirmed(t.id, lf_run)?;
            continue;
        }
        let hf = sim.run(&t.scenario, &t.phi, k.theta_hf(), false)?;
        work += hf.work;
        if hf.failure {
            found += 1;
            let space = &k.config().scenarios[t.scenario_index].space;
            cells.insert((t.scenario_index, space.arms_of(&t.phi)?));
        }
        economy[t.scenario_index].add_screened(&lf_run, Some(&told(&hf, robust)));
        k.tell(
            t.id,
            Observation::Paired {
                hf: told(&hf, robust),
                lf: lf_run,
            },
        )?;
    }
    if counterfactual {
        eprintln!(
            "deployed: {trials} trials, {found} confirmed, LF {:.0} % of the cost, {missed} HF failures the LF run passed; HF alone on the same φ: {} failures, {:.1} per 10⁹ wu",
            100.0 * lf_work as f64 / work as f64,
            alone.0,
            alone.0 as f64 / (alone.1 as f64 / 1e9)
        );
    }
    Ok((found, work, cells.len()))
}

fn search(
    name: &str,
    seed: u64,
    budget: u64,
    train: bool,
    deploy_as: Option<&str>,
    deploy_budget: u64,
) -> Result<Tally, Box<dyn std::error::Error>> {
    let (chosen, margin) = deployment(deploy_as.unwrap_or("paper"))?;
    let training: Vec<_> = SCENARIOS.iter().filter(|s| s.training() == train).collect();
    let spec = model(name)?;
    let mut b = Kernel::builder(fidelity::space(10), fidelity::theta_hf())
        .budget(0.3)
        .seed(seed)
        .search(spec.model)
        .pairing(spec.pairing)
        .deployment(chosen);
    for info in &training {
        b = b.scenario(info.name, phi_space(info), 1.0);
    }
    let mut k = b.build()?;
    let sim = DrivingSimulator::default();
    let robust = !name.split('+').any(|p| p == "binary");
    let mut t = Tally::default();
    let mut pairs = Vec::new();
    let mut window: std::collections::VecDeque<Trial> = (0..spec.window).map(|_| k.ask()).collect();
    while t.work < budget {
        let trial = window.pop_front().ok_or("empty window")?;
        let hf = sim.run(&trial.scenario, &trial.phi, k.theta_hf(), false)?;
        let lf = match &trial.theta_lf {
            Some(theta) => Some(sim.run(&trial.scenario, &trial.phi, theta, false)?),
            None => None,
        };
        let run = |r: &savme_sim::sim::RunResult| told(r, robust);
        let observation = match (&lf, &trial.theta_lf) {
            (Some(lf), Some(theta)) => {
                pairs.push(Pair {
                    scenario: trial.scenario_index,
                    theta_lf: k.config().fidelity.arms_of(theta)?,
                    lf: run(lf),
                    hf: run(&hf),
                });
                Observation::Paired {
                    hf: run(&hf),
                    lf: run(lf),
                }
            }
            _ => Observation::HfOnly(run(&hf)),
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
    if let Some(d) = deploy_as {
        let direct = d.ends_with("+direct");
        let found = deploy(k, &pairs, (margin, direct), deploy_budget, robust)?;
        t.deployed.insert(d.to_string(), found);
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
    let deploy_gwu: f64 = args.next().map_or(Ok(0.0), |a| a.parse())?;
    let deployments: Vec<String> = args
        .next()
        .unwrap_or_else(|| "paper,margin,adaptive,adaptive+margin".into())
        .split(',')
        .map(str::to_string)
        .collect();
    for d in &deployments {
        deployment(d)?;
    }
    let deploy_budget = (deploy_gwu * 1e9) as u64;
    let budget = (budget_gwu * 1e9) as u64;
    // One job per model, seed and deployment: the deployment does not change the search, so
    // every deployment of a seed deploys the same searched kernel (checked below).
    let deploy_as: Vec<Option<String>> = if deploy_budget > 0 {
        deployments.iter().cloned().map(Some).collect()
    } else {
        vec![None]
    };
    let jobs: Vec<(String, u64, Option<String>)> = models
        .iter()
        .flat_map(|m| (1..=seeds).map(move |s| (m.clone(), s)))
        .flat_map(|(m, s)| deploy_as.iter().map(move |d| (m.clone(), s, d.clone())))
        .collect();
    let queue = Arc::new(Mutex::new(jobs));
    let results: Results = Arc::default();
    let workers: Vec<_> = (0..threads.max(1))
        .map(|_| {
            let (queue, results) = (queue.clone(), results.clone());
            std::thread::spawn(move || loop {
                let job = queue.lock().ok().and_then(|mut q| q.pop());
                let Some((m, seed, d)) = job else { break };
                match search(&m, seed, budget, train, d.as_deref(), deploy_budget) {
                    Ok(t) => {
                        eprintln!(
                            "{m} seed {seed}: {} trials ({} paired), {} HF failures, {} cells",
                            t.trials,
                            t.paired,
                            t.failures,
                            t.cells.len()
                        );
                        if let Ok(mut r) = results.lock() {
                            let same = r.entry((m.clone(), seed)).or_insert_with(|| t.clone());
                            if (same.failures, same.work) != (t.failures, t.work) {
                                eprintln!("{m} seed {seed}: the deployment changed the search");
                            }
                            same.deployed.extend(t.deployed);
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
    if deploy_budget > 0 {
        report_deployed(&models, &results, &deployments, deploy_gwu);
    }
    Ok(())
}

fn report_deployed(
    models: &[String],
    results: &BTreeMap<(String, u64), Tally>,
    deployments: &[String],
    deploy_gwu: f64,
) {
    println!("\ndeployed: {deploy_gwu} × 10⁹ wu per seed after each search\n");
    println!("| model | deployment | seeds | HF-confirmed failures per 10⁹ wu | distinct failing cells |");
    println!("|---|---|---|---|---|");
    for m in models {
        for d in deployments {
            let runs: Vec<(u64, u64, usize)> = results
                .iter()
                .filter(|((n, _), _)| n == m)
                .filter_map(|(_, t)| t.deployed.get(d).copied())
                .collect();
            if runs.is_empty() {
                continue;
            }
            let rates: Vec<f64> = runs
                .iter()
                .map(|r| r.0 as f64 / (r.1 as f64 / 1e9))
                .collect();
            let (fm, fs) = mean_sd(&rates);
            let (cm, cs) = mean_sd(&runs.iter().map(|r| r.2 as f64).collect::<Vec<_>>());
            println!(
                "| {m} | {d} | {} | {fm:.1} ± {fs:.1} | {cm:.0} ± {cs:.0} |",
                runs.len()
            );
        }
    }
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

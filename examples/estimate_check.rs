//! The long check of `savme estimate` and its benchmark against plain Monte Carlo, on the
//! bundled simulator with idealised perception (docs/RESULTS.md and docs/BENCHMARKS.md record
//! the runs):
//!
//! 1. a campaign that meta-trains one scenario (`--train-iterations`, C = 0.3);
//! 2. the importance-sampling estimate from its posterior, to ± `--target` (or `--max-runs`);
//! 3. brute-force Monte Carlo under the same nominal with `--mc-runs` HF runs (0: none), drawn here
//!    independently of the estimation code (its own sampler), in `--jobs` threads;
//! 4. whether the estimate's 95 % interval covers the Monte Carlo value, and how many HF runs
//!    plain Monte Carlo would need for the same relative width, z²(1 − p)/(t² p), against the
//!    estimate's HF runs including the training runs that built the proposal.
//!
//! ```text
//! cargo run --release --example estimate_check -- --out DIR [--scenario NAME]
//!     [--train-iterations 200] [--mc-runs 20000] [--target 0.1] [--max-runs 200000]
//!     [--epsilon 0.1] [--nominal SCENARIO.VARIABLE=normal:MEAN,SD]… [--tilt nominal-weighted]
//!     [--refine-rounds 0 --refine-runs 0 --refine-reuse 0] [--noise-sd 0.1] [--jobs 2] [--seed 1]
//!     [--mc-seed 12648430] [--proposal joint --joint-components 8] [--estimate-seed N]
//!     [--pilot-fidelity lf] [--control-calibration 2000 [--control-extra K]]
//! ```
//!
//! `--pilot-fidelity lf` runs the pilot rounds at the campaign's learned θ_LF* (the
//! multi-fidelity estimator); the ratio then charges every run at its cost in HF runs
//! (`hf_equivalent_runs`) and each training trial as 2 HF runs (its HF and LF runs).
//! `--control-calibration N` adds LF runs as control variates for the HF estimate (N
//! calibration pairs choose α and the LF runs per pair; `--control-extra K` forces K), charged
//! the same way.
//!
//! `--proposal joint` makes the pilot rounds fit a joint proposal (a mixture over the whole
//! of φ; docs/ESTIMATION.md) instead of refitting each variable's bins. `--estimate-seed`
//! sets the estimate's own seed (default: derived from the campaign's `--seed`), so several
//! estimates can share one trained campaign.
//!
//! `--noise-sd` is the idealised perception's position noise in metres (0.1, the bundled
//! `--perception ideal`, by default; 0 makes the failure a deterministic function of φ
//! without the noise seeded by φ's hash).
use rand::{RngExt, SeedableRng};
use savme::campaign::estimate::{parse_nominal, EstimateRun, EstimateSettings};
use savme::campaign::{Campaign, Cost, Problem, Protocol};
use savme::compose;
use savme_kernel::estimation::{z95, Fidelity, Nominal, ProposalKind, Tilt};
use savme_kernel::{Assignment, Domain, Role, Simulator};
use savme_sim::sim::DrivingSimulator;
use statrs::distribution::{ContinuousCDF, Normal};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

struct Options {
    out: PathBuf,
    scenario: String,
    train_iterations: u64,
    mc_runs: u64,
    target: f64,
    max_runs: u64,
    epsilon: f64,
    nominal: BTreeMap<String, Nominal>,
    tilt: Tilt,
    refine_rounds: u32,
    refine_runs: u64,
    refine_reuse: u32,
    noise_sd: f64,
    mc_seed: u64,
    jobs: usize,
    seed: u64,
    proposal: ProposalKind,
    joint_components: Option<u32>,
    estimate_seed: Option<u64>,
    pilot_fidelity: Fidelity,
    control_calibration: u64,
    control_extra: Option<u32>,
}

fn options() -> Result<Options, String> {
    let mut o = Options {
        out: PathBuf::new(),
        scenario: "lead_vehicle_brakes".into(),
        train_iterations: 200,
        mc_runs: 20_000,
        target: 0.1,
        max_runs: 200_000,
        epsilon: 0.1,
        nominal: BTreeMap::new(),
        tilt: Tilt::Posterior,
        refine_rounds: 0,
        refine_runs: 0,
        refine_reuse: 0,
        noise_sd: 0.1,
        mc_seed: 0xC0FFEE,
        jobs: 2,
        seed: 1,
        proposal: ProposalKind::Product,
        joint_components: None,
        estimate_seed: None,
        pilot_fidelity: Fidelity::Hf,
        control_calibration: 0,
        control_extra: None,
    };
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let value = args.next().ok_or(format!("{flag} needs a value"))?;
        let num = |v: &str| v.parse::<f64>().map_err(|e| format!("{flag}: {e}"));
        match flag.as_str() {
            "--out" => o.out = value.into(),
            "--scenario" => o.scenario = value,
            "--train-iterations" => o.train_iterations = num(&value)? as u64,
            "--mc-runs" => o.mc_runs = num(&value)? as u64,
            "--target" => o.target = num(&value)?,
            "--max-runs" => o.max_runs = num(&value)? as u64,
            "--epsilon" => o.epsilon = num(&value)?,
            "--jobs" => o.jobs = num(&value)? as usize,
            "--refine-rounds" => o.refine_rounds = num(&value)? as u32,
            "--refine-runs" => o.refine_runs = num(&value)? as u64,
            "--refine-reuse" => o.refine_reuse = num(&value)? as u32,
            "--noise-sd" => o.noise_sd = num(&value)?,
            "--mc-seed" => o.mc_seed = value.parse().map_err(|e| format!("--mc-seed: {e}"))?,
            "--tilt" => {
                o.tilt = serde_json::from_value(serde_json::Value::String(value))
                    .map_err(|e| format!("--tilt: {e}"))?
            }
            "--seed" => o.seed = num(&value)? as u64,
            "--estimate-seed" => o.estimate_seed = Some(num(&value)? as u64),
            "--joint-components" => o.joint_components = Some(num(&value)? as u32),
            "--proposal" => {
                o.proposal = serde_json::from_value(serde_json::Value::String(value))
                    .map_err(|e| format!("--proposal: {e}"))?
            }
            "--pilot-fidelity" => {
                o.pilot_fidelity = serde_json::from_value(serde_json::Value::String(value))
                    .map_err(|e| format!("--pilot-fidelity: {e}"))?
            }
            "--control-calibration" => o.control_calibration = num(&value)? as u64,
            "--control-extra" => o.control_extra = Some(num(&value)? as u32),
            "--nominal" => {
                let (_, variable, n) = parse_nominal(&value).map_err(|e| e.to_string())?;
                o.nominal.insert(variable, n);
            }
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    if o.out.as_os_str().is_empty() {
        return Err("give --out DIR".into());
    }
    Ok(o)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let o = options()?;
    let sim = simulator(o.noise_sd);
    let (_, test) = savme_sim::scenario::train_test_names();
    let mut protocol = Protocol::quick(compose::IDEAL, vec![o.scenario.clone()], test);
    protocol.seed = o.seed;
    protocol.cost = Cost::Work;
    protocol.train_iterations = o.train_iterations;
    protocol.eval_iterations = 1;
    protocol.test_iterations = 1;
    protocol.baseline_train_iterations = 1;
    protocol.baseline_test_iterations = 1;
    let campaign_dir = o.out.join("campaign");
    let t0 = Instant::now();
    Campaign::new(
        protocol.clone(),
        Problem::from(savme_sim::problem(protocol.fidelity_bins)),
    )
    .out(&campaign_dir)
    .jobs(o.jobs)
    .run(&sim)?;
    let t_train = t0.elapsed().as_secs_f64();
    let mut nominal = BTreeMap::new();
    if !o.nominal.is_empty() {
        nominal.insert(o.scenario.clone(), o.nominal.clone());
    }
    let settings = EstimateSettings {
        epsilon: o.epsilon,
        target_width: Some(o.target),
        max_runs: o.max_runs,
        nominal,
        tilt: o.tilt,
        refine_rounds: o.refine_rounds,
        refine_runs: o.refine_runs,
        refine_reuse: o.refine_reuse,
        proposal: o.proposal,
        joint_components: o.joint_components,
        seed: o.estimate_seed,
        pilot_fidelity: o.pilot_fidelity,
        control_calibration: o.control_calibration,
        control_extra: o.control_extra,
        ..EstimateSettings::default()
    };
    let t1 = Instant::now();
    let est = EstimateRun::new(
        savme::campaign::source::DirSource::new(&campaign_dir),
        Problem::from(savme_sim::problem(protocol.fidelity_bins)),
        settings,
    )
    .out(o.out.join("estimate"))
    .jobs(o.jobs)
    .run(&sim)?;
    let t_is = t1.elapsed().as_secs_f64();
    println!("{}", est.table_md);
    let total = est.estimate.total;
    let reached = total.relative_half_width();
    let z = z95();
    let mc_needed = |p: f64| z * z * (1.0 - p) / (reached * reached * p);
    // With an LF pilot, every run in HF runs of equal cost (`hf_equivalent_runs`), and each
    // training trial charged as 2 HF runs (its HF run and its LF run, which costs less).
    let is_runs = if o.pilot_fidelity == Fidelity::Lf || o.control_calibration > 0 {
        est.hf_equivalent_runs + 2.0 * est.training_hf_runs as f64
    } else {
        (est.estimate_hf_runs + est.pilot_hf_runs - est.pilot_hf_runs_reused + est.training_hf_runs)
            as f64
    };
    let mut report = serde_json::json!({
        "scenario": o.scenario,
        "nominal": o.nominal,
        "epsilon": o.epsilon,
        "tilt": o.tilt,
        "refine_rounds": o.refine_rounds,
        "refine_runs": o.refine_runs,
        "refine_reuse": o.refine_reuse,
        "proposal": o.proposal,
        "joint_components": o.joint_components,
        "estimate_seed": o.estimate_seed,
        "noise_sd": o.noise_sd,
        "train_iterations": o.train_iterations,
        "importance_sampling": {
            "estimate": total.mean, "lo": total.lo, "hi": total.hi,
            "relative_half_width": reached, "hf_runs": est.estimate_hf_runs,
            "training_hf_runs": est.training_hf_runs, "stopped": est.stopped,
            "pilot_hf_runs": est.pilot_hf_runs, "pilot_failures": est.pilot_failures,
            "pilot_hf_runs_reused": est.pilot_hf_runs_reused,
            "pilot_fidelity": o.pilot_fidelity, "pilot_lf_runs": est.pilot_lf_runs,
            "pilot_lf_cost": est.pilot_lf_cost, "theta_lf": est.theta_lf,
            "hf_equivalent_runs": est.hf_equivalent_runs, "charged_runs": is_runs,
            "control_calibration": o.control_calibration, "control_extra": o.control_extra,
            "calibration_hf_runs": est.control.calibration_hf_runs,
            "control_lf_runs": est.control.control_lf_runs, "control_lf_cost": est.control.control_lf_cost,
            "control": est.estimate.scenarios[0].control,
            "failures": est.estimate.failures,
            "ess": est.estimate.scenarios[0].ess,
            "failure_ess": est.estimate.scenarios[0].failure_ess,
            "seconds": t_is, "training_seconds": t_train,
        },
        "plain_mc_runs_for_same_width": { "at_is_p": mc_needed(total.mean) },
        "ratio_mc_over_is_incl_training": { "at_is_p": mc_needed(total.mean) / is_runs },
    });
    let mut covered = true;
    if o.mc_runs > 0 {
        let t2 = Instant::now();
        let (mc_failures, mc_runs) = monte_carlo(&o)?;
        let t_mc = t2.elapsed().as_secs_f64();
        let p_mc = mc_failures as f64 / mc_runs as f64;
        let (mc_lo, mc_hi) = wilson(mc_failures as f64, mc_runs as f64, z);
        covered = total.lo <= p_mc && p_mc <= total.hi;
        report["monte_carlo"] = serde_json::json!({
            "estimate": p_mc, "wilson_lo": mc_lo, "wilson_hi": mc_hi,
            "runs": mc_runs, "failures": mc_failures, "seconds": t_mc, "seed": o.mc_seed,
        });
        report["is_interval_covers_mc"] = covered.into();
        // The two estimates' difference in combined standard errors (the MC value has its
        // own noise, which "covers" ignores).
        let se_mc = (p_mc * (1.0 - p_mc) / mc_runs as f64).sqrt();
        report["difference_in_combined_se"] =
            ((total.mean - p_mc) / (total.std_error.powi(2) + se_mc * se_mc).sqrt()).into();
        report["plain_mc_runs_for_same_width"]["at_mc_p"] = mc_needed(p_mc).into();
        report["ratio_mc_over_is_incl_training"]["at_mc_p"] = (mc_needed(p_mc) / is_runs).into();
    }
    let text = serde_json::to_string_pretty(&report)?;
    std::fs::write(o.out.join("check.json"), text.clone() + "\n")?;
    println!("{text}");
    if !covered {
        return Err(format!(
            "the IS interval [{}, {}] does not cover the MC value",
            total.lo, total.hi
        )
        .into());
    }
    Ok(())
}

/// The bundled simulator with idealised perception of this position noise.
fn simulator(noise_sd: f64) -> DrivingSimulator {
    DrivingSimulator {
        perception: savme_sim::sim::PerceptionMode::Ideal { noise_sd },
    }
}

/// Wilson's 95 % interval of `k` successes in `n`.
fn wilson(k: f64, n: f64, z: f64) -> (f64, f64) {
    let p = k / n;
    let d = 1.0 + z * z / n;
    let c = (p + z * z / (2.0 * n)) / d;
    let h = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / d;
    (c - h, c + h)
}

/// Plain Monte Carlo under the nominal, in `jobs` threads with their own seeded streams:
/// uniform variables drawn directly, normal ones by inverting the truncated normal's CDF.
fn monte_carlo(o: &Options) -> Result<(u64, u64), String> {
    let space = savme_sim::scenario::spaces()
        .remove(&o.scenario)
        .ok_or(format!("unknown scenario {}", o.scenario))?;
    let theta = savme_sim::fidelity::theta_hf();
    let per = o.mc_runs.div_ceil(o.jobs as u64);
    let results: Vec<Result<u64, String>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..o.jobs as u64)
            .map(|j| {
                let (space, theta) = (&space, &theta);
                s.spawn(move || {
                    let mut rng = rand_pcg::Pcg64::seed_from_u64(o.mc_seed + j);
                    let mut sim = simulator(o.noise_sd);
                    let mut failures = 0;
                    for _ in 0..per {
                        let mut phi = Assignment::new();
                        for v in space.variables() {
                            let Domain::Continuous { lo, hi, .. } = v.domain else {
                                return Err(format!("{} is not continuous", v.name));
                            };
                            let u: f64 = rng.random();
                            let x = match o.nominal.get(&*v.name) {
                                Some(Nominal::Normal { mean, sd }) => {
                                    let n = Normal::new(*mean, *sd).map_err(|e| e.to_string())?;
                                    let (a, b) = (n.cdf(lo), n.cdf(hi));
                                    n.inverse_cdf(a + u * (b - a)).clamp(lo, hi)
                                }
                                _ => lo + u * (hi - lo),
                            };
                            phi.set(&v.name, x);
                        }
                        let r = sim
                            .simulate_as(Role::High, &o.scenario, &phi, theta)
                            .map_err(|e| e.to_string())?;
                        failures += u64::from(r.failure);
                    }
                    Ok(failures)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err("a Monte Carlo thread panicked".into()))
            })
            .collect()
    });
    let mut failures = 0;
    for r in results {
        failures += r?;
    }
    Ok((failures, per * o.jobs as u64))
}

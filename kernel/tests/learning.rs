//! Seeded statistical tests on a synthetic paired problem whose best fidelity settings and
//! failure region are known: the posteriors must concentrate there, and a carried-over
//! fidelity prior must speed up learning on a new scenario.
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64 as Rng64;
use savme_kernel::metrics::Summary;
use savme_kernel::{
    Assignment, Estimator, Kernel, KernelBuilder, Observation, Phase, Run, Scale, Space, Variable,
};

/// Fidelity, built so that every variable's best arm is best whatever the others are (the
/// independence the bandits assume): `rate` (HF 10) trades cost for agreement and rate 10 is
/// over budget; high `detail` (HF) multiplies the cost by 4, which breaks the budget for rates
/// 2 and 5; disabling the lens model makes LF disagree often; a view distance below 50 m makes
/// LF disagree and the longest views cost too much at rate 5. With C_budget = 0.3 the best
/// setting is rate 5, detail low, lens kept, view in bin 2 or 3 ([120, 1443] m).
fn fidelity() -> (Space, Assignment) {
    let space = Space::new(vec![
        Variable::discrete("rate", [1, 2, 5, 10]),
        Variable::discrete("detail", ["low", "high"]),
        Variable::boolean("disable_lens"),
        Variable::continuous("view", 10.0, 5000.0, 5, Scale::Log),
    ])
    .unwrap();
    let hf = Assignment::new()
        .with("rate", 10)
        .with("detail", "high")
        .with("disable_lens", false)
        .with("view", 5000.0);
    (space, hf)
}

fn lf_model(theta: &Assignment) -> (f64, f64) {
    let rate = theta.get_f64("rate").unwrap() as i64;
    let high = theta.get("detail").and_then(|v| v.as_label()) == Some("high");
    let lens = theta.get_bool("disable_lens").unwrap();
    let view = theta.get_f64("view").unwrap();
    let frac = (view / 10.0).ln() / 500f64.ln();
    let (rate_cost, mut agree) = match rate {
        1 => (0.05, 0.5),
        2 => (0.1, 0.75),
        5 => (0.2, 0.97),
        _ => (1.0, 1.0),
    };
    let cost = rate_cost
        * if high { 4.0 } else { 1.0 }
        * if lens { 0.9 } else { 1.0 }
        * (0.8 + 0.8 * frac);
    if lens {
        agree *= 0.6;
    }
    if view < 50.0 {
        agree *= 0.5;
    }
    (cost, agree)
}

/// φ: speed (6 linear bins on [0, 30]) and gap (5 linear bins on [0, 100]).
fn phi() -> Space {
    Space::new(vec![
        Variable::continuous("speed", 0.0, 30.0, 6, Scale::Linear),
        Variable::continuous("gap", 0.0, 100.0, 5, Scale::Linear),
    ])
    .unwrap()
}

/// Scenario "train": fails for speed ≥ 20 and gap < 40. Scenario "new": speed < 10, gap ≥ 60.
fn hf_fails(scenario: &str, phi: &Assignment) -> bool {
    let (v, g) = (phi.get_f64("speed").unwrap(), phi.get_f64("gap").unwrap());
    match scenario {
        "train" => v >= 20.0 && g < 40.0,
        _ => v < 10.0 && g >= 60.0,
    }
}

fn observe(rng: &mut Rng64, t: &savme_kernel::Trial) -> Observation {
    let hf = hf_fails(&t.scenario, &t.phi);
    let (cost, agree) = lf_model(t.theta_lf.as_ref().unwrap());
    let lf = if rng.random::<f64>() < agree { hf } else { !hf };
    Observation::Paired {
        hf: Run::new(hf, 1.0),
        lf: Run::new(lf, cost),
    }
}

fn builder(scenario: &str, seed: u64) -> KernelBuilder {
    let (f, hf) = fidelity();
    Kernel::builder(f, hf)
        .scenario(scenario, phi(), 1.0)
        .budget(0.3)
        .seed(seed)
}

fn train(kernel: &mut Kernel, sim_seed: u64, n: usize) -> Vec<savme_kernel::TrialRecord> {
    let mut rng = Rng64::seed_from_u64(sim_seed);
    (0..n)
        .map(|_| {
            let t = kernel.ask();
            let o = observe(&mut rng, &t);
            kernel.tell(t.id, o).unwrap()
        })
        .collect()
}

#[test]
fn posteriors_concentrate_on_the_best_fidelity_and_the_failure_region() {
    for seed in 1..=3 {
        let mut k = builder("train", seed).build().unwrap();
        let records = train(&mut k, 100 + seed, 1500);
        let f = k.fidelity_posterior().best_arms(Estimator::Map);
        assert_eq!(
            f[0],
            2,
            "seed {seed}: rate 5 expected, posterior {:?}",
            k.fidelity_posterior().variable("rate")
        );
        assert_eq!(f[1], 0, "seed {seed}: detail low expected");
        assert_eq!(f[2], 0, "seed {seed}: lens kept expected");
        assert!(f[3] == 2 || f[3] == 3, "seed {seed}: view bin {}", f[3]);
        let p = k
            .scenario_posterior("train")
            .unwrap()
            .best_arms(Estimator::Map);
        assert!(p[0] >= 4, "seed {seed}: speed bin {}", p[0]);
        assert!(p[1] <= 1, "seed {seed}: gap bin {}", p[1]);
        // Uniform φ finds a failure 2/6 · 2/5 = 13 % of the time; the learned p_ψ far more often.
        let late = Summary::of(&records[1200..]);
        assert!(
            late.hf_failure_rate().unwrap() > 0.5,
            "seed {seed}: {:?}",
            late.hf_failure_rate()
        );
        // Evaluation with θ_LF* agrees with HF and is cheap.
        k.set_phase(Phase::Evaluate);
        let eval = Summary::of(&train(&mut k, 7, 200));
        assert!(
            eval.agreement().unwrap() > 0.9,
            "seed {seed}: {:?}",
            eval.agreement()
        );
        assert!(eval.mean_lf_cost().unwrap() <= 0.3);
    }
}

#[test]
fn a_learned_fidelity_prior_speeds_up_a_new_scenario() {
    // Meta-testing as in the paper: 200 trials on a new scenario, fidelity prior from
    // meta-training vs uniform. Scenario credit (an HF failure) does not depend on θ_LF, so the
    // prior shows in the fidelity credit: far fewer trials lost to disagreement or overspending.
    let (mut warm_ok, mut cold_ok) = (0usize, 0usize);
    let fid_ok = |r: &[savme_kernel::TrialRecord]| {
        r.iter().filter(|r| r.credit.fidelity == Some(true)).count()
    };
    for seed in 1..=6 {
        let mut k = builder("train", seed).build().unwrap();
        train(&mut k, 200 + seed, 800);
        let posterior = k.fidelity_posterior().clone();
        let mut warm = builder("new", 50 + seed)
            .fidelity_prior(posterior, 1.0)
            .build()
            .unwrap();
        let mut cold = builder("new", 50 + seed).build().unwrap();
        warm.set_phase(Phase::Test);
        cold.set_phase(Phase::Test);
        let w = train(&mut warm, 300 + seed, 200);
        let c = train(&mut cold, 300 + seed, 200);
        warm_ok += fid_ok(&w);
        cold_ok += fid_ok(&c);
    }
    // Out of 1,200 trials each: the uniform prior pays for exploring the fidelity space again.
    let (warm_loss, cold_loss) = (1200 - warm_ok, 1200 - cold_ok);
    assert!(
        3 * warm_loss < cold_loss,
        "fidelity losses: learned prior {warm_loss}, uniform {cold_loss}"
    );
}

//! What the evaluate phase (evaluation, LF screening) does with what the search learned: the
//! default is the paper's frozen proposal (serialised as before, crediting nothing); `learn`
//! credits the φ search with every evaluate-phase result (an unconfirmed LF pass as a pass)
//! and leaves θ_LF* alone; `exploit` draws for failures; snapshots restore the exact asks
//! mid-deployment; and on a synthetic problem an exploiting deployment confirms more failures
//! per cost than the frozen one (fixed seeds, with margins).
use savme_kernel::screening::{Rule, Screen};
use savme_kernel::{
    Assignment, Deployment, EliteMixture, Kernel, KernelConfig, Observation, Phase, Run, Scale,
    SearchModel, Space, Trial, Variable,
};

fn config(deployment: Deployment, seed: u64) -> KernelConfig {
    let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 5, 10])]).unwrap();
    let phi = Space::new(vec![
        Variable::continuous("a", 0.0, 1.0, 10, Scale::Linear),
        Variable::continuous("b", 0.0, 1.0, 10, Scale::Linear),
    ])
    .unwrap();
    Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
        .scenario("s", phi, 1.0)
        // Without the ρ model (issue 42), as when the figures below were measured: with it the
        // frozen proposal also lands in the corner (seed 1: exploiting 1.43 against frozen
        // 1.33 confirmed failures per unit cost), which is not what these tests measure.
        .search(SearchModel::EliteMixture(EliteMixture {
            rho_model: false,
            ..EliteMixture::default()
        }))
        .deployment(deployment)
        .seed(seed)
        .build()
        .unwrap()
        .config()
        .clone()
}

/// HF fails in the corner a + b > 1.5 (12.5 % of the square); a failing HF run costs 0.5, a
/// pass 1; LF costs rate / 10 and fails with HF at 5 Hz and above (below also at a + b > 1.2).
fn runs(t: &Trial) -> (Run, Option<Run>) {
    let [a, b] = ["a", "b"].map(|n| t.phi.get_f64(n).unwrap());
    let m = 1.5 - a - b;
    let hf = Run::new(m < 0.0, if m < 0.0 { 0.5 } else { 1.0 }).with_robustness(m);
    let lf = t.theta_lf.as_ref().map(|theta| {
        let rate = theta.get_f64("rate_hz").unwrap();
        let fails = m < 0.0 || (rate < 3.0 && m < 0.3);
        Run::new(fails, rate / 10.0).with_robustness(m)
    });
    (hf, lf)
}

/// A searched kernel: `n` paired train trials.
fn searched(deployment: Deployment, seed: u64, n: usize) -> Kernel {
    let mut k = Kernel::new(config(deployment, seed)).unwrap();
    for _ in 0..n {
        let t = k.ask();
        let (hf, lf) = runs(&t);
        k.tell(
            t.id,
            Observation::Paired {
                hf,
                lf: lf.unwrap(),
            },
        )
        .unwrap();
    }
    k.set_phase(Phase::Evaluate);
    k
}

/// One screened trial: LF, then HF if the paper's rule calls for it; returns (HF failure
/// confirmed, cost).
fn screen_one(k: &mut Kernel) -> (bool, f64) {
    let t = k.ask();
    let (hf, lf) = runs(&t);
    let lf = lf.expect("an evaluate trial runs LF");
    if Rule::PAPER.decide(&lf, false) == Screen::Pass {
        let cost = lf.runtime;
        k.tell_unconfirmed(t.id, lf).unwrap();
        return (false, cost);
    }
    let (found, cost) = (hf.failure, hf.runtime + lf.runtime);
    k.tell(t.id, Observation::Paired { hf, lf }).unwrap();
    (found, cost)
}

/// Confirmed failures per unit of cost over `n` screened trials.
fn deploy(k: &mut Kernel, n: usize) -> f64 {
    let (mut found, mut cost) = (0usize, 0.0);
    for _ in 0..n {
        let (f, c) = screen_one(k);
        found += usize::from(f);
        cost += c;
    }
    found as f64 / cost
}

#[test]
fn the_default_is_frozen_and_serialises_as_before() {
    let c = config(Deployment::default(), 1);
    assert!(c.deployment.is_frozen());
    assert!(!serde_json::to_string(&c).unwrap().contains("deployment"));
    let json = serde_json::to_string(&config(Deployment::ADAPTIVE, 1)).unwrap();
    assert!(
        json.contains(r#""deployment":{"learn":true,"exploit":true}"#),
        "{json}"
    );
    // An unknown field is refused, named.
    let bad = json.replace(r#""exploit":true"#, r#""exploits":true"#);
    let e = serde_json::from_str::<KernelConfig>(&bad).unwrap_err();
    assert!(e.to_string().contains("exploits"), "{e}");
}

#[test]
fn a_frozen_deployment_credits_nothing_and_a_learning_one_credits_the_search_only() {
    for (deployment, credited) in [(Deployment::FROZEN, false), (Deployment::ADAPTIVE, true)] {
        let mut k = searched(deployment, 3, 60);
        let theta_before = k.fidelity_posterior().clone();
        let bins_before = k.scenario_posterior("s").unwrap().clone();
        for _ in 0..40 {
            let t = k.ask();
            let (hf, lf) = runs(&t);
            let record = k
                .tell(
                    t.id,
                    Observation::Paired {
                        hf,
                        lf: lf.unwrap(),
                    },
                )
                .unwrap();
            assert_eq!(record.credit.fidelity, None);
            assert_eq!(record.credit.scenario.is_some(), credited);
        }
        // Unconfirmed LF passes too.
        let t = k.ask();
        k.tell_unconfirmed(t.id, Run::new(false, 0.2)).unwrap();
        assert_eq!(k.fidelity_posterior(), &theta_before, "θ_LF* moved");
        assert_eq!(k.scenario_posterior("s").unwrap() != &bins_before, credited);
        // The deployment is the evaluate phase's only: baseline trials credit nothing.
        k.set_phase(Phase::Baseline);
        let t = k.ask();
        let record = k
            .tell(t.id, Observation::HfOnly(Run::new(true, 1.0)))
            .unwrap();
        assert_eq!(record.credit.scenario, None);
    }
}

#[test]
fn a_restored_snapshot_mid_deployment_asks_the_same_trials() {
    let mut k = searched(Deployment::ADAPTIVE, 5, 80);
    for _ in 0..30 {
        screen_one(&mut k);
    }
    let mut copy = Kernel::from_json(&k.to_json()).unwrap();
    for _ in 0..30 {
        let (a, b) = (screen_one(&mut k), screen_one(&mut copy));
        assert_eq!(a, b);
    }
    assert_eq!(k.to_json(), copy.to_json());
}

/// Seeds 1–5: 150 search trials, then 300 screened trials. When this was written an
/// exploiting deployment confirmed 1.15–1.82× the frozen one's failures per cost per seed
/// (mean 1.46; the frozen proposal spreads over cells to find new ones); claim ≥ 1.1× in
/// every seed and ≥ 1.3× on the mean.
#[test]
fn an_exploiting_deployment_confirms_more_failures_per_cost() {
    let exploit = Deployment {
        learn: false,
        exploit: true,
    };
    let mut ratios = Vec::new();
    for seed in 1..=5 {
        let frozen = deploy(&mut searched(Deployment::FROZEN, seed, 150), 300);
        let exploiting = deploy(&mut searched(exploit, seed, 150), 300);
        assert!(
            exploiting >= 1.1 * frozen,
            "seed {seed}: {exploiting} vs {frozen}"
        );
        ratios.push(exploiting / frozen);
    }
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    assert!(mean >= 1.3, "{ratios:?}");
}

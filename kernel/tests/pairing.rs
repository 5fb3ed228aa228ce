//! Pairing only a fraction of the learning trials once θ_LF* has settled: the default pairs
//! every trial (the paper's, serialised as before); unpaired trials have no θ_LF, take the HF
//! run alone, credit the φ search and not the fidelity bandit; snapshots and journal replay
//! restore the exact asks; bad fractions are refused naming the parameter; and on a synthetic
//! problem the search finds more HF failures per cost (fixed seeds, with margins).
use savme_kernel::journal::{self, Event, Journaled};
use savme_kernel::{
    Assignment, ConfigError, EliteMixture, Kernel, KernelConfig, Observation, Pairing, Run, Scale,
    SearchModel, Space, TellError, Trial, Variable,
};

fn config(pairing: Pairing, seed: u64) -> KernelConfig {
    let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 5, 10])]).unwrap();
    let phi = Space::new(vec![
        Variable::continuous("a", 0.0, 1.0, 10, Scale::Linear),
        Variable::continuous("b", 0.0, 1.0, 10, Scale::Linear),
    ])
    .unwrap();
    Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
        .scenario("s", phi, 1.0)
        .search(SearchModel::EliteMixture(EliteMixture::default()))
        .pairing(pairing)
        .seed(seed)
        .build()
        .unwrap()
        .config()
        .clone()
}

fn quarter() -> Pairing {
    Pairing {
        fraction: 0.25,
        settle: 20,
    }
}

/// Fails in the corner a + b > 1.4 (about 18 % of the square); a failing HF run costs 0.5, a
/// pass 1; LF at `rate_hz` costs rate / 10 and also fails below 3 Hz.
fn observe(t: &Trial) -> Observation {
    let [a, b] = ["a", "b"].map(|n| t.phi.get_f64(n).unwrap());
    let m = 1.4 - a - b;
    let hf = Run::new(m < 0.0, if m < 0.0 { 0.5 } else { 1.0 }).with_robustness(m);
    match &t.theta_lf {
        Some(theta) => {
            let rate = theta.get_f64("rate_hz").unwrap();
            let lf = Run::new(m < 0.0 || rate < 3.0, rate / 10.0);
            Observation::Paired { hf, lf }
        }
        None => Observation::HfOnly(hf),
    }
}

/// HF failures per unit of cost (HF and LF charged) and paired trials, after `n` trials.
fn search(pairing: Pairing, seed: u64, n: usize) -> (f64, usize) {
    let mut k = Kernel::new(config(pairing, seed)).unwrap();
    let (mut failures, mut cost, mut paired) = (0usize, 0.0, 0usize);
    for _ in 0..n {
        let t = k.ask();
        let o = observe(&t);
        cost += o.hf().runtime + o.lf().map_or(0.0, |l| l.runtime);
        failures += usize::from(o.hf().failure);
        paired += usize::from(t.theta_lf.is_some());
        k.tell(t.id, o).unwrap();
    }
    (failures as f64 / cost, paired)
}

#[test]
fn the_default_pairs_every_trial_and_serialises_as_before() {
    let c = config(Pairing::default(), 1);
    assert!(!serde_json::to_string(&c).unwrap().contains("pairing"));
    let (_, paired) = search(Pairing::default(), 1, 200);
    assert_eq!(paired, 200);
    let json = serde_json::to_string(&config(quarter(), 1)).unwrap();
    assert!(
        json.contains(r#""pairing":{"fraction":0.25,"settle":20}"#),
        "{json}"
    );
}

#[test]
fn unpaired_trials_credit_the_search_and_not_the_fidelity_bandit() {
    let mut k = Kernel::new(config(quarter(), 2)).unwrap();
    let mut first_unpaired = None;
    for i in 0..300 {
        let t = k.ask();
        if t.theta_lf.is_some() {
            k.tell(t.id, observe(&t)).unwrap();
            continue;
        }
        first_unpaired.get_or_insert(i);
        let fidelity = k.fidelity_posterior().clone();
        let bogus = Observation::Paired {
            hf: Run::new(false, 1.0),
            lf: Run::new(false, 0.2),
        };
        assert_eq!(
            k.tell(t.id, bogus),
            Err(TellError::ExpectedHfOnly { id: t.id })
        );
        let r = k.tell(t.id, observe(&t)).unwrap();
        assert_eq!(r.credit.fidelity, None);
        assert_eq!(r.credit.scenario, Some(r.observation.hf().failure));
        assert_eq!(r.outcome, None);
        assert_eq!(k.fidelity_posterior(), &fidelity);
    }
    // Every trial is paired until the greedy fidelity arm holds 20 observations.
    assert!(
        first_unpaired.is_some_and(|i| i >= 20),
        "{first_unpaired:?}"
    );
}

#[test]
fn after_settling_about_the_fraction_is_paired() {
    // 1000 trials: ≥ 20 paired to settle, then ~25 % of the rest (binomial sd ≈ 14).
    let (_, paired) = search(quarter(), 3, 1000);
    assert!((220..330).contains(&paired), "{paired} paired of 1000");
}

#[test]
fn snapshots_and_journals_restore_the_exact_asks() {
    let mut k = Kernel::new(config(quarter(), 4)).unwrap();
    for _ in 0..150 {
        let t = k.ask();
        k.tell(t.id, observe(&t)).unwrap();
    }
    let mut restored = Kernel::from_json(&k.to_json()).unwrap();
    for _ in 0..50 {
        let (a, b) = (k.ask(), restored.ask());
        assert_eq!(a, b);
        k.tell(a.id, observe(&a)).unwrap();
        restored.tell(b.id, observe(&b)).unwrap();
    }
    let mut log = Journaled::start(config(quarter(), 5), Vec::new()).unwrap();
    for round in 0..40 {
        let batch = log.ask_batch(5).unwrap();
        for t in batch.iter().rev() {
            if round == 39 && t.id == batch[0].id {
                continue; // left pending: its snapshot check covers an unpaired learning trial
            }
            log.tell(t.id, observe(t)).unwrap();
        }
    }
    let mut original = log.kernel().clone();
    let events: Vec<Event> = log.into_sink();
    let mut replayed = journal::replay(events).unwrap().kernel;
    assert_eq!(replayed.to_json(), original.to_json());
    for _ in 0..20 {
        assert_eq!(replayed.ask(), original.ask());
    }
}

#[test]
fn a_fraction_outside_0_1_is_refused_naming_it() {
    for bad in [0.0, -0.5, 1.5, f64::NAN] {
        let mut c = config(Pairing::default(), 1);
        c.pairing.fraction = bad;
        let e = Kernel::new(c).unwrap_err();
        assert!(matches!(e, ConfigError::Pairing(_)), "{e:?}");
        assert!(
            e.to_string().contains("`fraction`") && e.to_string().contains("(0, 1]"),
            "{e}"
        );
    }
    let e = serde_json::from_str::<Pairing>(r#"{"fraction":0.5,"setle":3}"#).unwrap_err();
    assert!(e.to_string().contains("setle"), "{e}");
}

/// Seeds 1–5, 600 trials: HF failures per unit of cost with a quarter of the settled trials
/// paired against every trial paired. When this was written the ratio was 1.44–1.52 per seed
/// (here an LF run costs up to twice a failing HF run); claim ≥ 1.3 in every seed.
#[test]
fn pairing_a_fraction_finds_more_failures_per_cost() {
    for seed in 1..=5 {
        let (all, _) = search(Pairing::default(), seed, 600);
        let (some, _) = search(quarter(), seed, 600);
        assert!(some >= 1.3 * all, "seed {seed}: {some} vs {all}");
    }
}

//! The φ search models: the paper's independent bins stay the default and serialise as before;
//! the elite mixture is deterministic, survives snapshots and journal replay with batched,
//! out-of-order tells, and finds more failures and more failing joint cells on a synthetic
//! joint failure corner (fixed seeds, with margins).
use savme_kernel::journal::{self, Event, Journaled};
use savme_kernel::{
    Assignment, ConfigError, EliteMixture, Kernel, KernelConfig, Observation, Phase, Run, Scale,
    SearchModel, Space, TellError, Trial, Variable,
};
use std::collections::BTreeSet;

const VARS: [&str; 3] = ["a", "b", "c"];

fn config(search: SearchModel, seed: u64) -> KernelConfig {
    let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 5, 10])]).unwrap();
    let phi = Space::new(
        VARS.iter()
            .map(|n| Variable::continuous(n, 0.0, 1.0, 10, Scale::Linear))
            .collect(),
    )
    .unwrap();
    let other = Space::new(vec![
        Variable::continuous("x", 1.0, 100.0, 10, Scale::Log),
        Variable::discrete("mode", ["slow", "fast"]),
    ])
    .unwrap();
    Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
        .scenario("corner", phi, 3.0)
        .scenario("other", other, 1.0)
        .search(search)
        .seed(seed)
        .build()
        .unwrap()
        .config()
        .clone()
}

fn elite() -> SearchModel {
    SearchModel::EliteMixture(EliteMixture::default())
}

/// The elite mixture learning from near-misses (the lowest 10 % of passing margins), ranking
/// candidates by failure odds alone (its figures below were measured so).
fn near_misses() -> SearchModel {
    SearchModel::EliteMixture(EliteMixture {
        near_miss: 0.1,
        ..EliteMixture::legacy()
    })
}

/// Distance of `t`'s φ from a joint failure region of "corner" (≤ 0 inside: a failure): the
/// diagonal band `|a − b| < 0.05` with `c` in `[0.6, 0.9]`, 2.9 % of the uniform mass. Its
/// marginals in `a` and `b` are flat, so independent bins cannot concentrate on it. "other"
/// fails when x > 60 and mode = fast.
fn margin(t: &Trial) -> f64 {
    if &*t.scenario == "other" {
        let x = t.phi.get_f64("x").unwrap();
        let fast = t.phi.get("mode").unwrap().to_string().contains("fast");
        return if fast { (60.0 - x) / 100.0 } else { 0.5 };
    }
    let [a, b, c] = VARS.map(|n| t.phi.get_f64(n).unwrap());
    ((a - b).abs() - 0.05).max(0.6 - c).max(c - 0.9)
}

/// A needle: `|a − b| < 0.02` with `c` in `[0.85, 0.95]`, 0.4 % of the uniform mass.
fn needle(t: &Trial) -> f64 {
    if &*t.scenario == "other" {
        return margin(t);
    }
    let [a, b, c] = VARS.map(|n| t.phi.get_f64(n).unwrap());
    ((a - b).abs() - 0.02).max(0.85 - c).max(c - 0.95)
}

fn observe(t: &Trial, robust: bool) -> Observation {
    observe_with(t, robust, margin)
}

fn observe_with(t: &Trial, robust: bool, margin: fn(&Trial) -> f64) -> Observation {
    let m = margin(t);
    let mut hf = Run::new(m <= 0.0, if m <= 0.0 { 0.5 } else { 1.0 });
    if robust {
        hf = hf.with_robustness(m);
    }
    let rate = t.theta_lf.as_ref().unwrap().get_f64("rate_hz").unwrap();
    let lf = Run::new(m <= 0.0 || rate < 3.0, rate / 10.0);
    Observation::Paired { hf, lf }
}

/// HF failures and distinct failing joint cells of "corner" after `n` trials.
fn hunt(search: SearchModel, seed: u64, n: usize, robust: bool) -> (usize, usize) {
    hunt_with(search, seed, n, robust, margin)
}

fn hunt_with(
    search: SearchModel,
    seed: u64,
    n: usize,
    robust: bool,
    margin: fn(&Trial) -> f64,
) -> (usize, usize) {
    let mut k = Kernel::new(config(search, seed)).unwrap();
    let (mut fails, mut cells) = (0, BTreeSet::new());
    for _ in 0..n {
        let t = k.ask();
        let r = k.tell(t.id, observe_with(&t, robust, margin)).unwrap();
        if r.observation.hf().failure && &*t.scenario == "corner" {
            fails += 1;
            let space = &k.config().scenarios[0].space;
            cells.insert(space.arms_of(&t.phi).unwrap());
        }
    }
    (fails, cells.len())
}

#[test]
#[ignore = "prints the figures the margins below are set from"]
fn print_hunts() {
    for seed in 1..=5 {
        let b = hunt(SearchModel::IndependentBins, seed, 400, true);
        let e = hunt(elite(), seed, 400, true);
        let r = hunt_with(near_misses(), seed, 300, true, needle);
        let n = hunt_with(near_misses(), seed, 300, false, needle);
        println!("seed {seed}: bins {b:?} elite {e:?} needle robust {r:?} needle binary {n:?}");
    }
}

#[test]
fn the_default_is_the_paper_and_serialises_as_before() {
    let c = config(SearchModel::default(), 1);
    assert!(c.search.is_independent_bins());
    let json = serde_json::to_string(&c).unwrap();
    assert!(!json.contains("search"));
    let k = Kernel::new(c).unwrap();
    assert!(!k.to_json().contains("search"));
    // A configuration and runs written before the field existed load.
    let back: KernelConfig = serde_json::from_str(&json).unwrap();
    assert_eq!(back.search, SearchModel::IndependentBins);
    let old: Run = serde_json::from_str(r#"{"failure":false,"runtime":2.0}"#).unwrap();
    assert_eq!(old, Run::new(false, 2.0));
}

#[test]
fn the_elite_mixture_is_deterministic_from_the_seed() {
    let run = |seed| {
        let mut k = Kernel::new(config(elite(), seed)).unwrap();
        (0..300)
            .map(|_| {
                let t = k.ask();
                k.tell(t.id, observe(&t, true)).unwrap();
                t
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(run(4), run(4));
    assert_ne!(run(4), run(5));
}

#[test]
fn snapshots_restore_the_archive_and_the_same_asks() {
    let mut k = Kernel::new(config(near_misses(), 9)).unwrap();
    for _ in 0..200 {
        let t = k.ask();
        k.tell(t.id, observe(&t, true)).unwrap();
    }
    let json = k.to_json();
    assert!(json.contains("\"search\""));
    let mut restored = Kernel::from_json(&json).unwrap();
    for _ in 0..50 {
        let (a, b) = (k.ask(), restored.ask());
        assert_eq!(a, b);
        k.tell(a.id, observe(&a, true)).unwrap();
        restored.tell(b.id, observe(&b, true)).unwrap();
    }
    // An archive that does not fit its model is refused.
    let bins = Kernel::new(config(SearchModel::IndependentBins, 9)).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&bins.to_json()).unwrap();
    let archives: serde_json::Value =
        serde_json::from_str::<serde_json::Value>(&json).unwrap()["search"].clone();
    v["search"] = archives;
    assert!(Kernel::from_json(&v.to_string()).is_err());
}

#[test]
fn journal_replay_rebuilds_the_archive_with_batched_out_of_order_tells() {
    let mut log = Journaled::start(config(near_misses(), 3), Vec::new()).unwrap();
    for round in 0..40 {
        let batch = log.ask_batch(6).unwrap();
        // Tell in reverse order, leaving the last batch's first trial pending.
        for t in batch.iter().rev() {
            if round == 39 && t.id == batch[0].id {
                continue;
            }
            log.tell(t.id, observe(t, true)).unwrap();
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

/// Over seeds 1–5, 400 trials each, on the diagonal band: the paper's bins lock onto one or
/// two cells of the band (42 failing cells in all when this was written, 401 failures), the
/// elite mixture spreads along it (187 cells, 482 failures; with the defaults before issue
/// 25's tuning: 160 cells, 390 failures). Claims: ≥ 3× the distinct failing cells, ≥ 0.75×
/// the failures, and ≥ 15 failing cells in every seed (the fewest: 19, seed 4).
#[test]
fn the_elite_mixture_covers_a_joint_failure_band() {
    let total = |search: SearchModel| {
        (1..=5).fold((0, 0), |acc, seed| {
            let (f, c) = hunt(search, seed, 400, true);
            (acc.0 + f, acc.1 + c)
        })
    };
    let (bf, bc) = total(SearchModel::IndependentBins);
    let (ef, ec) = total(elite());
    assert!(ec >= 3 * bc, "cells: elite {ec} vs bins {bc}");
    assert!(4 * ef >= 3 * bf, "failures: elite {ef} vs bins {bf}");
    for seed in 1..=5 {
        let (_, c) = hunt(elite(), seed, 400, true);
        assert!(c >= 15, "seed {seed}: {c} failing cells");
    }
}

/// Near-misses lead the search to a needle (0.4 % of the mass): seeds 1–5, 300 trials each,
/// with robustness (near_miss = 0.1) it found 120 failures, with the failure flag alone 74 (83 and 39
/// with the defaults before issue 25's tuning).
/// Claim: ≥ 1.5×.
#[test]
fn robustness_finds_the_needle_sooner() {
    let total = |robust| {
        (1..=5)
            .map(|s| hunt_with(near_misses(), s, 300, robust, needle).0)
            .sum::<usize>()
    };
    let (with, without) = (total(true), total(false));
    assert!(
        2 * with >= 3 * without,
        "with robustness {with}, without {without}"
    );
}

#[test]
fn bad_parameters_and_robustness_are_refused() {
    let bad = SearchModel::EliteMixture(EliteMixture {
        explore: 1.5,
        ..EliteMixture::default()
    });
    let mut c = config(SearchModel::IndependentBins, 1);
    c.search = bad;
    assert!(matches!(Kernel::new(c), Err(ConfigError::Search(_))));
    let mut k = Kernel::new(config(elite(), 1)).unwrap();
    let t = k.ask();
    let before = k.to_json();
    let nan = Observation::Paired {
        hf: Run::new(false, 1.0).with_robustness(f64::NAN),
        lf: Run::new(false, 0.1),
    };
    assert!(matches!(
        k.tell(t.id, nan),
        Err(TellError::BadRobustness { .. })
    ));
    assert_eq!(k.to_json(), before);
    // The evaluate phase draws from the bins alone and learns nothing.
    k.set_phase(Phase::Evaluate);
    let e = k.ask();
    assert_eq!(e.phase, Phase::Evaluate);
}

/// Failures of "corner" and their distinct joint cells among `n` evaluation asks after
/// `train` learning trials (evaluation deploys what the search learned and credits nothing;
/// each is told before the next ask, as a harness with one trial in flight does).
fn deployed(search: SearchModel, seed: u64, train: usize, n: usize) -> (usize, usize) {
    let mut k = Kernel::new(config(search, seed)).unwrap();
    for _ in 0..train {
        let t = k.ask();
        k.tell(t.id, observe(&t, true)).unwrap();
    }
    k.set_phase(Phase::Evaluate);
    let learned = k.scenario_posterior("corner").unwrap().clone();
    let space = k.config().scenarios[0].space.clone();
    let (mut fails, mut cells) = (0, BTreeSet::new());
    for _ in 0..n {
        let t = k.ask();
        k.tell(t.id, observe(&t, true)).unwrap();
        if &*t.scenario == "corner" && margin(&t) <= 0.0 {
            fails += 1;
            cells.insert(space.arms_of(&t.phi).unwrap());
        }
    }
    assert_eq!(k.scenario_posterior("corner").unwrap(), &learned);
    (fails, cells.len())
}

/// Evaluation (and LF screening, which asks what evaluation asks) draws φ from the elite
/// proposal, not from the bins' Thompson draws: seeds 1–5, 300 training trials, 200
/// evaluation asks each. When this was written: bins 276 failures in 29 cells, elite 284
/// in 119 cells (279 in 108 once candidates were ranked per expected cost) (the bins' posterior sits on a few cells of the band; the proposal spreads
/// along it). Claims: ≥ 0.8× the failures, ≥ 3× the distinct failing cells.
#[test]
fn evaluation_deploys_the_elite_proposal() {
    let total = |search: SearchModel| {
        (1..=5).fold((0, 0), |acc, seed| {
            let (f, c) = deployed(search, seed, 300, 200);
            (acc.0 + f, acc.1 + c)
        })
    };
    let ((bf, bc), (ef, ec)) = (total(SearchModel::IndependentBins), total(elite()));
    println!("evaluation: bins {bf} failures in {bc} cells, elite {ef} in {ec}");
    assert!(5 * ef >= 4 * bf, "failures: elite {ef}, bins {bf}");
    assert!(ec >= 3 * bc, "cells: elite {ec}, bins {bc}");
}

//! Scouting ([`CostRate::scout`], with the elite search's ρ model from a scenario's fourth trial,
//! [`EliteMixture::rho_start`]): a scenario whose failures are hard to find is searched long
//! enough to find them. Measured on a synthetic problem (fixed seeds, with margins) shaped as
//! the bundled simulator's scenarios 1–8: most scenarios fail often, one fails only in a thin
//! corner of φ that the robustness leads to, and its passes cost five times its failures.
use savme_kernel::{
    Allocation, Assignment, CostRate, EliteMixture, Kernel, KernelConfig, Observation, Pairing,
    Run, Scale, SearchModel, Space, Trial, Variable,
};
use std::collections::VecDeque;

const SCENARIOS: [&str; 4] = ["broad", "wide", "dear", "thin"];

fn space() -> Space {
    let v = |n| Variable::continuous(n, 0.0, 1.0, 10, Scale::Linear);
    Space::new(vec![v("a"), v("b"), v("c")]).unwrap()
}

/// A tuned campaign's kernel, scouting (and the ρ model from the fourth trial) or not: what
/// `allocation = cost-rate-scout` and the elite defaults give, against `cost-rate-recent` and
/// the ρ model from `d + 2` runs (the defaults before).
fn config(scout: bool, seed: u64) -> KernelConfig {
    let mut c = paired_always(scout, seed);
    c.pairing = Pairing {
        fraction: 0.25,
        settle: 10,
    };
    c
}

/// The same with every learning trial paired (the kernel's default pairing).
fn paired_always(scout: bool, seed: u64) -> KernelConfig {
    let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 5, 10])]).unwrap();
    let mut b = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10));
    for name in SCENARIOS {
        b = b.scenario(name, space(), 1.0);
    }
    b.search(SearchModel::EliteMixture(EliteMixture {
        rho_start: if scout { Some(3) } else { None },
        ..EliteMixture::default()
    }))
    .allocation(Allocation::CostRate(CostRate {
        scout,
        ..CostRate::default()
    }))
    .seed(seed)
    .build()
    .unwrap()
    .config()
    .clone()
}

/// The HF run: "broad" fails where a < 0.5 (half of φ), "wide" where a + b < 0.6 (18 %),
/// "dear" where a < 0.3 at four times the cost; "thin" only where a + b + c > 2.8 (0.13 % of
/// φ). ρ is the distance to the failure region (0 on a failure, as the bundled simulator's
/// clearance); a failing run stops at the failure (cost 2), a pass runs to the end (cost 10;
/// "dear" 40).
fn run(t: &Trial) -> Run {
    let x = |n| t.phi.get_f64(n).unwrap();
    let (a, b, c) = (x("a"), x("b"), x("c"));
    let (rho, scale) = match &*t.scenario {
        "broad" => (a - 0.5, 1.0),
        "wide" => (a + b - 0.6, 1.0),
        "dear" => (a - 0.3, 4.0),
        _ => (2.8 - (a + b + c), 1.0),
    };
    let failure = rho < 0.0;
    let cost = scale * if failure { 2.0 } else { 10.0 };
    Run::new(failure, cost).with_robustness(rho.max(0.0))
}

/// An LF run agrees with HF and costs a quarter of it.
fn observe(t: &Trial) -> Observation {
    let hf = run(t);
    match t.theta_lf {
        Some(_) => {
            let lf = Run::new(hf.failure, hf.runtime / 4.0);
            Observation::Paired { hf, lf }
        }
        None => Observation::HfOnly(hf),
    }
}

/// Per scenario, HF failures and the cost of every run of `n` trials, 4 in flight (the
/// default window: the oldest told when it is full).
fn search(cfg: KernelConfig, n: usize) -> [(u64, f64); 4] {
    let mut k = Kernel::new(cfg).unwrap();
    let mut per = [(0u64, 0.0); 4];
    let mut pending = VecDeque::new();
    for i in 0..n + 4 {
        if pending.len() == 4 || i >= n {
            let Some(t) = pending.pop_front() else { break };
            let o = observe(&t);
            let s = SCENARIOS.iter().position(|&s| *s == *t.scenario).unwrap();
            per[s].0 += u64::from(o.hf().failure);
            per[s].1 += o.hf().runtime + o.lf().map_or(0.0, |lf| lf.runtime);
            k.tell(t.id, o).unwrap();
        }
        if i < n {
            pending.push_back(k.ask());
        }
    }
    per
}

/// Over seeds 1–12 of 200 trials: "thin"'s HF failures per unit cost (the mean of the
/// seeds'), the seeds in which it found a failure, and the whole search's failures per unit
/// cost (the mean of the seeds').
fn measure(scout: bool) -> (f64, usize, f64) {
    let (mut thin, mut found, mut total) = (0.0, 0, 0.0);
    for seed in 1..=12 {
        let per = search(config(scout, seed), 200);
        let (f, c) = per[3];
        thin += f as f64 / c;
        found += usize::from(f > 0);
        let (f, c) = per.iter().fold((0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
        total += f as f64 / c;
    }
    (thin / 12.0, found, total / 12.0)
}

#[test]
#[ignore = "prints the figures the margins below are set from"]
fn print_scouting() {
    for scout in [false, true] {
        let (thin, found, total) = measure(scout);
        println!("scout {scout}: thin {thin:.4} per unit cost, found in {found} of 12 seeds, all {total:.4}");
    }
}

/// Scouting finds the thin scenario's failures in more seeds and at a higher rate per cost
/// there, without losing the search's total: found in 3 → 12 of 12 seeds, 0.0091 → 0.0544
/// HF failures per unit cost there, 0.2417 → 0.2621 in all (when written).
#[test]
fn scouting_finds_a_thin_failure_region_that_the_floor_alone_starves() {
    let (thin0, found0, total0) = measure(false);
    let (thin1, found1, total1) = measure(true);
    let shown = format!(
        "thin {thin0:.4} → {thin1:.4}, found in {found0} → {found1} of 12 seeds, all {total0:.4} → {total1:.4}"
    );
    assert!(found1 >= found0 + 6, "{shown}");
    assert!(thin1 >= 3.0 * thin0, "{shown}");
    assert!(total1 >= total0, "{shown}");
}

/// A scouted scenario's learning trials run HF only until its first HF failure; then the
/// pairing applies as before (paired until θ_LF* settles).
#[test]
fn a_scouted_scenario_runs_hf_only_until_its_first_failure() {
    let mut k = Kernel::new(config(true, 3)).unwrap();
    let mut failed = [false; 4];
    for _ in 0..200 {
        let t = k.ask();
        let s = SCENARIOS.iter().position(|&s| *s == *t.scenario).unwrap();
        if !failed[s] {
            assert!(
                t.theta_lf.is_none(),
                "{} paired before its first failure",
                t.scenario
            );
        }
        let o = observe(&t);
        failed[s] |= o.hf().failure;
        k.tell(t.id, o).unwrap();
    }
    assert!(failed[0], "broad failed");
    // A scenario that has failed is paired again: the first trials after a failure, before
    // θ_LF* settles.
    let mut k = Kernel::new(config(true, 3)).unwrap();
    let paired_after_failure = (0..40).any(|_| {
        let t = k.ask();
        let paired = t.theta_lf.is_some();
        let o = observe(&t);
        k.tell(t.id, o).unwrap();
        paired
    });
    assert!(paired_after_failure);
    // Without scouting the first trials are paired.
    let mut k = Kernel::new(config(false, 3)).unwrap();
    assert!(k.ask().theta_lf.is_some());
    // A configuration stored before scouting existed reads it as off; the default is off.
    let stored = serde_json::json!({"rule": "cost_rate", "floor": 0.6});
    let a: Allocation = serde_json::from_value(stored).unwrap();
    assert!(matches!(a, Allocation::CostRate(r) if !r.scout));
    assert!(!CostRate::default().scout);
    let json = serde_json::to_string(&Allocation::CostRate(CostRate::default())).unwrap();
    assert!(!json.contains("scout"), "{json}");
}

/// A snapshot keeps a scouting kernel's asks: taken while an unpaired trial of a scouted
/// scenario is pending (with the pairing of every trial, where only scouting leaves a trial
/// unpaired), it restores, and the restored kernel asks what the original asks.
#[test]
fn a_scouting_kernel_restores_with_the_same_asks() {
    let mut k = Kernel::new(paired_always(true, 5)).unwrap();
    let pending = loop {
        let t = k.ask();
        if t.theta_lf.is_none() {
            break t;
        }
        k.tell(t.id, observe(&t)).unwrap();
    };
    let mut restored = Kernel::from_json(&k.to_json()).unwrap();
    k.tell(pending.id, observe(&pending)).unwrap();
    restored.tell(pending.id, observe(&pending)).unwrap();
    for _ in 0..50 {
        let t = k.ask();
        assert_eq!(restored.ask(), t);
        k.tell(t.id, observe(&t)).unwrap();
        restored.tell(t.id, observe(&t)).unwrap();
    }
}

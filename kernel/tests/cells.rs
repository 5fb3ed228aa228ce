//! The elite search's novelty (`EliteMixture::spread`, 5 by default since issue 42): on a
//! problem with three separate failure regions, one of them with far cheaper failures (the
//! shape where the ρ model's ranking per cost piles failures into a few cells), the default
//! search finds more distinct failing joint cells per unit cost than with the old spread of 1,
//! at no loss of failures per unit cost (fixed seeds, with margins).
mod common;

use savme_kernel::{EliteMixture, Kernel, KernelConfig, Observation, Run, Trial};
use std::collections::HashSet;

fn config(m: EliteMixture, seed: u64) -> KernelConfig {
    common::unit_square(m, "regions", ["x", "y"], seed)
}

/// Three failure regions: a disc of radius 0.12 at (0.15, 0.15) whose failures cost 1, a disc
/// of radius 0.15 at (0.75, 0.3) and a band y > 0.85, 0.3 < x < 0.9, whose failures cost 4;
/// a pass costs 20. ρ = the distance to the nearest region (negative inside).
fn run(t: &Trial) -> (bool, f64, f64) {
    let x = t.phi.get_f64("x").unwrap();
    let y = t.phi.get_f64("y").unwrap();
    let disc = |cx: f64, cy: f64, r: f64| ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - r;
    let band = (0.85 - y).max(0.3 - x).max(x - 0.9);
    let (cheap, dear) = (disc(0.15, 0.15, 0.12), disc(0.75, 0.3, 0.15).min(band));
    let rho = cheap.min(dear);
    let cost = if cheap < 0.0 {
        1.0
    } else if dear < 0.0 {
        4.0
    } else {
        20.0
    };
    (rho < 0.0, rho, cost)
}

fn observe(t: &Trial) -> Observation {
    let (failure, rho, cost) = run(t);
    let hf = Run::new(failure, cost).with_robustness(rho);
    match &t.theta_lf {
        Some(theta) => {
            let rate = theta.get_f64("rate_hz").unwrap();
            Observation::Paired {
                hf,
                lf: Run::new(failure, cost * rate / 20.0),
            }
        }
        None => Observation::HfOnly(hf),
    }
}

/// (HF failures, distinct failing joint cells, cost of every run) of `n` trials.
fn hunt(m: EliteMixture, seed: u64, n: usize) -> (u64, usize, f64) {
    let mut k = Kernel::new(config(m, seed)).unwrap();
    let (mut failures, mut cells, mut cost) = (0, HashSet::new(), 0.0);
    for _ in 0..n {
        let t = k.ask();
        let o = observe(&t);
        if o.hf().failure {
            failures += 1;
            let (x, y) = (t.phi.get_f64("x").unwrap(), t.phi.get_f64("y").unwrap());
            cells.insert(((x * 10.0).min(9.0) as u8, (y * 10.0).min(9.0) as u8));
        }
        cost += o.hf().runtime + o.lf().map_or(0.0, |lf| lf.runtime);
        k.tell(t.id, o).unwrap();
    }
    (failures, cells.len(), cost)
}

/// (failures, distinct failing cells) per unit cost over seeds 1–8, 200 trials each.
fn rates(m: EliteMixture) -> (f64, f64) {
    let (f, c, w) = (1..=8).fold((0, 0, 0.0), |acc, seed| {
        let (f, c, w) = hunt(m, seed, 200);
        (acc.0 + f, acc.1 + c, acc.2 + w)
    });
    (f as f64 / w, c as f64 / w)
}

fn old_spread() -> EliteMixture {
    EliteMixture {
        spread: 1.0,
        ..trial_cost()
    }
}

/// The default search with the archive keeping each trial's whole cost (HF + LF) and 8
/// candidates per draw, as when the spread claim below was measured (`hf_cost` and 32 `tries`
/// became the defaults later; with 32 tries the candidates' own ranking by visits spreads the
/// failures on this problem, and spread 1 finds more cells than 5 here: 0.02426 against
/// 0.01834 — on the benchmark's families spread 5 stayed the better, docs/RESULTS.md "More
/// candidates").
fn trial_cost() -> EliteMixture {
    EliteMixture {
        hf_cost: false,
        tries: 8,
        ..EliteMixture::default()
    }
}

#[test]
#[ignore = "prints the figures quoted below"]
fn print_rates() {
    for spread in [1.0, 3.0, 5.0, 10.0] {
        for hf_cost in [false, true] {
            let (f, c) = rates(EliteMixture {
                spread,
                hf_cost,
                ..EliteMixture::default()
            });
            println!(
                "spread {spread}, hf_cost {hf_cost}: failures {f:.4}, cells {c:.5} per unit cost"
            );
        }
    }
}

/// Seeds 1–8, 200 trials: the default (spread 5) 0.01642 distinct failing cells and 0.1704
/// failures per unit cost when written, spread 1 0.01313 and 0.1703 (cells 1.25×; spread 3:
/// 0.01714, 10: 0.01857). Claims: cells ≥ 1.15×, failures ≥ 0.95×. Measured, and held, with
/// the archive keeping each trial's whole cost (`hf_cost` false); with `hf_cost` spread 1 does
/// as well on this problem (below).
#[test]
fn the_default_novelty_finds_more_failing_cells_per_cost() {
    let (f_new, c_new) = rates(trial_cost());
    let (f_old, c_old) = rates(old_spread());
    assert!(
        c_new >= 1.15 * c_old,
        "cells per cost: spread 5 {c_new:.5}, spread 1 {c_old:.5}"
    );
    assert!(
        f_new >= 0.95 * f_old,
        "failures per cost: spread 5 {f_new:.4}, spread 1 {f_old:.4}"
    );
}

/// Seeds 1–8, 200 trials: the archive keeping a learning trial's HF cost (`hf_cost`, the
/// default) against its whole cost, HF + LF — the paired LF run's cost, drawn with θ_LF
/// whatever φ is, blurs where failures are cheap. When written: failures 0.1817 against 0.1704
/// per unit cost, distinct failing cells 0.01983 against 0.01642 (with spread 1: 0.2002 and
/// 0.02075 against 0.1703 and 0.01313). Claims: failures ≥ 1.03×, cells ≥ 1.1×. Measured, and
/// held, with the ρ model starting at d + 2 runs (`rho_start` None); with the later default
/// (`rho_start` 3, scouting) `hf_cost` finds as many cells as the whole cost here (0.01734
/// against 0.01736), so the claim is pinned to the start it was measured with, and to its 8
/// candidates per draw (32 later: failures 0.1943 against 0.1900).
#[test]
fn the_archives_hf_cost_finds_more_failures_and_cells_per_cost() {
    let measured = EliteMixture {
        rho_start: None,
        tries: 8,
        ..EliteMixture::default()
    };
    let (f_hf, c_hf) = rates(measured);
    let (f_trial, c_trial) = rates(EliteMixture {
        hf_cost: false,
        ..measured
    });
    assert!(
        f_hf >= 1.03 * f_trial,
        "failures per cost: hf_cost {f_hf:.4}, trial cost {f_trial:.4}"
    );
    assert!(
        c_hf >= 1.1 * c_trial,
        "cells per cost: hf_cost {c_hf:.5}, trial cost {c_trial:.5}"
    );
}

/// A configuration stored with the old spread keeps it (every parameter is stored), and one
/// stored without its elite parameters runs the legacy search (spread 1).
#[test]
fn stored_configurations_keep_their_spread() {
    let stored = serde_json::to_value(old_spread()).unwrap();
    let back: EliteMixture = serde_json::from_value(stored).unwrap();
    assert_eq!(back.spread, 1.0);
    assert_eq!(EliteMixture::legacy().spread, 1.0);
    assert_eq!(EliteMixture::default().spread, 5.0);
    // Likewise the candidates per draw: stored ones are kept, the legacy search has 8.
    assert_eq!(back.tries, 8);
    assert_eq!(EliteMixture::legacy().tries, 8);
    // The bound on a draw's Parzen work: stored with new configurations; one stored before it
    // existed (this JSON, without it) has none, so its draws replay as they were made.
    let before = serde_json::json!({"tries": 16, "rho_start": 3});
    let before: EliteMixture = serde_json::from_value(before).unwrap();
    assert_eq!(before.parzen_points, None);
    assert_eq!(before.tries_for(4096), 16);
    let now = serde_json::to_value(EliteMixture::default()).unwrap();
    assert_eq!(now["parzen_points"], 32 * 1024);
    let back: EliteMixture = serde_json::from_value(now).unwrap();
    assert_eq!(back.tries_for(4096), 8);
}

#[test]
#[ignore = "prints the figures the claim below quotes"]
fn print_tries_rates() {
    for tries in [8, 16, 32, 64] {
        let (f, c) = rates(EliteMixture {
            tries,
            ..EliteMixture::default()
        });
        println!("tries {tries}: failures {f:.4}, cells {c:.5} per unit cost");
    }
}

/// Seeds 1–8, 200 trials: the default 32 candidates per draw against the 8 of before: failures
/// 0.1990 against 0.1834 per unit cost, distinct failing cells 0.02204 against 0.01734 when
/// written (16: 0.1972 and 0.02088; 64: 0.1817 and 0.02078 — more candidates than that
/// crowd the cheap region again). Claims: failures ≥ 1.04×, cells ≥ 1.15×.
#[test]
fn more_candidates_per_draw_find_more_failures_and_cells_per_cost() {
    let (f_new, c_new) = rates(EliteMixture::default());
    let (f_old, c_old) = rates(EliteMixture {
        tries: 8,
        ..EliteMixture::default()
    });
    assert_eq!(EliteMixture::default().tries, 32);
    assert!(
        f_new >= 1.04 * f_old,
        "failures per cost: 32 tries {f_new:.4}, 8 tries {f_old:.4}"
    );
    assert!(
        c_new >= 1.15 * c_old,
        "cells per cost: 32 tries {c_new:.5}, 8 tries {c_old:.5}"
    );
}

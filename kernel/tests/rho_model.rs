//! The elite search's ρ model (`EliteMixture::rho_model`, issue 42): on a thin failure band
//! whose passes cost many failures — the shape of the Reference FMU BouncingBall's — a Gaussian
//! process of the robustness finds the band sooner and leaves it less often than the Parzen
//! failure odds alone (fixed seeds, with margins); runs without a robustness are drawn exactly
//! as before; journal replay and snapshots give the same asks.
mod common;

use savme_kernel::journal::{self, Event, Journaled};
use savme_kernel::{EliteMixture, Kernel, KernelConfig, Observation, Run, Trial};

fn config(m: EliteMixture, seed: u64) -> KernelConfig {
    common::unit_square(m, "band", ["h", "v"], seed)
}

/// The band: a failure for `v < 0.08 + 0.04·h` (6 % of φ), robustness `v − 0.08 − 0.04·h`
/// with a second, passing valley at `v = 1` (ρ ≥ 0.15 there: lower than the middle's, as an
/// upward throw's ρ is on BouncingBall); a failure costs 1, a pass 40.
fn run(t: &Trial) -> (bool, f64, f64) {
    let h = t.phi.get_f64("h").unwrap();
    let v = t.phi.get_f64("v").unwrap();
    let edge = 0.08 + 0.04 * h;
    let rho = if v < 0.6 {
        v - edge
    } else {
        (0.6 - edge).min(0.15 + 4.0 * (1.0 - v))
    };
    let failure = rho < 0.0;
    (failure, rho, if failure { 1.0 } else { 40.0 })
}

fn observe(t: &Trial, robust: bool) -> Observation {
    let (failure, rho, cost) = run(t);
    let mut hf = Run::new(failure, cost);
    if robust {
        hf = hf.with_robustness(rho);
    }
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

/// HF failures and the cost of every run of `n` trials, one at a time.
fn hunt(m: EliteMixture, seed: u64, n: usize, robust: bool) -> (u64, f64) {
    let mut k = Kernel::new(config(m, seed)).unwrap();
    let (mut failures, mut cost) = (0, 0.0);
    for _ in 0..n {
        let t = k.ask();
        let o = observe(&t, robust);
        failures += u64::from(o.hf().failure);
        cost += o.hf().runtime + o.lf().map_or(0.0, |lf| lf.runtime);
        k.tell(t.id, o).unwrap();
    }
    (failures, cost)
}

fn without_model() -> EliteMixture {
    EliteMixture {
        rho_model: false,
        ..EliteMixture::default()
    }
}

/// Failures per unit cost over seeds 1–8, 150 trials each.
fn rate(m: EliteMixture) -> f64 {
    let (f, c) = (1..=8).fold((0, 0.0), |acc, seed| {
        let (f, c) = hunt(m, seed, 150, true);
        (acc.0 + f, acc.1 + c)
    });
    f as f64 / c
}

#[test]
#[ignore = "prints the figures quoted below"]
fn print_rates() {
    println!("with the ρ model {:.4}", rate(EliteMixture::default()));
    println!("without {:.4}", rate(without_model()));
}

/// Seeds 1–8, 150 trials: with the ρ model 0.2450 failures per unit cost when written,
/// without 0.0880 (2.8×); with the default novelty `spread` 5 (issue 42, cells) 0.2641 and
/// 0.0828. Claim: ≥ 1.5×.
#[test]
fn the_rho_model_finds_more_failures_per_cost_on_a_thin_band() {
    let (with, without) = (rate(EliteMixture::default()), rate(without_model()));
    assert!(
        with >= 1.5 * without,
        "with the ρ model {with:.4}, without {without:.4}"
    );
}

/// Runs without a robustness: the ρ model changes no ask.
#[test]
fn without_a_robustness_the_asks_are_the_old_ones() {
    for seed in 1..=3 {
        let mut a = Kernel::new(config(EliteMixture::default(), seed)).unwrap();
        let mut b = Kernel::new(config(without_model(), seed)).unwrap();
        for _ in 0..200 {
            let (ta, tb) = (a.ask(), b.ask());
            assert_eq!(ta, tb);
            a.tell(ta.id, observe(&ta, false)).unwrap();
            b.tell(tb.id, observe(&tb, false)).unwrap();
        }
    }
}

/// A configuration stored before the ρ model existed reads back without it (and one with
/// it off writes no `rho_model`), so stored campaigns keep their asks.
#[test]
fn stored_configurations_keep_their_search() {
    let old = serde_json::to_value(without_model()).unwrap();
    assert!(old.get("rho_model").is_none(), "{old}");
    let back: EliteMixture = serde_json::from_value(old).unwrap();
    assert_eq!(back, without_model());
    let new = serde_json::to_value(EliteMixture::default()).unwrap();
    assert_eq!(new["rho_model"], true);
}

/// Journal replay (batched, out-of-order tells) and a snapshot ask what the kernel asks, with
/// the process fitted before and after the first failure.
#[test]
fn replay_and_snapshots_give_the_same_asks() {
    let mut log = Journaled::start(config(EliteMixture::default(), 4), Vec::new()).unwrap();
    for _ in 0..25 {
        let batch = log.ask_batch(4).unwrap();
        for t in batch.iter().rev() {
            log.tell(t.id, observe(t, true)).unwrap();
        }
    }
    let mut original = log.kernel().clone();
    let events: Vec<Event> = log.into_sink();
    let mut replayed = journal::replay(events).unwrap().kernel;
    assert_eq!(replayed.to_json(), original.to_json());
    let mut restored = Kernel::from_json(&original.to_json()).unwrap();
    for _ in 0..20 {
        let t = original.ask();
        assert_eq!(replayed.ask(), t);
        assert_eq!(restored.ask(), t);
    }
}

/// The price of the ρ model per ask + tell with a full archive (4,096 trials told with a
/// robustness, most of them failures near the band): run with `--release -- --ignored`.
#[test]
#[ignore = "a timing, printed"]
fn print_ask_tell_time_with_a_full_archive() {
    for m in [EliteMixture::default(), without_model()] {
        let mut k = Kernel::new(config(m, 3)).unwrap();
        let tell = |k: &mut Kernel| {
            let t = k.ask();
            let o = observe(&t, true);
            k.tell(t.id, o).unwrap();
        };
        for _ in 0..5000 {
            tell(&mut k);
        }
        let start = std::time::Instant::now();
        for _ in 0..500 {
            tell(&mut k);
        }
        let per = start.elapsed().as_secs_f64() / 500.0 * 1e6;
        println!("rho_model {}: {per:.0} µs per ask + tell", m.rho_model);
    }
}

/// FNV-1a (64 bits) over `bytes`, continuing from `h`: a digest that does not depend on the
/// standard library's hasher.
fn fnv(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// A digest of every ask of `n` trials on the band (ρ reported, shifted by `shift`: with a
/// positive shift no run fails and every draw that does not explore descends the process).
/// The novelty `spread` is pinned at 1, the default when the digests were recorded (it became
/// 5 afterwards), the process starts at `d + 2` runs (`rho_start` None, as then; 3 since
/// scouting) and 8 candidates are ranked per draw (`tries`, 32 since): the digest holds the
/// process's computation, not the search's other defaults.
fn ask_digest(seed: u64, n: usize, shift: f64) -> u64 {
    let search = EliteMixture {
        spread: 1.0,
        rho_start: None,
        tries: 8,
        ..EliteMixture::default()
    };
    let mut k = Kernel::new(config(search, seed)).unwrap();
    let mut h = 0xcbf2_9ce4_8422_2325;
    for _ in 0..n {
        let t = k.ask();
        h = fnv(h, serde_json::to_string(&t).unwrap().as_bytes());
        let (failure, rho, cost) = run(&t);
        let failure = failure && shift <= 0.0;
        let hf = Run::new(failure, cost).with_robustness(rho + shift);
        let o = match &t.theta_lf {
            Some(_) => Observation::Paired {
                hf,
                lf: Run::new(failure, cost / 4.0),
            },
            None => Observation::HfOnly(hf),
        };
        k.tell(t.id, o).unwrap();
    }
    h
}

/// The ρ model's Gaussian process is computed as it was when this was written, draw for draw:
/// a digest of every ask over long seeded runs with a robustness (4,000 trials past the first
/// failure, the process fitted to the 64 runs nearest an elite of a growing archive; 400 with
/// no failure, the process fitted to the lowest-ρ runs). Any change to the fit, its
/// evaluation or the choice of the runs it sees changes some draw and fails this test.
#[test]
fn the_rho_model_asks_what_it_asked_over_a_long_run() {
    let digests = [ask_digest(7, 4000, 0.0), ask_digest(8, 400, 1.0)];
    assert_eq!(
        digests,
        [0x4388_a2a1_3e91_5e79, 0x5be4_d36a_4aa0_f940],
        "{digests:x?}"
    );
}

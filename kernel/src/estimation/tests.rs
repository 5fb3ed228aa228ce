use super::*;
use crate::space::{Scale, Space, Variable};
use crate::PriorCounts;
use statrs::distribution::{ContinuousCDF, Normal};

pub(super) fn scenario(name: &str, vars: Vec<Variable>, weight: f64) -> (Scenario, Posterior) {
    let space = Space::new(vars).unwrap();
    let posterior = Posterior::new(&space, PriorCounts::UNIFORM).unwrap();
    (
        Scenario {
            name: Arc::from(name),
            space,
            weight,
        },
        posterior,
    )
}

/// One linear variable `x` on [0, 1] whose last bin the posterior believes fails often.
fn trained(eps: f64, seed: u64) -> Estimation {
    let (s, mut p) = scenario(
        "s",
        vec![Variable::continuous("x", 0.0, 1.0, 10, Scale::Linear)],
        1.0,
    );
    for _ in 0..30 {
        p.update(&[9], true);
        p.update(&[0], false);
    }
    Estimation::new(&[(s, p)], &EstimationConfig::new(eps, seed)).unwrap()
}

fn err(scenarios: &[(Scenario, Posterior)], c: &EstimationConfig) -> String {
    Estimation::new(scenarios, c).unwrap_err().to_string()
}

#[test]
fn epsilon_outside_0_1_is_refused() {
    let s = [scenario("s", vec![Variable::boolean("b")], 1.0)];
    for eps in [0.0, -0.1, 1.5, f64::NAN] {
        let m = err(&s, &EstimationConfig::new(eps, 0));
        assert!(m.contains("epsilon") && m.contains("(0, 1]"), "{m}");
    }
    assert!(Estimation::new(&s, &EstimationConfig::new(1.0, 0)).is_ok());
    assert_eq!(
        err(&[], &EstimationConfig::new(0.5, 0)),
        "no scenarios to estimate"
    );
}

#[test]
fn nominals_of_unknown_names_or_bad_shapes_are_refused_naming_them() {
    let s = [scenario(
        "cut_in",
        vec![
            Variable::continuous("speed", 0.0, 10.0, 5, Scale::Linear),
            Variable::discrete("lane", [0, 1, 2]),
        ],
        1.0,
    )];
    let with = |sc: &str, var: &str, n: Nominal| {
        let mut c = EstimationConfig::new(0.1, 0);
        c.nominal
            .entry(sc.into())
            .or_default()
            .insert(var.into(), n);
        err(&s, &c)
    };
    let m = with("cut_out", "speed", Nominal::Uniform);
    assert!(
        m.contains("unknown scenario `cut_out`") && m.contains("cut_in"),
        "{m}"
    );
    let m = with("cut_in", "sped", Nominal::Uniform);
    assert!(
        m.contains("unknown variable `sped`") && m.contains("speed, lane"),
        "{m}"
    );
    let normal = |mean, sd| Nominal::Normal { mean, sd };
    let m = with("cut_in", "speed", normal(5.0, 0.0));
    assert!(m.contains("`speed`") && m.contains("sd > 0"), "{m}");
    let m = with("cut_in", "speed", normal(500.0, 1.0));
    assert!(
        m.contains("`speed`") && m.contains("of its mass inside"),
        "{m}"
    );
    let m = with("cut_in", "lane", normal(1.0, 1.0));
    assert!(m.contains("`lane`") && m.contains("continuous"), "{m}");
    let weights = |w: Vec<f64>| Nominal::Weights { weights: w };
    let m = with("cut_in", "lane", weights(vec![1.0, 1.0]));
    assert!(
        m.contains("`lane`") && m.contains("2 weights for 3 values"),
        "{m}"
    );
    let m = with("cut_in", "lane", weights(vec![0.0, 0.0, 0.0]));
    assert!(m.contains("`lane`") && m.contains("not all 0"), "{m}");
    let m = with("cut_in", "speed", weights(vec![1.0]));
    assert!(m.contains("`speed`") && m.contains("discrete"), "{m}");
    let lognormal = |mu, sigma| Nominal::LogNormal { mu, sigma };
    let m = with("cut_in", "speed", lognormal(1.0, -1.0));
    assert!(m.contains("`speed`") && m.contains("sigma > 0"), "{m}");
    let m = with("cut_in", "lane", lognormal(1.0, 1.0));
    assert!(
        m.contains("`lane`") && m.contains("a lognormal needs a continuous"),
        "{m}"
    );
    let histogram = |edges: Vec<f64>, weights: Vec<f64>| Nominal::Histogram { edges, weights };
    let m = with("cut_in", "speed", histogram(vec![0.0, 1.0], vec![1.0, 1.0]));
    assert!(m.contains("one more edge than weights"), "{m}");
    let m = with(
        "cut_in",
        "speed",
        histogram(vec![0.0, 2.0, 1.0], vec![1.0, 1.0]),
    );
    assert!(m.contains("strictly increasing"), "{m}");
    let m = with("cut_in", "speed", histogram(vec![0.0, 1.0], vec![-1.0]));
    assert!(m.contains("not all 0"), "{m}");
    let m = with(
        "cut_in",
        "speed",
        histogram(vec![1000.0, 2000.0], vec![1.0]),
    );
    assert!(m.contains("of its mass inside"), "{m}");
}

/// Plain Monte Carlo (ε = 1) draws from the nominal: the sample mean of a truncated
/// log-normal and of a histogram is their mean (computed on a fine grid).
#[test]
fn draws_follow_the_lognormal_and_histogram_nominals() {
    let cases = [
        Nominal::LogNormal {
            mu: 1.0,
            sigma: 0.5,
        },
        Nominal::Histogram {
            edges: vec![0.5, 1.0, 3.0, 6.0],
            weights: vec![1.0, 0.0, 3.0],
        },
    ];
    for nominal in cases {
        let var = Variable::continuous("x", 0.5, 6.0, 10, Scale::Linear);
        let (s, p) = scenario("s", vec![var], 1.0);
        let mut c = EstimationConfig::new(1.0, 3);
        c.nominal
            .entry("s".into())
            .or_default()
            .insert("x".into(), nominal.clone());
        let mut e = Estimation::new(&[(s, p)], &c).unwrap();
        let n = 200_000;
        let (mut mean, mut exact) = (0.0, 0.0);
        for _ in 0..n {
            let t = e.ask().expect("no refinement");
            let x = t.phi.get("x").and_then(|v| v.as_f64()).unwrap();
            assert!((0.5..=6.0).contains(&x), "{x}");
            mean += x / n as f64;
            e.tell(t.id, false).unwrap();
        }
        let grid = 100_000;
        for i in 0..grid {
            let x = 0.5 + 5.5 * (i as f64 + 0.5) / grid as f64;
            let (_, p) = e.densities(0, &Assignment::new().with("x", x)).unwrap();
            exact += x * p * 5.5 / grid as f64;
        }
        assert!(
            (mean - exact).abs() < 0.01,
            "{nominal:?}: {mean} vs {exact}"
        );
    }
}

#[test]
fn weights_are_bounded_by_one_over_epsilon_and_equal_one_for_plain_monte_carlo() {
    let mut e = trained(0.2, 1);
    for _ in 0..2000 {
        let t = e.ask().expect("no refinement");
        assert!(t.weight <= 5.0 + 1e-9 && t.weight > 0.0, "{t:?}");
        assert!((t.weight - t.p / t.q).abs() < 1e-12);
    }
    let mut mc = trained(1.0, 1);
    for _ in 0..200 {
        let t = mc.ask().expect("no refinement");
        assert!((t.weight - 1.0).abs() < 1e-12 && (t.p - 1.0).abs() < 1e-12);
    }
}

/// ∫ q = 1 and ∫ p = 1 on a fine grid, for linear and log variables and a normal nominal.
#[test]
fn the_proposal_and_nominal_densities_integrate_to_one() {
    let cases = [
        (Variable::continuous("x", 0.0, 4.0, 8, Scale::Linear), None),
        (Variable::continuous("x", 1.0, 1000.0, 6, Scale::Log), None),
        (
            Variable::continuous("x", 0.0, 4.0, 8, Scale::Linear),
            Some(Nominal::Normal { mean: 1.0, sd: 0.7 }),
        ),
        (
            Variable::continuous("x", 0.5, 6.0, 8, Scale::Linear),
            Some(Nominal::LogNormal {
                mu: 1.0,
                sigma: 0.5,
            }),
        ),
        (
            Variable::continuous("x", 0.0, 4.0, 8, Scale::Linear),
            Some(Nominal::Histogram {
                edges: vec![0.0, 1.0, 3.0, 4.0],
                weights: vec![1.0, 0.0, 2.0],
            }),
        ),
        (
            // A histogram inside the variable's range: no density outside its edges.
            Variable::continuous("x", 0.0, 4.0, 8, Scale::Linear),
            Some(Nominal::Histogram {
                edges: vec![1.0, 1.5, 3.0],
                weights: vec![3.0, 1.0],
            }),
        ),
    ];
    for (var, nominal) in cases {
        let (lo, hi) = match var.domain {
            crate::Domain::Continuous { lo, hi, .. } => (lo, hi),
            _ => unreachable!(),
        };
        let (s, mut p) = scenario("s", vec![var], 1.0);
        p.update(&[2], true);
        p.update(&[2], true);
        p.update(&[5], false);
        let mut c = EstimationConfig::new(0.3, 0);
        if let Some(n) = nominal {
            c.nominal
                .entry("s".into())
                .or_default()
                .insert("x".into(), n);
        }
        let e = Estimation::new(&[(s, p)], &c).unwrap();
        let n = 200_000;
        let (mut iq, mut ip) = (0.0, 0.0);
        for i in 0..n {
            let x = lo + (hi - lo) * (i as f64 + 0.5) / n as f64;
            let (q, p) = e.densities(0, &Assignment::new().with("x", x)).unwrap();
            iq += q * (hi - lo) / n as f64;
            ip += p * (hi - lo) / n as f64;
        }
        assert!(
            (iq - 1.0).abs() < 2e-3 && (ip - 1.0).abs() < 2e-3,
            "{iq} {ip}"
        );
    }
}

#[test]
fn discrete_densities_are_probabilities() {
    let (s, mut p) = scenario("s", vec![Variable::discrete("lane", [0, 1, 2, 3])], 1.0);
    for _ in 0..5 {
        p.update(&[3], true);
    }
    let mut c = EstimationConfig::new(0.5, 0);
    c.nominal.entry("s".into()).or_default().insert(
        "lane".into(),
        Nominal::Weights {
            weights: vec![4.0, 2.0, 1.0, 1.0],
        },
    );
    let e = Estimation::new(&[(s, p)], &c).unwrap();
    let (mut sq, mut sp) = (0.0, 0.0);
    for lane in 0..4 {
        let (q, p) = e
            .densities(0, &Assignment::new().with("lane", lane))
            .unwrap();
        sq += q;
        sp += p;
    }
    assert!((sq - 1.0).abs() < 1e-12 && (sp - 1.0).abs() < 1e-12);
    let (_, p3) = e.densities(0, &Assignment::new().with("lane", 3)).unwrap();
    assert!((p3 - 0.125).abs() < 1e-12);
}

#[test]
fn the_same_seed_gives_the_same_trials_and_tells_are_checked() {
    let mut a = trained(0.1, 9);
    let mut b = trained(0.1, 9);
    for _ in 0..50 {
        assert_eq!(a.ask(), b.ask());
    }
    a.tell(3, true).unwrap();
    assert_eq!(a.tell(3, true), Err(EstimationError::NotPending(3)));
    assert_eq!(a.tell(99, false), Err(EstimationError::NotPending(99)));
    assert_eq!(a.estimate().runs, 1);
}

#[test]
fn trials_are_shared_out_in_proportion_to_p_s() {
    let s = [
        scenario("a", vec![Variable::boolean("b")], 1.0),
        scenario("b", vec![Variable::boolean("b")], 3.0),
    ];
    let mut e = Estimation::new(&s, &EstimationConfig::new(0.5, 0)).unwrap();
    let mut n = [0; 2];
    for _ in 0..400 {
        n[e.ask().expect("no refinement").scenario_index] += 1;
    }
    assert_eq!(n, [100, 300]);
    assert_eq!(e.probabilities(), &[0.25, 0.75]);
}

/// Failure iff x > 0.97 (true probability 0.03 under the uniform nominal): over 300 seeds the
/// 95 % interval of 1,000 weighted trials covers 0.03 in 92–98 % of them, and the proposal
/// draws failures more often than plain Monte Carlo would (≈ 30): bin 9 gets 0.97 / 5 of the
/// learned mass (the eight untried bins keep their prior mean 0.5).
#[test]
fn intervals_cover_the_true_probability_at_their_nominal_rate() {
    let truth = 0.03;
    let mut covered = 0;
    let mut mean = 0.0;
    let mut failures = 0;
    let seeds = 300;
    for seed in 0..seeds {
        let mut e = trained(0.1, seed);
        for _ in 0..1000 {
            let t = e.ask().expect("no refinement");
            let x = t.phi.get_f64("x").unwrap();
            e.tell(t.id, x > 1.0 - truth).unwrap();
        }
        let est = e.estimate();
        covered += u32::from(est.total.lo <= truth && truth <= est.total.hi);
        mean += est.total.mean / seeds as f64;
        failures += est.failures;
    }
    assert!(
        (276..=294).contains(&covered),
        "covered {covered} of {seeds}"
    );
    assert!((mean - truth).abs() < 0.001, "mean of the estimates {mean}");
    // ≈ 54 failures per 1,000 trials expected (0.9 · 0.19 · 0.3 + 0.1 · 0.03).
    let per_seed = failures as f64 / f64::from(seeds as u32);
    assert!(
        (48.0..60.0).contains(&per_seed),
        "{per_seed} failures per seed"
    );
}

/// A truncated-normal nominal: the estimate's interval covers the exact tail probability.
#[test]
fn a_declared_normal_nominal_is_estimated_without_bias() {
    let n = Normal::new(0.5, 0.2).unwrap();
    let truth = (n.cdf(1.0) - n.cdf(0.9)) / (n.cdf(1.0) - n.cdf(0.0));
    let mut c = EstimationConfig::new(0.1, 4);
    c.nominal
        .entry("s".into())
        .or_default()
        .insert("x".into(), Nominal::Normal { mean: 0.5, sd: 0.2 });
    let (s, mut p) = scenario(
        "s",
        vec![Variable::continuous("x", 0.0, 1.0, 10, Scale::Linear)],
        1.0,
    );
    for _ in 0..20 {
        p.update(&[9], true);
    }
    let mut e = Estimation::new(&[(s, p)], &c).unwrap();
    for _ in 0..4000 {
        let t = e.ask().expect("no refinement");
        e.tell(t.id, t.phi.get_f64("x").unwrap() > 0.9).unwrap();
    }
    let est = e.estimate().total;
    assert!(est.lo <= truth && truth <= est.hi, "{est:?} vs {truth}");
    assert!(est.relative_half_width() < 0.1, "{est:?}");
}

/// `nominal-weighted` multiplies each bin's posterior mean by the nominal's bin probability;
/// under the uniform nominal it is the posterior rule, and q still integrates to 1.
#[test]
fn the_nominal_weighted_tilt_weighs_bins_by_the_nominal() {
    let (s, mut p) = scenario(
        "s",
        vec![Variable::continuous("x", 0.0, 1.0, 4, Scale::Linear)],
        1.0,
    );
    for _ in 0..8 {
        p.update(&[3], true);
    }
    let with = |tilt: Tilt, nominal: Option<Nominal>| {
        let mut c = EstimationConfig::new(0.1, 0);
        c.tilt = tilt;
        if let Some(n) = nominal {
            c.nominal
                .entry("s".into())
                .or_default()
                .insert("x".into(), n);
        }
        Estimation::new(&[(s.clone(), p.clone())], &c).unwrap()
    };
    let uniform = with(Tilt::Posterior, None);
    assert_eq!(
        uniform.bin_probabilities(0),
        with(Tilt::NominalWeighted, None).bin_probabilities(0)
    );
    let normal = Nominal::Normal { mean: 0.2, sd: 0.2 };
    let e = with(Tilt::NominalWeighted, Some(normal));
    let n = Normal::new(0.2, 0.2).unwrap();
    let mass = |a: f64, b: f64| n.cdf(b) - n.cdf(a);
    let means = [0.5, 0.5, 0.5, 0.9];
    let scores: Vec<f64> = (0..4)
        .map(|k| means[k] * mass(k as f64 / 4.0, (k + 1) as f64 / 4.0))
        .collect();
    let total: f64 = scores.iter().sum();
    for (got, want) in e.bin_probabilities(0).unwrap()[0].iter().zip(&scores) {
        assert!(
            (got - want / total).abs() < 1e-12,
            "{got} vs {}",
            want / total
        );
    }
    let k = 20_000;
    let integral: f64 = (0..k)
        .map(|i| {
            let x = (i as f64 + 0.5) / k as f64;
            e.densities(0, &Assignment::new().with("x", x)).unwrap().0 / k as f64
        })
        .sum();
    assert!((integral - 1.0).abs() < 1e-3, "{integral}");
}

/// x on [0, 1] (10 bins) with a normal(0.3, 0.15) nominal and y uniform (irrelevant); the
/// posterior believes bins 7–9 of x fail. Failure iff x > 0.7: P = the normal's tail.
pub(super) fn rare(seed: u64, refine: Option<Refine>) -> (Estimation, f64) {
    let n = Normal::new(0.3, 0.15).unwrap();
    let truth = (n.cdf(1.0) - n.cdf(0.7)) / (n.cdf(1.0) - n.cdf(0.0));
    let (s, mut p) = scenario(
        "s",
        vec![
            Variable::continuous("x", 0.0, 1.0, 10, Scale::Linear),
            Variable::continuous("y", 0.0, 1.0, 5, Scale::Linear),
        ],
        1.0,
    );
    for k in 7..10 {
        for _ in 0..10 {
            p.update(&[k, 0], true);
            p.update(&[0, 0], false);
        }
    }
    let mut c = EstimationConfig::new(0.1, seed);
    c.nominal.entry("s".into()).or_default().insert(
        "x".into(),
        Nominal::Normal {
            mean: 0.3,
            sd: 0.15,
        },
    );
    c.refine = refine;
    (Estimation::new(&[(s, p)], &c).unwrap(), truth)
}

pub(super) fn fails(t: &EstimationTrial) -> bool {
    t.phi.get_f64("x").unwrap() > 0.7
}

#[test]
fn a_refinement_with_no_rounds_or_runs_is_refused() {
    for (rounds, runs) in [(0, 10), (3, 0)] {
        let refine = Some(Refine {
            rounds,
            runs,
            reuse: 0,
        });
        let (s, _) = scenario("s", vec![Variable::boolean("b")], 1.0);
        let p = Posterior::new(&s.space, PriorCounts::UNIFORM).unwrap();
        let mut c = EstimationConfig::new(0.1, 0);
        c.refine = refine;
        assert_eq!(
            err(&[(s, p)], &c),
            format!("refine needs at least 1 round of at least 1 run, got {rounds} rounds of {runs} runs")
        );
    }
}

/// A round asks its runs, then waits (None) until all are told; the refit does not depend on
/// the order of the tells; pilot trials carry their round and stay out of the estimate.
#[test]
fn a_round_waits_for_its_outcomes_and_the_tell_order_does_not_matter() {
    let refine = Some(Refine {
        rounds: 2,
        runs: 50,
        reuse: 0,
    });
    let (mut a, _) = rare(5, refine);
    let (mut b, _) = rare(5, refine);
    for round in 0..2 {
        assert_eq!(a.round(), Some(round));
        let ta: Vec<_> = (0..50).map(|_| a.ask().expect("round open")).collect();
        let tb: Vec<_> = (0..50).map(|_| b.ask().expect("round open")).collect();
        assert_eq!(ta, tb);
        assert!(ta.iter().all(|t| t.round == Some(round)));
        assert_eq!(a.ask(), None, "the round's runs are all out");
        for t in &ta {
            a.tell(t.id, fails(t)).unwrap();
        }
        for t in tb.iter().rev() {
            b.tell(t.id, fails(t)).unwrap();
        }
        assert_eq!(a.bin_probabilities(0), b.bin_probabilities(0));
    }
    assert_eq!(a.round(), None);
    let t = a.ask().expect("the estimate never waits");
    assert_eq!((t.round, Some(t.clone())), (None, b.ask()));
    assert_eq!((a.estimate().runs, a.told()), (0, 100));
    let pilot: u64 = a.pilot_runs().iter().map(|p| p.0).sum();
    assert_eq!(pilot, 100);
}

/// The refit moves x's bins toward where p(x)·P(failure | x) is largest (bin 7, just past the
/// threshold) instead of the posterior's far bins, draws x inside a bin from the truncated
/// normal, and keeps the estimate unbiased: over 60 seeds its interval covers the true tail
/// probability at about the nominal rate, and with the same 2,000 estimate runs its
/// relative width is far below the unrefined proposal's.
#[test]
fn refinement_aims_at_the_nominal_failure_mass_and_stays_unbiased() {
    let refine = Some(Refine {
        rounds: 3,
        runs: 400,
        reuse: 0,
    });
    let run = |seed: u64, refine: Option<Refine>| {
        let (mut e, truth) = rare(seed, refine);
        while e.told() < 3 * 400 * u64::from(refine.is_some()) {
            let t = e.ask().expect("told one by one");
            e.tell(t.id, fails(&t)).unwrap();
        }
        let bins = e.bin_probabilities(0).unwrap()[0].clone();
        for _ in 0..2000 {
            let t = e.ask().expect("no waiting after the pilot");
            e.tell(t.id, fails(&t)).unwrap();
        }
        (e.estimate().total, truth, bins)
    };
    let (_, _, unrefined_bins) = run(0, None);
    // The refitted q, with the truncated normal inside x's bins, still integrates to 1.
    let (mut e, _) = rare(
        0,
        Some(Refine {
            rounds: 1,
            runs: 300,
            reuse: 0,
        }),
    );
    for _ in 0..300 {
        let t = e.ask().expect("one round");
        e.tell(t.id, fails(&t)).unwrap();
    }
    let k = 400;
    let integral: f64 = (0..k * k)
        .map(|i| {
            let (x, y) = ((i % k) as f64 + 0.5, (i / k) as f64 + 0.5);
            let phi = Assignment::new()
                .with("x", x / k as f64)
                .with("y", y / k as f64);
            e.densities(0, &phi).unwrap().0 / (k * k) as f64
        })
        .sum();
    assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    let (_, _, bins) = run(0, refine);
    assert!(
        bins[7] > 0.5 && bins[7] > 2.0 * unrefined_bins[7],
        "{bins:?}"
    );
    assert!(
        bins[9] < unrefined_bins[9],
        "{bins:?} vs {unrefined_bins:?}"
    );
    let (mut covered, mut width, mut width_before) = (0, 0.0, 0.0);
    let seeds = 60;
    for seed in 0..seeds {
        let (est, truth, _) = run(seed, refine);
        covered += u32::from(est.lo <= truth && truth <= est.hi);
        width += est.relative_half_width() / seeds as f64;
        width_before += run(seed, None).0.relative_half_width() / seeds as f64;
    }
    assert!((53..=60).contains(&covered), "covered {covered} of {seeds}");
    // Measured: 0.031 against 0.110.
    assert!(width < 0.4 * width_before, "{width} vs {width_before}");
}

#[test]
fn reusing_more_rounds_than_there_are_is_refused() {
    let (s, _) = scenario("s", vec![Variable::boolean("b")], 1.0);
    let p = Posterior::new(&s.space, PriorCounts::UNIFORM).unwrap();
    let mut c = EstimationConfig::new(0.1, 0);
    c.refine = Some(Refine {
        rounds: 2,
        runs: 10,
        reuse: 3,
    });
    assert_eq!(
        err(&[(s, p)], &c),
        "refine reuse: 3 rounds to reuse in the estimate, but only 2 pilot rounds"
    );
}

/// Reusing the last pilot rounds changes no trial (the same draws), counts those rounds'
/// trials in the estimate with their own round's weights, and keeps it unbiased: over 60
/// seeds the interval covers the true tail probability at about the nominal rate, the mean
/// error is small against the spread, and the interval is narrower than without reuse.
#[test]
fn reused_pilot_rounds_join_the_estimate_and_keep_it_unbiased() {
    let refine = |reuse| {
        Some(Refine {
            rounds: 3,
            runs: 400,
            reuse,
        })
    };
    let run = |seed: u64, reuse: u32| {
        let (mut e, truth) = rare(seed, refine(reuse));
        let mut trials = Vec::new();
        while e.told() < 1200 {
            let t = e.ask().expect("told one by one");
            e.tell(t.id, fails(&t)).unwrap();
            trials.push(t);
        }
        let after_pilot = e.estimate().runs;
        for _ in 0..1000 {
            let t = e.ask().expect("no waiting after the pilot");
            e.tell(t.id, fails(&t)).unwrap();
            trials.push(t);
        }
        (e.estimate(), truth, trials, after_pilot)
    };
    let (with, _, trials_with, after_pilot) = run(3, 2);
    let (without, _, trials_without, _) = run(3, 0);
    assert_eq!(trials_with, trials_without, "reuse changes no draw");
    assert_eq!((after_pilot, with.runs, without.runs), (800, 1800, 1000));
    // The reused rounds' trials, with their own weights, make up the difference.
    let reused: Vec<&EstimationTrial> = trials_with
        .iter()
        .filter(|t| matches!(t.round, Some(1 | 2)))
        .collect();
    assert_eq!(reused.len(), 800);
    let failures = |ts: &[&EstimationTrial]| ts.iter().filter(|t| fails(t)).count() as u64;
    assert_eq!(with.failures, without.failures + failures(&reused));
    let seeds = 60;
    let (mut covered, mut error) = (0, 0.0);
    let (mut width_one, mut width_none) = (0.0, 0.0);
    for seed in 0..seeds {
        let (est, truth, _, _) = run(seed, 2);
        covered += u32::from(est.total.lo <= truth && truth <= est.total.hi);
        error += (est.total.mean - truth) / truth / seeds as f64;
        width_one += run(seed, 1).0.total.relative_half_width() / seeds as f64;
        width_none += run(seed, 0).0.total.relative_half_width() / seeds as f64;
    }
    assert!((53..=60).contains(&covered), "covered {covered} of {seeds}");
    assert!(error.abs() < 0.02, "mean relative error {error}");
    // Measured: ±3.94 % reusing the last round, ±4.34 % without (and ±4.02 % reusing two:
    // the earlier round's proposal is further from the final one, its terms spread more).
    assert!(width_one < 0.95 * width_none, "{width_one} vs {width_none}");
}

/// The multi-fidelity estimation's LF: it fails past 0.6 (false alarms on (0.6, 0.7]) unless
/// y > 0.8 (misses: a fifth of the HF failures), so a proposal fitted on it is off.
fn fails_lf(t: &EstimationTrial) -> bool {
    t.phi.get_f64("x").unwrap() > 0.6 && t.phi.get_f64("y").unwrap() <= 0.8
}

fn lf_pilot(rounds: u32, runs: u64) -> Option<Refine> {
    Some(Refine {
        rounds,
        runs,
        reuse: 0,
    })
}

/// An LF pilot without rounds, or reused in the estimate, is refused naming the setting.
#[test]
fn a_low_fidelity_pilot_needs_rounds_and_is_never_reused() {
    let (s, p) = scenario("s", vec![Variable::boolean("b")], 1.0);
    let mut c = EstimationConfig::new(0.1, 0);
    c.pilot_fidelity = Fidelity::Lf;
    let m = err(&[(s.clone(), p.clone())], &c);
    assert!(
        m.starts_with("pilot_fidelity: `lf`") && m.contains("give `refine`"),
        "{m}"
    );
    c.refine = Some(Refine {
        rounds: 2,
        runs: 10,
        reuse: 1,
    });
    let m = err(&[(s, p)], &c);
    assert!(
        m.contains("reuse must be 0") && m.contains("1 pilot rounds"),
        "{m}"
    );
}

/// Pilot trials run at LF, the estimate's at HF; the LF outcomes fit the proposal and never
/// enter the estimate.
#[test]
fn a_low_fidelity_pilot_runs_at_lf_and_stays_out_of_the_estimate() {
    let (mut e, _) = rare(3, lf_pilot(2, 40));
    e.pilot_fidelity = Fidelity::Lf;
    for _ in 0..80 {
        let t = e.ask().expect("told one by one");
        assert_eq!((t.fidelity, t.round.is_some()), (Fidelity::Lf, true));
        e.tell(t.id, fails_lf(&t)).unwrap();
    }
    assert_eq!(e.estimate().runs, 0, "no LF outcome is in the estimate");
    let t = e.ask().expect("the estimate");
    assert_eq!((t.fidelity, t.round), (Fidelity::Hf, None));
    assert!(!serde_json::to_string(&t).unwrap().contains("fidelity"));
}

/// The multi-fidelity estimate is unbiased for the HF probability however wrong the LF is:
/// over 60 seeds (fixed), the proposal fitted on the biased LF's failures (false alarms and
/// misses), the interval of 2,000 HF runs covers the exact HF tail probability in 53–60 of
/// them (measured: 57) and the mean estimate is within 3 % of it (measured: 0.4 %). (Its
/// width, ±11.1 %, is no better than the unrefined proposal's ±11.0 % here: this LF's false
/// alarms pull the proposal below the HF threshold.)
#[test]
fn a_low_fidelity_pilot_keeps_the_hf_estimate_unbiased() {
    let run = |seed: u64, refine: Option<Refine>| {
        let (mut e, truth) = rare(seed, refine);
        e.pilot_fidelity = Fidelity::Lf;
        let mut hf_runs = 0;
        while hf_runs < 2000 {
            let t = e.ask().expect("told one by one");
            let f = match t.fidelity {
                Fidelity::Lf => fails_lf(&t),
                Fidelity::Hf => {
                    hf_runs += 1;
                    fails(&t)
                }
            };
            e.tell(t.id, f).unwrap();
        }
        (e.estimate().total, truth)
    };
    let seeds = 60;
    let (mut covered, mut mean, mut truth) = (0, 0.0, 0.0);
    for seed in 0..seeds {
        let (est, t) = run(seed, lf_pilot(3, 400));
        truth = t;
        covered += u32::from(est.lo <= t && t <= est.hi);
        mean += est.mean / seeds as f64;
    }
    assert!((53..=60).contains(&covered), "covered {covered} of {seeds}");
    assert!((mean / truth - 1.0).abs() < 0.03, "{mean} vs {truth}");
}

//! Bad configurations and bad tells give typed errors and leave the kernel unchanged.
mod common;
use savme_kernel::{
    Assignment, ConfigError, Kernel, Observation, Phase, PriorCounts, Run, Space, SpaceError,
    TellError, Variable,
};

fn paired(hf: f64, lf: f64) -> Observation {
    Observation::Paired {
        hf: Run::new(true, hf),
        lf: Run::new(true, lf),
    }
}

#[test]
fn bad_configurations_are_rejected_with_the_culprit_named() {
    let (f, hf) = common::fidelity();
    let phi = common::phi_space;
    assert_eq!(
        Kernel::builder(f.clone(), hf.clone()).build().unwrap_err(),
        ConfigError::NoScenarios
    );
    for w in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = common::builder()
            .scenario("c", phi(), w)
            .build()
            .unwrap_err();
        assert!(
            matches!(&e, ConfigError::BadWeight { scenario, .. } if scenario == "c"),
            "{w}: {e}"
        );
    }
    let e = common::builder()
        .scenario("a", phi(), 1.0)
        .build()
        .unwrap_err();
    assert_eq!(e, ConfigError::DuplicateScenario("a".into()));
    let e = common::builder()
        .scenario("", phi(), 1.0)
        .build()
        .unwrap_err();
    assert_eq!(e, ConfigError::EmptyScenarioName { index: 2 });
    for b in [0.0, -0.1, 1.01, f64::NAN] {
        let e = common::builder().budget(b).build().unwrap_err();
        assert!(matches!(e, ConfigError::BadBudget(_)), "{b}");
    }
    assert!(common::builder().budget(1.0).build().is_ok());
    let outside = hf.clone().with("view_m", 6000.0);
    let e = Kernel::builder(f.clone(), outside)
        .scenario("a", phi(), 1.0)
        .build()
        .unwrap_err();
    assert!(
        matches!(&e, ConfigError::ThetaHf(SpaceError::OutOfSpace { variable, .. }) if variable == "view_m"),
        "{e}"
    );
    assert!(e.to_string().contains("θ_HF"));
    let incomplete = Assignment::new().with("rate_hz", 10);
    let e = Kernel::builder(f.clone(), incomplete)
        .scenario("a", phi(), 1.0)
        .build()
        .unwrap_err();
    assert!(matches!(
        e,
        ConfigError::ThetaHf(SpaceError::MissingValue { .. })
    ));
    let e = common::builder()
        .prior(PriorCounts {
            successes: 0.0,
            losses: 1.0,
        })
        .build()
        .unwrap_err();
    assert!(matches!(e, ConfigError::Prior(_)));
    // A fidelity prior from another space does not fit.
    let other = Space::new(vec![Variable::boolean("x")]).unwrap();
    let foreign = savme_kernel::Posterior::new(&other, PriorCounts::UNIFORM).unwrap();
    let e = common::builder()
        .fidelity_prior(foreign, 1.0)
        .build()
        .unwrap_err();
    assert!(matches!(e, ConfigError::Prior(_)), "{e}");
    let own = common::kernel().fidelity_posterior().clone();
    let e = common::builder()
        .fidelity_prior(own, 0.0)
        .build()
        .unwrap_err();
    assert!(matches!(e, ConfigError::Prior(_)), "{e}");
}

#[test]
fn weights_are_normalised() {
    let k = common::kernel();
    let p = k.scenario_probabilities();
    assert!(
        (p[0] - 0.25).abs() < 1e-12 && (p[1] - 0.75).abs() < 1e-12,
        "{p:?}"
    );
}

// Long because it is one table of bad tells, each checked the same way.
#[test]
fn bad_tells_are_typed_errors_and_change_nothing() {
    let mut k = common::kernel();
    let train = k.ask();
    k.set_phase(Phase::Baseline);
    let base = k.ask();
    let before = k.to_json();
    let cases: Vec<(u64, Observation, TellError)> = vec![
        (99, paired(1.0, 0.1), TellError::Unknown(99)),
        (
            train.id,
            Observation::HfOnly(Run::new(true, 1.0)),
            TellError::ExpectedPaired {
                id: train.id,
                phase: Phase::Train,
            },
        ),
        (
            base.id,
            paired(1.0, 0.1),
            TellError::ExpectedHfOnly { id: base.id },
        ),
        (
            train.id,
            paired(f64::NAN, 0.1),
            TellError::BadRuntime {
                id: train.id,
                simulator: "HF",
                runtime: f64::NAN,
            },
        ),
        (
            train.id,
            paired(1.0, f64::INFINITY),
            TellError::BadRuntime {
                id: train.id,
                simulator: "LF",
                runtime: f64::INFINITY,
            },
        ),
        (
            train.id,
            paired(-1.0, 0.1),
            TellError::BadRuntime {
                id: train.id,
                simulator: "HF",
                runtime: -1.0,
            },
        ),
        (
            train.id,
            paired(1.0, 0.0),
            TellError::BadRuntime {
                id: train.id,
                simulator: "LF",
                runtime: 0.0,
            },
        ),
        (
            base.id,
            Observation::HfOnly(Run::new(true, 0.0)),
            TellError::BadRuntime {
                id: base.id,
                simulator: "HF",
                runtime: 0.0,
            },
        ),
        // Both finite and > 0, but the ratio overflows: refused (it could not be replayed).
        (
            train.id,
            paired(5e-324, 1.0),
            TellError::BadCostRatio {
                id: train.id,
                hf: 5e-324,
                lf: 1.0,
            },
        ),
    ];
    for (id, obs, expected) in cases {
        let err = k.tell(id, obs).unwrap_err();
        match (&err, &expected) {
            // NaN != NaN: compare the rest.
            (
                TellError::BadRuntime {
                    id: a,
                    simulator: s,
                    runtime: r,
                },
                TellError::BadRuntime {
                    id: b,
                    simulator: t,
                    runtime: q,
                },
            ) if r.is_nan() => assert!(a == b && s == t && q.is_nan()),
            _ => assert_eq!(err, expected),
        }
        assert_eq!(k.to_json(), before, "state changed after {err}");
    }
    k.tell(train.id, paired(1.0, 0.1)).unwrap();
    let after_first = k.to_json();
    assert_eq!(
        k.tell(train.id, paired(1.0, 0.1)).unwrap_err(),
        TellError::AlreadyTold(train.id)
    );
    assert_eq!(k.to_json(), after_first);
    // Cancel: once, then it is gone.
    assert_eq!(k.cancel(base.id).unwrap().id, base.id);
    assert_eq!(
        k.cancel(base.id).unwrap_err(),
        TellError::AlreadyTold(base.id)
    );
    assert_eq!(
        k.tell(base.id, Observation::HfOnly(Run::new(true, 1.0)))
            .unwrap_err(),
        TellError::AlreadyTold(base.id)
    );
    assert_eq!(k.stats().cancelled, 1);
    assert_eq!(k.stats().told, 1);
}

#[test]
fn many_pending_asks_told_in_any_order() {
    let mut k = common::kernel();
    let trials: Vec<_> = (0..50).map(|_| k.ask()).collect();
    assert_eq!(k.pending().count(), 50);
    let ids: Vec<u64> = trials.iter().map(|t| t.id).collect();
    assert_eq!(ids, (0..50).collect::<Vec<_>>());
    // Tell evens backwards, then odds forwards.
    for t in trials
        .iter()
        .rev()
        .filter(|t| t.id % 2 == 0)
        .chain(trials.iter().filter(|t| t.id % 2 == 1))
    {
        let r = k.tell(t.id, paired(1.0, 0.2)).unwrap();
        assert_eq!(&r.trial, t);
    }
    assert_eq!(k.pending().count(), 0);
    assert_eq!(k.stats().told, 50);
}

#[test]
fn the_same_seed_and_calls_give_the_same_trials_and_other_seeds_differ() {
    let run = |seed: u64| {
        let mut k = common::builder().seed(seed).build().unwrap();
        let mut out = Vec::new();
        for i in 0..40 {
            let t = k.ask();
            if i % 3 != 0 {
                k.tell(t.id, paired(1.0, if i % 2 == 0 { 0.1 } else { 0.5 }))
                    .unwrap();
            }
            out.push(t);
        }
        out
    };
    assert_eq!(run(5), run(5));
    assert_ne!(run(5), run(6));
}

#[test]
fn scenarios_are_drawn_by_weight() {
    let mut k = common::kernel();
    let n = 4000;
    let b = (0..n).filter(|_| &*k.ask().scenario == "b").count();
    let share = b as f64 / n as f64;
    assert!((share - 0.75).abs() < 0.03, "{share}");
}

#[test]
fn evaluation_uses_the_estimate_and_baseline_draws_phi_uniformly() {
    let mut k = common::kernel();
    for _ in 0..30 {
        let t = k.ask();
        k.tell(t.id, paired(1.0, 0.1)).unwrap();
    }
    k.set_phase(Phase::Evaluate);
    let est = k.fidelity_estimate(savme_kernel::Estimator::Map);
    for _ in 0..10 {
        assert_eq!(k.ask().theta_lf.as_ref(), Some(&est));
    }
    // Baseline: each speed bin about equally often, whatever the posterior learned.
    k.set_phase(Phase::Baseline);
    let space = common::phi_space();
    let mut counts = [0usize; 6];
    let n = 6000;
    for _ in 0..n {
        let t = k.ask();
        counts[space.arms_of(&t.phi).unwrap()[0]] += 1;
    }
    for c in counts {
        assert!((c as f64 / n as f64 - 1.0 / 6.0).abs() < 0.02, "{counts:?}");
    }
}

#[test]
fn an_observation_with_an_unknown_key_is_refused_naming_it() {
    let e = serde_json::from_str::<Observation>(
        r#"{"paired":{"hf":{"failure":true,"runtme":5},"lf":{"failure":true,"runtime":1}}}"#,
    )
    .unwrap_err();
    assert!(e.to_string().contains("unknown field `runtme`"), "{e}");
}

#[test]
fn a_configuration_with_an_unknown_or_misplaced_key_is_refused_naming_it() {
    let json = common::kernel().config().clone();
    let text = serde_json::to_string(&json).unwrap();
    assert!(serde_json::from_str::<savme_kernel::KernelConfig>(&text).is_ok());
    let cases = [
        (
            text.replacen("\"budget\":", "\"budgt\":1,\"budget\":", 1),
            "unknown field `budgt`",
        ),
        (
            text.replacen("\"weight\":", "\"wieght\":1,\"weight\":", 1),
            "unknown field `wieght`",
        ),
        (
            text.replacen("\"bins\":", "\"binz\":1,\"bins\":", 1),
            "unknown field `binz`",
        ),
        (
            text.replacen("\"bins\":", "\"values\":[1],\"bins\":", 1),
            "not `values`",
        ),
        (
            text.replacen("\"successes\":", "\"sucesses\":1,\"successes\":", 1),
            "unknown field `sucesses`",
        ),
    ];
    for (bad, needle) in cases {
        assert_ne!(bad, text, "{needle}: the edit did not apply");
        let e = serde_json::from_str::<savme_kernel::KernelConfig>(&bad).unwrap_err();
        assert!(e.to_string().contains(needle), "{needle}: {e}");
    }
}

#[test]
fn a_nominal_with_an_unknown_key_is_refused_naming_it() {
    use savme_kernel::estimation::Nominal;
    // Every form, the uniform one included (serde lets a unit variant of a tagged enum
    // ignore extra keys: its `sd` was dropped silently).
    for (text, key) in [
        (r#"{"distribution":"uniform","sd":2.0}"#, "sd"),
        (
            r#"{"distribution":"normal","mean":1.0,"sd":2.0,"sdd":1}"#,
            "sdd",
        ),
        (r#"{"distribution":"weights","weights":[1.0],"w":1}"#, "w"),
    ] {
        let e = serde_json::from_str::<Nominal>(text).unwrap_err();
        assert!(
            e.to_string().contains(&format!("unknown field `{key}`")),
            "{text}: {e}"
        );
    }
    for n in [
        Nominal::Uniform,
        Nominal::Normal { mean: 1.0, sd: 2.0 },
        Nominal::Weights {
            weights: vec![1.0, 3.0],
        },
    ] {
        let text = serde_json::to_string(&n).unwrap();
        assert_eq!(serde_json::from_str::<Nominal>(&text).unwrap(), n, "{text}");
    }
    let n: Nominal = serde_json::from_str(r#"{"distribution":"uniform"}"#).unwrap();
    assert_eq!(n, Nominal::Uniform);
}

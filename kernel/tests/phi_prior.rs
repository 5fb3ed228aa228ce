//! A φ prior carried over to a scenario (`KernelBuilder::scenario_prior`, meta-testing's p_ψ
//! transfer): the scenario's p_ψ starts from it, its Thompson draws follow it, a prior that
//! names no scenario or does not fit is refused naming the scenario, and a configuration
//! without one serialises as before (journals and fixtures unchanged).
use savme_kernel::{
    Assignment, ConfigError, Kernel, KernelBuilder, Posterior, PriorCounts, Scale, Space, Variable,
};

fn gap() -> Space {
    Space::new(vec![Variable::continuous(
        "gap",
        0.0,
        1.0,
        4,
        Scale::Linear,
    )])
    .unwrap()
}

fn builder() -> KernelBuilder {
    let fidelity = Space::new(vec![Variable::discrete("rate_hz", [1, 10])]).unwrap();
    Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
        .scenario("a", gap(), 1.0)
        .scenario("b", gap(), 1.0)
        .seed(5)
}

/// A p_ψ of `gap` that has seen 40 failures in bin 2 and 40 passes everywhere else.
fn learned() -> Posterior {
    let mut p = Posterior::new(&gap(), PriorCounts::UNIFORM).unwrap();
    for _ in 0..40 {
        p.update(&[2], true);
        for k in [0, 1, 3] {
            p.update(&[k], false);
        }
    }
    p
}

#[test]
fn a_scenario_prior_starts_that_scenarios_p_psi_and_its_draws_follow_it() {
    let mut k = builder().scenario_prior("b", learned()).build().unwrap();
    assert_eq!(k.scenario_posterior("b"), Some(&learned()));
    assert_eq!(
        k.scenario_posterior("a"),
        Some(&Posterior::new(&gap(), PriorCounts::UNIFORM).unwrap())
    );
    let mut in_bin_2 = [0usize; 2];
    let mut asked = [0usize; 2];
    for _ in 0..200 {
        let t = k.ask();
        let s = usize::from(&*t.scenario == "b");
        asked[s] += 1;
        let x = t.phi.get("gap").and_then(|v| v.as_f64()).unwrap();
        in_bin_2[s] += usize::from((0.5..0.75).contains(&x));
        k.cancel(t.id).unwrap();
    }
    // b draws the bin its prior favours nearly always; a about a quarter of the time.
    assert!(
        in_bin_2[1] * 10 >= asked[1] * 9,
        "{in_bin_2:?} of {asked:?}"
    );
    assert!(in_bin_2[0] * 2 <= asked[0], "{in_bin_2:?} of {asked:?}");
}

#[test]
fn a_scenario_prior_that_names_no_scenario_or_does_not_fit_is_refused() {
    let err = builder()
        .scenario_prior("c", learned())
        .build()
        .unwrap_err();
    assert!(matches!(&err, ConfigError::ScenarioPrior { scenario, .. } if scenario == "c"));
    assert!(
        err.to_string().contains("no scenario has this name"),
        "{err}"
    );
    let other = Space::new(vec![Variable::boolean("gap")]).unwrap();
    let err = builder()
        .scenario_prior("a", Posterior::new(&other, PriorCounts::UNIFORM).unwrap())
        .build()
        .unwrap_err();
    assert!(
        err.to_string().starts_with("φ prior of scenario `a`: "),
        "{err}"
    );
}

#[test]
fn a_configuration_without_scenario_priors_serialises_as_before() {
    let plain = serde_json::to_value(builder().build().unwrap().config()).unwrap();
    assert!(plain.get("scenario_priors").is_none(), "{plain}");
    let with = builder().scenario_prior("a", learned()).build().unwrap();
    let json = serde_json::to_string(with.config()).unwrap();
    let back: savme_kernel::KernelConfig = serde_json::from_str(&json).unwrap();
    assert_eq!(&back, with.config());
    assert_eq!(
        Kernel::new(back).unwrap().scenario_posterior("a"),
        Some(&learned())
    );
}

//! MAP and mean estimators, ties, prior counts and prior transfer.
use savme_kernel::{Arm, Estimator, Posterior, PosteriorError, PriorCounts, Space, Variable};

fn space(arms: usize) -> Space {
    Space::new(vec![Variable::discrete("v", 0..arms as i64)]).unwrap()
}

fn posterior_with(counts: &[(u32, u32)]) -> Posterior {
    let mut p = Posterior::new(&space(counts.len()), PriorCounts::UNIFORM).unwrap();
    for (arm, &(s, l)) in counts.iter().enumerate() {
        for _ in 0..s {
            p.update(&[arm as u16], true);
        }
        for _ in 0..l {
            p.update(&[arm as u16], false);
        }
    }
    p
}

#[test]
fn mode_follows_the_papers_formula_and_its_documented_extensions() {
    let m = |a, b| Arm { alpha: a, beta: b }.mode();
    assert_eq!(m(3.0, 2.0), 2.0 / 3.0);
    assert_eq!(m(1.0, 1.0), 0.5, "Beta(1,1): documented as 0.5");
    assert_eq!(m(1.0, 3.0), 0.0);
    assert_eq!(m(3.0, 1.0), 1.0);
    assert_eq!(m(0.5, 2.0), 0.0);
    assert_eq!(m(2.0, 0.5), 1.0);
    assert_eq!(m(0.5, 0.5), 0.5, "both below 1: the mean");
}

#[test]
fn map_prefers_one_of_one_and_mean_prefers_forty_of_fifty() {
    let p = posterior_with(&[(1, 0), (40, 10)]);
    assert_eq!(p.best_arms(Estimator::Map), vec![0]);
    assert_eq!(p.best_arms(Estimator::Mean), vec![1]);
}

#[test]
fn untried_arms_tie_and_the_lowest_index_wins() {
    let p = posterior_with(&[(0, 0), (0, 0), (0, 0)]);
    assert_eq!(p.best_arms(Estimator::Map), vec![0]);
    assert_eq!(p.best_arms(Estimator::Mean), vec![0]);
}

#[test]
fn map_ties_go_to_the_higher_mean() {
    // Beta(2,1) and Beta(3,1) both have mode 1; Beta(3,1) has the higher mean.
    let p = posterior_with(&[(1, 0), (2, 0)]);
    assert_eq!(p.best_arms(Estimator::Map), vec![1]);
    // An untried arm (mode 0.5) beats an arm with one loss (mode 0).
    let q = posterior_with(&[(0, 1), (0, 0)]);
    assert_eq!(q.best_arms(Estimator::Map), vec![1]);
}

#[test]
fn explicit_prior_counts_are_used_and_validated() {
    let p = Posterior::new(
        &space(2),
        PriorCounts {
            successes: 2.0,
            losses: 5.0,
        },
    )
    .unwrap();
    assert_eq!(
        p.arms()[0][1],
        Arm {
            alpha: 2.0,
            beta: 5.0
        }
    );
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let r = Posterior::new(
            &space(2),
            PriorCounts {
                successes: bad,
                losses: 1.0,
            },
        );
        assert!(matches!(r, Err(PosteriorError::BadPrior { .. })), "{bad}");
    }
}

#[test]
fn transfer_carries_evidence_and_scales_it() {
    let learned = posterior_with(&[(4, 2), (0, 6)]);
    let same = learned.as_prior(PriorCounts::UNIFORM, 1.0).unwrap();
    assert_eq!(
        same.arms(),
        learned.arms(),
        "strength 1 passes the posterior on"
    );
    let half = learned.as_prior(PriorCounts::UNIFORM, 0.5).unwrap();
    assert_eq!(
        half.arms()[0][0],
        Arm {
            alpha: 3.0,
            beta: 2.0
        }
    );
    assert_eq!(
        half.arms()[0][1],
        Arm {
            alpha: 1.0,
            beta: 4.0
        }
    );
    let double = learned.as_prior(PriorCounts::UNIFORM, 2.0).unwrap();
    assert_eq!(
        double.arms()[0][0],
        Arm {
            alpha: 9.0,
            beta: 5.0
        }
    );
    // On another base prior the evidence is added to that base.
    let jeffreys = PriorCounts {
        successes: 0.5,
        losses: 0.5,
    };
    let j = learned.as_prior(jeffreys, 1.0).unwrap();
    assert_eq!(
        j.arms()[0][0],
        Arm {
            alpha: 4.5,
            beta: 2.5
        }
    );
    assert_eq!(j.prior(), jeffreys);
    // A chain of transfers keeps all the evidence.
    let again = j.as_prior(PriorCounts::UNIFORM, 1.0).unwrap();
    assert_eq!(again.arms(), learned.arms());
    for bad in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            learned.as_prior(PriorCounts::UNIFORM, bad),
            Err(PosteriorError::BadStrength(_))
        ));
    }
}

#[test]
fn a_posterior_that_does_not_fit_the_space_is_rejected() {
    let p = posterior_with(&[(1, 1), (1, 1)]);
    assert!(p.check_fits(&space(2)).is_ok());
    assert!(matches!(
        p.check_fits(&space(3)),
        Err(PosteriorError::Shape(_))
    ));
    let renamed = Space::new(vec![Variable::discrete("w", [0, 1])]).unwrap();
    assert!(matches!(
        p.check_fits(&renamed),
        Err(PosteriorError::Shape(_))
    ));
}

//! Every cell of the paper's Table I, through the kernel's tell.
mod common;
use savme_kernel::{Arm, Observation, Outcome, Phase, Run};

fn arms_total(p: &savme_kernel::Posterior) -> (f64, f64) {
    p.arms()
        .iter()
        .flatten()
        .fold((0.0, 0.0), |(a, b), arm: &Arm| {
            (a + arm.alpha, b + arm.beta)
        })
}

/// (hf failure, lf failure, t_lf, expected outcome, fidelity success, scenario success);
/// t_HF = 1 and C_budget = 0.3.
const CELLS: [(bool, bool, f64, Outcome, bool, bool); 8] = [
    (true, true, 0.3, Outcome::TP, true, true), // ratio == budget counts as within
    (true, true, 0.31, Outcome::TP, false, true),
    (false, false, 0.1, Outcome::TN, true, false),
    (false, false, 0.9, Outcome::TN, false, false),
    (false, true, 0.1, Outcome::FP, false, false),
    (false, true, 0.9, Outcome::FP, false, false),
    (true, false, 0.1, Outcome::FN, false, true),
    (true, false, 0.9, Outcome::FN, false, true),
];

#[test]
fn every_cell_credits_exactly_as_table_i() {
    for phase in [Phase::Train, Phase::Test] {
        for &(hf, lf, t_lf, outcome, fid, scen) in &CELLS {
            let mut k = common::kernel();
            k.set_phase(phase);
            let t = k.ask();
            let fid_before = arms_total(k.fidelity_posterior());
            let sc_before = arms_total(k.scenario_posterior(&t.scenario).unwrap());
            let r = k
                .tell(
                    t.id,
                    Observation::Paired {
                        hf: Run::new(hf, 1.0),
                        lf: Run::new(lf, t_lf),
                    },
                )
                .unwrap();
            assert_eq!(r.outcome, Some(outcome));
            assert_eq!(r.credit.fidelity, Some(fid), "{outcome:?} at ratio {t_lf}");
            assert_eq!(r.credit.scenario, Some(scen), "{outcome:?}");
            // One count per variable went to α (success) or β (loss), on the drawn arms.
            let fid_after = arms_total(k.fidelity_posterior());
            let sc_after = arms_total(k.scenario_posterior(&t.scenario).unwrap());
            let nf = k.config().fidelity.len() as f64;
            let ns = 2.0;
            let expect = |before: (f64, f64), ok: bool, n: f64| {
                if ok {
                    (before.0 + n, before.1)
                } else {
                    (before.0, before.1 + n)
                }
            };
            assert_eq!(fid_after, expect(fid_before, fid, nf));
            assert_eq!(sc_after, expect(sc_before, scen, ns));
        }
    }
}

#[test]
fn credit_goes_to_the_drawn_arms() {
    let mut k = common::kernel();
    let t = k.ask();
    let theta = t.theta_lf.clone().unwrap();
    let arms = k.config().fidelity.arms_of(&theta).unwrap();
    k.tell(
        t.id,
        Observation::Paired {
            hf: Run::new(false, 1.0),
            lf: Run::new(false, 0.1),
        },
    )
    .unwrap();
    for (v, &arm) in k.fidelity_posterior().arms().iter().zip(&arms) {
        for (j, a) in v.iter().enumerate() {
            let expected = if j == arm { 2.0 } else { 1.0 };
            assert_eq!(a.alpha, expected);
            assert_eq!(a.beta, 1.0);
        }
    }
}

#[test]
fn evaluation_and_baseline_update_nothing() {
    for phase in [Phase::Evaluate, Phase::Baseline] {
        let mut k = common::kernel();
        k.set_phase(phase);
        let before = (
            k.fidelity_posterior().clone(),
            k.scenario_posterior("a").cloned(),
        );
        for _ in 0..20 {
            let t = k.ask();
            let obs = if phase == Phase::Baseline {
                assert!(t.theta_lf.is_none());
                Observation::HfOnly(Run::new(true, 1.0))
            } else {
                Observation::Paired {
                    hf: Run::new(true, 1.0),
                    lf: Run::new(true, 0.1),
                }
            };
            let r = k.tell(t.id, obs).unwrap();
            assert_eq!(r.credit.fidelity, None);
            assert_eq!(r.credit.scenario, None);
        }
        let after = (
            k.fidelity_posterior().clone(),
            k.scenario_posterior("a").cloned(),
        );
        assert_eq!(before, after);
    }
}

#[test]
fn a_pending_trial_keeps_the_phase_it_was_asked_in() {
    let mut k = common::kernel();
    let train = k.ask();
    k.set_phase(Phase::Evaluate);
    let r = k
        .tell(
            train.id,
            Observation::Paired {
                hf: Run::new(true, 1.0),
                lf: Run::new(true, 0.1),
            },
        )
        .unwrap();
    assert_eq!(r.trial.phase, Phase::Train);
    assert_eq!(r.credit.fidelity, Some(true));
}

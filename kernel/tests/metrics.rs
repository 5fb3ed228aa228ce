//! TP-rate, LF cost, speedup (checked against the paper's Table III), curves and break-even.
mod common;
use savme_kernel::metrics::{break_even, speedup, Accounting, FailureCurve, Summary};
use savme_kernel::{Observation, Phase, Run};

/// The paper's Table III as printed (rounded to two decimals): C_budget (None for the HF-only
/// baseline), TP-rate, mean LF cost, speedup.
const TABLE_III: [(Option<f64>, f64, f64, f64); 4] = [
    (None, 0.17, 1.00, 1.00),
    (Some(0.4), 0.41, 0.26, 9.32),
    (Some(0.3), 0.74, 0.25, 17.99),
    (Some(0.2), 0.29, 0.22, 7.86),
];

#[test]
fn speedup_reproduces_table_ii_from_its_other_columns() {
    // The table prints two decimals; every input may be off by up to 0.005. The printed speedup
    // must lie inside the interval the rounded inputs allow.
    let baseline = TABLE_III[0].1;
    for (budget, tp, cost, printed) in &TABLE_III[1..] {
        let lo = speedup(tp - 0.005, cost + 0.005, baseline + 0.005).unwrap();
        let hi = speedup(tp + 0.005, cost - 0.005, baseline - 0.005).unwrap();
        assert!(
            lo <= *printed && *printed <= hi,
            "C={budget:?}: {printed} not in [{lo:.2}, {hi:.2}]"
        );
        let mid = speedup(*tp, *cost, baseline).unwrap();
        assert!(
            (mid - printed).abs() / printed < 0.04,
            "C={budget:?}: {mid:.2} vs {printed}"
        );
    }
    // The baseline row: HF only, cost 1, rate / rate.
    assert_eq!(speedup(0.17, 1.0, 0.17), Some(1.0));
    assert_eq!(speedup(0.5, 0.0, 0.17), None);
    assert_eq!(speedup(0.5, 0.2, 0.0), None);
}

#[test]
fn summary_counts_a_mixed_history() {
    let mut k = common::kernel();
    let mut records = Vec::new();
    // (hf, lf, t_lf): TP, TP, TN, FP, FN with t_HF = 2.
    for &(hf, lf, t_lf) in &[
        (true, true, 0.5),
        (true, true, 1.0),
        (false, false, 0.2),
        (false, true, 0.2),
        (true, false, 0.1),
    ] {
        let t = k.ask();
        records.push(
            k.tell(
                t.id,
                Observation::Paired {
                    hf: Run::new(hf, 2.0),
                    lf: Run::new(lf, t_lf),
                },
            )
            .unwrap(),
        );
    }
    let s = Summary::of(&records);
    assert_eq!(
        (s.trials, s.paired, s.tp, s.tn, s.fp, s.fn_, s.hf_failures),
        (5, 5, 2, 1, 1, 1, 3)
    );
    assert_eq!(s.tp_rate(), Some(0.4));
    assert!((s.mean_lf_cost().unwrap() - 2.0 / 10.0).abs() < 1e-12);
    assert_eq!(s.agreement(), Some(0.6));
    assert_eq!(s.hf_failure_rate(), Some(0.6));
    k.set_phase(Phase::Baseline);
    let t = k.ask();
    let b = k
        .tell(t.id, Observation::HfOnly(Run::new(true, 2.0)))
        .unwrap();
    let base = Summary::of([&b]);
    assert_eq!(
        (base.tp_rate(), base.mean_lf_cost(), base.hf_failure_rate()),
        (None, None, Some(1.0))
    );
    // Curves: all runs cost for training; LF only (TP found) for deployment.
    let all = FailureCurve::from_records(&records, Accounting::AllRuns);
    assert_eq!(all.end(), 10.0 + 2.0);
    assert_eq!(all.failures(), 3);
    let lf = FailureCurve::from_records(&records, Accounting::LfOnly);
    assert!((lf.end() - 2.0).abs() < 1e-12);
    assert_eq!(lf.failures(), 2);
    assert_eq!(lf.points()[1].failures, 2);
}

#[test]
fn break_even_is_the_last_overtaking_inside_the_common_horizon() {
    let curve = |steps: &[(f64, bool)]| {
        let mut c = FailureCurve::new();
        for &(dt, f) in steps {
            c.push(dt, f);
        }
        c
    };
    let base = curve(&[
        (1.0, true),
        (1.0, false),
        (1.0, true),
        (1.0, false),
        (1.0, true),
        (1.0, false),
    ]);
    // Ahead at 2, tied at 3, ahead again from 4.5 on.
    let method = curve(&[
        (0.5, true),
        (1.5, true),
        (1.0, false),
        (1.5, true),
        (0.25, true),
        (1.25, false),
    ]);
    assert_eq!(method.failures_at(2.0), 2);
    assert_eq!(method.failures_at(3.0), base.failures_at(3.0));
    assert_eq!(break_even(&method, &base), Some(4.5));
    // Never ahead at the end of the common horizon.
    let slow = curve(&[(10.0, true)]);
    assert_eq!(break_even(&slow, &base), None);
    // Ahead from the first trial.
    let fast = curve(&[(0.5, true), (0.5, true)]);
    assert_eq!(break_even(&fast, &base), Some(0.5));
    // Ties are not "ahead".
    assert_eq!(break_even(&base, &base), None);
    assert_eq!(break_even(&FailureCurve::new(), &base), None);
}

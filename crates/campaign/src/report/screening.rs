//! The LF screening stage's results: confirmed failures per unit of total runtime against the
//! paper's paired evaluation and the HF-only baseline, and the miss (FN) rate of the LF
//! simulator from the audit, with its Wilson interval.

use super::intervals::Interval;
use super::TrialLine;
use crate::log::ScreenLine;
use savme_kernel::screening::ScreeningCounts;
use serde::Serialize;

/// Screening at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Screening {
    /// Counts and costs.
    pub counts: ScreeningCounts,
    /// The audit fraction α.
    pub audit_fraction: f64,
    /// Miss rate among LF passes (audited passes whose HF run failed), Wilson 95 %.
    pub miss_rate: Option<Interval>,
    /// Share of LF failures the HF run confirmed, Wilson 95 %.
    pub confirmed_share: Option<Interval>,
    /// Estimated failures among all LF passes (miss rate × passes).
    pub estimated_misses: Option<f64>,
    /// Confirmed failures per unit of total runtime (LF + confirming and audit HF runs).
    pub confirmed_per_runtime: Option<f64>,
    /// The paired evaluation at this budget: HF failures per unit of runtime (HF + LF).
    pub paired_per_runtime: Option<f64>,
    /// The baseline on the meta-training scenarios: HF failures per unit of HF runtime.
    pub baseline_per_runtime: Option<f64>,
    /// confirmed_per_runtime / paired_per_runtime.
    pub vs_paired: Option<f64>,
    /// confirmed_per_runtime / baseline_per_runtime.
    pub vs_baseline: Option<f64>,
}

/// HF failures per unit of the trials' cost (HF + LF runs).
fn failures_per_runtime(lines: &[&TrialLine]) -> Option<f64> {
    let cost: f64 = lines
        .iter()
        .map(|l| l.hf.runtime + l.lf.map_or(0.0, |lf| lf.runtime))
        .sum();
    let failures = lines.iter().filter(|l| l.hf.failure).count();
    (cost > 0.0).then(|| failures as f64 / cost)
}

/// The screening report of the lines of one screening stage (None without any), against the
/// evaluation at the same budget and the meta-training baseline.
pub fn report(
    screened: &[&ScreenLine],
    evaluation: &[&TrialLine],
    baseline: &[&TrialLine],
    audit_fraction: f64,
) -> Option<Screening> {
    if screened.is_empty() {
        return None;
    }
    let mut counts = ScreeningCounts::default();
    for l in screened {
        counts.add(
            l.lf.map(|lf| lf.run()).as_ref(),
            l.hf.as_ref().map(|h| h.run()).as_ref(),
            l.screen,
        );
    }
    let confirmed_per_runtime = counts.confirmed_per_runtime();
    let paired_per_runtime = failures_per_runtime(evaluation);
    let baseline_per_runtime = failures_per_runtime(baseline);
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    };
    Some(Screening {
        counts,
        audit_fraction,
        miss_rate: Interval::wilson(counts.audit_misses, counts.audited),
        confirmed_share: Interval::wilson(counts.confirmed, counts.lf_failures),
        estimated_misses: counts.estimated_misses(),
        confirmed_per_runtime,
        paired_per_runtime,
        baseline_per_runtime,
        vs_paired: ratio(confirmed_per_runtime, paired_per_runtime),
        vs_baseline: ratio(confirmed_per_runtime, baseline_per_runtime),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::RunLine;
    use savme_kernel::screening::Screen;

    fn run(failure: bool, runtime: f64) -> RunLine {
        RunLine {
            failure,
            runtime,
            wall_seconds: runtime,
            work: None,
            robustness: None,
        }
    }

    fn screen(lf: RunLine, hf: Option<RunLine>, screen: Screen) -> ScreenLine {
        ScreenLine {
            stage: crate::StageId::new(crate::StageKind::Screen, Some(0.3)),
            index: 0,
            id: 0,
            budget: Some(0.3),
            scenario: "s".into(),
            phi: Default::default(),
            theta_lf: None,
            ladder: Vec::new(),
            screen,
            lf: Some(lf),
            hf,
            outcome: None,
        }
    }

    fn paired(hf: RunLine, lf: Option<RunLine>) -> TrialLine {
        TrialLine {
            stage: crate::StageId::new(crate::StageKind::Evaluate, Some(0.3)),
            index: 0,
            id: 0,
            phase: savme_kernel::Phase::Evaluate,
            budget: Some(0.3),
            scenario: "s".into(),
            phi: Default::default(),
            theta_lf: None,
            hf,
            lf,
            cost_ratio: None,
            outcome: None,
            credit: Default::default(),
        }
    }

    #[test]
    fn confirmed_failures_per_runtime_are_compared_with_paired_and_baseline() {
        // Screening: 2 confirmed of 3 LF failures, one audit that missed one; LF 0.2, HF 1.
        let s = [
            screen(run(true, 0.2), Some(run(true, 1.0)), Screen::Confirm),
            screen(run(true, 0.2), Some(run(true, 1.0)), Screen::Confirm),
            screen(run(true, 0.2), Some(run(false, 1.0)), Screen::Confirm),
            screen(run(false, 0.2), Some(run(true, 1.0)), Screen::Audit),
            screen(run(false, 0.2), None, Screen::Pass),
        ];
        // Paired: 2 HF failures in 4 trials of 1.2; baseline: 1 failure in 4 HF runs of 1.
        let e: Vec<TrialLine> = (0..4)
            .map(|i| paired(run(i < 2, 1.0), Some(run(i < 2, 0.2))))
            .collect();
        let b: Vec<TrialLine> = (0..4).map(|i| paired(run(i == 0, 1.0), None)).collect();
        let r = report(
            &s.iter().collect::<Vec<_>>(),
            &e.iter().collect::<Vec<_>>(),
            &b.iter().collect::<Vec<_>>(),
            0.1,
        )
        .unwrap();
        assert_eq!(r.counts.confirmed, 2);
        let screening = 2.0 / (5.0 * 0.2 + 4.0);
        assert!((r.confirmed_per_runtime.unwrap() - screening).abs() < 1e-12);
        assert!((r.vs_paired.unwrap() - screening / (2.0 / 4.8)).abs() < 1e-12);
        assert!((r.vs_baseline.unwrap() - screening / 0.25).abs() < 1e-12);
        let miss = r.miss_rate.unwrap();
        assert_eq!((miss.mean, miss.n), (1.0, 1));
        assert_eq!(r.estimated_misses, Some(2.0));
        assert!(report(&[], &[], &[], 0.1).is_none());
    }
}

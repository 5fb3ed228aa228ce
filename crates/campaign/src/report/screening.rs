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
    /// Per LF level the trials screened down, cheapest first (the stage's own budget last):
    /// one level for the two-level screening, one per budget of a fidelity ladder.
    pub levels: Vec<Level>,
}

/// One LF level of a screening stage: what its runs cost and flagged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Level {
    /// The level's budget (its meta-training's, whose θ_LF* it runs).
    pub budget: Option<f64>,
    /// LF runs made at this level.
    pub runs: u64,
    /// Of those, LF failures: sent up the ladder (HF after the last level).
    pub flagged: u64,
    /// Trials that passed this level by without running it (it did not pay; `direct` trials
    /// for the last level).
    pub skipped: u64,
    /// The cost of its runs.
    pub runtime: f64,
    /// Of its flagged runs, those whose trial ended with an HF failure.
    pub confirmed: u64,
}

/// Per level of the ladder (`budgets`, cheapest first), what the screened lines' LF runs
/// cost and flagged.
pub fn levels(screened: &[&ScreenLine], budgets: &[Option<f64>]) -> Vec<Level> {
    let mut out: Vec<Level> = budgets
        .iter()
        .map(|&budget| Level {
            budget,
            runs: 0,
            flagged: 0,
            skipped: 0,
            runtime: 0.0,
            confirmed: 0,
        })
        .collect();
    for l in screened {
        let runs = l.levels();
        let hf_failed = l.hf.is_some_and(|h| h.failure);
        for (i, level) in out.iter_mut().enumerate() {
            match runs.get(i).copied().flatten() {
                Some(r) => {
                    level.runs += 1;
                    level.runtime += r.runtime;
                    level.flagged += u64::from(r.failure);
                    level.confirmed += u64::from(r.failure && hf_failed);
                }
                None => {
                    // Reached (every run below it failed) and went on past it.
                    let below = runs.iter().take(i).flatten().all(|r| r.failure);
                    let above = runs.iter().skip(i + 1).flatten().next().is_some();
                    level.skipped += u64::from(below && (above || l.hf.is_some()));
                }
            }
        }
    }
    out
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
            l.lf_run().as_ref(),
            l.hf.as_ref().map(|h| h.run()).as_ref(),
            l.screen,
        );
    }
    let first = screened[0];
    let budgets: Vec<Option<f64>> = (first.ladder.iter().map(|r| Some(r.budget)))
        .chain([first.budget])
        .collect();
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
        levels: levels(screened, &budgets),
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
        // One level: its runs are the LF runs; the failures it flagged, 2 confirmed.
        let one = r.levels[0];
        assert_eq!((r.levels.len(), one.budget, one.runs), (1, Some(0.3), 5));
        assert_eq!((one.flagged, one.confirmed, one.skipped), (3, 2, 0));
    }

    #[test]
    fn a_ladders_levels_count_their_runs_what_they_flagged_and_what_passed_them_by() {
        let rung = |lf: Option<RunLine>| crate::log::RungLine {
            budget: 0.1,
            theta_lf: Default::default(),
            lf,
        };
        let on = |low: Option<RunLine>, top: Option<RunLine>, hf: Option<RunLine>| {
            let mut l = screen(run(false, 0.0), hf, Screen::Pass);
            l.ladder = vec![rung(low)];
            l.lf = top;
            l
        };
        let s = [
            // Flagged at 0.1, cleared at 0.3.
            on(Some(run(true, 0.1)), Some(run(false, 0.3)), None),
            // Flagged at both, confirmed on HF.
            on(
                Some(run(true, 0.1)),
                Some(run(true, 0.3)),
                Some(run(true, 1.0)),
            ),
            // Passed at 0.1: the top never ran, and was not skipped.
            on(Some(run(false, 0.1)), None, None),
            // 0.1 did not pay: straight to 0.3, which flagged a false alarm.
            on(None, Some(run(true, 0.3)), Some(run(false, 1.0))),
            // Neither paid: HF directly.
            on(None, None, Some(run(true, 1.0))),
        ];
        let lines: Vec<&ScreenLine> = s.iter().collect();
        let [low, top] = levels(&lines, &[Some(0.1), Some(0.3)])[..] else {
            panic!("two levels")
        };
        assert_eq!(
            (low.runs, low.flagged, low.confirmed, low.skipped),
            (3, 2, 1, 2)
        );
        assert_eq!(
            (top.runs, top.flagged, top.confirmed, top.skipped),
            (3, 2, 1, 1)
        );
        assert!((low.runtime - 0.3).abs() < 1e-12 && (top.runtime - 0.9).abs() < 1e-12);
        // The kernel is told the LF side as one run: the last verdict, every LF run's cost.
        let told = s[1].lf_run().unwrap();
        assert!(told.failure && (told.runtime - 0.4).abs() < 1e-12);
        assert!(s[4].lf_run().is_none());
        assert!((s[1].cost() - 1.4).abs() < 1e-12);
    }
}

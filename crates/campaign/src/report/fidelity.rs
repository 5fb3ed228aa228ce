//! What stands behind θ_LF* and the transferred prior of each budget, from the meta-training
//! trial lines alone: per fidelity setting, the chosen arm, how often meta-training tried it
//! and its false-alarm and miss rates on HF; the evaluation's own rates at θ_LF*; and the
//! strength of meta-testing's learned prior with the held-out likelihood of every candidate
//! (issue 37). `kernels.rs` computes the transfer from the same lines with the same function,
//! so the report says exactly what the campaign used.

use super::stage_lines;
use crate::log::TrialLine;
use crate::protocol::{Protocol, StageKind, ThetaLfChoice, Transfer};
use savme_kernel::evidence::{choose_strengths, ArmTally, FidelityEvidence, TransferChoice};
use savme_kernel::{Outcome, PriorCounts, Space};
use serde::Serialize;

/// The arm θ_LF* used for one fidelity setting and what meta-training showed about it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChosenSetting {
    /// The fidelity setting.
    pub variable: String,
    /// The arm (value or bin index) θ_LF* used.
    pub arm: usize,
    /// Its meta-training tally (paired trials that credited the fidelity bandit).
    #[serde(flatten)]
    pub tally: ArmTally,
    /// FP / (FP + TN) of those trials; None without an HF pass.
    pub false_alarm_rate: Option<f64>,
    /// FN / (TP + FN); None without an HF failure.
    pub miss_rate: Option<f64>,
}

/// θ_LF* at one budget on the evaluation's own trials (all settings together).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct JointRates {
    /// Evaluation trials.
    pub trials: u64,
    /// FP / (FP + TN); None without an HF pass.
    pub false_alarm_rate: Option<f64>,
    /// FN / (TP + FN); None without an HF failure.
    pub miss_rate: Option<f64>,
}

/// How meta-testing's learned prior was weighted at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransferReport {
    /// fixed or auto.
    pub mode: Transfer,
    /// The strength per fidelity setting (space order) the `test-learned` stage used.
    pub strengths: Vec<f64>,
    /// Leave-one-scenario-out on the meta-training scenarios (None with fewer than two
    /// training scenarios with evidence: auto then transfers nothing, strength 0).
    pub choice: Option<TransferChoice>,
}

/// θ_LF* and the transfer of one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FidelityReport {
    /// How θ_LF* was chosen.
    pub choice: ThetaLfChoice,
    /// Per fidelity setting, in space order (empty until the evaluation ran).
    pub settings: Vec<ChosenSetting>,
    /// θ_LF* on the evaluation trials (None until the evaluation ran).
    pub evaluation: Option<JointRates>,
    /// The learned prior's strength.
    pub transfer: TransferReport,
}

/// The meta-training evidence of budget `budget` from its `train@budget` lines: per training
/// scenario (protocol order), per fidelity arm.
pub fn evidence(p: &Protocol, lines: &[&TrialLine], space: &Space) -> FidelityEvidence {
    let mut e = FidelityEvidence::new(p.train_scenarios.len(), space);
    for l in lines {
        let (Some(theta), Some(ok), Some(o), Some(r)) =
            (&l.theta_lf, l.credit.fidelity, l.outcome, l.cost_ratio)
        else {
            continue;
        };
        let (Some(s), Ok(arms)) = (
            p.train_scenarios.iter().position(|n| *n == l.scenario),
            space.arms_of(theta),
        ) else {
            continue;
        };
        let arms: Vec<u16> = arms.into_iter().map(|a| a as u16).collect();
        e.record(s, &arms, o, ok, r);
    }
    e
}

/// The `train@budget` lines of `lines`.
pub fn train_lines<'a>(p: &Protocol, lines: &'a [TrialLine], budget: f64) -> Vec<&'a TrialLine> {
    stage_lines(lines, &super::stage_of(p, StageKind::Train, Some(budget)))
}

/// The transfer of budget `budget`: the strengths `test-learned` uses (fixed: the protocol's
/// `prior_strength` for every setting; auto: [`choose_strengths`] on the meta-training
/// evidence among [`STRENGTHS`](savme_kernel::evidence::STRENGTHS) × `prior_strength`, 0 where
/// it cannot choose).
pub fn transfer(p: &Protocol, train: &[&TrialLine], space: &Space) -> TransferReport {
    let candidates = savme_kernel::evidence::STRENGTHS.map(|c| c * p.prior_strength);
    let choice = choose_strengths(
        &evidence(p, train, space),
        space,
        PriorCounts::UNIFORM,
        &candidates,
    );
    let strengths = match (p.transfer, &choice) {
        (Transfer::Fixed, _) => vec![p.prior_strength; space.len()],
        (Transfer::Auto, Some(c)) => c.strengths(),
        (Transfer::Auto, None) => vec![0.0; space.len()],
    };
    TransferReport {
        mode: p.transfer,
        strengths,
        choice,
    }
}

/// The report of one budget from the campaign's lines.
pub fn at_budget(p: &Protocol, lines: &[TrialLine], budget: f64, space: &Space) -> FidelityReport {
    let train = train_lines(p, lines, budget);
    let eval = stage_lines(
        lines,
        &super::stage_of(p, StageKind::Evaluate, Some(budget)),
    );
    let totals = evidence(p, &train, space).totals();
    let chosen = eval
        .first()
        .and_then(|l| l.theta_lf.as_ref())
        .and_then(|t| space.arms_of(t).ok());
    let settings = chosen
        .map(|arms| {
            space
                .variables()
                .iter()
                .zip(arms)
                .enumerate()
                .map(|(v, (var, arm))| {
                    let tally = totals
                        .get(v)
                        .and_then(|t| t.get(arm))
                        .copied()
                        .unwrap_or_default();
                    ChosenSetting {
                        variable: var.name.to_string(),
                        arm,
                        false_alarm_rate: tally.false_alarm_rate(),
                        miss_rate: tally.miss_rate(),
                        tally,
                    }
                })
                .collect()
        })
        .unwrap_or_default();
    let evaluation = (!eval.is_empty()).then(|| {
        let mut t = ArmTally::default();
        for l in &eval {
            if let Some(o) = l.outcome {
                t.add(o, matches!(o, Outcome::TP | Outcome::TN), 0.0);
            }
        }
        JointRates {
            trials: eval.len() as u64,
            false_alarm_rate: t.false_alarm_rate(),
            miss_rate: t.miss_rate(),
        }
    });
    FidelityReport {
        choice: p.theta_lf_choice,
        settings,
        evaluation,
        transfer: transfer(p, &train, space),
    }
}

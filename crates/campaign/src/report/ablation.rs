//! The prior-strength ablation of meta-testing: for each strength of the transferred fidelity
//! prior (0 = the uniform prior, the protocol's `prior_strength` = the learned prior unless
//! `transfer = auto` chooses the strengths, and every other listed strength its own stage), the failures found by a common runtime horizon.

use super::{curve_as, paired_stats, stage_lines, TrialLine};
use crate::protocol::{Protocol, Stage, StageId, StageKind};
use savme_kernel::metrics::Accounting;
use serde::Serialize;

/// One strength of the transferred prior at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StrengthRow {
    /// The power-prior strength (0: uniform prior).
    pub strength: f64,
    /// Failures found by the common horizon, every run charged (HF failures).
    pub all_runs: u64,
    /// Failures found by the common LF-only horizon (TP, only LF runs charged).
    pub lf_only: u64,
    /// all_runs / the uniform prior's − 1 (None if the uniform prior found none).
    pub gain_all_runs: Option<f64>,
    /// lf_only / the uniform prior's − 1.
    pub gain_lf_only: Option<f64>,
    /// Mean t_LF / t_HF of the stage.
    pub mean_lf_cost: f64,
}

/// The ablation at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Ablation {
    /// The smallest total cost (every run charged) of the strengths' stages.
    pub horizon_all_runs: f64,
    /// The smallest total LF cost.
    pub horizon_lf_only: f64,
    /// One row per strength, in the protocol's order.
    pub rows: Vec<StrengthRow>,
}

/// The stage of meta-testing with prior strength `s` at budget `b`.
pub fn stage_id(p: &Protocol, b: f64, s: f64) -> StageId {
    let (kind, strength) = if s == 0.0 {
        (StageKind::TestUniform, None)
    } else if s == p.prior_strength && p.transfer == crate::protocol::Transfer::Fixed {
        (StageKind::TestLearned, None)
    } else {
        (StageKind::TestLearned, Some(s))
    };
    StageId {
        kind,
        budget: Some(b),
        strength,
    }
}

/// The ablation at budget `b` (None without `prior_strengths`, or before every stage ran).
pub fn at_budget(p: &Protocol, lines: &[TrialLine], b: f64) -> Option<Ablation> {
    if p.prior_strengths.is_empty() {
        return None;
    }
    let stages: Vec<Vec<&TrialLine>> = p
        .prior_strengths
        .iter()
        .map(|&s| {
            let id = stage_id(p, b, s);
            lines.iter().filter(|l| l.stage == id).collect()
        })
        .collect();
    if stages.iter().any(Vec::is_empty) {
        return None;
    }
    let uniform = stage_lines(
        lines,
        &Stage {
            kind: StageKind::TestUniform,
            budget: Some(b),
            iterations: 0,
            strength: None,
            spend: None,
        },
    );
    let found = |acc: Accounting| {
        let curves: Vec<_> = stages.iter().map(|s| curve_as(s, acc)).collect();
        let uniform = curve_as(&uniform, acc);
        let horizon = curves
            .iter()
            .chain([&uniform])
            .map(|c| c.end())
            .fold(f64::INFINITY, f64::min);
        let counts: Vec<u64> = curves.iter().map(|c| c.failures_at(horizon)).collect();
        (horizon, counts, uniform.failures_at(horizon))
    };
    let (h_all, all, u_all) = found(Accounting::AllRuns);
    let (h_lf, lf, u_lf) = found(Accounting::LfOnly);
    let gain = |a: u64, u: u64| (u > 0).then(|| a as f64 / u as f64 - 1.0);
    let rows = p
        .prior_strengths
        .iter()
        .enumerate()
        .map(|(i, &strength)| {
            let (_, ratio) = paired_stats(&stages[i]);
            StrengthRow {
                strength,
                all_runs: all[i],
                lf_only: lf[i],
                gain_all_runs: gain(all[i], u_all),
                gain_lf_only: gain(lf[i], u_lf),
                mean_lf_cost: ratio / stages[i].len() as f64,
            }
        })
        .collect();
    Some(Ablation {
        horizon_all_runs: h_all,
        horizon_lf_only: h_lf,
        rows,
    })
}

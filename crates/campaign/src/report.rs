//! What a campaign found, computed from its trials alone (so that every output can be checked
//! against `trials.jsonl`): the paper's Table III and Table IV, break-even times and the
//! meta-testing gain.

use super::log::{self, TrialLine};
use super::protocol::{Protocol, Stage, StageKind};
use savme_kernel::metrics::{break_even, speedup, Accounting, FailureCurve};
use savme_kernel::{Assignment, Outcome};
use serde::Serialize;

pub mod ablation;
pub mod failures;
pub mod fidelity;
pub mod intervals;
pub mod repeated;
pub mod screening;
mod text;

pub use text::{
    format_cost, format_probability, format_seconds, IDEAL_READS, IDEAL_SIMULATOR, TABLE_III_LEGEND,
};

/// Failure counts of an HF-only baseline stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Baseline {
    /// Trials.
    pub trials: u64,
    /// Trials whose HF run failed.
    pub failures: u64,
    /// failures / trials.
    pub failure_rate: f64,
    /// Sum of the HF costs.
    pub runtime: f64,
}

/// The evaluation of one budget (a row of Table III).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// Trials.
    pub trials: u64,
    /// TP / trials: failures the LF simulator alone would have found.
    pub tp_rate: f64,
    /// Mean t_LF / t_HF.
    pub mean_lf_cost: f64,
    /// (TP-rate / mean LF cost) / baseline failure rate; None if undefined.
    pub speedup: Option<f64>,
    /// Counts per class: TP, TN, FP, FN.
    pub tp: u64,
    /// Both runs passed.
    pub tn: u64,
    /// Only the LF run failed.
    pub fp: u64,
    /// Only the HF run failed (`fn` in JSON).
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// The learned fidelity θ_LF* (the evaluation's θ_LF).
    pub theta_star: Option<Assignment>,
}

/// Meta-training at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Training {
    /// Trials.
    pub trials: u64,
    /// Trials whose HF run failed.
    pub hf_failures: u64,
    /// TP-rate over the training trials.
    pub tp_rate: f64,
    /// Mean t_LF / t_HF over the training trials.
    pub mean_lf_cost: f64,
    /// Cost of all runs (HF + LF).
    pub runtime: f64,
    /// The cost from which on meta-training has found more failures than the baseline (both
    /// charged for every run they made); None if not reached within the shorter of the two.
    pub break_even: Option<f64>,
}

/// Failures found by the learned prior, the uniform prior and the baseline by a common cost
/// horizon, under one accounting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FoundByHorizon {
    /// The horizon: the smallest total cost of the three runs compared.
    pub horizon: f64,
    /// Failures found with the meta-training posterior as the fidelity prior.
    pub learned: u64,
    /// Failures found with a uniform fidelity prior.
    pub uniform: u64,
    /// Failures found by the baseline (uniform φ, HF only).
    pub baseline: u64,
    /// learned / uniform − 1; None if the uniform prior found none.
    pub gain_vs_uniform: Option<f64>,
    /// learned / baseline − 1; None if the baseline found none.
    pub gain_vs_baseline: Option<f64>,
}

/// Meta-testing at one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetaTesting {
    /// Every run charged (HF + LF), a failure found when the HF run fails: meta-testing as it
    /// runs. This is what `meta_testing.png` shows.
    pub all_runs: FoundByHorizon,
    /// Only the LF runs charged, a failure found when the LF run finds a true one (TP): the
    /// failures the learned-fidelity simulator itself finds per LF runtime.
    pub lf_only: FoundByHorizon,
    /// LF screening with HF confirmation (no audit) as the deployment-realistic accounting:
    /// the LF run charged, the HF run only to confirm an LF failure; a failure is found when
    /// the HF run confirms it (TP).
    pub screened: FoundByHorizon,
    /// Total cost of the learned-prior and uniform-prior runs.
    pub learned_runtime: f64,
    /// See `learned_runtime`.
    pub uniform_runtime: f64,
}

/// Everything about one budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BudgetReport {
    /// C_budget.
    pub budget: f64,
    /// Meta-training (None until it ran).
    pub training: Option<Training>,
    /// Evaluation (None until it ran).
    pub evaluation: Option<Evaluation>,
    /// Meta-testing (None until it ran).
    pub meta_testing: Option<MetaTesting>,
    /// The prior-strength ablation (None without `prior_strengths`, or until it ran).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ablation: Option<ablation::Ablation>,
    /// LF screening with HF confirmation (None without a screening stage, or until it ran).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub screening: Option<screening::Screening>,
    /// What stands behind θ_LF* (per setting: tries, false-alarm and miss rates) and the
    /// learned prior's strength (None until the campaign's outputs are written).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fidelity: Option<fidelity::FidelityReport>,
}

/// The campaign's results.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The protocol.
    pub protocol: Protocol,
    /// Baseline on the meta-training scenarios.
    pub baseline_train: Option<Baseline>,
    /// Baseline on the meta-testing scenarios.
    pub baseline_test: Option<Baseline>,
    /// Per budget.
    pub budgets: Vec<BudgetReport>,
}

fn stage_lines<'a>(lines: &'a [TrialLine], stage: &Stage) -> Vec<&'a TrialLine> {
    let id = stage.id();
    lines.iter().filter(|l| l.stage == id).collect()
}

fn stage_of(p: &Protocol, kind: StageKind, budget: Option<f64>) -> Stage {
    p.stages()
        .into_iter()
        .find(|s| s.kind == kind && s.budget == budget)
        .unwrap_or(Stage {
            kind,
            budget,
            iterations: 0,
            strength: None,
            spend: None,
        })
}

/// Found failures over cost, every run charged (HF + LF for paired trials).
pub fn curve(lines: &[&TrialLine]) -> FailureCurve {
    curve_as(lines, Accounting::AllRuns)
}

/// Found failures over cost under `accounting` (HF-only trials: their HF run either way).
pub fn curve_as(lines: &[&TrialLine], accounting: Accounting) -> FailureCurve {
    let mut c = FailureCurve::new();
    for l in lines {
        let (cost, found) = match (accounting, l.lf) {
            (_, None) => (l.hf.runtime, l.hf.failure),
            (Accounting::AllRuns, Some(lf)) => (l.hf.runtime + lf.runtime, l.hf.failure),
            (Accounting::LfOnly, Some(lf)) => (lf.runtime, l.hf.failure && lf.failure),
            (Accounting::Screened, Some(lf)) => (
                lf.runtime + if lf.failure { l.hf.runtime } else { 0.0 },
                l.hf.failure && lf.failure,
            ),
        };
        c.push(cost, found);
    }
    c
}

/// Found failures of three runs by the smallest of their total costs.
fn found_by_horizon(
    learned: &[&TrialLine],
    uniform: &[&TrialLine],
    base: &[&TrialLine],
    accounting: Accounting,
) -> FoundByHorizon {
    let (lc, uc, bc) = (
        curve_as(learned, accounting),
        curve_as(uniform, accounting),
        curve_as(base, accounting),
    );
    let mut horizon = lc.end().min(uc.end());
    if !base.is_empty() {
        horizon = horizon.min(bc.end());
    }
    let (l, u, b) = (
        lc.failures_at(horizon),
        uc.failures_at(horizon),
        bc.failures_at(horizon),
    );
    let gain = |a: u64, b: u64| (b > 0).then(|| a as f64 / b as f64 - 1.0);
    FoundByHorizon {
        horizon,
        learned: l,
        uniform: u,
        baseline: b,
        gain_vs_uniform: gain(l, u),
        gain_vs_baseline: gain(l, b),
    }
}

fn baseline(lines: &[&TrialLine]) -> Option<Baseline> {
    if lines.is_empty() {
        return None;
    }
    let failures = lines.iter().filter(|l| l.hf.failure).count() as u64;
    Some(Baseline {
        trials: lines.len() as u64,
        failures,
        failure_rate: failures as f64 / lines.len() as f64,
        runtime: lines.iter().map(|l| l.hf.runtime).sum(),
    })
}

fn paired_stats(lines: &[&TrialLine]) -> ([u64; 4], f64) {
    let mut counts = [0u64; 4];
    let mut ratio = 0.0;
    for l in lines {
        match l.outcome {
            Some(Outcome::TP) => counts[0] += 1,
            Some(Outcome::TN) => counts[1] += 1,
            Some(Outcome::FP) => counts[2] += 1,
            Some(Outcome::FN) => counts[3] += 1,
            None => {}
        }
        ratio += l.cost_ratio.unwrap_or(0.0);
    }
    (counts, ratio)
}

/// A meta-training stage's counts, with its break-even against the baseline's curve (if the
/// baseline ran); None without trials.
fn training(train: &[&TrialLine], baseline: Option<&FailureCurve>) -> Option<Training> {
    if train.is_empty() {
        return None;
    }
    let (c, ratio) = paired_stats(train);
    let n = train.len() as f64;
    let tc = curve(train);
    Some(Training {
        trials: train.len() as u64,
        hf_failures: train.iter().filter(|l| l.hf.failure).count() as u64,
        tp_rate: c[0] as f64 / n,
        mean_lf_cost: ratio / n,
        runtime: tc.end(),
        break_even: baseline.and_then(|base| break_even(&tc, base)),
    })
}

/// An evaluation stage's Table III row and θ_LF*; None without trials.
fn evaluation(eval: &[&TrialLine], baseline_train: Option<Baseline>) -> Option<Evaluation> {
    let first = eval.first()?;
    let (c, ratio) = paired_stats(eval);
    let n = eval.len() as f64;
    let (tp_rate, mean_lf_cost) = (c[0] as f64 / n, ratio / n);
    Some(Evaluation {
        trials: eval.len() as u64,
        tp_rate,
        mean_lf_cost,
        speedup: baseline_train.and_then(|base| speedup(tp_rate, mean_lf_cost, base.failure_rate)),
        tp: c[0],
        tn: c[1],
        fp: c[2],
        fn_: c[3],
        theta_star: first.theta_lf.clone(),
    })
}

/// Meta-testing with the learned against the uniform prior (and the baseline) under each
/// accounting; None unless both priors ran.
fn meta_testing(
    learned: &[&TrialLine],
    uniform: &[&TrialLine],
    base_test: &[&TrialLine],
) -> Option<MetaTesting> {
    if learned.is_empty() || uniform.is_empty() {
        return None;
    }
    let by = |accounting| found_by_horizon(learned, uniform, base_test, accounting);
    Some(MetaTesting {
        all_runs: by(Accounting::AllRuns),
        lf_only: by(Accounting::LfOnly),
        screened: by(Accounting::Screened),
        learned_runtime: curve(learned).end(),
        uniform_runtime: curve(uniform).end(),
    })
}

impl Report {
    /// The report of `lines` (all trials of a campaign run with `protocol`, possibly
    /// incomplete: stages without trials are left out).
    pub fn from_trials(protocol: &Protocol, lines: &[TrialLine]) -> Report {
        let get = |kind, budget| stage_lines(lines, &stage_of(protocol, kind, budget));
        let base_train = get(StageKind::BaselineTrain, None);
        let base_test = get(StageKind::BaselineTest, None);
        let baseline_train = baseline(&base_train);
        let baseline_test = baseline(&base_test);
        let base_curve = curve(&base_train);
        let budgets = protocol
            .budgets
            .iter()
            .map(|&b| {
                let train = get(StageKind::Train, Some(b));
                let eval = get(StageKind::Evaluate, Some(b));
                let learned = get(StageKind::TestLearned, Some(b));
                let uniform = get(StageKind::TestUniform, Some(b));
                let base = (!base_train.is_empty()).then_some(&base_curve);
                BudgetReport {
                    budget: b,
                    training: training(&train, base),
                    evaluation: evaluation(&eval, baseline_train),
                    meta_testing: meta_testing(&learned, &uniform, &base_test),
                    ablation: ablation::at_budget(protocol, lines, b),
                    screening: None,
                    fidelity: None,
                }
            })
            .collect();
        Report {
            protocol: protocol.clone(),
            baseline_train,
            baseline_test,
            budgets,
        }
    }

    /// Adds, per budget that meta-trained, what stands behind θ_LF* and the learned priors
    /// ([`fidelity::at_budget`]; `problem` binned as the campaign ran it; `trials`: every trial
    /// of the campaign).
    pub fn add_fidelity(&mut self, problem: &crate::Problem, trials: &[TrialLine]) {
        let p = &self.protocol;
        for b in &mut self.budgets {
            if b.training.is_some() {
                b.fidelity = Some(fidelity::at_budget(p, trials, b.budget, problem));
            }
        }
    }

    /// Adds the screening stages' results (`screened`: their lines; `trials`: every other
    /// trial of the campaign, for the paired evaluation and the baseline it is compared with).
    pub fn add_screening(&mut self, screened: &[log::ScreenLine], trials: &[TrialLine]) {
        let p = &self.protocol;
        let base = stage_lines(trials, &stage_of(p, StageKind::BaselineTrain, None));
        for b in &mut self.budgets {
            let id = stage_of(p, StageKind::Screen, Some(b.budget)).id();
            let lines: Vec<&log::ScreenLine> = screened.iter().filter(|l| l.stage == id).collect();
            let eval = stage_lines(trials, &stage_of(p, StageKind::Evaluate, Some(b.budget)));
            b.screening = screening::report(&lines, &eval, &base, p.audit_fraction);
        }
    }
}

//! What stands behind θ_LF* and the transferred prior of each budget, from the meta-training
//! trial lines alone: per fidelity setting, the chosen arm, how often meta-training tried it
//! and its false-alarm and miss rates on HF; the evaluation's own rates at θ_LF*; and the
//! strength of meta-testing's learned prior with the held-out likelihood of every candidate
//! (issue 37); and the φ (p_ψ) transfer to each meta-testing scenario where it shares φ
//! variables with training scenarios. `kernels.rs` computes both transfers from the same lines
//! with the same functions, so the report says exactly what the campaign used.

use super::stage_lines;
use crate::log::TrialLine;
use crate::protocol::{LadderTraining, Protocol, StageKind, ThetaLfChoice, Transfer};
use crate::Problem;
use savme_kernel::evidence::{choose_strengths, ArmTally, FidelityEvidence, TransferChoice};
use savme_kernel::phi_transfer::{choose_phi_transfer, PhiTransfer, TrainingScenario};
use savme_kernel::{Outcome, Posterior, PriorCounts, Space};
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
    /// The φ (p_ψ) transfer to each meta-testing scenario, in protocol order.
    pub phi: Vec<ScenarioPhiTransfer>,
}

/// The φ (p_ψ) transfer to one meta-testing scenario: per φ variable, the training scenarios
/// that share it (same name and domain) and the strength chosen by leave-one-scenario-out on
/// them ([`choose_phi_transfer`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioPhiTransfer {
    /// The meta-testing scenario.
    pub scenario: String,
    /// Whether its `test-learned` stage started p_ψ from the transfer (`transfer = auto` and a
    /// strength above 0 somewhere); with `fixed`, what auto would choose, unused.
    pub used: bool,
    /// The choice.
    #[serde(flatten)]
    pub transfer: PhiTransfer,
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
    /// With `ladder_training = shared` at the ladder's top budget: each level below, cheapest
    /// first, with the θ_LF* read off this budget's meta-training ([`shared_level_theta`]);
    /// empty otherwise (and left out of the JSON).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub shared_levels: Vec<SharedLevel>,
}

/// A level of a shared ladder below its top and the θ_LF* it screens with.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SharedLevel {
    /// The level's budget.
    pub budget: f64,
    /// Its θ_LF*.
    pub theta_lf: savme_kernel::Assignment,
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

/// θ_LF* of a level below the top of a shared ladder (`ladder_training = shared`): the
/// protocol's choice (MAP, or evidence with every false alarm charged at the level's budget) on
/// the top level's `train@top` lines `train`, every paired trial that credited p_ω re-credited
/// at `level` (Table I: a success when HF and LF agree and t_LF / t_HF ≤ `level`), from the
/// uniform prior — what a kernel meta-trained at `level` on those same trials would choose.
pub fn shared_level_theta(
    p: &Protocol,
    train: &[&TrialLine],
    space: &Space,
    level: f64,
) -> savme_kernel::Assignment {
    let mut posterior =
        Posterior::new(space, PriorCounts::UNIFORM).expect("the uniform prior is valid");
    let mut tallies = FidelityEvidence::new(1, space);
    for l in train {
        let (Some(theta), Some(_), Some(o), Some(r)) =
            (&l.theta_lf, l.credit.fidelity, l.outcome, l.cost_ratio)
        else {
            continue;
        };
        let Ok(arms) = space.arms_of(theta) else {
            continue;
        };
        let arms: Vec<u16> = arms.into_iter().map(|a| a as u16).collect();
        let success = o.fidelity_success(r, level);
        posterior.update(&arms, success);
        tallies.record(0, &arms, o, success, r);
    }
    let arms = match p.theta_lf_choice {
        ThetaLfChoice::Map => posterior.best_arms(savme_kernel::Estimator::Map),
        ThetaLfChoice::Evidence => {
            let totals = tallies.totals();
            posterior.best_arms_by(|v, k, a| {
                savme_kernel::evidence::evidence_score(a, &totals[v][k], level)
            })
        }
    };
    space
        .variables()
        .iter()
        .zip(arms)
        .fold(savme_kernel::Assignment::new(), |a, (var, arm)| {
            a.with(&var.name, var.representative(usize::from(arm)))
        })
}

/// The `train@budget` lines of `lines`.
pub fn train_lines<'a>(p: &Protocol, lines: &'a [TrialLine], budget: f64) -> Vec<&'a TrialLine> {
    stage_lines(lines, &super::stage_of(p, StageKind::Train, Some(budget)))
}

/// The candidate strengths of both transfers: [`STRENGTHS`](savme_kernel::evidence::STRENGTHS)
/// × `prior_strength`.
fn candidates(p: &Protocol) -> [f64; 6] {
    savme_kernel::evidence::STRENGTHS.map(|c| c * p.prior_strength)
}

/// p_ψ of every training scenario after meta-training, rebuilt from the `train@budget` lines
/// `train` as the kernel built it (every line whose trial credited p_ψ, at its φ's arms), in
/// protocol order, with the scenario's space; a scenario `problem` lacks is left out.
pub fn trained_phi(
    p: &Protocol,
    train: &[&TrialLine],
    problem: &Problem,
) -> Vec<(String, Space, Posterior)> {
    p.train_scenarios
        .iter()
        .filter_map(|name| {
            let space = problem.scenarios.get(name)?;
            let mut post = Posterior::new(space, PriorCounts::UNIFORM).ok()?;
            for l in train.iter().filter(|l| l.scenario == *name) {
                let (Some(found), Ok(arms)) = (l.credit.scenario, space.arms_of(&l.phi)) else {
                    continue;
                };
                let arms: Vec<u16> = arms.into_iter().map(|a| a as u16).collect();
                post.update(&arms, found);
            }
            Some((name.clone(), space.clone(), post))
        })
        .collect()
}

/// The φ transfer of budget `budget` to every meta-testing scenario (`train`: its
/// `train@budget` lines): per φ variable shared with training scenarios, the strength chosen
/// by leave-one-scenario-out ([`choose_phi_transfer`], the candidates of the fidelity
/// transfer); used with `transfer = auto` only.
pub fn phi_transfer(
    p: &Protocol,
    train: &[&TrialLine],
    problem: &Problem,
) -> Vec<ScenarioPhiTransfer> {
    let trained = trained_phi(p, train, problem);
    let training: Vec<TrainingScenario<'_>> = trained
        .iter()
        .map(|(name, space, posterior)| TrainingScenario {
            name,
            space,
            posterior,
        })
        .collect();
    p.test_scenarios
        .iter()
        .filter_map(|name| {
            let space = problem.scenarios.get(name)?;
            let transfer =
                choose_phi_transfer(space, &training, PriorCounts::UNIFORM, &candidates(p));
            Some(ScenarioPhiTransfer {
                scenario: name.clone(),
                used: p.transfer == Transfer::Auto && transfer.transfers(),
                transfer,
            })
        })
        .collect()
}

/// The φ priors of budget `budget`'s `test-learned` stage: per meta-testing scenario whose
/// transfer is used, its prior ([`PhiTransfer::prior`]).
pub fn phi_priors(
    p: &Protocol,
    train: &[&TrialLine],
    problem: &Problem,
) -> Result<Vec<(String, Posterior)>, savme_kernel::PosteriorError> {
    let trained = trained_phi(p, train, problem);
    let training: Vec<TrainingScenario<'_>> = trained
        .iter()
        .map(|(name, space, posterior)| TrainingScenario {
            name,
            space,
            posterior,
        })
        .collect();
    let mut priors = Vec::new();
    for t in phi_transfer(p, train, problem)
        .into_iter()
        .filter(|t| t.used)
    {
        let Some(space) = problem.scenarios.get(&t.scenario) else {
            continue;
        };
        if let Some(prior) = t.transfer.prior(space, &training, PriorCounts::UNIFORM)? {
            priors.push((t.scenario, prior));
        }
    }
    Ok(priors)
}

/// The transfer of budget `budget`: the strengths `test-learned` uses (fixed: the protocol's
/// `prior_strength` for every setting; auto: [`choose_strengths`] on the meta-training
/// evidence among [`STRENGTHS`](savme_kernel::evidence::STRENGTHS) × `prior_strength`, 0 where
/// it cannot choose).
pub fn transfer(p: &Protocol, train: &[&TrialLine], problem: &Problem) -> TransferReport {
    let space = &problem.fidelity;
    let choice = choose_strengths(
        &evidence(p, train, space),
        space,
        PriorCounts::UNIFORM,
        &candidates(p),
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
        phi: phi_transfer(p, train, problem),
    }
}

/// The report of one budget from the campaign's lines (`problem` binned as the campaign ran
/// it).
pub fn at_budget(
    p: &Protocol,
    lines: &[TrialLine],
    budget: f64,
    problem: &Problem,
) -> FidelityReport {
    let space = &problem.fidelity;
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
    let mut levels = p.levels(budget);
    levels.pop();
    let shared_levels = match p.ladder_training {
        LadderTraining::Shared => levels
            .into_iter()
            .map(|l| SharedLevel {
                budget: l,
                theta_lf: shared_level_theta(p, &train, space, l),
            })
            .collect(),
        LadderTraining::Separate => Vec::new(),
    };
    FidelityReport {
        choice: p.theta_lf_choice,
        settings,
        evaluation,
        transfer: transfer(p, &train, problem),
        shared_levels,
    }
}

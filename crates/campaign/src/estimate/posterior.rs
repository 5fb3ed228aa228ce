//! The trained posteriors p_ψ(φ | s) of a finished campaign, rebuilt from its trial lines.

use super::{EstimateError, EstimateSettings};
use crate::protocol::{StageId, StageKind};
use crate::{CampaignError, Problem, Protocol};
use savme_kernel::{Posterior, PriorCounts, Scenario};
use std::collections::BTreeMap;
use std::sync::Arc;

/// What the estimate's proposal is built from.
pub(crate) struct Trained {
    /// Each estimated scenario with its weight p(s) and its learned posterior.
    pub scenarios: Vec<(Scenario, Posterior)>,
    /// The stage whose trials taught each scenario (`train@b`, or `test-learned@b` for a
    /// meta-testing scenario).
    pub stages: BTreeMap<String, String>,
    /// Told trials (one HF run each) of the stages used, all their scenarios.
    pub stage_runs: u64,
    /// Told trials of the estimated scenarios in those stages.
    pub scenario_runs: u64,
    /// θ_LF* at the budget (the evaluation stage's θ_LF), for an LF pilot; None when the
    /// estimate does not need it.
    pub theta_lf: Option<savme_kernel::Assignment>,
}

/// The campaign's learned θ_LF* at `budget`: the θ_LF of its evaluation stage (which runs
/// θ_LF* on every trial). Refused, naming the stage, when that stage has no such trial.
fn learned_theta(
    campaign: &str,
    lines: Lines<'_>,
    budget: f64,
) -> Result<savme_kernel::Assignment, EstimateError> {
    let stage = StageId::new(StageKind::Evaluate, Some(budget));
    lines
        .1
        .iter()
        .filter_map(|(_, l)| l.trial())
        .find(|t| t.stage == stage && t.theta_lf.is_some())
        .and_then(|t| t.theta_lf.clone())
        .ok_or_else(|| EstimateError::NoLearnedFidelity {
            campaign: campaign.to_string(),
            budget,
            stage: stage.to_string(),
        })
}

/// The trial lines of a campaign with the name of their store (for errors).
type Lines<'a> = (&'a str, &'a [(u64, crate::log::LogLine)]);

/// Per scenario, the stage that taught it and how many trials that stage tells.
type Stages = BTreeMap<String, (StageId, u64)>;

/// Rebuilds the posteriors at `budget` from the campaign's `trials.jsonl`: every learning
/// trial's logged scenario credit, on the kernels' uniform prior (exactly the kernel's update).
pub(crate) fn trained(
    campaign: &str,
    lines: Lines<'_>,
    protocol: &Protocol,
    problem: &Problem,
    budget: f64,
    settings: &EstimateSettings,
) -> Result<Trained, EstimateError> {
    let names = if settings.scenarios.is_empty() {
        protocol.train_scenarios.clone()
    } else {
        settings.scenarios.clone()
    };
    let stages = learning_stages(protocol, budget, &names)?;
    let told_in = |stage: &StageId| {
        lines
            .1
            .iter()
            .filter(|(_, l)| l.stage() == *stage && l.is_told())
            .count() as u64
    };
    for (stage, needed) in stages.values() {
        let told = told_in(stage);
        if told < *needed {
            return Err(EstimateError::NotTrained {
                campaign: campaign.to_string(),
                stage: stage.to_string(),
                told,
                needed: *needed,
            });
        }
    }
    let mut scenarios = untrained(&names, protocol, problem)?;
    let mut scenario_runs = 0;
    for (scenario, posterior) in &mut scenarios {
        scenario_runs += learn(scenario, posterior, &stages[&*scenario.name].0, lines)?;
    }
    let mut used: Vec<StageId> = Vec::new();
    for (s, _) in stages.values() {
        if !used.contains(s) {
            used.push(*s);
        }
    }
    let theta_lf = if settings.uses_lf() {
        Some(learned_theta(campaign, lines, budget)?)
    } else {
        None
    };
    Ok(Trained {
        theta_lf,
        stage_runs: used.iter().map(told_in).sum(),
        scenario_runs,
        stages: stages
            .into_iter()
            .map(|(n, (s, _))| (n, s.to_string()))
            .collect(),
        scenarios,
    })
}

/// The stage that taught each of `names` at `budget` (`train@b` for a meta-training scenario,
/// `test-learned@b` for a meta-testing one) and its iterations; an unknown budget or scenario
/// is refused, listing the known ones.
fn learning_stages(
    protocol: &Protocol,
    budget: f64,
    names: &[String],
) -> Result<Stages, EstimateError> {
    if !protocol.budgets.contains(&budget) {
        let known: Vec<String> = protocol.budgets.iter().map(f64::to_string).collect();
        return Err(EstimateError::UnknownBudget {
            budget,
            known: known.join(", "),
        });
    }
    let train = StageId::new(StageKind::Train, Some(budget));
    let test = StageId::new(StageKind::TestLearned, Some(budget));
    let learned_in = |name: &str| {
        if protocol.train_scenarios.iter().any(|s| s == name) {
            Some((train, protocol.train_iterations))
        } else if protocol.test_scenarios.iter().any(|s| s == name) {
            Some((test, protocol.test_iterations))
        } else {
            None
        }
    };
    let mut stages = BTreeMap::new();
    for name in names {
        let stage = learned_in(name).ok_or_else(|| EstimateError::UnknownScenario {
            name: name.clone(),
            known: [&protocol.train_scenarios[..], &protocol.test_scenarios[..]]
                .concat()
                .join(", "),
        })?;
        stages.insert(name.clone(), stage);
    }
    Ok(stages)
}

/// Updates `posterior` with the scenario credit of every trial of `scenario` in `stage`;
/// returns how many trials of it the stage told.
fn learn(
    scenario: &Scenario,
    posterior: &mut Posterior,
    stage: &StageId,
    (store, lines): Lines<'_>,
) -> Result<u64, EstimateError> {
    let (name, space) = (&*scenario.name, &scenario.space);
    let mut runs = 0;
    for (line, t) in lines.iter().filter_map(|(n, l)| Some((*n, l.trial()?))) {
        if t.stage != *stage || t.scenario != name {
            continue;
        }
        runs += 1;
        if let Some(ok) = t.credit.scenario {
            let arms = space.arms_of(&t.phi).map_err(|e| CampaignError::Log {
                store: store.to_string(),
                line: line as usize,
                message: format!(
                    "{stage} trial {}: φ outside the scenario (a campaign file other than \
                     the campaign's?): {e}",
                    t.index
                ),
            })?;
            let arms: Vec<u16> = arms.iter().map(|&a| a as u16).collect();
            posterior.update(&arms, ok);
        }
    }
    Ok(runs)
}

/// The scenarios `names` with their weights p(s) and posteriors at the kernels' uniform prior
/// (what training starts from); an unknown name is refused, listing the known ones.
pub(crate) fn untrained(
    names: &[String],
    protocol: &Protocol,
    problem: &Problem,
) -> Result<Vec<(Scenario, Posterior)>, EstimateError> {
    names
        .iter()
        .map(|name| {
            let space =
                problem
                    .scenarios
                    .get(name)
                    .ok_or_else(|| EstimateError::UnknownScenario {
                        name: name.clone(),
                        known: problem
                            .scenarios
                            .keys()
                            .cloned()
                            .collect::<Vec<_>>()
                            .join(", "),
                    })?;
            let posterior = Posterior::new(space, PriorCounts::UNIFORM)
                .map_err(savme_kernel::ConfigError::Prior)
                .map_err(CampaignError::from)?;
            let scenario = Scenario {
                name: Arc::from(name.as_str()),
                space: space.clone(),
                weight: protocol.weight(name),
            };
            Ok((scenario, posterior))
        })
        .collect()
}

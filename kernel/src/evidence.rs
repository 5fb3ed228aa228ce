//! What the learning trials showed about each fidelity arm, and the two choices made from it:
//! θ_LF* by evidence ([`Estimator::Evidence`](crate::Estimator::Evidence)) and the strength of
//! the transferred fidelity prior by leave-one-scenario-out ([`choose_strengths`]).
//!
//! The paper reads θ_LF* off p_ω by its MAP, which trusts thin evidence: an arm tried once,
//! successfully, has mode 1 and beats an arm that agreed 40 times out of 50. And it transfers
//! the meta-training posterior to new scenarios at full strength, whether or not the training
//! scenarios agree on which settings are cheap and faithful. Both choices here are pure
//! functions of the told trials:
//! - **θ_LF* by evidence**: per fidelity variable, the arm with the highest lower
//!   [`EVIDENCE_QUANTILE`] quantile of its Beta belief, with every false alarm (LF fails, HF
//!   passes) charged as `1 / C_budget` losses instead of one: screening pays a whole HF run to
//!   confirm a false alarm, the price of `1 / C_budget` LF runs at the budget.
//! - **Transfer strength by empirical Bayes**: per fidelity variable, the strength among the
//!   candidates under which the evidence of the other training scenarios best predicts each
//!   held-out training scenario's fidelity outcomes (its Beta–Binomial log marginal
//!   likelihood, summed over the held-out scenarios). Strength 0 (the uniform prior) wins when
//!   the scenarios disagree, and unless another strength gains at least
//!   [`MIN_GAIN_PER_SCENARIO`] nats per held-out scenario over it.
//!
//! ```
//! use savme_kernel::evidence::{choose_strengths, FidelityEvidence};
//! use savme_kernel::{Outcome, PriorCounts, Space, Variable};
//! let space = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
//! let mut e = FidelityEvidence::new(4, &space);
//! // Every scenario agrees: arm 1 succeeds, arm 0 fails.
//! for s in 0..4 {
//!     for _ in 0..20 {
//!         e.record(s, &[1], Outcome::TN, true, 0.1);
//!         e.record(s, &[0], Outcome::FP, false, 0.05);
//!     }
//! }
//! let t = choose_strengths(&e, &space, PriorCounts::UNIFORM, &[0.0, 0.1, 1.0]).unwrap();
//! assert_eq!(t.variables[0].strength, 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::outcome::Outcome;
use crate::posterior::{Arm, PriorCounts};
use crate::space::Space;
use serde::{Deserialize, Serialize};
use statrs::function::beta::{inv_beta_reg, ln_beta};

/// The lower quantile of an arm's Beta belief that θ_LF* by evidence maximises.
pub const EVIDENCE_QUANTILE: f64 = 0.1;

/// The held-out log-likelihood (in nats) per held-out scenario that a strength above 0 must
/// gain over the uniform prior (strength 0) to be chosen: evidence that predicts the held-out
/// scenarios only marginally better than no evidence is not transferred, so that a transfer
/// the training scenarios barely support cannot hurt.
pub const MIN_GAIN_PER_SCENARIO: f64 = 1.0;

/// The candidate strengths of the transferred fidelity prior, ascending (0: the uniform
/// prior; 1: the meta-training posterior as learned, the paper's).
pub const STRENGTHS: [f64; 6] = [0.0, 0.03, 0.1, 0.3, 0.6, 1.0];

/// What the learning trials that drew one arm of one fidelity variable showed.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmTally {
    /// Paired learning trials with this arm (each credited the fidelity bandit).
    pub tried: u64,
    /// Of those, fidelity successes (Table I: agreement within the budget).
    pub successes: u64,
    /// Both runs failed.
    pub tp: u64,
    /// Both runs passed.
    pub tn: u64,
    /// False alarms: the LF run failed, the HF run passed.
    pub fp: u64,
    /// Misses: the HF run failed, the LF run passed (`fn` in JSON).
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// Summed `t_LF / t_HF`.
    pub cost: f64,
}

impl ArmTally {
    /// Adds one trial.
    pub fn add(&mut self, outcome: Outcome, success: bool, cost_ratio: f64) {
        self.tried += 1;
        self.successes += u64::from(success);
        match outcome {
            Outcome::TP => self.tp += 1,
            Outcome::TN => self.tn += 1,
            Outcome::FP => self.fp += 1,
            Outcome::FN => self.fn_ += 1,
        }
        self.cost += cost_ratio;
    }

    /// Adds another tally.
    pub fn merge(&mut self, o: &ArmTally) {
        self.tried += o.tried;
        self.successes += o.successes;
        self.tp += o.tp;
        self.tn += o.tn;
        self.fp += o.fp;
        self.fn_ += o.fn_;
        self.cost += o.cost;
    }

    /// Trials that were not fidelity successes.
    pub fn losses(&self) -> u64 {
        self.tried - self.successes
    }

    /// False alarms among the HF passes, `FP / (FP + TN)`; None without an HF pass.
    pub fn false_alarm_rate(&self) -> Option<f64> {
        let n = self.fp + self.tn;
        (n > 0).then(|| self.fp as f64 / n as f64)
    }

    /// Misses among the HF failures, `FN / (TP + FN)`; None without an HF failure.
    pub fn miss_rate(&self) -> Option<f64> {
        let n = self.tp + self.fn_;
        (n > 0).then(|| self.fn_ as f64 / n as f64)
    }

    /// Mean `t_LF / t_HF`; None if never tried.
    pub fn mean_cost(&self) -> Option<f64> {
        (self.tried > 0).then(|| self.cost / self.tried as f64)
    }
}

/// Per scenario, per fidelity variable, per arm: an [`ArmTally`] of the paired learning trials
/// that credited the fidelity bandit. A kernel keeps one with
/// [`Estimator::Evidence`](crate::Estimator::Evidence); a harness can build one from its told
/// trials with [`FidelityEvidence::record`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FidelityEvidence {
    /// `tallies[scenario][variable][arm]`.
    tallies: Vec<Vec<Vec<ArmTally>>>,
}

impl FidelityEvidence {
    /// No evidence, for `scenarios` scenarios and the fidelity space `space`.
    pub fn new(scenarios: usize, space: &Space) -> Self {
        let one: Vec<Vec<ArmTally>> = space
            .variables()
            .iter()
            .map(|v| vec![ArmTally::default(); v.arms()])
            .collect();
        FidelityEvidence {
            tallies: vec![one; scenarios],
        }
    }

    /// Adds a paired learning trial of scenario `scenario` that drew the fidelity `arms` (one
    /// per variable), classified `outcome`, a fidelity success or not, at `cost_ratio`. Arms
    /// or a scenario outside the shape are ignored (the kernel only passes fitting ones).
    pub fn record(
        &mut self,
        scenario: usize,
        arms: &[u16],
        outcome: Outcome,
        success: bool,
        cost_ratio: f64,
    ) {
        let Some(vars) = self.tallies.get_mut(scenario) else {
            return;
        };
        for (var, &k) in vars.iter_mut().zip(arms) {
            if let Some(t) = var.get_mut(k as usize) {
                t.add(outcome, success, cost_ratio);
            }
        }
    }

    /// Scenarios held.
    pub fn scenarios(&self) -> usize {
        self.tallies.len()
    }

    /// The tallies of scenario `s`: `[variable][arm]`.
    pub fn scenario(&self, s: usize) -> Option<&[Vec<ArmTally>]> {
        self.tallies.get(s).map(Vec::as_slice)
    }

    /// The tallies summed over the scenarios: `[variable][arm]`.
    pub fn totals(&self) -> Vec<Vec<ArmTally>> {
        let mut total: Vec<Vec<ArmTally>> = match self.tallies.first() {
            Some(first) => first
                .iter()
                .map(|v| vec![ArmTally::default(); v.len()])
                .collect(),
            None => return Vec::new(),
        };
        for sc in &self.tallies {
            for (tv, sv) in total.iter_mut().zip(sc) {
                for (t, s) in tv.iter_mut().zip(sv) {
                    t.merge(s);
                }
            }
        }
        total
    }

    /// Whether the shape fits `scenarios` scenarios and the fidelity space.
    pub(crate) fn fits(&self, scenarios: usize, space: &Space) -> bool {
        self.tallies.len() == scenarios
            && self.tallies.iter().all(|sc| {
                sc.len() == space.len()
                    && sc
                        .iter()
                        .zip(space.variables())
                        .all(|(a, v)| a.len() == v.arms())
            })
    }
}

/// An arm's evidence score: the lower [`EVIDENCE_QUANTILE`] quantile of `Beta(α, β + c)`, with
/// `c = FP · (1 / budget − 1)` — every false alarm, already one loss, charged as `1 / budget`.
///
/// ```
/// use savme_kernel::evidence::{evidence_score, ArmTally};
/// use savme_kernel::Arm;
/// let thin = evidence_score(&Arm { alpha: 2.0, beta: 1.0 }, &ArmTally::default(), 0.3);
/// let solid = evidence_score(&Arm { alpha: 41.0, beta: 11.0 }, &ArmTally::default(), 0.3);
/// assert!(solid > thin, "40 of 50 beats 1 of 1");
/// ```
pub fn evidence_score(arm: &Arm, tally: &ArmTally, budget: f64) -> f64 {
    let charge = tally.fp as f64 * (1.0 / budget - 1.0).max(0.0);
    let q = inv_beta_reg(arm.alpha, arm.beta + charge, EVIDENCE_QUANTILE);
    if q.is_finite() {
        q
    } else {
        0.0
    }
}

/// The transfer strength chosen for one fidelity variable, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariableTransfer {
    /// The fidelity variable.
    pub variable: String,
    /// The chosen strength (the best held-out log-likelihood, ties to the weaker; 0 unless it
    /// beats 0 by [`MIN_GAIN_PER_SCENARIO`] per held-out scenario).
    pub strength: f64,
    /// Held-out log marginal likelihood per candidate strength (summed over the held-out
    /// scenarios), in the order of [`TransferChoice::candidates`].
    pub log_likelihood: Vec<f64>,
}

/// Per fidelity variable, the strength of the transferred prior chosen by leave-one-scenario-
/// out on the training scenarios ([`choose_strengths`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransferChoice {
    /// The candidate strengths, ascending.
    pub candidates: Vec<f64>,
    /// Training scenarios with evidence (each held out once).
    pub scenarios: usize,
    /// Per fidelity variable, in space order.
    pub variables: Vec<VariableTransfer>,
    /// The held-out log-likelihood per candidate summed over the variables (a single strength
    /// for every variable would take the best of these).
    pub total: Vec<f64>,
}

impl TransferChoice {
    /// The chosen strengths, in space order.
    pub fn strengths(&self) -> Vec<f64> {
        self.variables.iter().map(|v| v.strength).collect()
    }
}

/// Chooses, per fidelity variable, the strength of the transferred prior from `candidates`
/// (each finite and ≥ 0; sorted here) by leave-one-scenario-out: for every training scenario
/// with evidence, the prior `base + λ · m · evidence of the others` (m = all trials / the
/// others' trials, so that λ means what it will mean with every scenario's evidence) scores
/// the held-out scenario's successes and losses per arm by their Beta–Binomial log marginal
/// likelihood `ln B(a + s, b + l) − ln B(a, b)`. The strength with the highest sum wins, ties
/// to the weaker — unless it beats strength 0 (when a candidate) by less than
/// [`MIN_GAIN_PER_SCENARIO`] nats per held-out scenario: then 0, the uniform prior. None with
/// fewer than two scenarios with evidence or no candidate.
pub fn choose_strengths(
    evidence: &FidelityEvidence,
    space: &Space,
    base: PriorCounts,
    candidates: &[f64],
) -> Option<TransferChoice> {
    let cands = clean_candidates(candidates);
    let tried = |sc: &[Vec<ArmTally>]| sc.first().map_or(0, |v| v.iter().map(|t| t.tried).sum());
    let held: Vec<usize> = (0..evidence.scenarios())
        .filter(|&s| evidence.scenario(s).is_some_and(|sc| tried(sc) > 0))
        .collect();
    if held.len() < 2 || cands.is_empty() || !evidence.fits(evidence.scenarios(), space) {
        return None;
    }
    let mut variables = Vec::with_capacity(space.len());
    for (v, var) in space.variables().iter().enumerate() {
        // Per held-out scenario, per arm: (successes, losses) of this variable.
        let counts: Vec<Vec<(f64, f64)>> = held
            .iter()
            .filter_map(|&s| evidence.scenario(s))
            .map(|sc| {
                sc[v]
                    .iter()
                    .map(|t| (t.successes as f64, t.losses() as f64))
                    .collect()
            })
            .collect();
        let (strength, ll) = choose_one(&counts, base, &cands);
        variables.push(VariableTransfer {
            variable: var.name.to_string(),
            strength,
            log_likelihood: ll,
        });
    }
    let total = (0..cands.len())
        .map(|c| variables.iter().map(|v| v.log_likelihood[c]).sum())
        .collect();
    Some(TransferChoice {
        candidates: cands,
        scenarios: held.len(),
        variables,
        total,
    })
}

/// Candidate strengths as [`choose_strengths`] takes them: finite, ≥ 0, sorted, deduplicated.
pub(crate) fn clean_candidates(candidates: &[f64]) -> Vec<f64> {
    let mut cands: Vec<f64> = candidates
        .iter()
        .copied()
        .filter(|c| c.is_finite() && *c >= 0.0)
        .collect();
    cands.sort_by(f64::total_cmp);
    cands.dedup();
    cands
}

/// Leave-one-scenario-out for one variable: `counts[scenario][arm]` = (successes, losses) of
/// each scenario with evidence, `cands` clean ([`clean_candidates`]). Every scenario is held
/// out once against `base + λ · m · the others' counts` (m = all trials / the others'); returns
/// the chosen strength (the best summed Beta–Binomial log marginal likelihood, ties to the
/// weaker; 0 unless it gains [`MIN_GAIN_PER_SCENARIO`] nats per held-out scenario over 0) and
/// the log-likelihood of every candidate.
pub(crate) fn choose_one(
    counts: &[Vec<(f64, f64)>],
    base: PriorCounts,
    cands: &[f64],
) -> (f64, Vec<f64>) {
    let arms = counts.iter().map(Vec::len).max().unwrap_or(0);
    let mut total = vec![(0.0, 0.0); arms];
    for sc in counts {
        for (t, &(s, l)) in total.iter_mut().zip(sc) {
            t.0 += s;
            t.1 += l;
        }
    }
    let all: f64 = total.iter().map(|(s, l)| s + l).sum();
    let mut ll = vec![0.0; cands.len()];
    for sc in counts {
        let own: f64 = sc.iter().map(|(s, l)| s + l).sum();
        let others = all - own;
        let m = if others > 0.0 { all / others } else { 0.0 };
        for (&(s_h, l_h), &(s_t, l_t)) in sc.iter().zip(&total) {
            if s_h + l_h == 0.0 {
                continue;
            }
            let (s_o, l_o) = (s_t - s_h, l_t - l_h);
            for (c, &lambda) in cands.iter().enumerate() {
                let a = base.successes + lambda * m * s_o;
                let b = base.losses + lambda * m * l_o;
                ll[c] += ln_beta(a + s_h, b + l_h) - ln_beta(a, b);
            }
        }
    }
    let mut best = best_index(&ll);
    let need = MIN_GAIN_PER_SCENARIO * counts.len() as f64;
    if cands.first() == Some(&0.0) && ll[best] - ll[0] < need {
        best = 0;
    }
    (cands.get(best).copied().unwrap_or(0.0), ll)
}

/// The index of the largest value, the first of equal ones.
fn best_index(xs: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in xs.iter().enumerate().skip(1) {
        if x > xs[best] {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::Variable;

    fn space() -> Space {
        Space::new(vec![
            Variable::discrete("rate_hz", [1, 2, 5, 10]),
            Variable::boolean("shadows"),
        ])
        .unwrap()
    }

    #[test]
    fn scenarios_that_disagree_shrink_the_transfer_to_the_uniform_prior() {
        // rate_hz: each scenario has its own good arm (they disagree); shadows: arm 1 is
        // good everywhere (they agree).
        let sp = space();
        let mut e = FidelityEvidence::new(4, &sp);
        for s in 0..4u16 {
            for i in 0..40u16 {
                let rate = i % 4;
                let shadows = (i / 4) % 2;
                let ok = rate == s && shadows == 1;
                let outcome = if ok { Outcome::TN } else { Outcome::FP };
                e.record(usize::from(s), &[rate, shadows], outcome, ok, 0.1);
            }
        }
        let t = choose_strengths(&e, &sp, PriorCounts::UNIFORM, &STRENGTHS).unwrap();
        assert_eq!(t.scenarios, 4);
        assert_eq!(t.variables[0].strength, 0.0, "{:?}", t.variables[0]);
        assert!(t.variables[1].strength >= 0.6, "{:?}", t.variables[1]);
        // The margins are wide, not knife-edge.
        let ll = &t.variables[0].log_likelihood;
        assert!(ll[0] > ll[5] + 10.0, "{ll:?}");
    }

    #[test]
    fn a_marginal_gain_over_the_uniform_prior_transfers_nothing() {
        // Four scenarios that agree on thin evidence (each arm tried twice per scenario, one
        // success): transferring it predicts the held-out scenarios a little better, by less
        // than a nat per held-out scenario, so nothing is transferred.
        let sp = Space::new(vec![Variable::boolean("shadows")]).unwrap();
        let mut e = FidelityEvidence::new(4, &sp);
        for s in 0..4 {
            for arm in [0, 1] {
                e.record(s, &[arm], Outcome::TN, true, 0.1);
                e.record(s, &[arm], Outcome::FP, false, 0.1);
            }
        }
        let t = choose_strengths(&e, &sp, PriorCounts::UNIFORM, &STRENGTHS).unwrap();
        let ll = &t.variables[0].log_likelihood;
        let best = ll.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(best > ll[0], "some strength predicts better: {ll:?}");
        assert!(best - ll[0] < 4.0 * MIN_GAIN_PER_SCENARIO, "{ll:?}");
        assert_eq!(t.variables[0].strength, 0.0);
    }

    #[test]
    fn one_scenario_cannot_be_held_out() {
        let sp = space();
        let mut e = FidelityEvidence::new(2, &sp);
        e.record(0, &[0, 0], Outcome::TN, true, 0.1);
        assert!(choose_strengths(&e, &sp, PriorCounts::UNIFORM, &STRENGTHS).is_none());
        e.record(1, &[0, 0], Outcome::TN, true, 0.1);
        assert!(choose_strengths(&e, &sp, PriorCounts::UNIFORM, &STRENGTHS).is_some());
        assert!(choose_strengths(&e, &sp, PriorCounts::UNIFORM, &[f64::NAN]).is_none());
    }

    #[test]
    fn a_false_alarm_costs_more_at_a_small_budget() {
        let arm = Arm {
            alpha: 31.0,
            beta: 11.0,
        };
        let alarms = ArmTally {
            tried: 40,
            successes: 30,
            fp: 8,
            tn: 22,
            fn_: 2,
            ..ArmTally::default()
        };
        let none = ArmTally::default();
        let (s2, s4) = (
            evidence_score(&arm, &alarms, 0.2),
            evidence_score(&arm, &alarms, 0.4),
        );
        assert!(
            s2 < s4 && s4 < evidence_score(&arm, &none, 0.2),
            "{s2} {s4}"
        );
        assert_eq!(alarms.false_alarm_rate(), Some(8.0 / 30.0));
        assert_eq!(alarms.miss_rate(), Some(1.0));
    }
}

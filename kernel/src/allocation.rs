//! Which scenario the next trial runs: the paper's p(s), or the scenarios whose failures have
//! cost least so far.
//!
//! The paper draws every trial's scenario from p(s) (the scenario weights), so each scenario
//! gets the same share of the *trials* whatever its runs cost and however often they fail. A
//! user pays for simulation, not for trials: with [`Allocation::CostRate`] the kernel keeps a
//! [`Ledger`] per scenario (what its told trials cost, how many HF failures they found) and
//! picks the scenario by Thompson sampling of its failure rate per unit cost — a Gamma–Poisson
//! bandit: failures arrive as a Poisson process in the cost spent, the rate's posterior is
//! Gamma(failures + 1, cost + 2·c̄) with c̄ the mean cost of a told trial. Two rules come
//! first: every scenario gets `warmup` trials, and no scenario's share of the cost falls below
//! `floor` times its share of p(s) (the coverage floor: a failure mode that is dear to find
//! is never starved). A scenario without an HF failure yet is *scouted* ([`CostRate::scout`]):
//! its floor is its whole share of p(s) and its learning trials run HF only, so that its φ
//! search gets the trials it needs to find a failure region at all (the ρ model descends
//! once it has three runs with a ρ). Trials in flight count with the scenario's mean cost and, for the
//! rate, as if they fail at its posterior mean (so a batch is spread without biasing the
//! allocation).
//!
//! ```
//! use savme_kernel::{Allocation, CostRate};
//! assert_eq!(Allocation::default(), Allocation::Weights); // the paper's
//! let a = Allocation::CostRate(CostRate::default());
//! let json = serde_json::to_string(&a)?;
//! assert!(json.starts_with(r#"{"rule":"cost_rate""#));
//! assert_eq!(serde_json::from_str::<Allocation>(&json)?, a);
//! assert!(CostRate { floor: 1.5, ..CostRate::default() }.validate().is_err());
//! # Ok::<(), serde_json::Error>(())
//! ```

use crate::sampler::gamma;
use rand::Rng;
use serde::{Deserialize, Serialize};

/// How the kernel chooses the scenario of each ask. Part of the [`crate::KernelConfig`]; the
/// default is the paper's (and is then left out of the JSON).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "snake_case")]
pub enum Allocation {
    /// The paper's: the scenario is drawn from p(s), the normalised scenario weights.
    #[default]
    Weights,
    /// A bandit over the scenarios by HF failures per unit cost, with a coverage floor.
    CostRate(CostRate),
}

impl Allocation {
    /// True for the paper's [`Allocation::Weights`].
    pub fn is_weights(&self) -> bool {
        matches!(self, Allocation::Weights)
    }

    /// Checks the parameters.
    pub fn validate(&self) -> Result<(), AllocationError> {
        match self {
            Allocation::Weights => Ok(()),
            Allocation::CostRate(r) => r.validate(),
        }
    }
}

/// The parameters of [`Allocation::CostRate`]; missing fields take their defaults.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CostRate {
    /// The coverage floor, in `[0, 1]`: every scenario's share of the cost spent stays at or
    /// above `floor` × its share of p(s) (1: the cost is split by the weights; 0: no floor).
    pub floor: f64,
    /// Trials (told or in flight) every scenario gets before the bandit chooses; at least 1.
    pub warmup: u32,
    /// The half-life, in told trials (of every scenario), of the evidence the Thompson draw
    /// weighs: each tell multiplies every ledger's weighted failures and cost by 2^(−1/h)
    /// before it adds its own. None: the whole history counts alike (absent from a stored
    /// campaign, so it keeps its meaning).
    /// The default, [`RECENT_HALF_LIFE`], is that of new kernels only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_life: Option<f64>,
    /// Scouting: until a scenario's first HF failure its floor is 1 (its whole share of p(s)
    /// in cost, whatever `floor` is) and its learning trials run HF only (no LF run paired,
    /// whatever the [`crate::Pairing`]): before it, the scenario's runs are nearly all passes,
    /// its failure rate is 0 to the bandit, and the trials it needs before its φ search finds
    /// the failure region would otherwise be rationed to its floor. Missing from a stored
    /// configuration: false (and left out of the JSON when false). Off by default, like the
    /// pairing of fewer than every trial it implies: on in campaigns of the tuned method
    /// (`allocation = cost-rate-scout`), whose harness tells unpaired trials anyway.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub scout: bool,
}

/// The default [`CostRate::half_life`] of new kernels, in told trials: on BouncingBall earth +
/// mars (seeds 1–20) deployed failures per cost 244 → 383 per 10³ wu with 16 trials in flight
/// and 44 → 121 with 64, the search's 11.0 → 11.8 at 16; with one in flight the search 26.2 →
/// 27.0 and the deployed search 381 → 353 (seeds 1–40) (docs/RESULTS.md, issue 42 item 4).
pub const RECENT_HALF_LIFE: f64 = 20.0;

impl Default for CostRate {
    fn default() -> Self {
        // Floor 0.6 over 0.3 on the bundled simulator's scenarios 1–8 (300 search trials, 3
        // seeds): HF failures per 10⁹ wu 59.1 vs 74.3, but every scenario but one within 0.8×
        // of the best VerifAI sampler's rate in it, against three below (docs/RESULTS.md).
        CostRate {
            floor: 0.6,
            warmup: 4,
            half_life: Some(RECENT_HALF_LIFE),
            scout: false,
        }
    }
}

impl CostRate {
    /// Checks `floor` ∈ [0, 1], `warmup` ≥ 1 and a `half_life` finite and positive.
    pub fn validate(&self) -> Result<(), AllocationError> {
        if !(0.0..=1.0).contains(&self.floor) {
            return Err(AllocationError::Floor(self.floor));
        }
        if self.warmup == 0 {
            return Err(AllocationError::Warmup);
        }
        match self.half_life {
            Some(h) if !(h.is_finite() && h > 0.0) => Err(AllocationError::HalfLife(h)),
            _ => Ok(()),
        }
    }
}

/// An allocation parameter out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AllocationError {
    /// `floor` outside [0, 1] (or NaN).
    #[error("allocation `floor` = {0} is outside [0, 1]")]
    Floor(f64),
    /// `warmup` of 0.
    #[error("allocation `warmup` must be at least 1")]
    Warmup,
    /// `half_life` not finite and positive.
    #[error("allocation `half_life` = {0} is not a positive number of trials")]
    HalfLife(f64),
}

/// What one scenario's told trials have cost and found (kept with [`Allocation::CostRate`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Ledger {
    /// Trials told.
    pub trials: u64,
    /// Their cost: every run told, HF and LF, in the runtimes' unit.
    pub cost: f64,
    /// Their HF failures (a screened trial's only when its HF run was made).
    pub failures: u64,
    /// Their cost, each trial's weighed by 2^(−k/h), k the trials told since it (kept only
    /// when [`CostRate::half_life`] is set; 0 otherwise).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub recent_cost: f64,
    /// Their HF failures, weighed likewise.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub recent_failures: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl Ledger {
    /// Adds a told trial.
    pub(crate) fn add(&mut self, cost: f64, failure: bool) {
        self.trials += 1;
        self.cost += cost;
        self.failures += u64::from(failure);
    }

    /// Weighs every ledger's recent evidence down by one told trial of half-life `h`.
    pub(crate) fn forget(ledgers: &mut [Ledger], h: f64) {
        let d = (-std::f64::consts::LN_2 / h).exp();
        for l in ledgers {
            l.recent_cost *= d;
            l.recent_failures *= d;
        }
    }

    /// Adds a told trial to the recent evidence.
    pub(crate) fn add_recent(&mut self, cost: f64, failure: bool) {
        self.recent_cost += cost;
        self.recent_failures += f64::from(u8::from(failure));
    }

    /// HF failures per unit cost so far (0 before any trial).
    pub fn rate(&self) -> f64 {
        if self.cost > 0.0 {
            self.failures as f64 / self.cost
        } else {
            0.0
        }
    }
}

/// Picks the next scenario: warm-up first, then the scenario furthest below its floor (1 for
/// a scenario scouted, [`CostRate::scout`]), else a Thompson draw of every scenario's failures per unit cost. `weights` is p(s), `pending` the
/// trials in flight per scenario.
pub(crate) fn choose<R: Rng + ?Sized>(
    rule: &CostRate,
    weights: &[f64],
    ledgers: &[Ledger],
    pending: &[u32],
    rng: &mut R,
) -> usize {
    let started = |s: usize| ledgers[s].trials + u64::from(pending[s]);
    if let Some(s) = (0..weights.len())
        .filter(|&s| started(s) < u64::from(rule.warmup))
        .min_by_key(|&s| started(s))
    {
        return s;
    }
    let told: u64 = ledgers.iter().map(|l| l.trials).sum();
    let spent: f64 = ledgers.iter().map(|l| l.cost).sum();
    let mean = if told > 0 { spent / told as f64 } else { 1.0 };
    // Cost per scenario with its trials in flight at its mean cost.
    let each = |s: usize| {
        let l = &ledgers[s];
        let m = if l.trials > 0 {
            l.cost / l.trials as f64
        } else {
            mean
        };
        (m, l.cost + f64::from(pending[s]) * m)
    };
    let costs: Vec<(f64, f64)> = (0..weights.len()).map(each).collect();
    let total: f64 = costs.iter().map(|c| c.1).sum();
    let floor = |s: usize| {
        if rule.scout && ledgers[s].failures == 0 {
            1.0
        } else {
            rule.floor
        }
    };
    let below = (0..weights.len())
        .map(|s| (s, 1.0 - costs[s].1 / (floor(s) * weights[s] * total)))
        .filter(|d| d.1 > 0.0 && d.1.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((s, _)) = below {
        return s;
    }
    let (shape0, rate0) = (1.0, 2.0 * mean);
    let mut best = (0, f64::NEG_INFINITY);
    for (s, l) in ledgers.iter().enumerate() {
        let m = costs[s].0;
        let (failures, spent) = match rule.half_life {
            Some(_) => (l.recent_failures, l.recent_cost),
            None => (l.failures as f64, l.cost),
        };
        let posterior_mean = (failures + shape0) / (spent + rate0);
        let believed = failures + f64::from(pending[s]) * m * posterior_mean;
        let cost = spent + f64::from(pending[s]) * m;
        let draw = gamma(believed + shape0, rng) / (cost + rate0);
        if draw > best.1 {
            best = (s, draw);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn ledger(trials: u64, cost: f64, failures: u64) -> Ledger {
        Ledger {
            trials,
            cost,
            failures,
            ..Ledger::default()
        }
    }

    #[test]
    fn warm_up_goes_to_the_scenario_with_fewest_trials() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        let rule = CostRate::default();
        let ledgers = [ledger(4, 4.0, 0), ledger(1, 1.0, 0), ledger(0, 0.0, 0)];
        assert_eq!(choose(&rule, &[0.3; 3], &ledgers, &[0, 0, 1], &mut rng), 1);
        assert_eq!(choose(&rule, &[0.3; 3], &ledgers, &[0, 1, 0], &mut rng), 2);
    }

    #[test]
    fn cheap_failures_win_most_draws_and_the_floor_holds() {
        // Scenario 0 finds a failure per 10 cost units, scenario 1 one per 100.
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let rule = CostRate {
            floor: 0.5,
            warmup: 1,
            half_life: None,
            scout: false,
        };
        let (mut l, weights) = ([ledger(0, 0.0, 0); 2], [0.5, 0.5]);
        let (rate, unit) = ([0.1, 0.01], [1.0, 1.0]);
        for _ in 0..4000 {
            let s = choose(&rule, &weights, &l, &[0, 0], &mut rng);
            // Deterministic failures at the scenario's rate: one per 1/rate cost.
            let before = (l[s].cost * rate[s]).floor();
            let after = ((l[s].cost + unit[s]) * rate[s]).floor();
            l[s].add(unit[s], after > before);
        }
        let share0 = l[0].cost / (l[0].cost + l[1].cost);
        assert!(
            share0 > 0.7,
            "the cheap scenario got {share0:.2} of the cost"
        );
        // floor 0.5 × weight 0.5: scenario 1 keeps at least a quarter (less one trial).
        assert!(1.0 - share0 >= 0.25 - 1e-3, "floor broken: {share0:.3}");
    }

    #[test]
    fn a_floor_of_one_splits_the_cost_by_weight() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let rule = CostRate {
            floor: 1.0,
            warmup: 1,
            half_life: None,
            scout: false,
        };
        let weights = [0.75, 0.25];
        let mut l = [ledger(0, 0.0, 0); 2];
        let unit = [1.0, 5.0];
        for _ in 0..2000 {
            let s = choose(&rule, &weights, &l, &[0, 0], &mut rng);
            l[s].add(unit[s], s == 1);
        }
        let share0 = l[0].cost / (l[0].cost + l[1].cost);
        assert!((share0 - 0.75).abs() < 0.01, "{share0}");
    }
}

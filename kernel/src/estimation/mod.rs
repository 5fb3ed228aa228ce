//! Estimation: the probability of failure under the nominal (field) distribution of φ, by
//! importance sampling with a defensive mixture proposal.
//!
//! After training, the posterior p_ψ(φ | s) says where the system fails. An [`Estimation`]
//! freezes it into a **fixed** proposal per scenario,
//!
//! > q(φ) = (1 − ε)·p̂_ψ(φ) + ε·p(φ),
//!
//! where p̂_ψ picks each variable's bin with probability proportional to the bin's posterior
//! mean (independently per variable) and draws uniformly — log-uniformly on a log scale —
//! inside the bin, and p is the nominal distribution ([`Nominal`], uniform by default). Both
//! densities are known in closed form, so every trial carries q(φ), p(φ) and the weight
//! w = p(φ)/q(φ). Every trial runs the high-fidelity simulator; its failure f is told back.
//! The estimate of P(failure | s) is the importance-weighted mean (1/n) Σ w_i f_i, unbiased
//! whenever q > 0 wherever p > 0 — which the defensive component guarantees, together with the
//! bound w ≤ 1/ε (Hesterberg 1995). Its 95 % interval is the normal approximation
//! mean ± 1.96·se; the p(s)-weighted total combines the scenarios' estimates ([`Estimate`]).
//! Trials are shared out over the scenarios in proportion to p(s), deterministically (the
//! scenario whose share is furthest behind goes next), so the asks do not depend on outcomes.
//!
//! **Cross-entropy refinement** (optional, [`Refine`]; Rubinstein & Kroese 2004): before the
//! estimate, `rounds` pilot rounds of `runs` HF trials each refit every scenario's p̂_ψ. After
//! a round, each variable's bin probabilities move ([`REFINE_SMOOTHING`]) toward the share of
//! the importance-weighted failures Σ w·f of all pilot rounds so far in each bin — estimates of
//! the marginals of the zero-variance density ∝ p(φ)·1{failure} — and φ is drawn inside a bin
//! from the nominal restricted to it.
//! This aims q at where p(φ)·P(failure | φ) is large, not merely where failures are frequent,
//! which matters when the nominal is concentrated away from the failures (a rare event).
//! Pilot trials are logged (`round`) and by default are **not** part of the estimate: it uses
//! only trials drawn from the final, fixed proposal. [`Refine::reuse`] = k adds the last k
//! pilot rounds' trials, each with the weight p/q_r of the proposal q_r it was drawn from.
//! q_r was fixed before round r's draws, so each such term has mean P(failure) given the
//! rounds before it, and the pooled mean (1/N) Σ w·f over a set of rounds chosen in advance
//! stays unbiased (a martingale argument; no trial is re-weighted with a proposal fitted on
//! it). Its interval treats the pooled terms as one sample: the rounds' terms have the same
//! mean and different spreads, so the pooled sample variance estimates their average spread —
//! the variance of the pooled mean. While a round's
//! trials are out, [`Estimation::ask`] returns None until they are told, so the proposal —
//! and every trial — does not depend on the order in which parallel runs finish.
//!
//! **Multi-fidelity pilot** ([`EstimationConfig::pilot_fidelity`] = [`Fidelity::Lf`]): the
//! pilot rounds' trials are marked to run at the learned low fidelity θ_LF* (multi-fidelity
//! importance sampling: Peherstorfer, Cui, Marzouk & Willcox 2016). Their outcomes only fit
//! the proposal — never the estimate, which stays the HF-weighted mean of the trials drawn
//! from the proposal frozen after the pilot — so it is unbiased for the HF probability
//! whatever the LF's errors (q ≥ ε·p keeps every weight finite).
//!
//! Estimation is a phase of its own type rather than a [`crate::Phase`]: it needs ε and the
//! nominal, must never change the posterior it was built from, and its trials carry densities.
//!
//! ```
//! use savme_kernel::estimation::{EstimationConfig, Estimation};
//! use savme_kernel::{Assignment, Kernel, Observation, Run, Scale, Space, Variable};
//! let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 10, Scale::Linear)])?;
//! let fidelity = Space::new(vec![Variable::discrete("rate", [10])])?;
//! let mut kernel = Kernel::builder(fidelity, Assignment::new().with("rate", 10))
//!     .scenario("s", phi, 1.0)
//!     .seed(3)
//!     .build()?;
//! let fails = |t: &savme_kernel::Trial| t.phi.get_f64("gap").unwrap() > 0.95;
//! for _ in 0..300 {                                    // training
//!     let t = kernel.ask();
//!     let f = fails(&t);
//!     kernel.tell(t.id, Observation::Paired { hf: Run::new(f, 1.0), lf: Run::new(f, 0.1) })?;
//! }
//! let mut est = kernel.estimation(&EstimationConfig::new(0.1, 7))?;
//! for _ in 0..2000 {
//!     let t = est.ask().expect("no refinement, so never waiting");
//!     assert!(t.weight <= 1.0 / 0.1 + 1e-9);           // the defensive bound
//!     let f = t.phi.get_f64("gap").unwrap() > 0.95;
//!     est.tell(t.id, f)?;
//! }
//! let e = est.estimate();
//! assert!(e.total.lo <= 0.05 && 0.05 <= e.total.hi);  // the true value is 0.05
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod config;
mod control;
mod joint;
mod joint_fit;
mod nominal;
mod proposal;
mod statistic;

pub use config::{
    EstimationConfig, EstimationError, Fidelity, Joint, ProposalKind, Refine, DEFAULT_COMPONENTS,
    MAX_COMPONENTS, REFINE_SMOOTHING,
};
pub use control::{Control, ControlPart, ControlPlan, ControlReport, MAX_EXTRA};
pub use nominal::Nominal;
pub use proposal::Tilt;
pub use statistic::{z95, Estimate, Interval, ScenarioEstimate};

use crate::kernel::{Kernel, Scenario};
use crate::posterior::Posterior;
use crate::value::Assignment;
use config::check_config;
use control::PairSums;
use joint::Mixture;
use joint_fit::{JointPilot, PilotPoint};
use nominal::NominalOf;
use proposal::{Densities, Proposal};
use rand::SeedableRng;
use rand_pcg::Pcg64 as Rng64;
use serde::{Deserialize, Serialize};
use statistic::Sums;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

/// One trial of an estimation: run the HF simulator on `scenario` with `phi`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimationTrial {
    /// Counts up from 0 in ask order.
    pub id: u64,
    /// The scenario.
    pub scenario: Arc<str>,
    /// Its index in the estimation.
    pub scenario_index: usize,
    /// The parameters, drawn from q.
    pub phi: Assignment,
    /// q(φ), the proposal's density.
    pub q: f64,
    /// p(φ), the nominal's density.
    pub p: f64,
    /// p(φ) / q(φ), at most 1/ε.
    pub weight: f64,
    /// The cross-entropy pilot round (0, 1, …) this trial belongs to; None for a trial of
    /// the estimate itself.
    pub round: Option<u32>,
    /// The fidelity to run it at: `hf`, except the pilot rounds of a multi-fidelity
    /// estimation ([`EstimationConfig::pilot_fidelity`] = `lf`), whose outcomes only fit the
    /// proposal.
    #[serde(default, skip_serializing_if = "Fidelity::is_hf")]
    pub fidelity: Fidelity,
    /// With control variates ([`EstimationConfig::control`]): which part of the estimation
    /// the trial is (a calibration pair's run, an estimate pair's run, an extra LF run; the
    /// two runs of a pair are consecutive trials with the same φ, HF first). None: a plain
    /// trial (the pilot's, or an HF-only estimate's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control: Option<ControlPart>,
}

/// The importance-sampling estimation of P(failure) under the nominal: asks φ from the fixed
/// proposal, takes HF failures, and keeps the running estimate. Pure and deterministic: the
/// same scenarios, posteriors, configuration and calls give the same trials.
#[derive(Debug, Clone)]
pub struct Estimation {
    names: Vec<Arc<str>>,
    probabilities: Vec<f64>,
    proposals: Vec<Proposal>,
    /// The fitted joint proposals' mixtures (None: the scenario draws from its product
    /// proposal).
    mixtures: Vec<Option<Mixture>>,
    rng: Rng64,
    next_id: u64,
    asked: Vec<u64>,
    told: u64,
    pending: BTreeMap<u64, Pending>,
    sums: Vec<Sums>,
    pilot: Option<Pilot>,
    pilot_sums: Vec<Sums>,
    /// The fidelity of the pilot rounds' runs.
    pilot_fidelity: Fidelity,
    /// LF runs as control variates (None: HF runs only).
    control: Option<ControlState>,
}

/// The control-variate estimation's state (after the pilot, if any).
#[derive(Debug, Clone)]
struct ControlState {
    config: Control,
    /// Calibration pairs asked.
    calibration_asked: u64,
    /// Calibration runs told by trial id: (scenario, weight, fidelity, failure, cost), summed
    /// in id order when the calibration is complete (so the plan does not depend on the
    /// order of the tells).
    calibration_runs: BTreeMap<u64, (usize, f64, Fidelity, bool, Option<f64>)>,
    /// Per scenario, chosen when every calibration run is told.
    plans: Option<Vec<ControlPlan>>,
    /// Per scenario: the estimate's pairs and extra LF runs.
    pairs: Vec<PairSums>,
    extra: Vec<Sums>,
    /// Trials drawn (a pair's LF twin, the extra LF runs) and not yet asked.
    queue: VecDeque<(EstimationTrial, Pending)>,
    /// Estimate pairs with one run told, by the HF trial's id: (HF, LF) failure.
    halves: BTreeMap<u64, (Option<bool>, Option<bool>)>,
}

impl ControlState {
    fn new(config: Control, scenarios: usize) -> Self {
        ControlState {
            config,
            calibration_asked: 0,
            calibration_runs: BTreeMap::new(),
            plans: None,
            pairs: vec![PairSums::default(); scenarios],
            extra: vec![Sums::default(); scenarios],
            queue: VecDeque::new(),
            halves: BTreeMap::new(),
        }
    }

    /// The plans from the complete calibration: pairs and costs summed in trial-id order.
    fn plan(&mut self, scenarios: usize) {
        let mut sums = vec![PairSums::default(); scenarios];
        let mut costs = [0.0, 0.0];
        let mut counted = [0u64, 0];
        let mut hf = None;
        for &(s, w, fidelity, failure, cost) in self.calibration_runs.values() {
            let i = usize::from(fidelity == Fidelity::Lf);
            if let Some(c) = cost {
                costs[i] += c;
                counted[i] += 1;
            }
            match (fidelity, hf.take()) {
                (Fidelity::Hf, _) => hf = Some(failure),
                (Fidelity::Lf, Some(h)) => sums[s].add(w, h, failure),
                (Fidelity::Lf, None) => {}
            }
        }
        let ratio = if counted[0] > 0 && counted[1] > 0 && costs[0] > 0.0 {
            (costs[1] / counted[1] as f64) / (costs[0] / counted[0] as f64)
        } else {
            1.0
        };
        self.plans = Some(
            sums.iter()
                .map(|c| ControlPlan::new(c, ratio, self.config.extra))
                .collect(),
        );
    }
}

/// A trial asked and not yet told.
#[derive(Debug, Clone)]
struct Pending {
    scenario: usize,
    weight: f64,
    /// For a pilot trial: its round and φ's bin of each variable.
    pilot: Option<(u32, Vec<usize>)>,
    /// For a control-variate trial: its part, the id of its pair's HF trial (its own id for
    /// an extra run) and its fidelity.
    control: Option<(ControlPart, u64, Fidelity)>,
}

/// The cross-entropy pilot while it lasts.
#[derive(Debug, Clone)]
struct Pilot {
    refine: Refine,
    round: u32,
    asked: u64,
    told: u64,
    /// Per scenario, variable and bin: Σ w·f of the pilot's trials so far (all rounds: each
    /// round's sum estimates the same marginals, so adding them lowers the noise).
    mass: Vec<Vec<Vec<f64>>>,
    /// This round's failures by trial id (scenario, weight, bins), added to `mass` in id
    /// order at the round's end so that the sums, to the last bit, do not depend on the
    /// order of the tells.
    failed: BTreeMap<u64, (usize, f64, Vec<usize>)>,
    /// The joint proposal's pilot (None: the product proposal is refitted).
    joint: Option<JointPilot>,
}

/// Every scenario and variable a declared nominal names exists (`names`: the scenarios').
fn check_nominal_names(
    scenarios: &[(Scenario, Posterior)],
    config: &EstimationConfig,
    names: &[Arc<str>],
) -> Result<(), EstimationError> {
    for (scenario, vars) in &config.nominal {
        let Some((s, _)) = scenarios.iter().find(|(s, _)| &*s.name == scenario) else {
            return Err(EstimationError::UnknownScenario {
                scenario: scenario.clone(),
                known: names.join(", "),
            });
        };
        for variable in vars.keys() {
            if s.space.variable(variable).is_none() {
                let known: Vec<&str> = s.space.variables().iter().map(|v| &*v.name).collect();
                return Err(EstimationError::UnknownVariable {
                    scenario: scenario.clone(),
                    variable: variable.clone(),
                    known: known.join(", "),
                });
            }
        }
    }
    Ok(())
}

/// Scenario `s`'s frozen proposal: its posterior mixed with its nominal (declared per
/// variable, else uniform on the variable's scale).
fn proposal_of(
    s: &Scenario,
    posterior: &Posterior,
    config: &EstimationConfig,
) -> Result<Proposal, EstimationError> {
    posterior
        .check_fits(&s.space)
        .map_err(|e| EstimationError::Posterior {
            scenario: s.name.to_string(),
            message: e.to_string(),
        })?;
    let declared = config.nominal.get(&*s.name);
    let nominal = s
        .space
        .variables()
        .iter()
        .map(|v| {
            let n = declared.and_then(|d| d.get(&*v.name)).cloned();
            NominalOf::new(&n.unwrap_or_default(), &s.name, v)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Proposal::new(
        &s.space,
        posterior,
        nominal,
        config.epsilon,
        config.tilt,
    ))
}

impl Estimation {
    /// Freezes a proposal for each scenario from its posterior p_ψ(φ | s). Errors name the
    /// bad ε, scenario or variable.
    pub fn new(
        scenarios: &[(Scenario, Posterior)],
        config: &EstimationConfig,
    ) -> Result<Estimation, EstimationError> {
        check_config(config, scenarios.len())?;
        if scenarios.is_empty() {
            return Err(EstimationError::NoScenarios);
        }
        let names: Vec<Arc<str>> = scenarios.iter().map(|(s, _)| s.name.clone()).collect();
        check_nominal_names(scenarios, config, &names)?;
        let proposals = scenarios
            .iter()
            .map(|(s, posterior)| proposal_of(s, posterior, config))
            .collect::<Result<Vec<_>, _>>()?;
        let total: f64 = scenarios.iter().map(|(s, _)| s.weight).sum();
        let pilot = config.refine.map(|refine| Pilot {
            refine,
            round: 0,
            asked: 0,
            told: 0,
            mass: empty_mass(scenarios),
            failed: BTreeMap::new(),
            joint: config
                .joint
                .map(|j| JointPilot::new(j.components as usize, config.seed, scenarios.len())),
        });
        Ok(Estimation {
            probabilities: scenarios.iter().map(|(s, _)| s.weight / total).collect(),
            names,
            mixtures: vec![None; proposals.len()],
            proposals,
            rng: Rng64::seed_from_u64(config.seed),
            next_id: 0,
            asked: vec![0; scenarios.len()],
            told: 0,
            pending: BTreeMap::new(),
            sums: vec![Sums::default(); scenarios.len()],
            pilot,
            pilot_sums: vec![Sums::default(); scenarios.len()],
            pilot_fidelity: config.pilot_fidelity,
            control: config
                .control
                .map(|c| ControlState::new(c, scenarios.len())),
        })
    }

    /// The scenario names, in order.
    pub fn scenarios(&self) -> &[Arc<str>] {
        &self.names
    }

    /// The normalised p(s), in scenario order.
    pub fn probabilities(&self) -> &[f64] {
        &self.probabilities
    }

    /// The learned part p̂_ψ of scenario `index`'s proposal: per variable, each bin's
    /// probability (the posterior means, normalised).
    pub fn bin_probabilities(&self, index: usize) -> Option<&[Vec<f64>]> {
        self.proposals.get(index).map(Proposal::bins)
    }

    /// q(φ) and p(φ) of `phi` for scenario `index` under its current proposal (None for an
    /// unknown index).
    pub fn densities(&self, index: usize, phi: &Assignment) -> Option<(f64, f64)> {
        let d = self.densities_of(index, phi)?;
        Some((d.q, d.p))
    }

    fn densities_of(&self, index: usize, phi: &Assignment) -> Option<Densities> {
        let base = self.proposals.get(index)?;
        Some(match &self.mixtures[index] {
            Some(m) => joint::densities(m, base, phi),
            None => base.densities(phi),
        })
    }

    /// Whether scenario `index` draws from a fitted joint proposal (a mixture over the whole
    /// of φ) rather than its product proposal.
    pub fn is_joint(&self, index: usize) -> bool {
        self.mixtures.get(index).is_some_and(Option::is_some)
    }

    /// The next trial: the scenario furthest behind its share p(s) (ties: the first), φ ~ q.
    /// None while a refinement round has asked all its trials and waits for their outcomes
    /// (tell them, then ask again).
    pub fn ask(&mut self) -> Option<EstimationTrial> {
        if self.pilot.is_none() && self.control.is_some() {
            return self.ask_control();
        }
        let round = match &mut self.pilot {
            Some(p) if p.asked >= p.refine.runs => return None,
            Some(p) => {
                p.asked += 1;
                Some(p.round)
            }
            None => None,
        };
        let s = self.next_scenario();
        let (phi, d) = self.draw(s);
        let weight = d.p / d.q;
        let trial = EstimationTrial {
            id: self.next_id,
            scenario: self.names[s].clone(),
            scenario_index: s,
            phi,
            q: d.q,
            p: d.p,
            weight,
            round,
            fidelity: match round {
                Some(_) => self.pilot_fidelity,
                None => Fidelity::Hf,
            },
            control: None,
        };
        self.next_id += 1;
        self.asked[s] += 1;
        let pilot = round.map(|r| {
            let arms = self.proposals[s].arms_of(&trial.phi).unwrap_or_default();
            (r, arms)
        });
        self.pending.insert(
            trial.id,
            Pending {
                scenario: s,
                weight,
                pilot,
                control: None,
            },
        );
        Some(trial)
    }

    /// The scenario furthest behind its share p(s) (ties: the first).
    fn next_scenario(&self) -> usize {
        (0..self.names.len())
            .min_by(|&a, &b| {
                let behind = |i: usize| (self.asked[i] + 1) as f64 / self.probabilities[i];
                behind(a).total_cmp(&behind(b))
            })
            .unwrap_or(0)
    }

    /// φ ~ q of scenario `s` with its densities.
    fn draw(&mut self, s: usize) -> (Assignment, Densities) {
        match &self.mixtures[s] {
            Some(m) => joint::draw(m, &self.proposals[s], &mut self.rng),
            None => {
                let phi = self.proposals[s].draw(&mut self.rng);
                let d = self.proposals[s].densities(&phi);
                (phi, d)
            }
        }
    }

    /// The next control-variate trial: from the queue, else a new calibration pair, estimate
    /// pair (with its extra LF runs) or HF-only trial; None while the calibration waits for
    /// its outcomes.
    fn ask_control(&mut self) -> Option<EstimationTrial> {
        let c = self.control.as_ref()?;
        if c.queue.is_empty() {
            let part = if c.calibration_asked < c.config.calibration {
                ControlPart::Calibration
            } else if c.plans.is_some() {
                ControlPart::Paired
            } else {
                return None;
            };
            self.draw_block(part);
        }
        let (trial, pending) = self.control.as_mut()?.queue.pop_front()?;
        self.pending.insert(trial.id, pending);
        Some(trial)
    }

    /// Draws the next block into the queue: a pair (HF, then LF at the same φ) and, for an
    /// estimate pair, its extra LF runs; or one plain HF trial when the plan runs HF only.
    fn draw_block(&mut self, part: ControlPart) {
        let s = self.next_scenario();
        self.asked[s] += 1;
        let plan = self
            .control
            .as_ref()
            .and_then(|c| c.plans.as_ref())
            .map(|p| p[s]);
        let (extra, paired) = match (part, plan) {
            (ControlPart::Calibration, _) => (0, true),
            (_, Some(p)) => (p.extra, p.use_lf),
            (_, None) => (0, false),
        };
        let (phi, d) = self.draw(s);
        let mut block = Vec::new();
        let hf_id = self.next_id;
        block.push((phi.clone(), d, Fidelity::Hf, paired.then_some(part)));
        if paired {
            block.push((phi, d, Fidelity::Lf, Some(part)));
        }
        for _ in 0..extra {
            let (phi, d) = self.draw(s);
            block.push((phi, d, Fidelity::Lf, Some(ControlPart::Extra)));
        }
        for (phi, d, fidelity, part) in block {
            let id = self.next_id;
            self.next_id += 1;
            let weight = d.p / d.q;
            let trial = EstimationTrial {
                id,
                scenario: self.names[s].clone(),
                scenario_index: s,
                phi,
                q: d.q,
                p: d.p,
                weight,
                round: None,
                fidelity,
                control: part,
            };
            let pair = if part == Some(ControlPart::Extra) {
                id
            } else {
                hf_id
            };
            let pending = Pending {
                scenario: s,
                weight,
                pilot: None,
                control: part.map(|p| (p, pair, fidelity)),
            };
            if let Some(c) = self.control.as_mut() {
                if part == Some(ControlPart::Calibration) && fidelity == Fidelity::Hf {
                    c.calibration_asked += 1;
                }
                c.queue.push_back((trial, pending));
            }
        }
    }

    /// Takes the outcome of trial `id` at its [`EstimationTrial::fidelity`] (HF, except an
    /// LF pilot's). The last outcome of a refinement round refits the proposals.
    pub fn tell(&mut self, id: u64, failure: bool) -> Result<(), EstimationError> {
        self.tell_run(id, failure, None)
    }

    /// [`Estimation::tell`] with the run's robustness (how close it came to failing, ≤ 0
    /// failed; finite), which a joint proposal's pilot uses to aim its early rounds at the
    /// near-misses. The estimate itself uses the failure only.
    pub fn tell_run(
        &mut self,
        id: u64,
        failure: bool,
        robustness: Option<f64>,
    ) -> Result<(), EstimationError> {
        self.tell_measured(id, failure, robustness, None)
    }

    /// [`Estimation::tell_run`] with the run's cost (finite, ≥ 0; in any unit, the same for
    /// every run): the control variates' calibration compares the mean LF and HF costs to
    /// choose how many LF runs pay (without costs it takes them as equal).
    pub fn tell_measured(
        &mut self,
        id: u64,
        failure: bool,
        robustness: Option<f64>,
        cost: Option<f64>,
    ) -> Result<(), EstimationError> {
        if let Some(r) = robustness.filter(|r| !r.is_finite()) {
            return Err(EstimationError::BadRobustness { id, robustness: r });
        }
        if let Some(c) = cost.filter(|c| !(c.is_finite() && *c >= 0.0)) {
            return Err(EstimationError::BadCost { id, cost: c });
        }
        let t = self
            .pending
            .remove(&id)
            .ok_or(EstimationError::NotPending(id))?;
        self.told += 1;
        if let Some((part, pair, fidelity)) = t.control {
            self.tell_control(&t, (part, pair, fidelity), id, failure, cost);
            return Ok(());
        }
        let s = t.scenario;
        let (Some((round, arms)), Some(pilot)) = (t.pilot, self.pilot.as_mut()) else {
            self.sums[s].add(t.weight, failure);
            return Ok(());
        };
        self.pilot_sums[s].add(t.weight, failure);
        // An LF pilot is never reused (refused when the estimation is built); checked here
        // too so that no LF outcome can enter the HF estimate.
        if self.pilot_fidelity.is_hf() && round + pilot.refine.reuse >= pilot.refine.rounds {
            self.sums[s].add(t.weight, failure);
        }
        if let Some(j) = pilot.joint.as_mut() {
            let point = PilotPoint {
                point: arms,
                weight: t.weight,
                failure,
                robustness,
            };
            j.told(id, s, point);
        } else if failure {
            pilot.failed.insert(id, (s, t.weight, arms));
        }
        pilot.told += 1;
        if pilot.told == pilot.refine.runs {
            self.end_round();
        }
        Ok(())
    }

    /// Takes a control-variate trial's outcome.
    fn tell_control(
        &mut self,
        t: &Pending,
        (part, pair, fidelity): (ControlPart, u64, Fidelity),
        id: u64,
        failure: bool,
        cost: Option<f64>,
    ) {
        let n = self.names.len();
        let Some(c) = self.control.as_mut() else {
            return;
        };
        let s = t.scenario;
        match part {
            ControlPart::Extra => c.extra[s].add(t.weight, failure),
            ControlPart::Calibration => {
                c.calibration_runs
                    .insert(id, (s, t.weight, fidelity, failure, cost));
                if c.calibration_runs.len() as u64 == 2 * c.config.calibration {
                    c.plan(n);
                }
            }
            ControlPart::Paired => {
                let half = c.halves.entry(pair).or_default();
                match fidelity {
                    Fidelity::Hf => half.0 = Some(failure),
                    Fidelity::Lf => half.1 = Some(failure),
                }
                if let (Some(hf), Some(lf)) = *half {
                    c.halves.remove(&pair);
                    c.pairs[s].add(t.weight, hf, lf);
                }
            }
        }
    }

    /// The control variates' plan per scenario, once the calibration is complete (None
    /// before, and without control variates).
    pub fn control_plans(&self) -> Option<&[ControlPlan]> {
        self.control.as_ref().and_then(|c| c.plans.as_deref())
    }

    /// Whether the control variates' calibration is under way (asked, or waiting for
    /// outcomes).
    pub fn calibrating(&self) -> bool {
        self.pilot.is_none() && self.control.as_ref().is_some_and(|c| c.plans.is_none())
    }

    /// Refits every scenario's proposal from the round's weighted failures and starts the
    /// next round, or the estimate after the last.
    fn end_round(&mut self) {
        let Some(mut pilot) = self.pilot.take() else {
            return;
        };
        if let Some(j) = pilot.joint.as_mut() {
            let bins: Vec<_> = self.proposals.iter().map(Proposal::nominal_bins).collect();
            let fitted = j.end_round(pilot.round, &bins);
            for (m, f) in self.mixtures.iter_mut().zip(fitted) {
                if f.is_some() {
                    *m = f;
                }
            }
        }
        for (s, weight, arms) in std::mem::take(&mut pilot.failed).into_values() {
            for (m, arm) in pilot.mass[s].iter_mut().zip(arms) {
                m[arm] += weight;
            }
        }
        for (proposal, mass) in self.proposals.iter_mut().zip(&pilot.mass) {
            proposal.refit(mass, REFINE_SMOOTHING);
        }
        pilot.round += 1;
        if pilot.round < pilot.refine.rounds {
            pilot.asked = 0;
            pilot.told = 0;
            self.pilot = Some(pilot);
        }
    }

    /// The refinement round under way (None: none asked, or the pilot is over).
    pub fn round(&self) -> Option<u32> {
        self.pilot.as_ref().map(|p| p.round)
    }

    /// Trials told so far, pilot and estimate together.
    pub fn told(&self) -> u64 {
        self.told
    }

    /// Per scenario, the pilot's trials told and how many of them failed.
    pub fn pilot_runs(&self) -> Vec<(u64, u64)> {
        self.pilot_sums
            .iter()
            .map(|s| (s.runs, s.failures))
            .collect()
    }

    /// The estimate from the trials told so far: those of the final proposal and of the
    /// pilot rounds it reuses ([`Refine::reuse`]).
    pub fn estimate(&self) -> Estimate {
        let plans = self.control_plans();
        Estimate::from_scenarios(
            self.names
                .iter()
                .zip(&self.probabilities)
                .enumerate()
                .map(|(i, (n, &p))| match (plans, self.control.as_ref()) {
                    (Some(plans), Some(c)) if plans[i].use_lf => {
                        ScenarioEstimate::with_control(n, p, &c.pairs[i], &c.extra[i], plans[i])
                    }
                    (Some(plans), _) => {
                        let mut e = ScenarioEstimate::new(n, p, &self.sums[i]);
                        e.control = Some(ControlReport {
                            plan: plans[i],
                            lf_runs: 0,
                            lf_failures: 0,
                            hf_only_mean: e.estimate.mean,
                        });
                        e
                    }
                    _ => ScenarioEstimate::new(n, p, &self.sums[i]),
                })
                .collect(),
        )
    }
}

/// Zeroed Σ w·f per scenario, variable and bin.
fn empty_mass(scenarios: &[(Scenario, Posterior)]) -> Vec<Vec<Vec<f64>>> {
    scenarios
        .iter()
        .map(|(s, _)| {
            s.space
                .variables()
                .iter()
                .map(|v| vec![0.0; v.arms()])
                .collect()
        })
        .collect()
}

impl Kernel {
    /// An [`Estimation`] from this kernel's current φ posteriors and p(s) (typically after
    /// meta-training). The kernel itself is not changed.
    pub fn estimation(&self, config: &EstimationConfig) -> Result<Estimation, EstimationError> {
        let scenarios: Vec<(Scenario, Posterior)> = self
            .config()
            .scenarios
            .iter()
            .map(|s| {
                let posterior = self
                    .scenario_posterior(&s.name)
                    .cloned()
                    .ok_or(EstimationError::NoScenarios)?;
                Ok((s.clone(), posterior))
            })
            .collect::<Result<_, EstimationError>>()?;
        Estimation::new(&scenarios, config)
    }
}

#[cfg(test)]
mod control_tests;
#[cfg(test)]
mod joint_tests;
#[cfg(test)]
mod tests;

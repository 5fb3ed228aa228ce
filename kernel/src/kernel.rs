//! The ask/tell kernel: suggests trials, ingests their outcomes, learns p_ψ(φ | s) and p_ω(θ_LF).

use crate::allocation::{self, Allocation, Ledger};
use crate::deployment::Deployment;
use crate::evidence::FidelityEvidence;
use crate::outcome::{Credit, Observation, Outcome};
use crate::pairing::{Pairing, PairingError};
use crate::posterior::{Estimator, Posterior, PosteriorError, PriorCounts};
use crate::search::{Archive, InFlight, SearchError, SearchModel};
use crate::space::{Space, SpaceError};
use crate::value::Assignment;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64 as Rng64;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::sync::Arc;
use validation::validate_config;

mod builder;
mod snapshot;
mod tell;
mod validation;

pub use builder::{KernelBuilder, Preset};
pub use snapshot::{RestoreError, Snapshot};

/// The phase a trial belongs to; it fixes how the trial is drawn and what its tell updates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// Meta-training: φ and θ_LF by Thompson sampling; both bandits updated (Table I).
    #[default]
    Train,
    /// Evaluation: θ_LF greedy (MAP, or the configured estimator), φ drawn from p_ψ by Thompson
    /// sampling (with [`SearchModel::EliteMixture`]: from its proposal); nothing updated.
    Evaluate,
    /// Baseline: φ uniform over the arms (and uniform / log-uniform inside a bin), high fidelity
    /// only; nothing updated.
    Baseline,
    /// Meta-testing: like `Train`, on new scenarios, typically with a fidelity prior carried
    /// over from a meta-training posterior ([`KernelBuilder::fidelity_prior`]).
    Test,
}

impl Phase {
    /// True for phases whose trials run both simulators.
    pub fn is_paired(self) -> bool {
        self != Phase::Baseline
    }

    /// True for phases whose tells update the bandits.
    pub fn learns(self) -> bool {
        matches!(self, Phase::Train | Phase::Test)
    }
}

impl fmt::Display for Phase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Phase::Train => "train",
            Phase::Evaluate => "evaluate",
            Phase::Baseline => "baseline",
            Phase::Test => "test",
        })
    }
}

/// A suggested trial: run scenario `scenario` with parameters `phi` on the high-fidelity
/// simulator (θ_HF, see [`Kernel::theta_hf`]) and — unless this is a baseline trial — on the
/// learned-fidelity simulator with `theta_lf`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trial {
    /// Unique id, counting up from 0 in ask order.
    pub id: u64,
    /// The phase the trial was asked in.
    pub phase: Phase,
    /// Name of the scenario.
    pub scenario: Arc<str>,
    /// Index of the scenario in the kernel's list.
    pub scenario_index: usize,
    /// Scenario parameters φ.
    pub phi: Assignment,
    /// Learned-fidelity settings θ_LF; `None` for baseline trials.
    pub theta_lf: Option<Assignment>,
}

/// A told trial: the trial, what was observed, its class and what it credited. The kernel
/// returns one per tell and keeps none (the history is the caller's, or the journal's), so a
/// long campaign never slows the kernel down.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// The trial as it was asked.
    #[serde(flatten)]
    pub trial: Trial,
    /// The runs reported.
    pub observation: Observation,
    /// TP/TN/FP/FN for paired trials.
    pub outcome: Option<Outcome>,
    /// `t_LF / t_HF` for paired trials.
    pub cost_ratio: Option<f64>,
    /// What the bandits were credited.
    pub credit: Credit,
}

/// A scenario: its name, its φ-space and its weight in p(s).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Unique name.
    pub name: Arc<str>,
    /// The space of its parameters φ.
    pub space: Space,
    /// Relative weight in p(s) (normalised by the kernel); finite and > 0.
    pub weight: f64,
}

/// A fidelity prior carried over from an earlier posterior (meta-testing).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FidelityPrior {
    /// The posterior p_ω(θ_LF) of an earlier run (must fit the fidelity space).
    pub posterior: Posterior,
    /// How strongly its evidence counts ([`Posterior::as_prior`]); 1 = as learned.
    pub strength: f64,
}

/// A φ prior carried over to one scenario (meta-testing's p_ψ transfer:
/// [`crate::phi_transfer`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioPrior {
    /// The scenario it is for.
    pub scenario: Arc<str>,
    /// Its p_ψ before any trial (must fit the scenario's φ-space).
    pub posterior: Posterior,
}

/// Everything that defines a kernel before its first ask. Serialisable: it heads every journal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KernelConfig {
    /// Scenarios with their φ-spaces and weights.
    pub scenarios: Vec<Scenario>,
    /// The shared fidelity space.
    pub fidelity: Space,
    /// The high-fidelity settings θ_HF (a complete assignment inside `fidelity`).
    pub theta_hf: Assignment,
    /// C_budget in (0, 1].
    pub budget: f64,
    /// Seed of the kernel's random stream.
    pub seed: u64,
    /// Base prior counts of every arm.
    pub prior: PriorCounts,
    /// How evaluation picks θ_LF.
    pub estimator: Estimator,
    /// A fidelity prior carried over from an earlier posterior.
    pub fidelity_prior: Option<FidelityPrior>,
    /// How the learning phases draw φ (default: the paper's independent bins, which leaves
    /// the field out of the serialised configuration).
    #[serde(default, skip_serializing_if = "SearchModel::is_independent_bins")]
    pub search: SearchModel,
    /// Which learning trials also run LF (default: every one, the paper's; then left out).
    #[serde(default, skip_serializing_if = "Pairing::is_default")]
    pub pairing: Pairing,
    /// What the evaluate phase (evaluation, LF screening) learns and how it draws φ (default:
    /// frozen, the paper's; then left out).
    #[serde(default, skip_serializing_if = "Deployment::is_frozen")]
    pub deployment: Deployment,
    /// How each ask chooses its scenario (default: from p(s), the paper's; then left out).
    #[serde(default, skip_serializing_if = "Allocation::is_weights")]
    pub allocation: Allocation,
    /// φ priors carried over to some scenarios (default none, the paper's: every p_ψ starts at
    /// the base prior; then left out).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub scenario_priors: Vec<ScenarioPrior>,
}

/// Why a kernel cannot be built or restored.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// No scenario was given.
    #[error("no scenarios: give at least one")]
    NoScenarios,
    /// A scenario has an empty name.
    #[error("scenario {index} has an empty name")]
    EmptyScenarioName {
        /// Its position in the list.
        index: usize,
    },
    /// Two scenarios share a name.
    #[error("scenario `{0}` is defined twice")]
    DuplicateScenario(String),
    /// A scenario weight is zero, negative, NaN or infinite.
    #[error("scenario `{scenario}` has weight {weight}; weights must be finite and > 0")]
    BadWeight {
        /// The scenario.
        scenario: String,
        /// Its weight.
        weight: f64,
    },
    /// A scenario's φ-space is invalid.
    #[error("scenario `{scenario}`: {source}")]
    ScenarioSpace {
        /// The scenario.
        scenario: String,
        /// What is wrong.
        source: SpaceError,
    },
    /// The fidelity space is invalid.
    #[error("fidelity space: {0}")]
    FidelitySpace(SpaceError),
    /// θ_HF is not a complete assignment inside the fidelity space.
    #[error("high-fidelity settings θ_HF: {0}")]
    ThetaHf(SpaceError),
    /// C_budget outside (0, 1].
    #[error("C_budget must lie in (0, 1], got {0}")]
    BadBudget(f64),
    /// Bad prior counts, a bad prior strength, or a fidelity prior that does not fit.
    #[error("fidelity prior: {0}")]
    Prior(PosteriorError),
    /// A φ prior names no scenario of the kernel, names one twice, or does not fit its space.
    #[error("φ prior of scenario `{scenario}`: {problem}")]
    ScenarioPrior {
        /// The scenario it names.
        scenario: String,
        /// What is wrong.
        problem: String,
    },
    /// A restored state is inconsistent.
    #[error("inconsistent kernel state: {0}")]
    State(String),
    /// The search model's parameters are out of range.
    #[error("search model: {0}")]
    Search(SearchError),
    /// The pairing's parameters are out of range.
    #[error("{0}")]
    Pairing(PairingError),
    /// The scenario allocation's parameters are out of range.
    #[error("{0}")]
    Allocation(allocation::AllocationError),
}

/// Why a tell (or a cancel) was refused. A refused tell leaves the kernel unchanged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TellError {
    /// No trial with this id was ever asked.
    #[error("trial {0} was never asked")]
    Unknown(u64),
    /// The trial was told (or cancelled) before.
    #[error("trial {0} was already told or cancelled")]
    AlreadyTold(u64),
    /// A baseline (HF-only) observation for a paired trial.
    #[error("trial {id} is a {phase} trial and needs a paired (HF and LF) observation")]
    ExpectedPaired {
        /// The trial.
        id: u64,
        /// Its phase.
        phase: Phase,
    },
    /// A paired observation for a trial without θ_LF (a baseline trial, or a learning trial
    /// the [`Pairing`] left unpaired).
    #[error("trial {id} has no θ_LF and takes the HF run only")]
    ExpectedHfOnly {
        /// The trial.
        id: u64,
    },
    /// A runtime that is NaN, infinite, negative or zero.
    #[error("trial {id}: {simulator} runtime must be finite and > 0, got {runtime}")]
    BadRuntime {
        /// The trial.
        id: u64,
        /// `"HF"` or `"LF"`.
        simulator: &'static str,
        /// The runtime given.
        runtime: f64,
    },
    /// An LF-only (screened, unconfirmed) tell for a trial that learns or runs HF only.
    #[error(
        "trial {id} is a {phase} trial: only evaluation trials can be screened (told with an LF run alone, or an HF run alone)"
    )]
    NotScreened {
        /// The trial.
        id: u64,
        /// Its phase.
        phase: Phase,
    },
    /// A screened trial told with neither an LF nor an HF run.
    #[error("trial {id}: a screened trial needs its LF run, its HF run, or both")]
    NoRun {
        /// The trial.
        id: u64,
    },
    /// A robustness value that is NaN or infinite.
    #[error("trial {id}: {simulator} robustness must be a finite number, got {robustness}")]
    BadRobustness {
        /// The trial.
        id: u64,
        /// `"HF"` or `"LF"`.
        simulator: &'static str,
        /// The robustness given.
        robustness: f64,
    },
    /// Runtimes whose ratio t_LF / t_HF is not a finite number (e.g. HF 5e-324, LF 1): the
    /// ratio could not be credited, logged or replayed.
    #[error("trial {id}: the runtime ratio LF {lf} / HF {hf} is not a finite number; give runtimes on a common scale")]
    BadCostRatio {
        /// The trial.
        id: u64,
        /// The HF runtime.
        hf: f64,
        /// The LF runtime.
        lf: f64,
    },
}

/// Counters of a kernel's life so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KernelStats {
    /// Trials asked.
    pub asked: u64,
    /// Trials told.
    pub told: u64,
    /// Trials cancelled.
    pub cancelled: u64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Pending {
    trial: Trial,
    /// The drawn arms: one per φ variable, then (paired trials only) one per θ variable.
    arms: Vec<u16>,
}

/// The SAVME ask/tell kernel.
///
/// Pure and deterministic: no threads, files or clocks. The same configuration (seed included)
/// and the same sequence of calls give the same trials.
///
/// ```
/// use savme_kernel::{Kernel, Observation, Run, Scale, Space, Variable, Assignment, Phase};
/// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 5, 10])])?;
/// let mut kernel = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
///     .scenario("cut_in", Space::new(vec![
///         Variable::continuous("speed", 5.0, 30.0, 10, Scale::Linear),
///     ])?, 1.0)
///     .budget(0.3)
///     .seed(7)
///     .build()?;
/// let trial = kernel.ask();
/// assert_eq!(trial.phase, Phase::Train);
/// let speed = trial.phi.get_f64("speed").unwrap();
/// let record = kernel.tell(trial.id, Observation::Paired {
///     hf: Run::new(speed > 20.0, 1.0),
///     lf: Run::new(speed > 20.0, 0.2),
/// })?;
/// assert_eq!(record.credit.fidelity, Some(true)); // agreed, within the budget
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone)]
pub struct Kernel {
    state: Snapshot,
    /// Cumulative normalised scenario weights (derived from the config).
    cumulative: Vec<f64>,
}

impl Kernel {
    /// A builder with the fidelity space and θ_HF; add scenarios, then [`KernelBuilder::build`].
    pub fn builder(fidelity: Space, theta_hf: Assignment) -> KernelBuilder {
        KernelBuilder {
            config: KernelConfig {
                scenarios: Vec::new(),
                fidelity,
                theta_hf,
                budget: 0.3,
                seed: 0,
                prior: PriorCounts::UNIFORM,
                estimator: Estimator::Map,
                fidelity_prior: None,
                search: SearchModel::IndependentBins,
                pairing: Pairing::default(),
                deployment: Deployment::FROZEN,
                allocation: Allocation::Weights,
                scenario_priors: Vec::new(),
            },
        }
    }

    /// Validates `config` and builds a fresh kernel in the [`Phase::Train`] phase.
    pub fn new(config: KernelConfig) -> Result<Kernel, ConfigError> {
        let cumulative = validate_config(&config)?;
        let fidelity = match &config.fidelity_prior {
            Some(fp) => fp
                .posterior
                .as_prior(config.prior, fp.strength)
                .map_err(ConfigError::Prior)?,
            None => Posterior::new(&config.fidelity, config.prior).map_err(ConfigError::Prior)?,
        };
        let scenarios = config
            .scenarios
            .iter()
            .map(
                |s| match config.scenario_priors.iter().find(|p| p.scenario == s.name) {
                    Some(p) => Ok(p.posterior.clone()),
                    None => Posterior::new(&s.space, config.prior),
                },
            )
            .collect::<Result<Vec<_>, _>>()
            .map_err(ConfigError::Prior)?;
        let rng = Rng64::seed_from_u64(config.seed);
        let search = match config.search {
            SearchModel::IndependentBins => Vec::new(),
            SearchModel::EliteMixture(_) => vec![Archive::default(); config.scenarios.len()],
        };
        let ledgers = match config.allocation {
            Allocation::Weights => Vec::new(),
            Allocation::CostRate(_) => vec![Ledger::default(); config.scenarios.len()],
        };
        let evidence = (config.estimator == Estimator::Evidence)
            .then(|| FidelityEvidence::new(config.scenarios.len(), &config.fidelity));
        Ok(Kernel {
            state: Snapshot {
                config,
                phase: Phase::Train,
                next_id: 0,
                stats: KernelStats::default(),
                fidelity,
                scenarios,
                pending: Vec::new(),
                rng,
                search,
                ledgers,
                evidence,
            },
            cumulative,
        })
    }

    /// The configuration the kernel was built with.
    pub fn config(&self) -> &KernelConfig {
        &self.state.config
    }

    /// θ_HF.
    pub fn theta_hf(&self) -> &Assignment {
        &self.state.config.theta_hf
    }

    /// C_budget.
    pub fn budget(&self) -> f64 {
        self.state.config.budget
    }

    /// The phase new asks are drawn in.
    pub fn phase(&self) -> Phase {
        self.state.phase
    }

    /// Switches the phase of future asks. Pending trials keep the phase they were asked in.
    pub fn set_phase(&mut self, phase: Phase) {
        self.state.phase = phase;
    }

    /// Counters: asked, told, cancelled.
    pub fn stats(&self) -> KernelStats {
        self.state.stats
    }

    /// The current fidelity posterior p_ω(θ_LF).
    pub fn fidelity_posterior(&self) -> &Posterior {
        &self.state.fidelity
    }

    /// The current φ posterior p_ψ(φ | s) of the scenario called `name`.
    pub fn scenario_posterior(&self, name: &str) -> Option<&Posterior> {
        let i = self.scenario_index(name)?;
        Some(&self.state.scenarios[i])
    }

    /// The index of the scenario called `name`.
    pub fn scenario_index(&self, name: &str) -> Option<usize> {
        self.state
            .config
            .scenarios
            .iter()
            .position(|s| &*s.name == name)
    }

    /// The normalised p(s), in scenario order.
    pub fn scenario_probabilities(&self) -> Vec<f64> {
        let mut prev = 0.0;
        self.cumulative
            .iter()
            .map(|&c| {
                let p = c - prev;
                prev = c;
                p
            })
            .collect()
    }

    /// θ_LF* — the greedy fidelity settings under `estimator` (continuous variables at their
    /// bin's expected value). What evaluation asks use, with the configured estimator.
    pub fn fidelity_estimate(&self, estimator: Estimator) -> Assignment {
        let arms = self.fidelity_arms(estimator);
        self.state.config.fidelity.representatives(&arms)
    }

    /// The arms of θ_LF* under `estimator`, one per fidelity variable. [`Estimator::Evidence`]
    /// charges the false alarms of the kept tallies (none kept: none charged).
    pub fn fidelity_arms(&self, estimator: Estimator) -> Vec<u16> {
        let st = &self.state;
        match (estimator, &st.evidence) {
            (Estimator::Evidence, Some(e)) => {
                let totals = e.totals();
                let budget = st.config.budget;
                st.fidelity.best_arms_by(|v, k, a| {
                    crate::evidence::evidence_score(a, &totals[v][k], budget)
                })
            }
            _ => st.fidelity.best_arms(estimator),
        }
    }

    /// Per scenario, per fidelity arm, what the paired learning trials showed; kept with
    /// [`Estimator::Evidence`] only.
    pub fn fidelity_evidence(&self) -> Option<&FidelityEvidence> {
        self.state.evidence.as_ref()
    }

    /// Trials asked and not yet told or cancelled, in id order.
    pub fn pending(&self) -> impl Iterator<Item = &Trial> {
        self.state.pending.iter().map(|p| &p.trial)
    }

    /// Suggests the next trial in the current phase. Any number may be pending at once.
    pub fn ask(&mut self) -> Trial {
        let mut rng = self.state.rng.clone();
        let pending = self.draw(&mut rng);
        self.state.rng = rng;
        self.commit_ask(pending)
    }

    /// Draws the next trial with `rng` without changing the kernel (the journal writes it
    /// before [`Kernel::commit_ask`] makes it pending).
    fn draw(&self, rng: &mut Rng64) -> Pending {
        let st = &self.state;
        let phase = st.phase;
        let s = self.draw_scenario(rng);
        let scenario = &st.config.scenarios[s];
        let n_phi = scenario.space.len();
        let mut arms = Vec::with_capacity(n_phi + st.config.fidelity.len());
        let phi = self.draw_phi(phase, s, rng, &mut arms);
        let theta_lf = match phase {
            Phase::Baseline => None,
            Phase::Evaluate => {
                arms.extend(self.fidelity_arms(st.config.estimator));
                Some(st.config.fidelity.representatives(&arms[n_phi..]))
            }
            Phase::Train | Phase::Test => {
                let c = &st.config;
                // A scouted scenario (no HF failure yet) runs HF only.
                let scouting = match &c.allocation {
                    Allocation::CostRate(r) => {
                        r.scout && st.ledgers.get(s).is_some_and(|l| l.failures == 0)
                    }
                    Allocation::Weights => false,
                };
                (!scouting && c.pairing.pairs(&st.fidelity, rng)).then(|| {
                    st.fidelity.thompson(rng, &mut arms);
                    c.fidelity.draw(&arms[n_phi..], rng)
                })
            }
        };
        Pending {
            trial: Trial {
                id: st.next_id,
                phase,
                scenario: scenario.name.clone(),
                scenario_index: s,
                phi,
                theta_lf,
            },
            arms,
        }
    }

    /// Draws the scenario of the next ask: from p(s), or by the cost-rate allocation.
    fn draw_scenario(&self, rng: &mut Rng64) -> usize {
        match &self.state.config.allocation {
            Allocation::Weights => {
                let u: f64 = rng.random();
                self.cumulative
                    .iter()
                    .position(|&c| u < c)
                    .unwrap_or(self.cumulative.len() - 1)
            }
            Allocation::CostRate(rule) => {
                let mut pending = vec![0u32; self.cumulative.len()];
                for p in &self.state.pending {
                    pending[p.trial.scenario_index] += 1;
                }
                let weights = self.scenario_probabilities();
                allocation::choose(rule, &weights, &self.state.ledgers, &pending, rng)
            }
        }
    }

    /// Per scenario (kernel order), what its told trials cost and found; empty unless the
    /// allocation is [`Allocation::CostRate`].
    pub fn ledgers(&self) -> &[Ledger] {
        &self.state.ledgers
    }

    /// Draws φ of scenario `s` in `phase`, pushing its arms onto `arms`.
    fn draw_phi(&self, phase: Phase, s: usize, rng: &mut Rng64, arms: &mut Vec<u16>) -> Assignment {
        let st = &self.state;
        let space = &st.config.scenarios[s].space;
        match (phase, &st.config.search, st.search.get(s)) {
            (Phase::Baseline, _, _) => {
                arms.extend(
                    space
                        .variables()
                        .iter()
                        .map(|v| rng.random_range(0..v.arms()) as u16),
                );
            }
            // Evaluation (and LF screening, which asks what evaluation asks) deploys what the
            // search learned: the elite proposal of the frozen archive.
            (
                Phase::Train | Phase::Test | Phase::Evaluate,
                SearchModel::EliteMixture(m),
                Some(archive),
            ) => {
                let exploit = phase == Phase::Evaluate && st.config.deployment.exploit;
                let in_flight: Vec<InFlight> = if m.crowding > 0.0 || m.fantasies {
                    st.pending
                        .iter()
                        .filter(|p| p.trial.scenario_index == s)
                        .map(|p| {
                            let cell = &p.arms[..space.len()];
                            InFlight {
                                u: space.unit_of(&p.trial.phi, cell),
                                cell: cell.to_vec(),
                            }
                        })
                        .collect()
                } else {
                    Vec::new()
                };
                let draw = crate::search::Draw {
                    exploit,
                    bins: &st.scenarios[s],
                    space,
                    in_flight: &in_flight,
                };
                return archive.propose(m, &draw, rng, arms);
            }
            _ => st.scenarios[s].thompson(rng, arms),
        }
        space.draw(arms, rng)
    }

    fn commit_ask(&mut self, pending: Pending) -> Trial {
        let trial = pending.trial.clone();
        self.state.next_id += 1;
        self.state.stats.asked += 1;
        // Ids only grow, so pushing keeps `pending` sorted by id.
        self.state.pending.push(pending);
        trial
    }

    /// The complete state, to save and later [`Kernel::restore`].
    pub fn snapshot(&self) -> &Snapshot {
        &self.state
    }

    // Journal support: draw without committing, then commit.
    pub(crate) fn draw_next(&self) -> (Rng64, PendingTrial) {
        let mut rng = self.state.rng.clone();
        let pending = self.draw(&mut rng);
        (rng, PendingTrial(pending))
    }

    pub(crate) fn commit_drawn(&mut self, rng: Rng64, pending: PendingTrial) -> Trial {
        self.state.rng = rng;
        self.commit_ask(pending.0)
    }
}

/// A trial drawn but not yet pending.
pub(crate) struct PendingTrial(Pending);

impl PendingTrial {
    pub(crate) fn trial(&self) -> &Trial {
        &self.0.trial
    }
}

//! The ask/tell kernel: suggests trials, ingests their outcomes, learns p_ψ(φ | s) and p_ω(θ_LF).

use crate::outcome::{Credit, Observation, Outcome, Run};
use crate::pairing::{Pairing, PairingError};
use crate::posterior::{Estimator, Posterior, PosteriorError, PriorCounts};
use crate::search::{Archive, SearchError, SearchModel};
use crate::space::{Space, SpaceError};
use crate::validation::validate_config;
use crate::value::Assignment;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64 as Rng64;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::sync::Arc;

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
    /// A restored state is inconsistent.
    #[error("inconsistent kernel state: {0}")]
    State(String),
    /// The search model's parameters are out of range.
    #[error("search model: {0}")]
    Search(SearchError),
    /// The pairing's parameters are out of range.
    #[error("{0}")]
    Pairing(PairingError),
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
        "trial {id} is a {phase} trial: only evaluation trials take an LF run alone (screening)"
    )]
    NotScreened {
        /// The trial.
        id: u64,
        /// Its phase.
        phase: Phase,
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

/// The complete, serialisable state of a kernel ([`Kernel::snapshot`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    config: KernelConfig,
    phase: Phase,
    next_id: u64,
    stats: KernelStats,
    fidelity: Posterior,
    scenarios: Vec<Posterior>,
    pending: Vec<Pending>,
    rng: Rng64,
    /// Per scenario, the archive of [`SearchModel::EliteMixture`] (empty for the paper's
    /// independent bins, and then left out of the JSON).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    search: Vec<Archive>,
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

/// Builds a [`Kernel`]; see [`Kernel::builder`].
#[derive(Debug, Clone)]
pub struct KernelBuilder {
    config: KernelConfig,
}

impl KernelBuilder {
    /// Adds a scenario with its φ-space and weight in p(s).
    pub fn scenario(mut self, name: &str, space: Space, weight: f64) -> Self {
        self.config.scenarios.push(Scenario {
            name: Arc::from(name),
            space,
            weight,
        });
        self
    }

    /// Sets C_budget (default 0.3).
    pub fn budget(mut self, budget: f64) -> Self {
        self.config.budget = budget;
        self
    }

    /// Sets the seed (default 0).
    pub fn seed(mut self, seed: u64) -> Self {
        self.config.seed = seed;
        self
    }

    /// Sets the base prior counts of every arm (default uniform, 1 and 1).
    pub fn prior(mut self, prior: PriorCounts) -> Self {
        self.config.prior = prior;
        self
    }

    /// Sets how evaluation picks θ_LF (default [`Estimator::Map`], the paper's).
    pub fn estimator(mut self, estimator: Estimator) -> Self {
        self.config.estimator = estimator;
        self
    }

    /// Starts p_ω(θ_LF) from an earlier posterior, its evidence scaled by `strength`
    /// (meta-testing; `strength = 1` is the paper's rule).
    pub fn fidelity_prior(mut self, posterior: Posterior, strength: f64) -> Self {
        self.config.fidelity_prior = Some(FidelityPrior {
            posterior,
            strength,
        });
        self
    }

    /// Sets how the train and test phases draw φ (default [`SearchModel::IndependentBins`],
    /// the paper's).
    ///
    /// ```
    /// use savme_kernel::{Assignment, EliteMixture, Kernel, Scale, SearchModel, Space, Variable};
    /// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
    /// let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 10, Scale::Linear)])?;
    /// let kernel = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
    ///     .scenario("s", phi, 1.0)
    ///     .search(SearchModel::EliteMixture(EliteMixture::default()))
    ///     .build()?;
    /// assert!(!kernel.config().search.is_independent_bins());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn search(mut self, model: SearchModel) -> Self {
        self.config.search = model;
        self
    }

    /// Sets which learning trials also run LF (default [`Pairing::default`]: all, the
    /// paper's).
    pub fn pairing(mut self, pairing: Pairing) -> Self {
        self.config.pairing = pairing;
        self
    }

    /// Validates the configuration and builds the kernel.
    pub fn build(self) -> Result<Kernel, ConfigError> {
        Kernel::new(self.config)
    }
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
            .map(|s| Posterior::new(&s.space, config.prior))
            .collect::<Result<Vec<_>, _>>()
            .map_err(ConfigError::Prior)?;
        let rng = Rng64::seed_from_u64(config.seed);
        let search = match config.search {
            SearchModel::IndependentBins => Vec::new(),
            SearchModel::EliteMixture(_) => vec![Archive::default(); config.scenarios.len()],
        };
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
        let arms = self.state.fidelity.best_arms(estimator);
        self.state.config.fidelity.representatives(&arms)
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
        let u: f64 = rng.random();
        let s = self
            .cumulative
            .iter()
            .position(|&c| u < c)
            .unwrap_or(self.cumulative.len() - 1);
        let scenario = &st.config.scenarios[s];
        let n_phi = scenario.space.len();
        let mut arms = Vec::with_capacity(n_phi + st.config.fidelity.len());
        let phi = self.draw_phi(phase, s, rng, &mut arms);
        let theta_lf = match phase {
            Phase::Baseline => None,
            Phase::Evaluate => {
                arms.extend(st.fidelity.best_arms(st.config.estimator));
                Some(st.config.fidelity.representatives(&arms[n_phi..]))
            }
            Phase::Train | Phase::Test => {
                let c = &st.config;
                c.pairing.pairs(&st.fidelity, rng).then(|| {
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
                return archive.propose(m, &st.scenarios[s], space, rng, arms);
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

    fn pending_index(&self, id: u64) -> Result<usize, TellError> {
        if id >= self.state.next_id {
            return Err(TellError::Unknown(id));
        }
        self.state
            .pending
            .binary_search_by_key(&id, |p| p.trial.id)
            .map_err(|_| TellError::AlreadyTold(id))
    }

    pub(crate) fn check_pending(&self, id: u64) -> Result<(), TellError> {
        self.pending_index(id).map(|_| ())
    }

    /// Checks a tell and works out its record without changing anything.
    fn assess(&self, id: u64, observation: &Observation) -> Result<(usize, Assessed), TellError> {
        let index = self.pending_index(id)?;
        let pending = &self.state.pending[index];
        let phase = pending.trial.phase;
        let check = |run: &Run, simulator: &'static str| {
            if run.runtime.is_finite() && run.runtime > 0.0 {
                Ok(())
            } else {
                Err(TellError::BadRuntime {
                    id,
                    simulator,
                    runtime: run.runtime,
                })
            }
        };
        match (pending.trial.theta_lf.is_some(), observation) {
            (true, Observation::HfOnly(_)) => return Err(TellError::ExpectedPaired { id, phase }),
            (false, Observation::Paired { .. }) => return Err(TellError::ExpectedHfOnly { id }),
            _ => {}
        }
        check(observation.hf(), "HF")?;
        check_robustness(id, observation.hf(), "HF")?;
        if let Some(lf) = observation.lf() {
            check(lf, "LF")?;
            check_robustness(id, lf, "LF")?;
        }
        let outcome = observation.outcome();
        let cost_ratio = observation.cost_ratio();
        if let (Some(r), Some(lf)) = (cost_ratio, observation.lf()) {
            if !r.is_finite() {
                return Err(TellError::BadCostRatio {
                    id,
                    hf: observation.hf().runtime,
                    lf: lf.runtime,
                });
            }
        }
        let credit = match (phase.learns(), outcome, cost_ratio) {
            (true, Some(o), Some(r)) => Credit {
                fidelity: Some(o.fidelity_success(r, self.state.config.budget)),
                scenario: Some(o.scenario_success()),
            },
            // An unpaired learning trial: the HF run credits the φ search alone.
            (true, None, None) => Credit {
                fidelity: None,
                scenario: Some(observation.hf().failure),
            },
            _ => Credit::default(),
        };
        Ok((
            index,
            Assessed {
                outcome,
                cost_ratio,
                credit,
            },
        ))
    }

    /// Ingests the outcome of trial `id`: classifies it, credits the bandits per Table I (in
    /// the learning phases) and returns the record. On error nothing changes.
    pub fn tell(&mut self, id: u64, observation: Observation) -> Result<TrialRecord, TellError> {
        let (index, assessed) = self.assess(id, &observation)?;
        Ok(self.commit_tell(index, observation, assessed))
    }

    fn commit_tell(
        &mut self,
        index: usize,
        observation: Observation,
        assessed: Assessed,
    ) -> TrialRecord {
        let pending = self.state.pending.remove(index);
        let s = pending.trial.scenario_index;
        let (phi_arms, theta_arms) = pending.arms.split_at(self.state.scenarios[s].arms().len());
        if let Some(ok) = assessed.credit.scenario {
            self.state.scenarios[s].update(phi_arms, ok);
            if let (Some(archive), SearchModel::EliteMixture(m)) =
                (self.state.search.get_mut(s), &self.state.config.search)
            {
                let space = &self.state.config.scenarios[s].space;
                archive.record(space, &pending.trial.phi, phi_arms, observation.hf());
                archive.truncate(m.archive);
            }
        }
        if let Some(ok) = assessed.credit.fidelity {
            self.state.fidelity.update(theta_arms, ok);
        }
        self.state.stats.told += 1;
        TrialRecord {
            trial: pending.trial,
            observation,
            outcome: assessed.outcome,
            cost_ratio: assessed.cost_ratio,
            credit: assessed.credit,
        }
    }

    /// Tells an evaluation trial whose HF run was not made: LF screening passed it without an
    /// audit ([`crate::screening`]). Only trials of a phase that runs both simulators and
    /// learns nothing take it; on error nothing changes.
    ///
    /// ```
    /// use savme_kernel::{Kernel, Phase, Run, Space, Variable, Assignment, Scale};
    /// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
    /// let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 4, Scale::Linear)])?;
    /// let mut k = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
    ///     .scenario("s", phi, 1.0)
    ///     .build()?;
    /// let learning = k.ask();
    /// assert!(k.tell_unconfirmed(learning.id, Run::new(false, 0.2)).is_err());
    /// k.set_phase(Phase::Evaluate);
    /// let t = k.ask();
    /// assert_eq!(k.tell_unconfirmed(t.id, Run::new(false, 0.2))?.id, t.id);
    /// assert_eq!(k.stats().told, 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn tell_unconfirmed(&mut self, id: u64, lf: Run) -> Result<Trial, TellError> {
        let index = self.pending_index(id)?;
        let phase = self.state.pending[index].trial.phase;
        if phase.learns() || !phase.is_paired() {
            return Err(TellError::NotScreened { id, phase });
        }
        if !(lf.runtime.is_finite() && lf.runtime > 0.0) {
            return Err(TellError::BadRuntime {
                id,
                simulator: "LF",
                runtime: lf.runtime,
            });
        }
        check_robustness(id, &lf, "LF")?;
        self.state.stats.told += 1;
        Ok(self.state.pending.remove(index).trial)
    }

    /// Withdraws a pending trial (e.g. its simulation crashed); it will never be told.
    pub fn cancel(&mut self, id: u64) -> Result<Trial, TellError> {
        let index = self.pending_index(id)?;
        self.state.stats.cancelled += 1;
        Ok(self.state.pending.remove(index).trial)
    }

    /// The complete state, to save and later [`Kernel::restore`].
    pub fn snapshot(&self) -> &Snapshot {
        &self.state
    }

    /// Rebuilds a kernel from a snapshot, checking it for consistency first. The restored
    /// kernel makes exactly the asks the original would have made.
    pub fn restore(snapshot: Snapshot) -> Result<Kernel, ConfigError> {
        let cumulative = validate_config(&snapshot.config)?;
        let cfg = &snapshot.config;
        let state = |m: String| ConfigError::State(m);
        snapshot
            .fidelity
            .check_fits(&cfg.fidelity)
            .map_err(|e| state(format!("fidelity posterior: {e}")))?;
        if snapshot.scenarios.len() != cfg.scenarios.len() {
            return Err(state(format!(
                "{} scenario posteriors for {} scenarios",
                snapshot.scenarios.len(),
                cfg.scenarios.len()
            )));
        }
        for (p, s) in snapshot.scenarios.iter().zip(&cfg.scenarios) {
            p.check_fits(&s.space)
                .map_err(|e| state(format!("scenario `{}` posterior: {e}", s.name)))?;
        }
        check_archives(&snapshot)?;
        let mut last = None;
        for p in &snapshot.pending {
            let t = &p.trial;
            let bad = |m: &str| state(format!("pending trial {}: {m}", t.id));
            if t.id >= snapshot.next_id || last.is_some_and(|l| t.id <= l) {
                return Err(bad("id out of order"));
            }
            last = Some(t.id);
            let sc = cfg
                .scenarios
                .get(t.scenario_index)
                .filter(|s| s.name == t.scenario)
                .ok_or_else(|| bad("unknown scenario"))?;
            let arms_ok = |space: &Space, arms: &[u16]| {
                arms.len() == space.len()
                    && space
                        .variables()
                        .iter()
                        .zip(arms)
                        .all(|(v, &a)| (a as usize) < v.arms())
            };
            let (phi_arms, theta_arms) = p.arms.split_at(sc.space.len().min(p.arms.len()));
            if !arms_ok(&sc.space, phi_arms) {
                return Err(bad("φ arms do not fit the scenario"));
            }
            let paired = t.theta_lf.is_some();
            let may_skip = t.phase.learns() && !cfg.pairing.is_always();
            if (paired && !(t.phase.is_paired() && arms_ok(&cfg.fidelity, theta_arms)))
                || (!paired && (t.phase.is_paired() && !may_skip || !theta_arms.is_empty()))
            {
                return Err(bad("θ_LF does not fit its phase or the fidelity space"));
            }
        }
        Ok(Kernel {
            state: snapshot,
            cumulative,
        })
    }

    /// The snapshot as JSON.
    pub fn to_json(&self) -> String {
        // A snapshot holds only strings, numbers and maps with string keys: it always serialises.
        serde_json::to_string(&self.state).unwrap_or_default()
    }

    /// Restores from [`Kernel::to_json`] output; errors name what is wrong.
    pub fn from_json(json: &str) -> Result<Kernel, RestoreError> {
        let snapshot: Snapshot = serde_json::from_str(json).map_err(RestoreError::Parse)?;
        Kernel::restore(snapshot).map_err(RestoreError::Config)
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

    pub(crate) fn assess_tell(
        &self,
        id: u64,
        observation: Observation,
    ) -> Result<AssessedTell, TellError> {
        let (index, assessed) = self.assess(id, &observation)?;
        let pending = &self.state.pending[index];
        Ok(AssessedTell {
            index,
            record: TrialRecord {
                trial: pending.trial.clone(),
                observation,
                outcome: assessed.outcome,
                cost_ratio: assessed.cost_ratio,
                credit: assessed.credit,
            },
            assessed,
        })
    }

    pub(crate) fn commit_assessed(&mut self, a: AssessedTell) -> TrialRecord {
        let record = a.record;
        let committed = self.commit_tell(a.index, record.observation, a.assessed);
        debug_assert_eq!(committed, record);
        committed
    }
}

/// A trial drawn but not yet pending.
pub(crate) struct PendingTrial(Pending);

impl PendingTrial {
    pub(crate) fn trial(&self) -> &Trial {
        &self.0.trial
    }
}

#[derive(Debug, Clone, Copy)]
struct Assessed {
    outcome: Option<Outcome>,
    cost_ratio: Option<f64>,
    credit: Credit,
}

/// A tell checked and worked out, not yet applied.
pub(crate) struct AssessedTell {
    index: usize,
    assessed: Assessed,
    pub(crate) record: TrialRecord,
}

/// Why a JSON snapshot could not be restored.
#[derive(Debug, thiserror::Error)]
pub enum RestoreError {
    /// Not a snapshot (the message names line and column).
    #[error("snapshot is not valid JSON for a kernel state: {0}")]
    Parse(serde_json::Error),
    /// A snapshot whose contents are inconsistent.
    #[error(transparent)]
    Config(ConfigError),
}

/// Checks a finite robustness, if any.
fn check_robustness(id: u64, run: &Run, simulator: &'static str) -> Result<(), TellError> {
    match run.robustness {
        Some(r) if !r.is_finite() => Err(TellError::BadRobustness {
            id,
            simulator,
            robustness: r,
        }),
        _ => Ok(()),
    }
}

/// Checks that a snapshot's search archives fit its search model and scenarios.
fn check_archives(snapshot: &Snapshot) -> Result<(), ConfigError> {
    let cfg = &snapshot.config;
    let expected = match cfg.search {
        SearchModel::IndependentBins => 0,
        SearchModel::EliteMixture(_) => cfg.scenarios.len(),
    };
    if snapshot.search.len() != expected {
        return Err(ConfigError::State(format!(
            "{} search archives for {expected} expected",
            snapshot.search.len()
        )));
    }
    for (a, s) in snapshot.search.iter().zip(&cfg.scenarios) {
        a.check_fits(&s.space)
            .map_err(|e| ConfigError::State(format!("scenario `{}`: {e}", s.name)))?;
    }
    Ok(())
}

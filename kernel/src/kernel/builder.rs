//! [`KernelBuilder`]: a kernel's configuration assembled call by call (scenarios, budget,
//! seed, priors, estimator, search, pairing), checked when built.

use super::{ConfigError, FidelityPrior, Kernel, KernelConfig, Scenario};
use crate::allocation::Allocation;
use crate::deployment::Deployment;
use crate::pairing::Pairing;
use crate::posterior::{Estimator, Posterior, PriorCounts};
use crate::search::SearchModel;
use crate::space::Space;
use std::sync::Arc;

/// The settings a kernel starts from before any other is given: savme's tuned method or the
/// paper's SAVME. [`Kernel::builder`] starts from the paper's ([`Preset::Paper`]);
/// [`KernelBuilder::preset`] switches. The one place the kernel-level part of each method is
/// written: `savme example-config`, Python's `Kernel`, the C ABI's builder and a campaign's
/// `Method` (θ_LF*'s choice) all read it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// savme's: θ_LF* from evidence ([`Estimator::Evidence`]), the elite search
    /// ([`SearchModel::EliteMixture`]), a deployment that keeps learning
    /// ([`Deployment::ADAPTIVE`]) and scenarios by cost rate ([`Allocation::CostRate`]).
    Tuned,
    /// The paper's SAVME: θ_LF* = MAP, independent bins, a frozen deployment, scenarios from
    /// p(s).
    Paper,
}

impl Preset {
    /// How θ_LF* is read off the fidelity posterior.
    pub fn estimator(self) -> Estimator {
        match self {
            Preset::Tuned => Estimator::Evidence,
            Preset::Paper => Estimator::Map,
        }
    }

    /// How the learning phases draw φ.
    pub fn search(self) -> SearchModel {
        match self {
            Preset::Tuned => SearchModel::EliteMixture(Default::default()),
            Preset::Paper => SearchModel::IndependentBins,
        }
    }

    /// What the evaluate phase learns.
    pub fn deployment(self) -> Deployment {
        match self {
            Preset::Tuned => Deployment::ADAPTIVE,
            Preset::Paper => Deployment::FROZEN,
        }
    }

    /// How each ask chooses its scenario.
    pub fn allocation(self) -> Allocation {
        match self {
            Preset::Tuned => Allocation::CostRate(Default::default()),
            Preset::Paper => Allocation::Weights,
        }
    }
}

/// Builds a [`Kernel`]; see [`Kernel::builder`].
#[derive(Debug, Clone)]
pub struct KernelBuilder {
    pub(super) config: KernelConfig,
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

    /// Sets the estimator, search, deployment and allocation `preset` decides (the other
    /// settings stay; a later call overrides one of them).
    ///
    /// ```
    /// use savme_kernel::{Assignment, Estimator, Kernel, Preset, Scale, Space, Variable};
    /// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
    /// let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 10, Scale::Linear)])?;
    /// let kernel = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
    ///     .scenario("s", phi, 1.0)
    ///     .preset(Preset::Tuned)
    ///     .build()?;
    /// assert_eq!(kernel.config().estimator, Estimator::Evidence);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn preset(self, preset: Preset) -> Self {
        self.estimator(preset.estimator())
            .search(preset.search())
            .deployment(preset.deployment())
            .allocation(preset.allocation())
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

    /// Starts p_ψ(φ | `scenario`) from `posterior` instead of the base prior (meta-testing's
    /// φ transfer: [`crate::phi_transfer::PhiTransfer::prior`]); it must fit the scenario's
    /// φ-space ([`ConfigError::ScenarioPrior`](crate::ConfigError::ScenarioPrior) otherwise).
    pub fn scenario_prior(mut self, scenario: &str, posterior: Posterior) -> Self {
        self.config
            .scenario_priors
            .retain(|p| &*p.scenario != scenario);
        self.config.scenario_priors.push(super::ScenarioPrior {
            scenario: scenario.into(),
            posterior,
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

    /// Sets what the evaluate phase learns and how it draws φ (default
    /// [`Deployment::FROZEN`], the paper's).
    ///
    /// ```
    /// use savme_kernel::{Assignment, Deployment, Kernel, Scale, Space, Variable};
    /// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
    /// let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 10, Scale::Linear)])?;
    /// let kernel = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
    ///     .scenario("s", phi, 1.0)
    ///     .deployment(Deployment::ADAPTIVE)
    ///     .build()?;
    /// assert!(kernel.config().deployment.learn);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn deployment(mut self, deployment: Deployment) -> Self {
        self.config.deployment = deployment;
        self
    }

    /// Sets how each ask chooses its scenario (default [`Allocation::Weights`]: from p(s),
    /// the paper's).
    ///
    /// ```
    /// use savme_kernel::{Allocation, Assignment, CostRate, Kernel, Scale, Space, Variable};
    /// let fidelity = Space::new(vec![Variable::discrete("rate_hz", [2, 10])])?;
    /// let phi = Space::new(vec![Variable::continuous("gap", 0.0, 1.0, 10, Scale::Linear)])?;
    /// let kernel = Kernel::builder(fidelity, Assignment::new().with("rate_hz", 10))
    ///     .scenario("s", phi, 1.0)
    ///     .allocation(Allocation::CostRate(CostRate::default()))
    ///     .build()?;
    /// assert_eq!(kernel.ledgers().len(), 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn allocation(mut self, allocation: Allocation) -> Self {
        self.config.allocation = allocation;
        self
    }

    /// Validates the configuration and builds the kernel.
    pub fn build(self) -> Result<Kernel, ConfigError> {
        Kernel::new(self.config)
    }
}

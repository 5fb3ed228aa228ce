//! The kernels of a campaign, one per stage family: the baselines (uniform φ), one per budget
//! for meta-training and its evaluation, and a fresh one per meta-testing stage (learned or
//! uniform fidelity prior). All are configured before the first run, so that a configuration
//! error comes before any simulation.

use super::log::{LogLine, TrialLine};
use super::protocol::{Compact, LadderTraining, Protocol, Stage, StageId, StageKind, Transfer};
use super::report::fidelity;
use super::{CampaignError, Problem};
use savme_kernel::{Assignment, Kernel, KernelBuilder, Space};

/// Scenario names with their parameter spaces.
type NamedSpaces = Vec<(String, Space)>;

/// The kernels of one campaign.
pub(crate) struct StageKernels<'a> {
    protocol: &'a Protocol,
    problem: &'a Problem,
    test_spaces: NamedSpaces,
    /// baseline-train, train@b for every budget, baseline-test.
    kernels: Vec<Kernel>,
    /// The current meta-testing kernel.
    test: Option<Kernel>,
}

/// A transferred prior that cannot be built (a bad strength), as the kernel would say it.
fn prior_error(e: savme_kernel::PosteriorError) -> CampaignError {
    CampaignError::Kernel(savme_kernel::ConfigError::Prior(e))
}

/// The spaces of the scenarios `names`, or an error naming an unknown one.
fn pick(names: &[String], problem: &Problem) -> Result<NamedSpaces, CampaignError> {
    names
        .iter()
        .map(|n| {
            problem
                .scenarios
                .get(n)
                .map(|s| (n.clone(), s.clone()))
                .ok_or_else(|| CampaignError::UnknownScenario {
                    name: n.clone(),
                    known: problem
                        .scenarios
                        .keys()
                        .cloned()
                        .collect::<Vec<_>>()
                        .join(", "),
                })
        })
        .collect()
}

impl<'a> StageKernels<'a> {
    /// Checks every scenario and configures every kernel.
    pub(crate) fn new(protocol: &'a Protocol, problem: &'a Problem) -> Result<Self, CampaignError> {
        let train = pick(&protocol.train_scenarios, problem)?;
        let test_spaces = pick(&protocol.test_scenarios, problem)?;
        let mut k = StageKernels {
            protocol,
            problem,
            test_spaces,
            kernels: Vec::new(),
            test: None,
        };
        let seed_of = |kind, budget| StageId::new(kind, budget).to_string();
        // The baselines are random search: scenarios from p(s) whatever the allocation.
        let uniform = savme_kernel::Allocation::Weights;
        let baseline = seed_of(StageKind::BaselineTrain, None);
        let mut kernels = vec![k
            .builder(&train, 1.0, &baseline)
            .allocation(uniform)
            .build()?];
        for &b in &protocol.budgets {
            kernels.push(
                k.builder(&train, b, &seed_of(StageKind::Train, Some(b)))
                    .build()?,
            );
        }
        let baseline = seed_of(StageKind::BaselineTest, None);
        kernels.push(
            k.builder(&k.test_spaces, 1.0, &baseline)
                .allocation(uniform)
                .build()?,
        );
        k.kernels = kernels;
        // The meta-testing kernels are built per stage; build one now to check them too.
        k.test_kernel(StageKind::TestUniform, protocol.budgets[0], None, &[])?;
        Ok(k)
    }

    /// A kernel builder seeded by `label`: a stage's label (a [`StageId`] written out), or
    /// `test@B` for the meta-testing kernels of budget B.
    fn builder(&self, scenarios: &[(String, Space)], budget: f64, label: &str) -> KernelBuilder {
        let p = self.protocol;
        let mut b = Kernel::builder(self.problem.fidelity.clone(), self.problem.theta_hf.clone())
            .budget(budget)
            .seed(p.kernel_seed(label))
            .search(p.search.model(p.elite))
            .pairing(p.pairing())
            .deployment(p.deployment.kernel())
            .allocation(p.allocation.kernel(p.coverage_floor))
            .estimator(p.theta_lf_choice.kernel());
        for (name, space) in scenarios {
            b = b.scenario(name, space.clone(), p.weight(name));
        }
        b
    }

    fn budget_index(&self, b: f64) -> usize {
        self.protocol
            .budgets
            .iter()
            .position(|&x| x == b)
            .unwrap_or(0)
    }

    /// A meta-testing kernel at budget `b`: with the meta-training posterior as its fidelity
    /// prior (learned), or a uniform one. Both share a seed: common random numbers make the
    /// comparison fairer.
    /// A prior-strength ablation stage (`strength`) is a learned-prior kernel with another
    /// strength, from the same seed too. With `transfer = auto` the learned prior's strength
    /// per fidelity setting comes from the meta-training lines among `lines`
    /// ([`report::fidelity::transfer`], which the report shows), and so does p_ψ's prior of
    /// each test scenario that shares φ variables with training scenarios
    /// ([`report::fidelity::phi_priors`]).
    fn test_kernel(
        &self,
        kind: StageKind,
        b: f64,
        strength: Option<f64>,
        lines: &[LogLine],
    ) -> Result<Kernel, CampaignError> {
        let mut builder = self.builder(&self.test_spaces, b, &format!("test@{}", Compact(b)));
        if kind == StageKind::TestLearned {
            let trained = self.kernels[1 + self.budget_index(b)].fidelity_posterior();
            let p = self.protocol;
            builder = match (strength, p.transfer) {
                (None, Transfer::Auto) => {
                    let trials: Vec<TrialLine> =
                        lines.iter().filter_map(|l| l.trial().cloned()).collect();
                    let train = fidelity::train_lines(p, &trials, b);
                    let strengths = fidelity::transfer(p, &train, self.problem).strengths;
                    let prior = trained
                        .as_prior_per_variable(trained.prior(), &strengths)
                        .map_err(prior_error)?;
                    // p_ψ too, where test scenarios share φ variables with training ones.
                    let phi = fidelity::phi_priors(p, &train, self.problem).map_err(prior_error)?;
                    phi.into_iter()
                        .fold(builder.fidelity_prior(prior, 1.0), |b, (name, prior)| {
                            b.scenario_prior(&name, prior)
                        })
                }
                _ => builder.fidelity_prior(trained.clone(), strength.unwrap_or(p.prior_strength)),
            };
        }
        Ok(builder.build()?)
    }

    /// The fidelity ladder's levels below a screening stage's budget, cheapest first: each
    /// level's budget and the θ_LF* its meta-training kernel deploys (what its evaluation
    /// asks) — with `ladder_training = shared`, the θ_LF* read off the top level's meta-training
    /// lines among `lines` re-credited at the level's budget
    /// ([`fidelity::shared_level_theta`]). Empty for a stage at no ladder's top (the two-level
    /// screening) and for every other stage. Each level's meta-training comes before
    /// (`Protocol::validate`), and deployment never changes a kernel's fidelity posterior, so
    /// θ_LF* is final here.
    pub(crate) fn rungs(&self, stage: &Stage, lines: &[LogLine]) -> Vec<(f64, Assignment)> {
        let (StageKind::Screen, Some(b)) = (stage.kind, stage.budget) else {
            return Vec::new();
        };
        let p = self.protocol;
        let mut levels = p.levels(b);
        levels.pop();
        if levels.is_empty() {
            return Vec::new();
        }
        if p.ladder_training == LadderTraining::Shared {
            let trials: Vec<TrialLine> = lines.iter().filter_map(|l| l.trial().cloned()).collect();
            let train = fidelity::train_lines(p, &trials, b);
            return levels
                .into_iter()
                .map(|l| {
                    let theta = fidelity::shared_level_theta(p, &train, &self.problem.fidelity, l);
                    (l, theta)
                })
                .collect();
        }
        levels
            .into_iter()
            .map(|l| {
                let k = &self.kernels[1 + self.budget_index(l)];
                (l, k.fidelity_estimate(k.config().estimator))
            })
            .collect()
    }

    /// The kernel that runs `stage` (a meta-testing stage gets a new one).
    /// `lines`: every stage's lines so far (the transfer of `transfer = auto` reads them).
    pub(crate) fn for_stage(
        &mut self,
        stage: &Stage,
        lines: &[LogLine],
    ) -> Result<&mut Kernel, CampaignError> {
        let n = self.protocol.budgets.len();
        match (stage.kind, stage.budget) {
            (StageKind::BaselineTrain, _) => Ok(&mut self.kernels[0]),
            (StageKind::Train | StageKind::Evaluate | StageKind::Screen, Some(b)) => {
                let i = 1 + self.budget_index(b);
                Ok(&mut self.kernels[i])
            }
            (StageKind::BaselineTest, _) => Ok(&mut self.kernels[1 + n]),
            (kind, b) => {
                let kernel = self.test_kernel(kind, b.unwrap_or(1.0), stage.strength, lines)?;
                Ok(self.test.insert(kernel))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{self, Overrides};
    use crate::Method;

    #[test]
    fn the_baselines_draw_scenarios_from_p_s_whatever_the_allocation() {
        let over = Overrides {
            method: Some(Method::Tuned),
            ..Overrides::default()
        };
        let (p, problem) = config::toy(config::TOY, &over).expect("toy protocol");
        let mut kernels = StageKernels::new(&p, &problem).expect("kernels");
        for stage in p.stages() {
            let k = kernels.for_stage(&stage, &[]).expect("a kernel");
            let baseline = matches!(
                stage.kind,
                StageKind::BaselineTrain | StageKind::BaselineTest
            );
            assert_eq!(
                k.config().allocation.is_weights(),
                baseline,
                "{}",
                stage.label()
            );
        }
    }
}

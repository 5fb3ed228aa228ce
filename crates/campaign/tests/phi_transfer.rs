//! Meta-testing's φ (p_ψ) transfer in a whole campaign: a test scenario sharing the φ variable
//! `gap` (same name and domain) with three training scenarios gets p_ψ's prior from them when
//! they agree on where `gap` fails, and the uniform prior when they disagree; the report says
//! which strength and why, and the paper's method (transfer fixed) transfers no φ.

use savme_campaign::report::fidelity::ScenarioPhiTransfer;
use savme_campaign::{Campaign, Cost, Method, Problem, Protocol, StageKind};
use savme_kernel::{Assignment, Role, Scale, SimError, SimResult, Simulator, Space, Variable};
use std::collections::BTreeMap;

const TRAIN: [&str; 3] = ["train_a", "train_b", "train_c"];
const TEST: &str = "test_d";

/// Fails where the scenario's `gap` bin (of 5 over 0–10 m) is its failing one; costs 4 work
/// units a run. `agree`: every scenario fails in bin 0; otherwise
/// the training scenarios fail in bins 0, 2 and 4 and the test scenario in bin 0.
#[derive(Clone)]
struct GapBins {
    agree: bool,
}

impl Simulator for GapBins {
    fn simulate_as(
        &mut self,
        _role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        let gap = phi.get("gap").and_then(|v| v.as_f64()).unwrap_or(0.0);
        let rate = fidelity.get("rate").and_then(|v| v.as_f64()).unwrap_or(4.0);
        let bin = match (self.agree, scenario) {
            (false, "train_b") => 2.0,
            (false, "train_c") => 4.0,
            _ => 0.0,
        };
        let failure = gap >= 2.0 * bin && gap < 2.0 * (bin + 1.0);
        Ok(SimResult::new(failure, 0.001, Some(rate as u64)))
    }
}

fn problem() -> Problem {
    let gap = || Variable::continuous("gap", 0.0, 10.0, 5, Scale::Linear);
    let own = |name: &str, hi: f64| Variable::continuous(name, 0.0, hi, 4, Scale::Linear);
    let mut scenarios = BTreeMap::new();
    for (i, name) in TRAIN.iter().enumerate() {
        let space = Space::new(vec![gap(), own("speed", 10.0 + i as f64)]).unwrap();
        scenarios.insert(name.to_string(), space);
    }
    scenarios.insert(
        TEST.to_string(),
        Space::new(vec![own("speed", 20.0), gap()]).unwrap(),
    );
    Problem {
        // One LF arm: the fidelity transfer cannot change which θ a trial draws, so
        // test-learned and test-uniform differ by the φ transfer alone.
        fidelity: Space::new(vec![Variable::discrete("rate", [4])]).unwrap(),
        theta_hf: Assignment::new().with("rate", 4),
        scenarios,
    }
}

/// Runs the tiny campaign; its φ transfer report and the HF failures of test-learned and
/// test-uniform.
fn campaign(agree: bool, method: Method, dir: &str) -> (Vec<ScenarioPhiTransfer>, usize, usize) {
    let out = std::env::temp_dir().join(format!("savme-phi-transfer-{dir}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let train: Vec<String> = TRAIN.iter().map(|s| s.to_string()).collect();
    let mut p = Protocol::quick("phi-transfer", train, vec![TEST.into()]).with_method(method);
    p.cost = Cost::Work;
    p.seed = 3;
    p.train_iterations = 150;
    p.eval_iterations = 4;
    p.test_iterations = 30;
    p.baseline_train_iterations = 4;
    p.baseline_test_iterations = 4;
    // Every trial paired (the tuned method pairs a quarter once θ_LF* settles, and the
    // transferred fidelity prior settles it sooner, which would move the φ draws too): what
    // differs between the learned and the uniform stage is then the φ transfer alone.
    p.pair_fraction = 1.0;
    let outcome = Campaign::new(p, problem())
        .out(&out)
        .jobs(1)
        .run(&GapBins { agree })
        .expect("the campaign runs");
    let failures = |kind| {
        outcome
            .trials
            .iter()
            .filter(|l| l.stage.kind == kind && l.hf.failure)
            .count()
    };
    let phi = outcome.report.budgets[0]
        .fidelity
        .as_ref()
        .expect("a fidelity report")
        .transfer
        .phi
        .clone();
    let found = (
        failures(StageKind::TestLearned),
        failures(StageKind::TestUniform),
    );
    let _ = std::fs::remove_dir_all(&out);
    (phi, found.0, found.1)
}

fn gap_of(phi: &[ScenarioPhiTransfer]) -> &savme_kernel::phi_transfer::SharedVariable {
    assert_eq!(phi.len(), 1);
    assert_eq!(phi[0].scenario, TEST);
    let vars = &phi[0].transfer.variables;
    assert_eq!(vars[0].variable, "speed");
    assert!(
        vars[0].scenarios.is_empty(),
        "speed's ranges differ: {vars:?}"
    );
    assert_eq!(vars[0].strength, 0.0);
    assert_eq!(vars[1].variable, "gap");
    assert_eq!(vars[1].scenarios, TRAIN);
    assert_eq!(vars[1].held_out, 3);
    &vars[1]
}

#[test]
fn training_scenarios_that_agree_transfer_p_psi_and_ones_that_disagree_shrink_to_uniform() {
    let (phi, learned, uniform) = campaign(true, Method::Tuned, "agree");
    let gap = gap_of(&phi);
    assert!(gap.strength > 0.0, "{gap:?}");
    assert!(phi[0].used);
    assert!(gap.why().contains("agree"), "{}", gap.why());
    // The transferred prior draws the failing bin first: more HF failures in 30 trials
    // (27 against 14 when written).
    assert!(
        learned >= uniform + 5,
        "learned {learned}, uniform {uniform}"
    );

    let (phi, learned, uniform) = campaign(false, Method::Tuned, "disagree");
    let gap = gap_of(&phi);
    assert_eq!(gap.strength, 0.0, "{gap:?}");
    assert!(!phi[0].used);
    assert!(gap.why().contains("disagree"), "{}", gap.why());
    let ll = &gap.log_likelihood;
    assert!(ll[0] > ll[ll.len() - 1] + 10.0, "{ll:?}");
    // Nothing transferred: the learned-prior stage is the uniform one, trial for trial.
    assert_eq!(learned, uniform);
}

#[test]
fn the_papers_method_transfers_no_phi() {
    let (phi, learned, uniform) = campaign(true, Method::Paper, "paper");
    let gap = gap_of(&phi);
    assert!(gap.strength > 0.0, "what auto would choose: {gap:?}");
    assert!(!phi[0].used, "transfer fixed uses none");
    assert_eq!(learned, uniform);
}

//! What the campaign recording's layout needs before the first trial ([`CampaignPlan`]: the
//! fidelity space and one tab per learning stage) and the geometry of the posterior grids
//! (cell size, name column, key row, [`grid_bounds`]) that both the layout and the campaign
//! view use.

use savme_campaign::{Problem, Protocol, StageKind};
use savme_kernel::Space;

/// Cell size of the posterior grids (2D view units). A cell's box takes [`CELL_FILL`] of it;
/// the viewer draws labels at a fixed pixel size, so a cell is as tall as it is wide: in the
/// default window (1600×1000) a θ grid row is then ~50 px, room for its two lines of text
/// (name and posterior mean, ~16 px each) inside its borders.
pub(crate) const CELL: (f32, f32) = (10.0, 10.0);
/// The share of a cell its box takes (the rest is the gap between boxes).
pub(crate) const CELL_FILL: f32 = 0.95;
/// Columns the key row under a grid takes: five steps of the colour scale, θ_HF, MAP.
pub(crate) const KEY_CELLS: usize = 7;
/// Width of the column of row names left of a grid, in cells (a label is centred on its box,
/// so a name never reaches into the grid, and the view, which frames the boxes, never crops it).
pub(crate) const NAME_CELLS: f32 = 4.0;

/// The box of a row's name: `NAME_CELLS` cells wide, left of the grid's first column, at `y`.
pub(crate) fn name_box(y: f32) -> ((f32, f32), (f32, f32)) {
    let (w, h) = CELL;
    (
        (-(NAME_CELLS + 0.1) * w, y),
        (NAME_CELLS * w, h * CELL_FILL),
    )
}

/// The part of the 2D plane a grid of `space` takes (with its names and key row), as
/// `[x_min, x_max, y_min, y_max]`: what its view shows, with a margin, so that no cell, name or
/// key is cropped.
pub fn grid_bounds(space: &Space) -> [f32; 4] {
    let (w, h) = CELL;
    let cols = space
        .variables()
        .iter()
        .map(|v| v.arms())
        .max()
        .unwrap_or(1)
        .max(KEY_CELLS) as f32;
    let rows = space.variables().len() as f32;
    [
        -(NAME_CELLS + 0.4) * w,
        (cols + 0.3) * w,
        -0.4 * h,
        (rows + 1.6) * h,
    ]
}

/// A learning stage's tab of posterior grids: its entity label, its label, and the scenarios
/// it learns φ-bins of.
#[derive(Debug, Clone)]
pub struct LearningTab {
    /// The stage's entity-path label (`train_0_3`).
    pub entity: String,
    /// The stage's label (`train@0.3`).
    pub label: String,
    /// Its scenarios with their spaces.
    pub scenarios: Vec<(String, Space)>,
}

/// What the campaign layout needs to know before the first trial.
#[derive(Debug, Clone)]
pub struct CampaignPlan {
    /// The fidelity space (the θ grid's extent).
    pub fidelity: Space,
    /// One tab per learning stage.
    pub learning: Vec<LearningTab>,
}

impl CampaignPlan {
    /// What the layout needs: the fidelity space, and the learning stages (one tab of
    /// posterior grids each) with their scenarios.
    pub fn new(problem: &Problem, protocol: &Protocol) -> CampaignPlan {
        let learning = protocol
            .stages()
            .iter()
            .filter(|s| s.phase().learns())
            .map(|s| {
                let names = match s.kind {
                    StageKind::TestLearned | StageKind::TestUniform | StageKind::BaselineTest => {
                        &protocol.test_scenarios
                    }
                    _ => &protocol.train_scenarios,
                };
                LearningTab {
                    entity: entity_label(&s.label()),
                    label: s.label(),
                    scenarios: names
                        .iter()
                        .filter_map(|n| Some((n.clone(), problem.scenarios.get(n)?.clone())))
                        .collect(),
                }
            })
            .collect();
        CampaignPlan {
            fidelity: problem.fidelity.clone(),
            learning,
        }
    }
}

/// A stage label as an entity-path part: `train@0.3` → `train_0_3`.
pub fn entity_label(label: &str) -> String {
    label.replace(['@', '.'], "_")
}

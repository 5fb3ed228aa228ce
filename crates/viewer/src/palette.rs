//! The colours every view shares: one fixed colour per stage kind (the same stage has the same
//! colour on every campaign plot and in the stage key), HF and LF runs of a trial, and the
//! posterior grids' heat scale.

use rerun::Color;
use savme_campaign::{Protocol, StageKind};
use std::collections::BTreeMap;

/// The HF run's colour (its ego, its curves): red.
pub const HF: [u8; 3] = [230, 60, 50];
/// The LF run's colour: blue.
pub const LF: [u8; 3] = [60, 140, 240];
/// Reference lines (the failure threshold, budgets): light grey.
pub const REFERENCE: [u8; 3] = [200, 200, 200];

/// A colour as rerun takes it.
pub fn rgb([r, g, b]: [u8; 3]) -> Color {
    Color::from_rgb(r, g, b)
}

/// The colour of a stage kind: distinct hues, the three curves a reader compares most —
/// learned prior, uniform prior, baseline — far apart (orange, blue, white).
pub fn kind_colour(kind: StageKind) -> [u8; 3] {
    match kind {
        StageKind::TestLearned => [255, 140, 20],
        StageKind::TestUniform => [50, 130, 255],
        StageKind::BaselineTest => [235, 235, 235],
        StageKind::Train => [40, 200, 90],
        StageKind::Evaluate => [190, 110, 240],
        StageKind::Screen => [240, 220, 40],
        StageKind::BaselineTrain => [240, 110, 180],
    }
}

/// Every stage's colour by its label: its kind's colour, darker for each further stage of the
/// same kind (another budget, a prior-strength ablation) in protocol order.
///
/// ```
/// use savme_campaign::Protocol;
/// let p = Protocol::paper("demo", vec!["a".into()], vec!["b".into()]);
/// let colours = savme_viewer::stage_colours(&p);
/// assert_eq!(colours.len(), p.stages().len());
/// ```
pub fn stage_colours(protocol: &Protocol) -> BTreeMap<String, Color> {
    let mut seen: BTreeMap<&'static str, u32> = BTreeMap::new();
    let mut out = BTreeMap::new();
    for stage in protocol.stages() {
        let k = seen.entry(stage.kind.name()).or_insert(0);
        let shade = 0.72f32.powi(*k as i32);
        *k += 1;
        let [r, g, b] = kind_colour(stage.kind);
        let s = |c: u8| (f32::from(c) * shade).round() as u8;
        out.insert(stage.label(), Color::from_rgb(s(r), s(g), s(b)));
    }
    out
}

/// Light blue (0) to yellow (1): a posterior mean (as a grid cell's outline and text, so even
/// the low end stays readable on the viewer's dark background).
pub fn heat(t: f64) -> Color {
    let t = t.clamp(0.0, 1.0) as f32;
    let lerp = |a: f32, b: f32| (a + (b - a) * t) as u8;
    Color::from_rgb(lerp(100.0, 250.0), lerp(150.0, 220.0), lerp(255.0, 40.0))
}

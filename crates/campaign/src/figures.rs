//! The campaign's figures, drawn by savme-plot: which curves each shows, from the trial lines.
//! A campaign's `breakeven.png` (found failures over runtime during meta-training per budget,
//! against the baseline, break-even points ringed) and `meta_testing.png` (per budget the
//! baseline, the uniform and the learned fidelity prior); a repeated campaign's figures show the
//! same curves as the median over the seeds with a min–max band.

use super::log::TrialLine;
use super::protocol::{Compact, Protocol, StageKind};
use super::report::curve;
use super::report::intervals::band;
use super::CampaignError;
use savme_kernel::metrics::{break_even, FailureCurve};
use savme_plot::{BandCurve, Colour, Curve, Panel, PlotError};
use std::path::Path;

/// The baselines' legend entry.
const BASELINE: &str = "baseline (φ uniform, HF only)";

/// Grid points per band.
const GRID: usize = 200;

fn lines_of<'a>(lines: &'a [TrialLine], label: &str) -> Vec<&'a TrialLine> {
    let id = label.parse::<crate::StageId>().ok();
    lines.iter().filter(|l| Some(l.stage) == id).collect()
}

/// Draws a figure into `path` through a fresh file savme created (the PNG encoder opens the
/// path itself), naming the file in the error.
fn save(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), PlotError>,
) -> Result<(), CampaignError> {
    let drawn = super::store::safe_file::write_via_fresh_file(
        path,
        |p| draw(p).map_err(|e| e.to_string()),
        |e| e.to_string(),
    );
    drawn.map_err(|message| CampaignError::Plot {
        path: path.to_path_buf(),
        message,
    })
}

/// A curve without a break-even point.
fn plain(label: &str, colour: Colour, curve: FailureCurve) -> Curve {
    Curve {
        label: label.to_string(),
        colour,
        curve,
        break_even: None,
    }
}

/// `breakeven.png`: found failures over runtime during meta-training for each budget, against
/// the baseline (every run charged), as in the paper's break-even figure.
pub fn breakeven(path: &Path, p: &Protocol, lines: &[TrialLine]) -> Result<(), CampaignError> {
    let base = curve(&lines_of(lines, StageKind::BaselineTrain.name()));
    let mut series = vec![plain(BASELINE, Colour::BLACK, base)];
    for (i, b) in p.budgets.iter().enumerate() {
        let train = curve(&lines_of(lines, &format!("train@{}", Compact(*b))));
        let at = (!series[0].curve.points().is_empty())
            .then(|| break_even(&train, &series[0].curve))
            .flatten();
        series.push(Curve {
            label: format!("SAVME meta-training, C_budget = {b}"),
            colour: Colour::nth(i),
            curve: train,
            break_even: at,
        });
    }
    let panel = Panel {
        title: "Found failures during meta-training".into(),
        series,
        x_max: None,
    };
    save(path, |path| {
        savme_plot::curves(path, (900, 560), p.cost.measure(), &[panel])
    })
}

/// `meta_testing.png`: one panel per budget with the baseline, the uniform fidelity prior and
/// the learned one, up to the shortest of the three runtimes.
pub fn meta_testing(path: &Path, p: &Protocol, lines: &[TrialLine]) -> Result<(), CampaignError> {
    let base = curve(&lines_of(lines, StageKind::BaselineTest.name()));
    let panels: Vec<Panel<Curve>> = p
        .budgets
        .iter()
        .map(|b| {
            let stage = |s: &str| curve(&lines_of(lines, &format!("{s}@{}", Compact(*b))));
            let series = vec![
                plain(BASELINE, Colour::BLACK, base.clone()),
                plain(
                    "uniform fidelity prior",
                    Colour::nth(1),
                    stage("test-uniform"),
                ),
                plain(
                    "learned fidelity prior",
                    Colour::nth(0),
                    stage("test-learned"),
                ),
            ];
            let horizon = series
                .iter()
                .map(|s| s.curve.end())
                .filter(|&e| e > 0.0)
                .fold(f64::INFINITY, f64::min);
            Panel {
                title: format!("Meta-testing, C_budget = {b}"),
                series,
                x_max: horizon.is_finite().then_some(horizon),
            }
        })
        .collect();
    let width = 620 * panels.len().max(1) as u32;
    save(path, |path| {
        savme_plot::curves(path, (width, 520), p.cost.measure(), &panels)
    })
}

/// One stage's curves over the seeds.
struct Seeds {
    label: String,
    colour: Colour,
    curves: Vec<FailureCurve>,
}

impl Seeds {
    fn of(label: String, colour: Colour, runs: &[&[TrialLine]], stage: &str) -> Self {
        Seeds {
            label,
            colour,
            curves: runs.iter().map(|l| curve(&lines_of(l, stage))).collect(),
        }
    }

    /// The shortest of the seeds' runtimes (where every seed's curve is defined).
    fn common_end(&self) -> f64 {
        self.curves
            .iter()
            .map(FailureCurve::end)
            .fold(f64::INFINITY, f64::min)
    }

    /// The median and range over the seeds on a grid from 0 to `end`.
    fn band(self, end: f64) -> BandCurve {
        let grid: Vec<f64> = (0..=GRID).map(|i| end * i as f64 / GRID as f64).collect();
        let fns: Vec<Box<dyn Fn(f64) -> f64 + '_>> = self
            .curves
            .iter()
            .map(|c| Box::new(move |x: f64| c.failures_at(x) as f64) as Box<dyn Fn(f64) -> f64>)
            .collect();
        let refs: Vec<&dyn Fn(f64) -> f64> = fns.iter().map(|f| f.as_ref()).collect();
        let band = band(&grid, &refs);
        BandCurve {
            label: self.label,
            colour: self.colour,
            band,
        }
    }
}

/// A band panel: every series up to the shortest runtime of any seed's stage.
fn band_panel(title: String, series: Vec<Seeds>) -> Panel<BandCurve> {
    let end = series
        .iter()
        .map(Seeds::common_end)
        .fold(f64::INFINITY, f64::min);
    let end = if end.is_finite() { end } else { 0.0 };
    Panel {
        title,
        series: series.into_iter().map(|s| s.band(end)).collect(),
        x_max: Some(end),
    }
}

/// `breakeven.png` of a repeated campaign: median found failures over runtime during
/// meta-training per budget and of the baseline, each with its min–max band over the seeds.
pub fn breakeven_bands(
    path: &Path,
    p: &Protocol,
    runs: &[&[TrialLine]],
) -> Result<(), CampaignError> {
    let n = runs.len();
    let base = StageKind::BaselineTrain.name();
    let mut series = vec![Seeds::of(BASELINE.into(), Colour::BLACK, runs, base)];
    for (i, b) in p.budgets.iter().enumerate() {
        series.push(Seeds::of(
            format!("SAVME meta-training, C_budget = {b}"),
            Colour::nth(i),
            runs,
            &format!("train@{}", Compact(*b)),
        ));
    }
    let title = format!("Found failures during meta-training ({n} seeds: median, min–max)");
    let panel = band_panel(title, series);
    save(path, |path| {
        savme_plot::bands(path, (900, 560), p.cost.measure(), &[panel])
    })
}

/// `meta_testing.png` of a repeated campaign: one panel per budget with the baseline, the
/// uniform and the learned prior, median and min–max band over the seeds, up to the shortest
/// runtime of any seed's stage.
pub fn meta_testing_bands(
    path: &Path,
    p: &Protocol,
    runs: &[&[TrialLine]],
) -> Result<(), CampaignError> {
    let panels: Vec<Panel<BandCurve>> = p
        .budgets
        .iter()
        .map(|b| {
            let stage = |s: &str| format!("{s}@{}", Compact(*b));
            let series = vec![
                Seeds::of(
                    BASELINE.into(),
                    Colour::BLACK,
                    runs,
                    StageKind::BaselineTest.name(),
                ),
                Seeds::of(
                    "uniform fidelity prior".into(),
                    Colour::nth(1),
                    runs,
                    &stage("test-uniform"),
                ),
                Seeds::of(
                    "learned fidelity prior".into(),
                    Colour::nth(0),
                    runs,
                    &stage("test-learned"),
                ),
            ];
            let title = format!(
                "Meta-testing, C_budget = {b} ({} seeds: median, min–max)",
                runs.len()
            );
            band_panel(title, series)
        })
        .collect();
    let width = 620 * panels.len().max(1) as u32;
    save(path, |path| {
        savme_plot::bands(path, (width, 520), p.cost.measure(), &panels)
    })
}

//! The figures of a repeated campaign: per curve the median over the seeds and a band from the
//! smallest to the largest seed, on a common runtime grid.

use super::{bitmap, legend, lines_of, save, scale, tick, FONT, PALETTE};
use crate::log::TrialLine;
use crate::protocol::{Compact, Cost, Protocol, StageKind};
use crate::report::curve;
use crate::report::intervals::Band;
use crate::CampaignError;
use plotters::prelude::*;
use savme_kernel::metrics::FailureCurve;
use std::path::Path;

/// Grid points per band.
const GRID: usize = 200;

/// One stage's curves over the seeds.
struct BandSeries {
    label: String,
    colour: RGBColor,
    curves: Vec<FailureCurve>,
}

impl BandSeries {
    fn of(label: String, colour: RGBColor, runs: &[&[TrialLine]], stage: &str) -> Self {
        BandSeries {
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

    fn band(&self, end: f64) -> Band {
        let grid: Vec<f64> = (0..=GRID).map(|i| end * i as f64 / GRID as f64).collect();
        let fns: Vec<Box<dyn Fn(f64) -> f64 + '_>> = self
            .curves
            .iter()
            .map(|c| Box::new(move |x: f64| c.failures_at(x) as f64) as Box<dyn Fn(f64) -> f64>)
            .collect();
        let refs: Vec<&dyn Fn(f64) -> f64> = fns.iter().map(|f| f.as_ref()).collect();
        Band::of(&grid, &refs)
    }
}

fn draw_bands<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    series: &[BandSeries],
    cost: Cost,
    x_max: f64,
) -> Result<(), String> {
    let (k, x_desc, _) = scale(cost, x_max);
    let bands: Vec<Band> = series.iter().map(|s| s.band(x_max)).collect();
    let y_end = bands
        .iter()
        .flat_map(|b| b.hi.iter().copied())
        .fold(1.0, f64::max);
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..(x_max * k).max(1e-9), 0.0..y_end * 1.05)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("found failures")
        .x_label_formatter(&|x| tick(*x, x_max * k))
        .y_label_formatter(&|y| format!("{y:.0}"))
        .label_style((FONT, 14))
        .draw()
        .map_err(e)?;
    // Every band first (light fill), then each band's edges in its own colour (where bands
    // overlap, the edges still tell them apart), then the medians on top.
    for (s, b) in series.iter().zip(&bands) {
        let mut outline: Vec<(f64, f64)> =
            b.x.iter().zip(&b.hi).map(|(x, y)| (x * k, *y)).collect();
        outline.extend(b.x.iter().zip(&b.lo).rev().map(|(x, y)| (x * k, *y)));
        chart
            .draw_series(std::iter::once(Polygon::new(outline, s.colour.mix(0.12))))
            .map_err(e)?;
    }
    for (s, b) in series.iter().zip(&bands) {
        for edge in [&b.lo, &b.hi] {
            let pts: Vec<(f64, f64)> = b.x.iter().zip(edge).map(|(x, y)| (x * k, *y)).collect();
            chart
                .draw_series(LineSeries::new(pts, s.colour.mix(0.6).stroke_width(1)))
                .map_err(e)?;
        }
    }
    for (s, b) in series.iter().zip(&bands) {
        let colour = s.colour;
        let median: Vec<(f64, f64)> =
            b.x.iter()
                .zip(&b.median)
                .map(|(x, y)| (x * k, *y))
                .collect();
        chart
            .draw_series(LineSeries::new(median, colour.stroke_width(2)))
            .map_err(e)?
            .label(format!("{}: median, min–max band", s.label))
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + Rectangle::new([(0, -6), (20, 6)], colour.mix(0.25).filled())
                    + PathElement::new(vec![(0, 0), (20, 0)], colour.stroke_width(2))
            });
    }
    legend(&mut chart)
}

/// `breakeven.png` of a repeated campaign: median found failures over runtime during
/// meta-training per budget and of the baseline, each with its min–max band over the seeds.
pub fn breakeven(path: &Path, p: &Protocol, runs: &[&[TrialLine]]) -> Result<(), CampaignError> {
    let n = runs.len();
    let mut series = vec![BandSeries::of(
        "baseline (φ uniform, HF only)".to_string(),
        RGBColor(0, 0, 0),
        runs,
        StageKind::BaselineTrain.name(),
    )];
    for (i, b) in p.budgets.iter().enumerate() {
        series.push(BandSeries::of(
            format!("SAVME meta-training, C_budget = {b}"),
            PALETTE[i % PALETTE.len()],
            runs,
            &format!("train@{}", Compact(*b)),
        ));
    }
    let end = series
        .iter()
        .map(BandSeries::common_end)
        .fold(f64::INFINITY, f64::min);
    save(path, |path| {
        let root = bitmap(path, (900, 560))?;
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw_bands(
            &root,
            &format!("Found failures during meta-training ({n} seeds: median, min–max)"),
            &series,
            p.cost,
            if end.is_finite() { end } else { 0.0 },
        )?;
        root.present().map_err(|e| e.to_string())
    })
}

/// `meta_testing.png` of a repeated campaign: one panel per budget with the baseline, the
/// uniform and the learned prior, median and min–max band over the seeds, up to the shortest
/// runtime of any seed's stage.
pub fn meta_testing(path: &Path, p: &Protocol, runs: &[&[TrialLine]]) -> Result<(), CampaignError> {
    let panels: Vec<(String, Vec<BandSeries>)> = p
        .budgets
        .iter()
        .map(|b| {
            let series = vec![
                BandSeries::of(
                    "baseline (φ uniform, HF only)".into(),
                    RGBColor(0, 0, 0),
                    runs,
                    StageKind::BaselineTest.name(),
                ),
                BandSeries::of(
                    "uniform fidelity prior".into(),
                    PALETTE[1],
                    runs,
                    &format!("test-uniform@{}", Compact(*b)),
                ),
                BandSeries::of(
                    "learned fidelity prior".into(),
                    PALETTE[0],
                    runs,
                    &format!("test-learned@{}", Compact(*b)),
                ),
            ];
            (
                format!(
                    "Meta-testing, C_budget = {b} ({} seeds: median, min–max)",
                    runs.len()
                ),
                series,
            )
        })
        .collect();
    save(path, |path| {
        let width = 620 * panels.len().max(1) as u32;
        let root = bitmap(path, (width, 520))?;
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = root.split_evenly((1, panels.len().max(1)));
        for ((title, series), area) in panels.iter().zip(areas.iter()) {
            let end = series
                .iter()
                .map(BandSeries::common_end)
                .fold(f64::INFINITY, f64::min);
            draw_bands(
                area,
                title,
                series,
                p.cost,
                if end.is_finite() { end } else { 0.0 },
            )?;
        }
        root.present().map_err(|e| e.to_string())
    })
}

//! The figures of a repeated campaign: per series the median over the seeds and a band from
//! the smallest to the largest seed, on a common runtime grid.

use super::{figure, legend, scale, tick, Colour, CostMeasure, Panel, PlotError, FONT};
use plotters::prelude::*;
use std::path::Path;

/// Per-point median and range of several curves sampled on a common grid (savme-campaign's
/// `report::intervals::band` computes it).
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// The grid (runtime, in the cost's own unit).
    pub x: Vec<f64>,
    /// Median over the curves at each grid point.
    pub median: Vec<f64>,
    /// Smallest value.
    pub lo: Vec<f64>,
    /// Largest value.
    pub hi: Vec<f64>,
}

/// One series of a band figure: its label (the legend adds "median, min–max band"), colour
/// and band.
#[derive(Debug, Clone)]
pub struct BandCurve {
    /// Its legend entry.
    pub label: String,
    /// Its colour (the median line; the band and its edges in lighter shades).
    pub colour: Colour,
    /// Median and range over the seeds.
    pub band: Band,
}

/// Draws `panels` of [`BandCurve`]s side by side into a PNG of `size` pixels at `path`. Each
/// panel's runtime axis ends at its `x_max` (else at its bands' last grid point).
pub fn bands(
    path: &Path,
    size: (u32, u32),
    cost: CostMeasure,
    panels: &[Panel<BandCurve>],
) -> Result<(), PlotError> {
    figure(path, size, panels, |area, panel| {
        let end = panel.x_max.unwrap_or_else(|| {
            let ends = panel.series.iter().filter_map(|s| s.band.x.last());
            ends.copied().fold(0.0, f64::max)
        });
        draw_bands(area, &panel.title, &panel.series, cost, end)
    })
}

fn draw_bands<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    series: &[BandCurve],
    cost: CostMeasure,
    x_max: f64,
) -> Result<(), String> {
    let (k, x_desc, _) = scale(cost, x_max);
    let y_end = series
        .iter()
        .flat_map(|s| s.band.hi.iter().copied())
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
    for (s, b) in series.iter().map(|s| (s, &s.band)) {
        let mut outline: Vec<(f64, f64)> =
            b.x.iter().zip(&b.hi).map(|(x, y)| (x * k, *y)).collect();
        outline.extend(b.x.iter().zip(&b.lo).rev().map(|(x, y)| (x * k, *y)));
        chart
            .draw_series(std::iter::once(Polygon::new(
                outline,
                s.colour.rgb().mix(0.12),
            )))
            .map_err(e)?;
    }
    for (s, b) in series.iter().map(|s| (s, &s.band)) {
        for edge in [&b.lo, &b.hi] {
            let pts: Vec<(f64, f64)> = b.x.iter().zip(edge).map(|(x, y)| (x * k, *y)).collect();
            chart
                .draw_series(LineSeries::new(
                    pts,
                    s.colour.rgb().mix(0.6).stroke_width(1),
                ))
                .map_err(e)?;
        }
    }
    for (s, b) in series.iter().map(|s| (s, &s.band)) {
        let colour = s.colour.rgb();
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

//! Step curves of found failures over runtime, each with its break-even point ringed: a
//! campaign's `breakeven.png` and `meta_testing.png`.

use super::FONT;
use super::{figure, format_seconds, legend, scale, tick, Colour, CostMeasure, Panel, PlotError};
use plotters::coord::types::{RangedCoordf64, RangedCoordu64};
use plotters::prelude::*;
use savme_kernel::metrics::FailureCurve;
use std::path::Path;

/// A curve with its label and colour, and where it overtakes the baseline for good.
#[derive(Debug, Clone)]
pub struct Curve {
    /// Its legend entry (the break-even time is appended when there is one).
    pub label: String,
    /// Its colour.
    pub colour: Colour,
    /// Found failures over the summed runtime.
    pub curve: FailureCurve,
    /// Where it overtakes the baseline for good (`savme_kernel::metrics::break_even`), in the
    /// cost's own unit: ringed on the curve and given in the legend.
    pub break_even: Option<f64>,
}

/// Draws `panels` of [`Curve`]s side by side into a PNG of `size` pixels at `path` (which the
/// PNG encoder creates or replaces). Each panel's runtime axis ends at its `x_max`, else at
/// its longest curve's end; its count axis at the most failures found by then.
pub fn curves(
    path: &Path,
    size: (u32, u32),
    cost: CostMeasure,
    panels: &[Panel<Curve>],
) -> Result<(), PlotError> {
    figure(path, size, panels, |area, panel| {
        draw_panel(area, &panel.title, &panel.series, cost, panel.x_max)
    })
}

/// A break-even time as the legend gives it: seconds below three minutes of wall time,
/// whatever the axis shows; else in the axis' unit.
fn break_even_text(t: f64, (k, unit): (f64, &str)) -> String {
    match unit {
        "s" | "min" if t < 180.0 => format!("break-even {}", format_seconds(t)),
        _ => format!("break-even {:.1} {unit}", t * k),
    }
}

/// The marker of a break-even point: a ringed dot on the curve (its time is in the legend, so
/// that no label is drawn over a curve).
fn break_even_mark<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordu64>>,
    s: &Curve,
    k: f64,
) -> Result<(), String> {
    let Some(t) = s.break_even else {
        return Ok(());
    };
    let (x, y) = (t * k, s.curve.failures_at(t));
    let colour = s.colour.rgb();
    chart
        .draw_series(std::iter::once(
            EmptyElement::at((x, y))
                + Circle::new((0, 0), 7, WHITE.filled())
                + Circle::new((0, 0), 7, colour.stroke_width(2))
                + Circle::new((0, 0), 3, colour.filled()),
        ))
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// The points of `curve`'s step line, its runtime scaled by `k`, up to `x_end`.
fn steps(curve: &FailureCurve, k: f64, x_end: f64) -> Vec<(f64, u64)> {
    let mut pts = vec![(0.0, 0)];
    let mut last = 0u64;
    for p in curve.points() {
        let x = p.time * k;
        if x > x_end {
            break;
        }
        if p.failures != last {
            // A step: the count rises when the trial completes.
            pts.push((x, last));
            last = p.failures;
        }
        pts.push((x, last));
    }
    pts
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    series: &[Curve],
    cost: CostMeasure,
    x_max: Option<f64>,
) -> Result<(), String> {
    let end = x_max.unwrap_or_else(|| series.iter().map(|s| s.curve.end()).fold(0.0, f64::max));
    let (k, x_desc, unit) = scale(cost, end);
    let x_end = end * k;
    let y_end = series
        .iter()
        .map(|s| s.curve.failures_at(x_end / k))
        .max()
        .unwrap_or(0)
        .max(1);
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    // Counts on an integer axis: whole-number ticks, no "10.0".
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..x_end.max(1e-9), 0u64..y_end + y_end.div_ceil(20))
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("found failures")
        .y_labels(y_end.min(10) as usize + 1)
        .x_label_formatter(&|x| tick(*x, x_end))
        .label_style((FONT, 14))
        .draw()
        .map_err(e)?;
    for s in series {
        let pts = steps(&s.curve, k, x_end);
        let colour = s.colour.rgb();
        let label = match s.break_even {
            Some(t) => format!("{}, {} (ringed)", s.label, break_even_text(t, (k, unit))),
            None => s.label.clone(),
        };
        chart
            .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
            .map_err(e)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
    }
    for s in series {
        break_even_mark(&mut chart, s, k)?;
    }
    legend(&mut chart)
}

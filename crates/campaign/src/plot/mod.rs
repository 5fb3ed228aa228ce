//! The campaign's figures: found failures over runtime during meta-training (break-even) and
//! during meta-testing, drawn with plotters into PNG files (text laid out by `text`).

mod text;

use super::log::TrialLine;
use super::protocol::{Compact, Cost, Protocol, StageKind};
use super::report::curve;
use super::CampaignError;
use plotters::coord::types::{RangedCoordf64, RangedCoordu64};
use plotters::prelude::*;
use savme_kernel::metrics::{break_even, FailureCurve};
use std::path::Path;
use text::GlyphText;

pub mod bands;

const FONT: &str = "sans-serif";

/// Registers the bundled font once (plotters draws text with it; no system fonts needed).
fn font() -> Result<(), String> {
    static ONCE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    ONCE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT)
            .map_err(|_| "the bundled font could not be loaded".to_string())
    })
    .clone()
}

/// A curve with its label and colour, and where it overtakes the baseline for good.
struct Series {
    label: String,
    colour: RGBColor,
    curve: FailureCurve,
    break_even: Option<f64>,
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
];

fn lines_of<'a>(lines: &'a [TrialLine], label: &str) -> Vec<&'a TrialLine> {
    let id = label.parse::<crate::StageId>().ok();
    lines.iter().filter(|l| Some(l.stage) == id).collect()
}

/// Axis scale, label and unit for cumulative costs up to `end`: the x axis is the summed
/// cost of the simulator runs (every HF and LF run charged), not the campaign's wall time.
fn scale(cost: Cost, end: f64) -> (f64, &'static str, &'static str) {
    match cost {
        Cost::Wall if end < 180.0 => (1.0, "summed simulator runtime, HF + LF runs (s)", "s"),
        Cost::Wall => (
            1.0 / 60.0,
            "summed simulator runtime, HF + LF runs (min)",
            "min",
        ),
        Cost::Work if end < 1e7 => (
            1e-3,
            "summed simulator work, HF + LF runs (thousand work units)",
            "k work units",
        ),
        Cost::Work => (
            1e-6,
            "summed simulator work, HF + LF runs (million work units)",
            "M work units",
        ),
    }
}

/// A runtime tick label on an axis ending at `end`: `20`, `2.5`, `0.0015` (no `20.0`, and
/// enough decimals for an axis of milliseconds).
fn tick(x: f64, end: f64) -> String {
    let step = (end / 10.0).abs().max(1e-12);
    let decimals = (1 - step.log10().floor() as i32).clamp(1, 12) as usize;
    let s = format!("{x:.decimals$}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() || s == "-0" {
        "0".into()
    } else {
        s.to_string()
    }
}

/// A break-even time as the legend gives it: seconds below three minutes of wall time,
/// whatever the axis shows; else in the axis' unit.
fn break_even_text(t: f64, (k, unit): (f64, &str)) -> String {
    match unit {
        "s" | "min" if t < 180.0 => format!("break-even {}", crate::report::format_seconds(t)),
        _ => format!("break-even {:.1} {unit}", t * k),
    }
}

/// The marker of a break-even point: a ringed dot on the curve (its time is in the legend, so
/// that no label is drawn over a curve).
fn break_even_mark<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordu64>>,
    s: &Series,
    k: f64,
) -> Result<(), String> {
    let Some(t) = s.break_even else {
        return Ok(());
    };
    let (x, y) = (t * k, s.curve.failures_at(t));
    let colour = s.colour;
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

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    series: &[Series],
    cost: Cost,
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
        let mut pts = vec![(0.0, 0)];
        let mut last = 0u64;
        for p in s.curve.points() {
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
        let colour = s.colour;
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

/// The series' legend, as every figure draws it: upper left, on a light box.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

/// A PNG of `size` pixels at `path` (text drawn by `GlyphText`).
fn bitmap(
    path: &Path,
    size: (u32, u32),
) -> Result<DrawingArea<GlyphText<BitMapBackend<'_>>, plotters::coord::Shift>, String> {
    let font = text::font().ok_or("the bundled font could not be read")?;
    Ok(GlyphText::new(BitMapBackend::new(path, size), font).into_drawing_area())
}

fn save(path: &Path, draw: impl FnOnce(&Path) -> Result<(), String>) -> Result<(), CampaignError> {
    font()
        .and_then(|()| {
            // The encoder opens the path itself: hand it a fresh file savme created.
            super::store::safe_file::write_via_fresh_file(path, draw, |e| e.to_string())
        })
        .map_err(|message| CampaignError::Plot {
            path: path.to_path_buf(),
            message,
        })
}

/// `breakeven.png`: found failures over runtime during meta-training for each budget, against
/// the baseline (every run charged), as in the paper's break-even figure.
pub fn breakeven(path: &Path, p: &Protocol, lines: &[TrialLine]) -> Result<(), CampaignError> {
    let mut series = vec![Series {
        label: "baseline (φ uniform, HF only)".into(),
        colour: RGBColor(0, 0, 0),
        curve: curve(&lines_of(lines, StageKind::BaselineTrain.name())),
        break_even: None,
    }];
    for (i, b) in p.budgets.iter().enumerate() {
        let train = curve(&lines_of(lines, &format!("train@{}", Compact(*b))));
        let at = (!series[0].curve.points().is_empty())
            .then(|| break_even(&train, &series[0].curve))
            .flatten();
        series.push(Series {
            label: format!("SAVME meta-training, C_budget = {b}"),
            colour: PALETTE[i % PALETTE.len()],
            curve: train,
            break_even: at,
        });
    }
    save(path, |path| {
        let root = bitmap(path, (900, 560))?;
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw_panel(
            &root,
            "Found failures during meta-training",
            &series,
            p.cost,
            None,
        )?;
        root.present().map_err(|e| e.to_string())
    })
}

/// `meta_testing.png`: one panel per budget with the baseline, the uniform fidelity prior and
/// the learned one, up to the shortest of the three runtimes.
pub fn meta_testing(path: &Path, p: &Protocol, lines: &[TrialLine]) -> Result<(), CampaignError> {
    let base = curve(&lines_of(lines, StageKind::BaselineTest.name()));
    let panels: Vec<(String, Vec<Series>)> = p
        .budgets
        .iter()
        .map(|b| {
            let series = vec![
                Series {
                    label: "baseline (φ uniform, HF only)".into(),
                    colour: RGBColor(0, 0, 0),
                    curve: base.clone(),
                    break_even: None,
                },
                Series {
                    label: "uniform fidelity prior".into(),
                    colour: PALETTE[1],
                    curve: curve(&lines_of(lines, &format!("test-uniform@{}", Compact(*b)))),
                    break_even: None,
                },
                Series {
                    label: "learned fidelity prior".into(),
                    colour: PALETTE[0],
                    curve: curve(&lines_of(lines, &format!("test-learned@{}", Compact(*b)))),
                    break_even: None,
                },
            ];
            (format!("Meta-testing, C_budget = {b}"), series)
        })
        .collect();
    save(path, |path| {
        let width = 620 * panels.len().max(1) as u32;
        let root = bitmap(path, (width, 520))?;
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = root.split_evenly((1, panels.len().max(1)));
        for ((title, series), area) in panels.iter().zip(areas.iter()) {
            let horizon = series
                .iter()
                .map(|s| s.curve.end())
                .filter(|&e| e > 0.0)
                .fold(f64::INFINITY, f64::min);
            draw_panel(
                area,
                title,
                series,
                p.cost,
                horizon.is_finite().then_some(horizon),
            )?;
        }
        root.present().map_err(|e| e.to_string())
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn ticks_have_the_decimals_their_axis_needs() {
        use super::tick;
        assert_eq!(tick(20.0, 120.0), "20");
        assert_eq!(tick(2.5, 30.0), "2.5");
        assert_eq!(tick(0.001, 0.006), "0.001");
        assert_eq!(tick(0.0, 0.006), "0");
    }
}

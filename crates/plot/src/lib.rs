//! savme's figures: found failures over runtime drawn with plotters into PNG files.
//!
//! - [`curves`]: one step curve per series (a stage's failures over the summed runtime of its
//!   runs), each with its break-even point ringed — a campaign's `breakeven.png` and
//!   `meta_testing.png`;
//! - [`bands`]: per series the median over seeds with its min–max [`Band`] — the figures of a
//!   repeated campaign.
//!
//! A figure is one or more [`Panel`]s side by side. The caller chooses what each series is,
//! its label and [`Colour`]; this crate only draws (axes scaled to the [`CostMeasure`], legend,
//! text laid out glyph by glyph in the embedded Ubuntu font by `text`).
//!
//! ```no_run
//! use savme_kernel::metrics::FailureCurve;
//! use savme_kernel::CostMeasure;
//! use savme_plot::{curves, Colour, Curve, Panel};
//!
//! let mut found = FailureCurve::new();
//! found.push(2.0, true);
//! found.push(1.5, false);
//! let panel = Panel {
//!     title: "Found failures".into(),
//!     series: vec![Curve {
//!         label: "baseline".into(),
//!         colour: Colour::BLACK,
//!         curve: found,
//!         break_even: None,
//!     }],
//!     x_max: None,
//! };
//! curves(std::path::Path::new("found.png"), (900, 560), CostMeasure::Wall, &[panel])?;
//! # Ok::<(), savme_plot::PlotError>(())
//! ```

mod bands;
mod curves;
mod text;

pub use bands::{bands, Band, BandCurve};
pub use curves::{curves, Curve};
pub use savme_kernel::CostMeasure;

use plotters::prelude::*;
use std::path::Path;
use text::GlyphText;

/// Why a figure could not be drawn.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlotError {
    /// The embedded font could not be registered with plotters.
    #[error("the bundled font could not be loaded")]
    FontNotLoaded,
    /// The embedded font could not be parsed for the text layout.
    #[error("the bundled font could not be read")]
    FontNotRead,
    /// plotters failed (drawing, encoding or writing the PNG).
    #[error("{0}")]
    Draw(String),
}

/// One panel of a figure: a title, its series and where its runtime axis ends (`None`: at
/// the end of the longest series).
#[derive(Debug, Clone)]
pub struct Panel<S> {
    /// Caption above the panel.
    pub title: String,
    /// What the panel draws ([`Curve`]s or [`BandCurve`]s), in legend order.
    pub series: Vec<S>,
    /// The runtime axis' end, in the cost's own unit (seconds or work units).
    pub x_max: Option<f64>,
}

/// A series' colour (RGB).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Colour(pub u8, pub u8, pub u8);

impl Colour {
    /// The baselines' colour.
    pub const BLACK: Colour = Colour(0, 0, 0);
    /// The series' colours (Okabe–Ito, colour-blind safe), in order.
    pub const PALETTE: [Colour; 6] = [
        Colour(0, 114, 178),
        Colour(213, 94, 0),
        Colour(0, 158, 115),
        Colour(204, 121, 167),
        Colour(230, 159, 0),
        Colour(86, 180, 233),
    ];

    /// The `i`-th colour of [`Colour::PALETTE`] (repeating after the last).
    pub fn nth(i: usize) -> Colour {
        Colour::PALETTE[i % Colour::PALETTE.len()]
    }

    fn rgb(self) -> RGBColor {
        RGBColor(self.0, self.1, self.2)
    }
}

/// A duration for people: `2.5 min` from two minutes on, `1.5 s`, `12.3 ms`, `4.2 µs`, `0 s` —
/// never `0.0 s` for a time below a second (the figures' break-even times; savme-campaign's
/// tables and progress lines say durations the same way).
///
/// ```
/// use savme_plot::format_seconds;
/// assert_eq!(format_seconds(0.0042), "4.2 ms");
/// assert_eq!(format_seconds(3.1e-6), "3.1 µs");
/// assert_eq!(format_seconds(41.25), "41.2 s");
/// ```
pub fn format_seconds(s: f64) -> String {
    match s {
        s if s >= 120.0 => format!("{:.1} min", s / 60.0),
        s if s >= 1.0 => format!("{s:.1} s"),
        s if s >= 1e-3 => format!("{:.1} ms", s * 1e3),
        s if s > 0.0 => format!("{:.1} µs", s * 1e6),
        _ => "0 s".into(),
    }
}

const FONT: &str = "sans-serif";

/// Registers the bundled font once (plotters draws text with it; no system fonts needed).
fn font() -> Result<(), PlotError> {
    static ONCE: std::sync::OnceLock<Result<(), PlotError>> = std::sync::OnceLock::new();
    ONCE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT)
            .map_err(|_| PlotError::FontNotLoaded)
    })
    .clone()
}

/// Axis scale, label and unit for cumulative costs up to `end`: the x axis is the summed
/// cost of the simulator runs (every HF and LF run charged), not the campaign's wall time.
fn scale(cost: CostMeasure, end: f64) -> (f64, &'static str, &'static str) {
    match cost {
        CostMeasure::Wall if end < 180.0 => {
            (1.0, "summed simulator runtime, HF + LF runs (s)", "s")
        }
        CostMeasure::Wall => (
            1.0 / 60.0,
            "summed simulator runtime, HF + LF runs (min)",
            "min",
        ),
        CostMeasure::Work if end < 1e7 => (
            1e-3,
            "summed simulator work, HF + LF runs (thousand work units)",
            "k work units",
        ),
        CostMeasure::Work => (
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

/// The drawing area of one panel (text drawn by `GlyphText`).
type Area<'a> = DrawingArea<GlyphText<BitMapBackend<'a>>, plotters::coord::Shift>;

/// A PNG of `size` pixels at `path`, white, with `panels` side by side, each drawn by `draw`.
fn figure<S>(
    path: &Path,
    size: (u32, u32),
    panels: &[Panel<S>],
    draw: impl Fn(&Area<'_>, &Panel<S>) -> Result<(), String>,
) -> Result<(), PlotError> {
    font()?;
    let glyphs = text::font().ok_or(PlotError::FontNotRead)?;
    let root = GlyphText::new(BitMapBackend::new(path, size), glyphs).into_drawing_area();
    let drawn = (|| {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = root.split_evenly((1, panels.len().max(1)));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            draw(area, panel)?;
        }
        root.present().map_err(png_error)
    })();
    drawn.map_err(PlotError::Draw)
}

/// The PNG backend's error type (plotters does not re-export its name).
type PngError = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

/// Why writing the PNG failed, in words: plotters' own text for its bitmap errors is their
/// Rust debug form (`ImageError(IoError(Os { code: 2, .. }))`).
fn png_error(e: DrawingAreaErrorKind<PngError>) -> String {
    use plotters_backend::DrawingErrorKind;
    match e {
        DrawingAreaErrorKind::BackendError(DrawingErrorKind::DrawingError(b)) => match b {
            PngError::IOError(io) => format!("could not write the PNG: {io}"),
            PngError::ImageError(image) => format!("could not write the PNG: {image}"),
            PngError::InvalidBuffer => "the image buffer has the wrong size".into(),
            #[allow(unreachable_patterns)] // other variants exist with other plotters features
            other => format!("could not write the PNG ({})", other),
        },
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Issue 40: a failed PNG write showed plotters' debug text, "ImageError(IoError(Os {…}))".
    #[test]
    fn a_png_that_cannot_be_written_says_why_in_words() {
        let dir = std::env::temp_dir().join(format!("savme-plot-{}-missing", std::process::id()));
        let path = dir.join("no-such-dir").join("f.png");
        let panel = Panel {
            title: "t".into(),
            series: Vec::<Curve>::new(),
            x_max: Some(1.0),
        };
        let e = curves(&path, (200, 150), CostMeasure::Wall, &[panel]).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with("could not write the PNG: No such file or directory"),
            "{text}"
        );
        assert!(!text.contains("Error(") && !text.contains("Os {"), "{text}");
    }

    #[test]
    fn ticks_have_the_decimals_their_axis_needs() {
        use super::tick;
        assert_eq!(tick(20.0, 120.0), "20");
        assert_eq!(tick(2.5, 30.0), "2.5");
        assert_eq!(tick(0.001, 0.006), "0.001");
        assert_eq!(tick(0.0, 0.006), "0");
    }
}

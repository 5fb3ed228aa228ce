//! What a simulator gives the viewer to plot a trial's outputs as time series — an FMU
//! campaign's `[fmu] record` outputs, or any simulator's: [`Rerun`] re-runs a trial recording
//! the named outputs into a [`Series`]; [`Signal`] is the failure signal as the plots and events
//! show it. The recording itself (`SeriesFrames`) is behind the `rerun` feature; this part is in
//! every build, so that an adapter builds its frames the same way in every build
//! ([`super::Frames::series`]).

use savme_kernel::{Assignment, Role, SimResult};

/// One re-run's recorded outputs: `values[k][i]` is `names[k]` at `times[i]`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// The recorded outputs, in the order asked for.
    pub names: Vec<String>,
    /// The communication points, simulated seconds.
    pub times: Vec<f64>,
    /// One series per output (a Boolean as 0 or 1).
    pub values: Vec<Vec<f64>>,
    /// The first time the failure signal held, if it did.
    pub failure_time: Option<f64>,
}

/// A simulator that re-runs a trial (as the campaign ran it) recording named outputs.
///
/// ```
/// use savme_kernel::{Assignment, Role, SimResult};
/// use savme_viewer::{Rerun, Series};
/// struct Ramp;
/// impl Rerun for Ramp {
///     fn rerun(&mut self, _: Role, _: &str, _: &Assignment, _: &Assignment, record: &[String])
///         -> Result<(SimResult, Series), String> {
///         let times = vec![0.0, 1.0];
///         let values = record.iter().map(|_| vec![0.0, 1.0]).collect();
///         let series = Series { names: record.to_vec(), times, values, failure_time: None };
///         Ok((SimResult::new(false, 0.0, None), series))
///     }
/// }
/// let frames = savme_viewer::Frames::series(Ramp, vec!["x".into()], savme_viewer::Signal::Flag {
///     variable: "crashed".into(),
///     robustness: None,
/// });
/// assert_eq!(frames.is_none(), !cfg!(feature = "rerun"));
/// ```
pub trait Rerun: Send {
    /// One run of `scenario` at `phi`, with fidelity `theta` in `role`, recording `record`.
    fn rerun(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
        record: &[String],
    ) -> Result<(SimResult, Series), String>;
}

/// The failure signal, as the plots (its threshold) and the events (its text) show it.
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    /// A Boolean output that is true on failure.
    Flag {
        /// The output.
        variable: String,
        /// The output reported as the run's robustness ρ beside the flag (`[failure]
        /// robustness`), if the campaign names one: its plot gets a line at ρ = 0.
        robustness: Option<String>,
    },
    /// A real output crossing a threshold.
    Threshold {
        /// The output.
        variable: String,
        /// True: a failure at or above `value`; false: at or below.
        above: bool,
        /// The threshold.
        value: f64,
    },
}

impl Signal {
    /// The signal in words: "`collision`", "`collision` (robustness `distance`)",
    /// "`distance` ≤ 0.5".
    ///
    /// ```
    /// use savme_viewer::Signal;
    /// let s = Signal::Threshold { variable: "distance".into(), above: false, value: 0.5 };
    /// assert_eq!(s.text(), "`distance` ≤ 0.5");
    /// let s = Signal::Flag { variable: "collision".into(), robustness: Some("gap".into()) };
    /// assert_eq!(s.text(), "`collision` (robustness `gap`)");
    /// ```
    pub fn text(&self) -> String {
        match self {
            Signal::Flag {
                variable,
                robustness: None,
            } => format!("`{variable}`"),
            Signal::Flag {
                variable,
                robustness: Some(rho),
            } => format!("`{variable}` (robustness `{rho}`)"),
            Signal::Threshold {
                variable,
                above,
                value,
            } => format!("`{variable}` {} {value}", if *above { "≥" } else { "≤" }),
        }
    }

    /// The reference line drawn on an output's plot, as (output, value, name): a threshold at
    /// its value ("failure threshold"), a flag's robustness output at 0 ("robustness 0");
    /// none for a flag alone.
    ///
    /// ```
    /// use savme_viewer::Signal;
    /// let s = Signal::Flag { variable: "collision".into(), robustness: Some("gap".into()) };
    /// assert_eq!(s.line(), Some(("gap", 0.0, "robustness 0")));
    /// assert_eq!(Signal::Flag { variable: "collision".into(), robustness: None }.line(), None);
    /// ```
    pub fn line(&self) -> Option<(&str, f64, &'static str)> {
        match self {
            Signal::Threshold {
                variable, value, ..
            } => Some((variable, *value, "failure threshold")),
            Signal::Flag {
                robustness: Some(rho),
                ..
            } => Some((rho, 0.0, "robustness 0")),
            Signal::Flag {
                robustness: None, ..
            } => None,
        }
    }
}

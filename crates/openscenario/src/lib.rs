//! OpenSCENARIO 1.x parameter value distributions (`ParameterValueDistribution` files, the
//! variation of a scenario's parameters) as savme scenarios: every parameter a φ variable,
//! every stochastic distribution its nominal distribution (what `savme estimate` weighs
//! P(failure) by).
//!
//! | OpenSCENARIO | φ variable | nominal |
//! |---|---|---|
//! | `DistributionSet` | the listed values | uniform over them |
//! | `DistributionRange` (`stepWidth`) | the grid `lower, lower + step, …, ≤ upper` | uniform over it |
//! | `UniformDistribution` | continuous over its `Range` | uniform |
//! | `NormalDistribution` with a `Range` | continuous over the range | normal (`expectedValue`, √`variance`) truncated to it |
//! | `LogNormalDistribution` with a `Range` | continuous over the range | log-normal with that mean and variance, truncated |
//! | `Histogram` | continuous over its bins | piecewise constant (the bins' weights) |
//! | `ProbabilityDistributionSet` | the listed values | their weights |
//! | `PoissonDistribution` with a `Range` | the integers in the range | Poisson(`expectedValue`) probabilities |
//!
//! Values are integers when every value of a set reads as one, then reals, then booleans,
//! else labels. A normal, log-normal or Poisson distribution without a `Range` is refused
//! (savme's φ-space is bounded), as are `UserDefinedDistribution`s (savme cannot draw from
//! them) and `DeterministicMultiParameterDistribution`s (joint value sets are no product
//! space). Every error names the file, the line and the element ([`OpenScenarioError`]).
//!
//! Reading takes time linear in the file's size. A file is refused (naming it and the limit)
//! when it is larger than [`Limits::bytes`] (default [`MAX_BYTES`], 32 MiB) or holds more
//! elements than [`Limits::elements`] (default [`MAX_ELEMENTS`], 500,000): parameter variation
//! files are a few kilobytes; the limits leave room for sets of [`savme_kernel::MAX_ARMS`]
//! values and thousands of parameters. A reading asks its stop (see
//! [`ParameterDistribution::read_with`] and [`stop_reading_when`]) every
//! 1024 elements and parameters, so that a program can end a long one promptly.
//!
//! ```
//! use savme_openscenario::ParameterDistribution;
//! use savme_kernel::estimation::Nominal;
//! let file = r#"<?xml version="1.0"?>
//! <OpenSCENARIO>
//!   <FileHeader revMajor="1" revMinor="2" author="a" description="d" date="2024-01-01T00:00:00"/>
//!   <ParameterValueDistribution>
//!     <ScenarioFile filepath="cut_in.xosc"/>
//!     <Stochastic numberOfTestRuns="100" randomSeed="7">
//!       <StochasticDistribution parameterName="EgoSpeed">
//!         <NormalDistribution expectedValue="25" variance="4">
//!           <Range lowerLimit="15" upperLimit="35"/>
//!         </NormalDistribution>
//!       </StochasticDistribution>
//!     </Stochastic>
//!   </ParameterValueDistribution>
//! </OpenSCENARIO>"#;
//! let d = ParameterDistribution::parse(file, "cut_in_variation.xosc")?;
//! assert_eq!(d.scenario_file.as_deref(), Some("cut_in.xosc"));
//! let space = d.space(10)?;
//! assert_eq!(space.variables()[0].name.as_ref(), "EgoSpeed");
//! assert_eq!(d.nominal()["EgoSpeed"], Nominal::Normal { mean: 25.0, sd: 2.0 });
//! # Ok::<(), savme_openscenario::OpenScenarioError>(())
//! ```

mod reader;
mod xml;

use savme_kernel::estimation::Nominal;
use savme_kernel::{Scale, Space, Value, Variable};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The largest file read by default: 32 MiB.
pub const MAX_BYTES: u64 = 32 << 20;
/// The most elements a file may hold by default.
pub const MAX_ELEMENTS: usize = 500_000;

/// How large a file may be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// The most bytes.
    pub bytes: u64,
    /// The most XML elements.
    pub elements: usize,
}

impl Default for Limits {
    /// [`MAX_BYTES`] and [`MAX_ELEMENTS`].
    fn default() -> Self {
        Limits {
            bytes: MAX_BYTES,
            elements: MAX_ELEMENTS,
        }
    }
}

/// The message of the error a stopped reading gives.
pub const STOPPED: &str = "reading stopped before its end (a stop was requested)";

/// The process-wide stop of [`ParameterDistribution::read`] and [`ParameterDistribution::parse`].
static STOP: OnceLock<fn() -> bool> = OnceLock::new();

/// Makes every later [`ParameterDistribution::read`] and [`ParameterDistribution::parse`] in
/// this process ask `stop` every 1024 elements and give up (with a [`STOPPED`] error) when it
/// says true — for a program whose signal handler sets a flag (`savme` does, so that Ctrl-C
/// and SIGTERM end a long load). The first call sets it; later ones are ignored.
pub fn stop_reading_when(stop: fn() -> bool) {
    let _ = STOP.set(stop);
}

/// The process-wide stop: true once [`stop_reading_when`]'s function says so.
fn stop_requested() -> bool {
    STOP.get().is_some_and(|stop| stop())
}

/// A problem with a parameter value distribution file: where it is and what is wrong.
/// Displayed as ``FILE, line N, element `E`: message`` (line and element when known).
///
/// ```
/// use savme_openscenario::OpenScenarioError;
/// let e = OpenScenarioError {
///     file: "cut_in_variation.xosc".into(),
///     line: Some(9),
///     element: Some("NormalDistribution".into()),
///     message: "no <Range>".into(),
/// };
/// assert_eq!(
///     e.to_string(),
///     "cut_in_variation.xosc, line 9, element `NormalDistribution`: no <Range>"
/// );
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}{}{}: {message}", line.map_or(String::new(), |l| format!(", line {l}")), element.as_ref().map_or(String::new(), |e| format!(", element `{e}`")))]
pub struct OpenScenarioError {
    /// The file.
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// The element, when known.
    pub element: Option<String>,
    /// What is wrong.
    pub message: String,
}

/// Whether the file's variation is deterministic (an enumeration) or stochastic (draws).
#[derive(Debug, Clone, PartialEq)]
pub enum Variation {
    /// `<Deterministic>`: every parameter's values equally likely.
    Deterministic,
    /// `<Stochastic>` with its `numberOfTestRuns` and `randomSeed` (kept for the caller: savme
    /// draws with its own seed and stops by its own rule).
    Stochastic {
        /// `numberOfTestRuns`.
        runs: Option<u64>,
        /// `randomSeed`.
        seed: Option<f64>,
    },
}

/// What values a parameter takes.
#[derive(Debug, Clone, PartialEq)]
pub enum Domain {
    /// Every real number in `[lo, hi]` (binned by [`ParameterDistribution::space`]).
    Continuous {
        /// Lower limit.
        lo: f64,
        /// Upper limit.
        hi: f64,
    },
    /// These values.
    Values(Vec<Value>),
}

/// One parameter of the file: its φ variable's domain, its nominal, where it is declared.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// `parameterName` (a leading `$` dropped).
    pub name: String,
    /// Its values.
    pub domain: Domain,
    /// Its nominal distribution (uniform for a deterministic variation).
    pub nominal: Nominal,
    /// The distribution's element (`NormalDistribution`, `DistributionSet`, …).
    pub element: String,
    /// The 1-based line of that element.
    pub line: usize,
}

impl Parameter {
    /// The parameter as a savme variable: continuous ones in `bins` linear bins.
    pub fn variable(&self, bins: u32) -> Variable {
        match &self.domain {
            Domain::Continuous { lo, hi } => {
                Variable::continuous(&self.name, *lo, *hi, bins, Scale::Linear)
            }
            Domain::Values(values) => Variable::discrete(&self.name, values.iter().cloned()),
        }
    }
}

/// A `ParameterValueDistribution` file, read and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterDistribution {
    /// The file.
    pub path: PathBuf,
    /// `ScenarioFile filepath`: the scenario whose parameters vary (as written).
    pub scenario_file: Option<String>,
    /// Deterministic or stochastic.
    pub variation: Variation,
    /// Every parameter, in file order.
    pub parameters: Vec<Parameter>,
}

impl ParameterDistribution {
    /// Reads and checks the file at `path`, within the default [`Limits`], stopped by the
    /// process-wide stop ([`stop_reading_when`]).
    pub fn read(path: &Path) -> Result<ParameterDistribution, OpenScenarioError> {
        Self::read_with(path, Limits::default(), &stop_requested)
    }

    /// Reads and checks the file at `path` within `limits`; `stop` is asked every 1024
    /// elements and parameters, and true gives up with a [`STOPPED`] error.
    ///
    /// ```
    /// use savme_openscenario::{Limits, ParameterDistribution};
    /// let dir = std::env::temp_dir().join(format!("savme-openscenario-doc-{}", std::process::id()));
    /// std::fs::create_dir_all(&dir)?;
    /// let path = dir.join("big.xosc");
    /// std::fs::write(&path, "<OpenSCENARIO/>")?;
    /// let small = Limits { bytes: 10, elements: 100 };
    /// let e = ParameterDistribution::read_with(&path, small, &|| false).unwrap_err();
    /// assert_eq!(
    ///     e.to_string(),
    ///     format!("{}: the file has 15 bytes, more than the 10 bytes savme reads (a parameter variation file is a few kB)", path.display())
    /// );
    /// # std::fs::remove_dir_all(&dir)?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn read_with(
        path: &Path,
        limits: Limits,
        stop: &dyn Fn() -> bool,
    ) -> Result<ParameterDistribution, OpenScenarioError> {
        let name = path.display().to_string();
        let err = |message: String| OpenScenarioError {
            file: name.clone(),
            line: None,
            element: None,
            message,
        };
        let too_large = |bytes: u64| {
            err(format!(
                "the file has {bytes} bytes, more than the {} bytes savme reads (a parameter variation file is a few kB)",
                limits.bytes
            ))
        };
        let file = std::fs::File::open(path).map_err(|e| err(e.to_string()))?;
        // Its size as it is now, then a reading that takes no more than the limit (should it
        // grow meanwhile, or be a pipe).
        if let Ok(meta) = file.metadata() {
            if meta.is_file() && meta.len() > limits.bytes {
                return Err(too_large(meta.len()));
            }
        }
        let mut bytes = Vec::new();
        file.take(limits.bytes.saturating_add(1))
            .read_to_end(&mut bytes)
            .map_err(|e| err(e.to_string()))?;
        if bytes.len() as u64 > limits.bytes {
            return Err(err(format!(
                "the file has more than the {} bytes savme reads (a parameter variation file is a few kB)",
                limits.bytes
            )));
        }
        let text = String::from_utf8(bytes)
            .map_err(|e| err(format!("the file is not UTF-8 text: {e}")))?;
        let mut d = reader::read(&text, &name, limits, stop)?;
        d.path = path.to_path_buf();
        Ok(d)
    }

    /// Reads and checks `text`, naming it `file` in errors, within the default [`Limits`]'
    /// element count, stopped by the process-wide stop ([`stop_reading_when`]).
    pub fn parse(text: &str, file: &str) -> Result<ParameterDistribution, OpenScenarioError> {
        reader::read(text, file, Limits::default(), &stop_requested)
    }

    /// The φ-space: one variable per parameter, in file order, continuous ones in `bins`
    /// linear bins (1 ..= [`savme_kernel::MAX_ARMS`]).
    pub fn space(&self, bins: u32) -> Result<Space, OpenScenarioError> {
        let vars = self.parameters.iter().map(|p| p.variable(bins)).collect();
        Space::new(vars).map_err(|e| OpenScenarioError {
            file: self.path.display().to_string(),
            line: None,
            element: None,
            message: e.to_string(),
        })
    }

    /// The nominal distribution of every parameter whose nominal is not uniform (the
    /// estimator's default), by parameter name.
    pub fn nominal(&self) -> BTreeMap<String, Nominal> {
        self.parameters
            .iter()
            .filter(|p| p.nominal != Nominal::Uniform)
            .map(|p| (p.name.clone(), p.nominal.clone()))
            .collect()
    }

    /// The parameter named `name`.
    pub fn parameter(&self, name: &str) -> Option<&Parameter> {
        self.parameters.iter().find(|p| p.name == name)
    }
}

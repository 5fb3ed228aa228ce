//! Spaces of named variables: what a scenario's φ or a simulator's fidelity θ may be.
//!
//! A [`Space`] is an ordered list of [`Variable`]s. Each variable has *arms*, the choices a
//! bandit picks among: a discrete variable has one arm per value; a continuous variable is cut
//! into `bins` intervals (equal in width for [`Scale::Linear`], equal in ratio for
//! [`Scale::Log`]) and each bin is an arm. Drawing an arm of a continuous variable then draws the
//! value inside the bin uniformly (linear) or log-uniformly (log), as the SAVME paper describes.
//!
//! **Log scale** needs a strictly positive range (`0 < lo < hi`): the paper's log-scaled settings
//! (view distance 10–5000 m, clipping distances 0.2–20 m) are all positive. The authors' code
//! bins a log-scaled variable differently — equally in `ln(x − lo + 1)`, with a shift of its own
//! inside each bin — which is [`Scale::ShiftedLog`]: any range, the paper's code's numbers
//! (docs/RESULTS.md, "Log bins").
//!
//! **Bins are half-open**, `[e_k, e_{k+1})`, except the last, which also holds `hi`. A value on an
//! inner edge belongs to the upper bin.
//!
//! One file of ~750 lines: [`Variable`] (its arms, bins, draws and the checks that make every
//! bin representable) and [`Space`] (an ordered list of them, with the same checks across
//! variables) are one concept; most of the length is the documented edge cases of binning.

use crate::value::{Assignment, Num, Value};
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// How a continuous variable is cut into bins.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// Bins of equal width; values uniform inside a bin.
    Linear,
    /// Bins of equal ratio (`hi_k / lo_k` constant); values log-uniform inside a bin.
    Log,
    /// The authors' SAVME code's log bins (`bin_edge_type = "log"`): edges equally spaced in
    /// `ln(x − lo + 1)`, so `e_k = lo − 1 + (hi − lo + 1)^(k/bins)`, and inside bin `[a, b]`
    /// `x − a + 1` log-uniform on `[1, 1 + b − a]`. Any range (it may touch or cross 0); bins
    /// narrower near `lo` than [`Scale::Log`]'s on a range with `lo` far from 1. `savme
    /// reproduce --log-bins paper` uses it for the bundled simulator's log-scaled settings.
    #[serde(rename = "shifted-log")]
    #[cfg_attr(feature = "schema", schemars(rename = "shifted-log"))]
    ShiftedLog,
}

impl Scale {
    /// The name a space file, the campaign file and Python give the scale: `linear`, `log`,
    /// `shifted-log`.
    ///
    /// ```
    /// use savme_kernel::Scale;
    /// assert_eq!(Scale::ShiftedLog.name(), "shifted-log");
    /// assert_eq!(Scale::from_name("log"), Some(Scale::Log));
    /// assert_eq!(Scale::from_name("cubic"), None);
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Scale::Linear => "linear",
            Scale::Log => "log",
            Scale::ShiftedLog => "shifted-log",
        }
    }

    /// The scale named `name` ([`Scale::name`]), if any.
    pub fn from_name(name: &str) -> Option<Scale> {
        [Scale::Linear, Scale::Log, Scale::ShiftedLog]
            .into_iter()
            .find(|s| s.name() == name)
    }
}

/// The values a variable may take.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum Domain {
    /// A finite list of values (numbers, booleans or labels); one arm each.
    Discrete {
        /// The values, in arm order.
        values: Vec<Value>,
    },
    /// A real interval `[lo, hi]` cut into `bins` arms.
    Continuous {
        /// Lower bound (inclusive).
        lo: f64,
        /// Upper bound (inclusive).
        hi: f64,
        /// Number of bins (arms), at least 1.
        bins: u32,
        /// Linear or logarithmic binning.
        scale: Scale,
    },
}

/// One named variable of a [`Space`].
///
/// ```
/// use savme_kernel::{Scale, Variable};
/// let v = Variable::continuous("view_distance", 10.0, 5000.0, 10, Scale::Log);
/// assert_eq!(v.arms(), 10);
/// let b = Variable::boolean("disable_shadows");
/// assert_eq!(b.arms(), 2);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawVariable")]
pub struct Variable {
    /// The variable's name, unique in its space.
    pub name: Arc<str>,
    /// Its values.
    #[serde(flatten)]
    pub domain: Domain,
}

/// A variable as written in JSON: every key of either kind, unknown keys refused.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVariable {
    name: Arc<str>,
    #[serde(rename = "type")]
    kind: RawKind,
    values: Option<Vec<Value>>,
    lo: Option<f64>,
    hi: Option<f64>,
    bins: Option<u32>,
    scale: Option<Scale>,
}

#[derive(Deserialize)]
#[serde(rename_all = "lowercase")]
enum RawKind {
    Discrete,
    Continuous,
}

impl TryFrom<RawVariable> for Variable {
    type Error = String;

    fn try_from(r: RawVariable) -> Result<Self, String> {
        let name = r.name.clone();
        let domain = match r.kind {
            RawKind::Discrete => {
                if r.lo.is_some() || r.hi.is_some() || r.bins.is_some() || r.scale.is_some() {
                    return Err(format!(
                        "discrete variable `{name}` takes `values`, not `lo`/`hi`/`bins`/`scale`"
                    ));
                }
                let values = r
                    .values
                    .ok_or_else(|| format!("discrete variable `{name}` needs `values`"))?;
                Domain::Discrete { values }
            }
            RawKind::Continuous => {
                if r.values.is_some() {
                    return Err(format!(
                        "continuous variable `{name}` takes `lo`, `hi`, `bins`, `scale`, not `values`"
                    ));
                }
                let need = |v: Option<f64>, key: &str| {
                    v.ok_or_else(|| format!("continuous variable `{name}` needs `{key}`"))
                };
                Domain::Continuous {
                    lo: need(r.lo, "lo")?,
                    hi: need(r.hi, "hi")?,
                    bins: r
                        .bins
                        .ok_or_else(|| format!("continuous variable `{name}` needs `bins`"))?,
                    scale: r.scale.unwrap_or(Scale::Linear),
                }
            }
        };
        Ok(Variable {
            name: r.name,
            domain,
        })
    }
}

impl Variable {
    /// A discrete variable over `values`.
    pub fn discrete<V: Into<Value>>(name: &str, values: impl IntoIterator<Item = V>) -> Self {
        Variable {
            name: Arc::from(name),
            domain: Domain::Discrete {
                values: values.into_iter().map(Into::into).collect(),
            },
        }
    }

    /// A boolean variable: arms `false` (0) and `true` (1).
    pub fn boolean(name: &str) -> Self {
        Self::discrete(name, [false, true])
    }

    /// A continuous variable on `[lo, hi]` cut into `bins` arms.
    pub fn continuous(name: &str, lo: f64, hi: f64, bins: u32, scale: Scale) -> Self {
        Variable {
            name: Arc::from(name),
            domain: Domain::Continuous {
                lo,
                hi,
                bins,
                scale,
            },
        }
    }

    /// Number of arms.
    pub fn arms(&self) -> usize {
        match &self.domain {
            Domain::Discrete { values } => values.len(),
            Domain::Continuous { bins, .. } => *bins as usize,
        }
    }

    /// The interval `[e_arm, e_arm+1]` of a continuous variable's bin (None for discrete
    /// variables or an arm out of range).
    pub fn bin(&self, arm: usize) -> Option<(f64, f64)> {
        match self.domain {
            Domain::Continuous {
                lo,
                hi,
                bins,
                scale,
            } if arm < bins as usize => Some((
                edge(lo, hi, bins, scale, arm),
                edge(lo, hi, bins, scale, arm + 1),
            )),
            _ => None,
        }
    }

    /// Draws a value of `arm`: the discrete value itself, or a value inside the bin,
    /// uniform (linear) or log-uniform (log).
    ///
    /// # Panics
    /// If `arm >= self.arms()`; the kernel only passes arms it drew from this variable.
    pub fn draw_in_arm<R: Rng + ?Sized>(&self, arm: usize, rng: &mut R) -> Value {
        self.draw_with_span(arm, self.log_span(), rng)
    }

    /// `ln(hi / lo)` of a log-scaled variable (0 otherwise).
    fn log_span(&self) -> f64 {
        match self.domain {
            Domain::Continuous {
                lo,
                hi,
                scale: Scale::Log,
                ..
            } => (hi / lo).ln(),
            _ => 0.0,
        }
    }

    fn draw_with_span<R: Rng + ?Sized>(&self, arm: usize, log_span: f64, rng: &mut R) -> Value {
        match &self.domain {
            Domain::Discrete { values } => values[arm].clone(),
            Domain::Continuous {
                lo,
                hi,
                bins,
                scale,
            } => {
                assert!(arm < *bins as usize, "arm of this variable");
                let u: f64 = rng.random();
                // Position of the draw in [0, 1] along the variable's scale.
                let t = (arm as f64 + u) / f64::from(*bins);
                let x = match scale {
                    Scale::Linear => {
                        let (a, b) = self.bin(arm).expect("arm of this variable");
                        (lo + t * (hi - lo)).clamp(a, b)
                    }
                    Scale::Log => lo * (t * log_span).exp(),
                    Scale::ShiftedLog => {
                        let (a, b) = self.bin(arm).expect("arm of this variable");
                        // x − a + 1 log-uniform on [1, 1 + b − a].
                        (a + (u * (b - a).ln_1p()).exp_m1()).clamp(a, b)
                    }
                };
                Value::Real(x.clamp(*lo, *hi))
            }
        }
    }

    /// The value that stands for `arm` at evaluation: the discrete value, or the expected value
    /// of the bin under its scale — the midpoint (linear), `(b − a) / ln(b / a)` (log) or
    /// `a − 1 + (b − a) / ln(1 + b − a)` (shifted-log).
    ///
    /// # Panics
    /// If `arm >= self.arms()`.
    pub fn representative(&self, arm: usize) -> Value {
        match &self.domain {
            Domain::Discrete { values } => values[arm].clone(),
            Domain::Continuous { scale, .. } => {
                let (a, b) = self.bin(arm).expect("arm of this variable");
                Value::Real(match scale {
                    Scale::Linear => 0.5 * (a + b),
                    Scale::Log => (b - a) / (b / a).ln(),
                    // The mean of a − 1 + y, y log-uniform on [1, 1 + b − a] (the authors' MAP
                    // value).
                    Scale::ShiftedLog => (a - 1.0 + (b - a) / (b - a).ln_1p()).clamp(a, b),
                })
            }
        }
    }

    /// The density of `x` when bin `arm` draws it ([`Variable::draw_in_arm`]): uniform (linear),
    /// log-uniform (log) or `x − a + 1` log-uniform on `[1, 1 + b − a]` (shifted-log) over the
    /// bin `[a, b]`; 1 for a discrete variable's value.
    ///
    /// ```
    /// use savme_kernel::{Scale, Value, Variable};
    /// let v = Variable::continuous("x", 0.0, 10.0, 5, Scale::Linear);
    /// assert!((v.in_bin_density(1, &Value::Real(3.0)) - 0.5).abs() < 1e-12);
    /// ```
    pub fn in_bin_density(&self, arm: usize, x: &Value) -> f64 {
        match (&self.domain, self.bin(arm)) {
            (Domain::Continuous { scale, .. }, Some((a, b))) => {
                let x = x.as_f64().unwrap_or(f64::NAN);
                match scale {
                    Scale::Linear => 1.0 / (b - a),
                    Scale::Log => 1.0 / (x * (b / a).ln()),
                    Scale::ShiftedLog => 1.0 / ((x - a + 1.0) * (b - a).ln_1p()),
                }
            }
            _ => 1.0,
        }
    }

    /// The arm that holds `value`, or None when the value lies outside the variable.
    ///
    /// ```
    /// use savme_kernel::{Scale, Value, Variable};
    /// let v = Variable::continuous("x", 0.0, 10.0, 5, Scale::Linear);
    /// assert_eq!(v.arm_of(&Value::Real(0.0)), Some(0));
    /// assert_eq!(v.arm_of(&Value::Real(2.0)), Some(1)); // an inner edge belongs to the upper bin
    /// assert_eq!(v.arm_of(&Value::Real(10.0)), Some(4)); // hi belongs to the last bin
    /// assert_eq!(v.arm_of(&Value::Real(10.5)), None);
    /// ```
    pub fn arm_of(&self, value: &Value) -> Option<usize> {
        match &self.domain {
            Domain::Discrete { values } => values.iter().position(|v| v.same_as(value)),
            Domain::Continuous {
                lo,
                hi,
                bins,
                scale,
            } => {
                let x = value.as_f64()?;
                if !(x >= *lo && x <= *hi) {
                    return None;
                }
                let frac = match scale {
                    Scale::Linear => (x - lo) / (hi - lo),
                    Scale::Log => (x / lo).ln() / (hi / lo).ln(),
                    Scale::ShiftedLog => (x - lo).ln_1p() / (hi - lo).ln_1p(),
                };
                let n = *bins as usize;
                let mut k = ((frac * n as f64).floor() as usize).min(n - 1);
                // Correct rounding at the edges so that the arm agrees with `bin()`.
                while k > 0 && x < edge(*lo, *hi, *bins, *scale, k) {
                    k -= 1;
                }
                while k + 1 < n && x >= edge(*lo, *hi, *bins, *scale, k + 1) {
                    k += 1;
                }
                Some(k)
            }
        }
    }

    fn validate(&self) -> Result<(), SpaceError> {
        let name = || self.name.to_string();
        if self.name.trim().is_empty() {
            return Err(SpaceError::EmptyName);
        }
        match &self.domain {
            Domain::Discrete { values } => {
                if values.is_empty() {
                    return Err(SpaceError::NoValues { variable: name() });
                }
                // Each value's key in a set (not a search of the earlier values, which takes
                // time quadratic in their number): keys equal exactly when `same_as`.
                let mut seen = std::collections::HashSet::with_capacity(values.len());
                for v in values {
                    if v.is_non_finite() {
                        return Err(SpaceError::NonFiniteValue { variable: name() });
                    }
                    if !seen.insert(ValueKey::of(v)) {
                        return Err(SpaceError::DuplicateValue {
                            variable: name(),
                            value: v.to_string(),
                        });
                    }
                }
            }
            Domain::Continuous {
                lo,
                hi,
                bins,
                scale,
            } => {
                if !lo.is_finite() || !hi.is_finite() {
                    return Err(SpaceError::NonFiniteBound {
                        variable: name(),
                        lo: *lo,
                        hi: *hi,
                    });
                }
                if lo >= hi {
                    return Err(SpaceError::EmptyRange {
                        variable: name(),
                        lo: *lo,
                        hi: *hi,
                    });
                }
                if *bins == 0 {
                    return Err(SpaceError::ZeroBins { variable: name() });
                }
                if *bins > MAX_ARMS as u32 {
                    return Err(SpaceError::TooManyArms {
                        variable: name(),
                        arms: *bins as usize,
                    });
                }
                if *scale == Scale::Log && *lo <= 0.0 {
                    return Err(SpaceError::LogRangeNotPositive {
                        variable: name(),
                        lo: *lo,
                    });
                }
                if !representable(*lo, *hi, *bins, *scale) {
                    return Err(SpaceError::RangeNotRepresentable {
                        variable: name(),
                        lo: *lo,
                        hi: *hi,
                    });
                }
            }
        }
        if self.arms() > MAX_ARMS {
            return Err(SpaceError::TooManyArms {
                variable: name(),
                arms: self.arms(),
            });
        }
        Ok(())
    }
}

/// A finite value as a set key, equal exactly when [`Value::same_as`] says so: an integral
/// number by the integer it is (so `Int(2)` and `Real(2.0)` are one key, `-0.0` is `0`, and
/// `Int(2⁵³ + 1)` is not `Int(2⁵³)`), another real by its bits, others as they are.
#[derive(PartialEq, Eq, Hash)]
enum ValueKey<'a> {
    Integer(i128),
    Number(u64),
    Bool(bool),
    Label(&'a str),
}

impl<'a> ValueKey<'a> {
    fn of(v: &'a Value) -> Self {
        match v {
            Value::Bool(b) => ValueKey::Bool(*b),
            Value::Label(s) => ValueKey::Label(s),
            Value::Int(i) => ValueKey::Integer(i128::from(*i)),
            // `as` is exact for an integral double inside ±2¹²⁶.
            Value::Real(x) if x.fract() == 0.0 && x.abs() < 8.5e37 => ValueKey::Integer(*x as i128),
            Value::Real(x) => ValueKey::Number(x.to_bits()),
        }
    }
}

/// The most arms one variable may have (arm indices are stored as `u16`).
pub const MAX_ARMS: usize = u16::MAX as usize;

/// Whether `[lo, hi]` (finite, `lo < hi`) cut into `bins` bins can be computed with: its width
/// (linear: `hi − lo`; log: `hi / lo`) is a finite number and a bin's width and its inverse (the
/// density of a uniform draw in it) are positive finite numbers. `[-1e308, 1e308]` is not
/// (`hi − lo` overflows to infinity: every draw and density would be NaN or infinite).
fn representable(lo: f64, hi: f64, bins: u32, scale: Scale) -> bool {
    let usable = |w: f64| w.is_finite() && w > 0.0 && w.recip().is_finite();
    let bins = f64::from(bins.max(1));
    match scale {
        Scale::Linear => usable((hi - lo) / bins),
        Scale::Log => (hi / lo).is_finite() && usable((hi / lo).ln() / bins),
        // The narrowest bin is the first: (hi − lo + 1)^(1 / bins) − 1 wide.
        Scale::ShiftedLog => {
            (hi - lo).is_finite()
                && usable(((hi - lo).ln_1p() / bins).exp_m1())
                && lo + ((hi - lo).ln_1p() / bins).exp_m1() > lo
        }
    }
}

/// Edge `k` (0..=bins) of a continuous variable; edge 0 is `lo` and edge `bins` is `hi` exactly.
fn edge(lo: f64, hi: f64, bins: u32, scale: Scale, k: usize) -> f64 {
    if k == 0 {
        return lo;
    }
    if k >= bins as usize {
        return hi;
    }
    let t = k as f64 / f64::from(bins);
    match scale {
        Scale::Linear => lo + t * (hi - lo),
        Scale::Log => (lo.ln() + t * (hi.ln() - lo.ln())).exp(),
        Scale::ShiftedLog => lo + (t * (hi - lo).ln_1p()).exp_m1(),
    }
}

/// Why a space, a variable or an assignment is invalid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpaceError {
    /// The space has no variables.
    #[error("the space has no variables")]
    Empty,
    /// A variable has an empty or blank name.
    #[error("a variable has an empty name")]
    EmptyName,
    /// Two variables share a name.
    #[error("variable `{0}` is defined twice")]
    DuplicateName(String),
    /// A discrete variable lists no values.
    #[error("discrete variable `{variable}` has no values")]
    NoValues {
        /// The variable.
        variable: String,
    },
    /// A discrete variable lists one value twice.
    #[error("discrete variable `{variable}` lists the value {value} twice")]
    DuplicateValue {
        /// The variable.
        variable: String,
        /// The repeated value.
        value: String,
    },
    /// A discrete variable lists NaN or an infinity.
    #[error("discrete variable `{variable}` lists a NaN or infinite value")]
    NonFiniteValue {
        /// The variable.
        variable: String,
    },
    /// A continuous bound is NaN or infinite.
    #[error("continuous variable `{variable}` has a non-finite bound: lo = {}, hi = {}", Num(*lo), Num(*hi))]
    NonFiniteBound {
        /// The variable.
        variable: String,
        /// Its lower bound.
        lo: f64,
        /// Its upper bound.
        hi: f64,
    },
    /// `lo >= hi`.
    #[error("continuous variable `{variable}` needs lo < hi, got lo = {}, hi = {}", Num(*lo), Num(*hi))]
    EmptyRange {
        /// The variable.
        variable: String,
        /// Its lower bound.
        lo: f64,
        /// Its upper bound.
        hi: f64,
    },
    /// A range too wide (or too narrow) to compute with although both bounds are finite.
    #[error(
        "continuous variable `{variable}` has a range too wide to compute with: lo = {lo_}, hi = {hi_} \
         (hi − lo, or hi / lo on a log scale, must be a finite number, at most {max:e}, and a \
         bin's width must be above {min:e}; narrow the range, or rescale the variable)",
        lo_ = Num(*lo),
        hi_ = Num(*hi),
        max = f64::MAX,
        min = 1.0 / f64::MAX
    )]
    RangeNotRepresentable {
        /// The variable.
        variable: String,
        /// Its lower bound.
        lo: f64,
        /// Its upper bound.
        hi: f64,
    },
    /// `bins == 0`.
    #[error("continuous variable `{variable}` needs at least one bin")]
    ZeroBins {
        /// The variable.
        variable: String,
    },
    /// More arms than [`MAX_ARMS`].
    #[error("variable `{variable}` has {arms} arms; at most {MAX_ARMS} are supported")]
    TooManyArms {
        /// The variable.
        variable: String,
        /// Its number of arms.
        arms: usize,
    },
    /// A log-scaled variable whose range is not strictly positive.
    #[error(
        "log-scaled variable `{variable}` needs 0 < lo, got lo = {lo_} \
         (shift the variable, or use a linear scale)",
        lo_ = Num(*lo)
    )]
    LogRangeNotPositive {
        /// The variable.
        variable: String,
        /// Its lower bound.
        lo: f64,
    },
    /// An assignment lacks a variable of the space.
    #[error("no value for variable `{variable}`")]
    MissingValue {
        /// The variable.
        variable: String,
    },
    /// An assignment names a variable the space does not have.
    #[error("unknown variable `{variable}`")]
    UnknownVariable {
        /// The name given.
        variable: String,
    },
    /// A continuous variable's value is not a number (a label or a boolean).
    #[error("value {value} of variable `{variable}` is not a number; the variable is continuous")]
    NotANumber {
        /// The variable.
        variable: String,
        /// The value given.
        value: String,
    },
    /// An assignment's value lies outside its variable.
    #[error("value {value} is outside variable `{variable}` ({allowed})")]
    OutOfSpace {
        /// The variable.
        variable: String,
        /// The value given.
        value: String,
        /// What the variable allows.
        allowed: String,
    },
}

/// An ordered, validated list of named variables.
///
/// ```
/// use savme_kernel::{Scale, Space, Variable};
/// let space = Space::new(vec![
///     Variable::discrete("rate_hz", [2, 4, 6, 8, 10]),
///     Variable::continuous("view_distance", 10.0, 5000.0, 10, Scale::Log),
/// ])?;
/// assert_eq!(space.len(), 2);
/// assert_eq!(space.total_arms(), 15);
/// assert!(Space::new(vec![]).is_err());
/// # Ok::<(), savme_kernel::SpaceError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<Variable>", into = "Vec<Variable>")]
pub struct Space {
    vars: Vec<Variable>,
    /// The variable names, shared by every assignment drawn from this space.
    names: Arc<Vec<Arc<str>>>,
    /// `ln(hi / lo)` of every log-scaled variable (0 for the others), for fast draws.
    log_spans: Vec<f64>,
}

impl TryFrom<Vec<Variable>> for Space {
    type Error = SpaceError;
    fn try_from(vars: Vec<Variable>) -> Result<Self, SpaceError> {
        Space::new(vars)
    }
}

impl From<Space> for Vec<Variable> {
    fn from(s: Space) -> Self {
        s.vars
    }
}

impl Space {
    /// Validates and builds a space.
    pub fn new(vars: Vec<Variable>) -> Result<Self, SpaceError> {
        if vars.is_empty() {
            return Err(SpaceError::Empty);
        }
        let mut seen = std::collections::HashSet::with_capacity(vars.len());
        for v in &vars {
            v.validate()?;
            if !seen.insert(&*v.name) {
                return Err(SpaceError::DuplicateName(v.name.to_string()));
            }
        }
        let names = Arc::new(vars.iter().map(|v| v.name.clone()).collect());
        let log_spans = vars.iter().map(Variable::log_span).collect();
        Ok(Space {
            vars,
            names,
            log_spans,
        })
    }

    /// This space with every log-scaled variable ([`Scale::Log`]) cut as `scale` instead — e.g.
    /// [`Scale::ShiftedLog`], the authors' code's bins; the other variables unchanged.
    ///
    /// ```
    /// use savme_kernel::{Scale, Space, Variable};
    /// let s = Space::new(vec![Variable::continuous("view_m", 10.0, 5000.0, 10, Scale::Log)])?;
    /// let paper = s.with_log_scale(Scale::ShiftedLog)?;
    /// assert_eq!(paper.variables()[0].bin(0).unwrap().0, 10.0);
    /// assert_ne!(paper.variables()[0].bin(0), s.variables()[0].bin(0));
    /// # Ok::<(), savme_kernel::SpaceError>(())
    /// ```
    pub fn with_log_scale(&self, scale: Scale) -> Result<Space, SpaceError> {
        let vars = self
            .vars
            .iter()
            .map(|v| match v.domain {
                Domain::Continuous {
                    lo,
                    hi,
                    bins,
                    scale: Scale::Log,
                } => Variable::continuous(&v.name, lo, hi, bins, scale),
                _ => v.clone(),
            })
            .collect();
        Space::new(vars)
    }

    /// The variables, in order.
    pub fn variables(&self) -> &[Variable] {
        &self.vars
    }

    /// Number of variables.
    pub fn len(&self) -> usize {
        self.vars.len()
    }

    /// Always false: a valid space has at least one variable.
    pub fn is_empty(&self) -> bool {
        self.vars.is_empty()
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.vars.iter().find(|v| &*v.name == name)
    }

    /// Total number of arms over all variables.
    pub fn total_arms(&self) -> usize {
        self.vars.iter().map(Variable::arms).sum()
    }

    /// The arm of every variable for a complete assignment: every variable present, each value
    /// inside its variable, no unknown names.
    ///
    /// ```
    /// use savme_kernel::{Assignment, Space, Variable, SpaceError};
    /// let space = Space::new(vec![Variable::discrete("rate", [2, 10])])?;
    /// assert_eq!(space.arms_of(&Assignment::new().with("rate", 10))?, vec![1]);
    /// assert!(matches!(
    ///     space.arms_of(&Assignment::new().with("rate", 3)),
    ///     Err(SpaceError::OutOfSpace { .. })
    /// ));
    /// # Ok::<(), SpaceError>(())
    /// ```
    pub fn arms_of(&self, a: &Assignment) -> Result<Vec<usize>, SpaceError> {
        if let Some((name, _)) = a.iter().find(|(n, _)| self.variable(n).is_none()) {
            return Err(SpaceError::UnknownVariable {
                variable: name.to_string(),
            });
        }
        self.vars
            .iter()
            .map(|v| {
                let value = a.get(&v.name).ok_or_else(|| SpaceError::MissingValue {
                    variable: v.name.to_string(),
                })?;
                v.arm_of(value)
                    .ok_or_else(|| match (&v.domain, value.as_f64()) {
                        (Domain::Continuous { .. }, None) => SpaceError::NotANumber {
                            variable: v.name.to_string(),
                            value: value.to_string(),
                        },
                        _ => SpaceError::OutOfSpace {
                            variable: v.name.to_string(),
                            value: value.to_string(),
                            allowed: describe(&v.domain),
                        },
                    })
            })
            .collect()
    }

    /// Draws a value for every variable from the given arms (one per variable, in order).
    pub(crate) fn draw<R: Rng + ?Sized>(&self, arms: &[u16], rng: &mut R) -> Assignment {
        let values = self
            .vars
            .iter()
            .zip(arms)
            .zip(&self.log_spans)
            .map(|((v, &arm), &span)| v.draw_with_span(arm as usize, span, rng))
            .collect();
        Assignment::from_parts(self.names.clone(), values)
    }

    /// The position of every variable of `phi` in the unit cube along its scale: a continuous
    /// value at `(x − lo) / (hi − lo)` (linear), `ln(x / lo) / ln(hi / lo)` (log) or
    /// `ln(1 + x − lo) / ln(1 + hi − lo)` (shifted-log), a
    /// discrete value at the centre of its arm's slice `(arm + ½) / n`. `arms` are the arms of
    /// `phi` (one per variable, as drawn).
    pub(crate) fn unit_of(&self, phi: &Assignment, arms: &[u16]) -> Vec<f64> {
        self.vars
            .iter()
            .zip(arms)
            .map(|(v, &arm)| {
                let centre = (f64::from(arm) + 0.5) / v.arms() as f64;
                match (&v.domain, phi.get(&v.name).and_then(Value::as_f64)) {
                    (Domain::Continuous { lo, hi, scale, .. }, Some(x)) => {
                        let t = match scale {
                            Scale::Linear => (x - lo) / (hi - lo),
                            Scale::Log => (x / lo).ln() / (hi / lo).ln(),
                            Scale::ShiftedLog => (x - lo).ln_1p() / (hi - lo).ln_1p(),
                        };
                        if t.is_finite() {
                            t.clamp(0.0, 1.0)
                        } else {
                            centre
                        }
                    }
                    _ => centre,
                }
            })
            .collect()
    }

    /// The inverse of [`Space::unit_of`]: the arms and the assignment at unit-cube position `u`
    /// (one coordinate per variable, each clamped into `[0, 1]`); a discrete variable takes
    /// the value whose slice holds its coordinate.
    pub(crate) fn at_unit(&self, u: &[f64], arms: &mut Vec<u16>) -> Assignment {
        let values = self
            .vars
            .iter()
            .zip(u)
            .zip(&self.log_spans)
            .map(|((v, &t), &span)| {
                let t = if t.is_finite() {
                    t.clamp(0.0, 1.0)
                } else {
                    0.5
                };
                let n = v.arms();
                let slice = ((t * n as f64).floor() as usize).min(n - 1);
                let value = match &v.domain {
                    Domain::Discrete { values } => values[slice].clone(),
                    Domain::Continuous { lo, hi, scale, .. } => Value::Real(
                        match scale {
                            Scale::Linear => lo + t * (hi - lo),
                            Scale::Log => lo * (t * span).exp(),
                            Scale::ShiftedLog => lo + (t * (hi - lo).ln_1p()).exp_m1(),
                        }
                        .clamp(*lo, *hi),
                    ),
                };
                arms.push(v.arm_of(&value).unwrap_or(slice) as u16);
                value
            })
            .collect();
        Assignment::from_parts(self.names.clone(), values)
    }

    /// The representative value of every variable for the given arms (one per variable).
    pub(crate) fn representatives(&self, arms: &[u16]) -> Assignment {
        let values = self
            .vars
            .iter()
            .zip(arms)
            .map(|(v, &arm)| v.representative(arm as usize))
            .collect();
        Assignment::from_parts(self.names.clone(), values)
    }
}

fn describe(d: &Domain) -> String {
    match d {
        Domain::Discrete { values } => {
            let vs: Vec<String> = values.iter().map(Value::to_string).collect();
            format!("one of {{{}}}", vs.join(", "))
        }
        Domain::Continuous { lo, hi, .. } => format!("a number in [{}, {}]", Num(*lo), Num(*hi)),
    }
}

//! The nominal (field) distribution of each φ variable: its declared form (uniform, normal,
//! log-normal, histogram, …), its probability or density on the variable's scale, its mass in
//! each bin, and draws inside a bin — what the importance weights p(φ)/q(φ) divide by.

use super::EstimationError;
use crate::space::{Domain, Scale, Variable};
use crate::value::Value;
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};
use statrs::distribution::{Continuous, ContinuousCDF, LogNormal, Normal};

/// The nominal (field) distribution of one φ variable.
///
/// ```
/// use savme_kernel::estimation::Nominal;
/// let n: Nominal = serde_json::from_str(r#"{"distribution":"normal","mean":12.0,"sd":2.0}"#)?;
/// assert_eq!(n, Nominal::Normal { mean: 12.0, sd: 2.0 });
/// # Ok::<(), serde_json::Error>(())
/// ```
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(
    tag = "distribution",
    rename_all = "lowercase",
    deny_unknown_fields,
    from = "NominalForm"
)]
pub enum Nominal {
    /// Uniform over the variable on its own scale: uniform on `[lo, hi]` for a linear variable,
    /// log-uniform for a log-scaled one, every value equally likely for a discrete one. This is
    /// also what the baseline stage draws.
    #[default]
    Uniform,
    /// A normal distribution truncated to `[lo, hi]` (continuous variables only).
    Normal {
        /// Mean before truncation.
        mean: f64,
        /// Standard deviation before truncation, finite and > 0.
        sd: f64,
    },
    /// Probabilities of a discrete variable's values, in value order (normalised; finite,
    /// ≥ 0, not all 0).
    Weights {
        /// One weight per value.
        weights: Vec<f64>,
    },
    /// A log-normal distribution truncated to `[lo, hi]` (continuous variables only): ln φ is
    /// normal with mean `mu` and standard deviation `sigma` (the parameters of the logarithm,
    /// as numpy's `lognormal` and statrs take them).
    #[serde(rename = "lognormal")]
    LogNormal {
        /// Mean of ln φ.
        mu: f64,
        /// Standard deviation of ln φ, finite and > 0.
        sigma: f64,
    },
    /// A piecewise-constant density truncated to `[lo, hi]` (continuous variables only):
    /// `weights[k]` is the probability of `[edges[k], edges[k + 1])` (normalised; finite,
    /// ≥ 0, not all 0), spread uniformly over it. Edges strictly increase.
    Histogram {
        /// `weights.len() + 1` increasing bin edges.
        edges: Vec<f64>,
        /// One weight per bin.
        weights: Vec<f64>,
    },
}

/// [`Nominal`] as read: serde ignores `deny_unknown_fields` on a unit variant of an
/// internally tagged enum, so `{"distribution":"uniform","sd":2}` would lose its `sd`
/// silently; an empty struct variant refuses it.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Deserialize)]
#[serde(tag = "distribution", rename_all = "lowercase", deny_unknown_fields)]
enum NominalForm {
    Uniform {},
    Normal {
        mean: f64,
        sd: f64,
    },
    Weights {
        weights: Vec<f64>,
    },
    #[serde(rename = "lognormal")]
    LogNormal {
        mu: f64,
        sigma: f64,
    },
    Histogram {
        edges: Vec<f64>,
        weights: Vec<f64>,
    },
}

impl From<NominalForm> for Nominal {
    fn from(f: NominalForm) -> Nominal {
        match f {
            NominalForm::Uniform {} => Nominal::Uniform,
            NominalForm::Normal { mean, sd } => Nominal::Normal { mean, sd },
            NominalForm::Weights { weights } => Nominal::Weights { weights },
            NominalForm::LogNormal { mu, sigma } => Nominal::LogNormal { mu, sigma },
            NominalForm::Histogram { edges, weights } => Nominal::Histogram { edges, weights },
        }
    }
}

/// A [`Nominal`] checked against its variable, with what its density needs precomputed.
#[derive(Debug, Clone)]
pub(crate) enum NominalOf {
    Uniform,
    /// A continuous distribution truncated to the variable's `[lo, hi]`.
    Truncated {
        shape: Shape,
        /// Its CDF at `lo`.
        cdf_lo: f64,
        /// Its mass inside `[lo, hi]`.
        mass: f64,
    },
    Weights(Vec<f64>),
}

/// A continuous nominal before truncation.
#[derive(Debug, Clone)]
pub(crate) enum Shape {
    Normal(Normal),
    LogNormal(LogNormal),
    Histogram(Histogram),
}

impl Shape {
    fn pdf(&self, x: f64) -> f64 {
        match self {
            Shape::Normal(n) => n.pdf(x),
            Shape::LogNormal(n) if x <= 0.0 => 0.0,
            Shape::LogNormal(n) => n.pdf(x),
            Shape::Histogram(h) => h.pdf(x),
        }
    }

    fn cdf(&self, x: f64) -> f64 {
        match self {
            Shape::Normal(n) => n.cdf(x),
            Shape::LogNormal(n) if x <= 0.0 => 0.0,
            Shape::LogNormal(n) => n.cdf(x),
            Shape::Histogram(h) => h.cdf(x),
        }
    }

    fn inverse_cdf(&self, u: f64) -> f64 {
        match self {
            Shape::Normal(n) => n.inverse_cdf(u),
            Shape::LogNormal(n) => n.inverse_cdf(u),
            Shape::Histogram(h) => h.inverse_cdf(u),
        }
    }
}

/// A piecewise-constant density: bin k is `[edges[k], edges[k + 1])` with probability
/// `p[k]` (normalised), `cum[k]` the probability below `edges[k]`.
#[derive(Debug, Clone)]
pub(crate) struct Histogram {
    edges: Vec<f64>,
    p: Vec<f64>,
    cum: Vec<f64>,
}

impl Histogram {
    /// Checks and normalises a histogram (the message says what is wrong).
    fn new(edges: &[f64], weights: &[f64]) -> Result<Histogram, String> {
        if weights.is_empty() || edges.len() != weights.len() + 1 {
            return Err(format!(
                "a histogram needs one more edge than weights, got {} edges and {} weights",
                edges.len(),
                weights.len()
            ));
        }
        if edges.iter().any(|e| !e.is_finite()) || edges.windows(2).any(|w| w[0] >= w[1]) {
            return Err(format!(
                "histogram edges must be finite and strictly increasing, got {edges:?}"
            ));
        }
        let total: f64 = weights.iter().sum();
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
            || !(total.is_finite() && total > 0.0)
        {
            return Err(format!(
                "histogram weights must be finite, ≥ 0 and not all 0, got {weights:?}"
            ));
        }
        let p: Vec<f64> = weights.iter().map(|w| w / total).collect();
        let mut cum = vec![0.0];
        for w in &p {
            cum.push(cum[cum.len() - 1] + w);
        }
        Ok(Histogram {
            edges: edges.to_vec(),
            p,
            cum,
        })
    }

    /// The bin holding `x` (None outside the edges; the last edge belongs to the last bin).
    fn bin(&self, x: f64) -> Option<usize> {
        let n = self.p.len();
        if !(x >= self.edges[0] && x <= self.edges[n]) {
            return None;
        }
        Some(self.edges.partition_point(|e| *e <= x).clamp(1, n) - 1)
    }

    fn pdf(&self, x: f64) -> f64 {
        self.bin(x)
            .map_or(0.0, |k| self.p[k] / (self.edges[k + 1] - self.edges[k]))
    }

    fn cdf(&self, x: f64) -> f64 {
        let n = self.p.len();
        if x < self.edges[0] {
            return 0.0;
        }
        match self.bin(x) {
            None => 1.0,
            Some(k) => {
                let share = (x - self.edges[k]) / (self.edges[k + 1] - self.edges[k]);
                (self.cum[k] + share * self.p[k]).min(self.cum[n])
            }
        }
    }

    fn inverse_cdf(&self, u: f64) -> f64 {
        // The first bin of positive probability whose upper cumulative probability exceeds u.
        let n = self.p.len();
        let k = (0..n)
            .find(|&k| self.p[k] > 0.0 && u < self.cum[k + 1])
            .or_else(|| (0..n).rfind(|&k| self.p[k] > 0.0))
            .unwrap_or(n - 1);
        let share = if self.p[k] > 0.0 {
            ((u - self.cum[k]) / self.p[k]).clamp(0.0, 1.0)
        } else {
            0.5
        };
        self.edges[k] + share * (self.edges[k + 1] - self.edges[k])
    }
}

impl NominalOf {
    /// Checks `nominal` against `var` of `scenario`.
    pub(crate) fn new(
        nominal: &Nominal,
        scenario: &str,
        var: &Variable,
    ) -> Result<NominalOf, EstimationError> {
        let bad = |message: String| EstimationError::BadNominal {
            scenario: scenario.to_string(),
            variable: var.name.to_string(),
            message,
        };
        match (nominal, &var.domain) {
            (Nominal::Uniform, _) => Ok(NominalOf::Uniform),
            (Nominal::Weights { weights }, Domain::Discrete { values }) => {
                if weights.len() != values.len() {
                    return Err(bad(format!(
                        "{} weights for {} values",
                        weights.len(),
                        values.len()
                    )));
                }
                let total: f64 = weights.iter().sum();
                if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
                    || !(total.is_finite() && total > 0.0)
                {
                    return Err(bad(format!(
                        "weights must be finite, ≥ 0 and not all 0, got {weights:?}"
                    )));
                }
                Ok(NominalOf::Weights(
                    weights.iter().map(|w| w / total).collect(),
                ))
            }
            (Nominal::Weights { .. }, Domain::Continuous { .. }) => Err(bad(
                "weights need a discrete variable; give a normal (or uniform) for a continuous one"
                    .into(),
            )),
            (_, Domain::Discrete { .. }) => Err(bad(format!(
                "a {} needs a continuous variable; give `weights` for a discrete one",
                nominal.kind()
            ))),
            (_, Domain::Continuous { lo, hi, .. }) => {
                let shape = Shape::of(nominal).map_err(bad)?;
                let cdf_lo = shape.cdf(*lo);
                let mass = shape.cdf(*hi) - cdf_lo;
                if mass.is_nan() || mass < 1e-9 {
                    return Err(bad(format!(
                        "{} puts {mass:e} of its mass inside [{lo}, {hi}]; it must put at least 1e-9 there",
                        nominal.describe()
                    )));
                }
                Ok(NominalOf::Truncated {
                    shape,
                    cdf_lo,
                    mass,
                })
            }
        }
    }

    /// The density (continuous) or probability (discrete) of `x`; 0 outside the variable.
    pub(crate) fn density(&self, var: &Variable, x: &Value) -> f64 {
        let Some(arm) = var.arm_of(x) else {
            return 0.0;
        };
        match (self, &var.domain) {
            (NominalOf::Weights(w), _) => w[arm],
            (NominalOf::Uniform, Domain::Discrete { values }) => 1.0 / values.len() as f64,
            (NominalOf::Uniform, Domain::Continuous { lo, hi, scale, .. }) => {
                let v = x.as_f64().unwrap_or(f64::NAN);
                match scale {
                    Scale::Linear => 1.0 / (hi - lo),
                    Scale::Log => 1.0 / (v * (hi / lo).ln()),
                    // A bin drawn uniformly, then the value inside it as the bin draws.
                    Scale::ShiftedLog => var.in_bin_density(arm, x) / var.arms() as f64,
                }
            }
            (NominalOf::Truncated { shape, mass, .. }, _) => {
                shape.pdf(x.as_f64().unwrap_or(f64::NAN)) / mass
            }
        }
    }

    /// The nominal's probability of bin (or value) `arm` of `var`.
    pub(crate) fn bin_mass(&self, var: &Variable, arm: usize) -> f64 {
        match (self, var.bin(arm)) {
            (NominalOf::Weights(w), _) => w[arm],
            (NominalOf::Truncated { shape, mass, .. }, Some((a, b))) => {
                (shape.cdf(b) - shape.cdf(a)) / mass
            }
            // Uniform on the variable's scale: every bin (linear or log) or value alike.
            _ => 1.0 / var.arms() as f64,
        }
    }

    /// Draws from the nominal restricted to bin (or value) `arm` of `var`: uniform or
    /// log-uniform inside the bin for a uniform nominal, the truncated distribution otherwise.
    pub(crate) fn draw_in_bin<R: Rng + ?Sized>(
        &self,
        var: &Variable,
        arm: usize,
        rng: &mut R,
    ) -> Value {
        match (self, var.bin(arm)) {
            (NominalOf::Truncated { shape, .. }, Some((a, b))) => {
                let (ca, cb) = (shape.cdf(a), shape.cdf(b));
                let u: f64 = rng.random();
                Value::Real(shape.inverse_cdf(ca + u * (cb - ca)).clamp(a, b))
            }
            _ => var.draw_in_arm(arm, rng),
        }
    }

    /// The density of `x` under the nominal restricted to its bin `arm` (0 for a bin the
    /// nominal gives no mass).
    pub(crate) fn density_in_bin(&self, var: &Variable, arm: usize, x: &Value) -> f64 {
        let mass = self.bin_mass(var, arm);
        if mass > 0.0 {
            self.density(var, x) / mass
        } else {
            0.0
        }
    }

    pub(crate) fn draw<R: Rng + ?Sized>(&self, var: &Variable, rng: &mut R) -> Value {
        match (self, &var.domain) {
            (NominalOf::Weights(w), _) => var.draw_in_arm(categorical(w, rng), rng),
            (NominalOf::Uniform, _) => {
                let arm = rng.random_range(0..var.arms());
                var.draw_in_arm(arm, rng)
            }
            (
                NominalOf::Truncated {
                    shape,
                    cdf_lo,
                    mass,
                },
                Domain::Continuous { lo, hi, .. },
            ) => {
                let u: f64 = rng.random();
                Value::Real(shape.inverse_cdf(cdf_lo + u * mass).clamp(*lo, *hi))
            }
            (NominalOf::Truncated { .. }, Domain::Discrete { values }) => values[0].clone(),
        }
    }
}

impl Shape {
    /// The distribution of a continuous nominal, its parameters checked.
    fn of(nominal: &Nominal) -> Result<Shape, String> {
        match nominal {
            Nominal::Normal { mean, sd } => {
                if !(mean.is_finite() && sd.is_finite() && *sd > 0.0) {
                    return Err(format!(
                        "a normal needs a finite mean and a finite sd > 0, got mean = {mean}, sd = {sd}"
                    ));
                }
                Normal::new(*mean, *sd)
                    .map(Shape::Normal)
                    .map_err(|e| e.to_string())
            }
            Nominal::LogNormal { mu, sigma } => {
                if !(mu.is_finite() && sigma.is_finite() && *sigma > 0.0) {
                    return Err(format!(
                        "a log-normal needs a finite mu and a finite sigma > 0, got mu = {mu}, sigma = {sigma}"
                    ));
                }
                LogNormal::new(*mu, *sigma)
                    .map(Shape::LogNormal)
                    .map_err(|e| e.to_string())
            }
            Nominal::Histogram { edges, weights } => {
                Histogram::new(edges, weights).map(Shape::Histogram)
            }
            Nominal::Uniform | Nominal::Weights { .. } => {
                Err(format!("{} is not a continuous shape", nominal.kind()))
            }
        }
    }
}

impl Nominal {
    /// The kind's name as the files write it (`"normal"`, `"lognormal"`, …).
    pub fn kind(&self) -> &'static str {
        match self {
            Nominal::Uniform => "uniform",
            Nominal::Normal { .. } => "normal",
            Nominal::Weights { .. } => "weights",
            Nominal::LogNormal { .. } => "lognormal",
            Nominal::Histogram { .. } => "histogram",
        }
    }

    /// The distribution with its parameters, for messages.
    fn describe(&self) -> String {
        match self {
            Nominal::Normal { mean, sd } => format!("normal({mean}, {sd})"),
            Nominal::LogNormal { mu, sigma } => format!("lognormal(mu {mu}, sigma {sigma})"),
            Nominal::Histogram { edges, .. } => format!(
                "the histogram over [{}, {}]",
                edges.first().copied().unwrap_or(f64::NAN),
                edges.last().copied().unwrap_or(f64::NAN)
            ),
            other => other.kind().to_string(),
        }
    }

    /// Checks the nominal against the variable it is declared for, as an estimation checks
    /// it (parameters, kind, mass inside the variable's range); the message says what is
    /// wrong.
    ///
    /// ```
    /// use savme_kernel::estimation::Nominal;
    /// use savme_kernel::{Scale, Variable};
    /// let gap = Variable::continuous("gap", 2.0, 8.0, 10, Scale::Linear);
    /// assert!(Nominal::LogNormal { mu: 1.5, sigma: 0.3 }.check(&gap).is_ok());
    /// let e = Nominal::Normal { mean: 500.0, sd: 1.0 }.check(&gap).unwrap_err();
    /// assert!(e.contains("of its mass inside [2, 8]"), "{e}");
    /// ```
    pub fn check(&self, var: &Variable) -> Result<(), String> {
        NominalOf::new(self, "", var)
            .map(drop)
            .map_err(|e| match e {
                EstimationError::BadNominal { message, .. } => message,
                other => other.to_string(),
            })
    }
}

/// Index drawn from normalised probabilities `p` (the last index of positive probability
/// takes rounding leftovers, so an index of probability 0 is never drawn).
pub(crate) fn categorical<R: Rng + ?Sized>(p: &[f64], rng: &mut R) -> usize {
    let u: f64 = rng.random();
    let mut acc = 0.0;
    for (i, w) in p.iter().enumerate() {
        acc += w;
        if u < acc {
            return i;
        }
    }
    p.iter().rposition(|w| *w > 0.0).unwrap_or(p.len() - 1)
}

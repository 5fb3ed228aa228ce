//! The reading of a `ParameterValueDistribution` file's elements into parameters.

use crate::xml::{self, Budget, Element, ParseError, STOP_EVERY};
use crate::{Domain, Limits, OpenScenarioError, Parameter, ParameterDistribution, Variation};
use savme_kernel::estimation::Nominal;
use savme_kernel::{Value, MAX_ARMS};
use std::collections::HashMap;
use std::path::PathBuf;

/// The file being read: builds errors that name it, and asks whether to stop.
struct File<'a> {
    name: &'a str,
    stop: &'a dyn Fn() -> bool,
}

impl File<'_> {
    fn err(&self, at: &Element, message: impl Into<String>) -> OpenScenarioError {
        OpenScenarioError {
            file: self.name.to_string(),
            line: Some(at.line),
            element: Some(at.name.clone()),
            message: message.into(),
        }
    }

    /// A [`crate::STOPPED`] error if the stop says so (asked before the `k`th parameter, every
    /// [`STOP_EVERY`]th).
    fn check_stop(&self, k: usize) -> Result<(), OpenScenarioError> {
        if k > 0 && k.is_multiple_of(STOP_EVERY) && (self.stop)() {
            return Err(OpenScenarioError {
                file: self.name.to_string(),
                line: None,
                element: None,
                message: crate::STOPPED.into(),
            });
        }
        Ok(())
    }

    /// Attribute `name` of `e`, required.
    fn attribute<'e>(&self, e: &'e Element, name: &str) -> Result<&'e str, OpenScenarioError> {
        e.attribute(name)
            .ok_or_else(|| self.err(e, format!("the attribute `{name}` is missing")))
    }

    /// Attribute `name` of `e` as a finite number.
    fn number(&self, e: &Element, name: &str) -> Result<f64, OpenScenarioError> {
        let text = self.attribute(e, name)?;
        number(text).ok_or_else(|| {
            let why = if text.trim_start().starts_with('$') {
                "is a parameter reference or expression; savme needs the number itself here"
            } else {
                "is not a finite number"
            };
            self.err(e, format!("`{name}` = \"{text}\" {why}"))
        })
    }

    /// The one child of `e` named `name`, required.
    fn child<'e>(&self, e: &'e Element, name: &'e str) -> Result<&'e Element, OpenScenarioError> {
        let mut found = e.children_named(name);
        match (found.next(), found.next()) {
            (Some(c), None) => Ok(c),
            (None, _) => Err(self.err(e, format!("no <{name}> inside"))),
            (Some(_), Some(second)) => Err(self.err(second, format!("a second <{name}>"))),
        }
    }

    /// `e`'s one child, the distribution of a parameter.
    fn only_child<'e>(&self, e: &'e Element) -> Result<&'e Element, OpenScenarioError> {
        match e.children.as_slice() {
            [one] => Ok(one),
            [] => Err(self.err(e, "no distribution inside")),
            [_, second, ..] => Err(self.err(second, "a second distribution for one parameter")),
        }
    }

    /// A `<Range lowerLimit upperLimit>` child of `e`: `lo < hi`, or `lo ≤ hi` if `closed`.
    fn range(&self, e: &Element, closed: bool) -> Result<(f64, f64), OpenScenarioError> {
        let r = self.child(e, "Range")?;
        // OpenSCENARIO 1.x's Range has these two attributes and no other: a third (`step`, a
        // misspelt `uperLimit`) would be ignored, so it is refused.
        if let Some((name, _)) = r
            .attributes
            .iter()
            .find(|(n, _)| n != "lowerLimit" && n != "upperLimit")
        {
            return Err(self.err(
                r,
                format!(
                    "unknown attribute `{name}`: a <Range> has `lowerLimit` and `upperLimit` only"
                ),
            ));
        }
        let (lo, hi) = (self.number(r, "lowerLimit")?, self.number(r, "upperLimit")?);
        if lo < hi || (closed && lo == hi) {
            Ok((lo, hi))
        } else {
            Err(self.err(r, format!("lowerLimit {lo} is not below upperLimit {hi}")))
        }
    }
}

/// A finite number (OpenSCENARIO writes doubles as XML Schema does, e.g. `1.5E1`, `INF`).
fn number(text: &str) -> Option<f64> {
    text.trim().parse::<f64>().ok().filter(|x| x.is_finite())
}

/// Reads `text` (the file `name`): at most `limits.elements` elements, `stop` asked every
/// [`STOP_EVERY`] elements and parameters.
pub(crate) fn read(
    text: &str,
    name: &str,
    limits: Limits,
    stop: &dyn Fn() -> bool,
) -> Result<ParameterDistribution, OpenScenarioError> {
    let f = File { name, stop };
    let budget = Budget {
        elements: limits.elements,
        stop,
    };
    let root = xml::parse(text, &budget).map_err(|e| {
        let (line, message) = match e {
            ParseError::Xml(e) => (Some(e.line), e.message),
            ParseError::TooManyElements { line } => (
                Some(line),
                format!(
                    "the file holds more than the {} elements savme reads (a parameter variation file holds a few dozen)",
                    limits.elements
                ),
            ),
            ParseError::Stopped => (None, crate::STOPPED.to_string()),
        };
        OpenScenarioError {
            file: name.to_string(),
            line,
            element: None,
            message,
        }
    })?;
    if root.name != "OpenSCENARIO" {
        return Err(f.err(&root, "the root element must be <OpenSCENARIO>"));
    }
    let Some(pvd) = root.children_named("ParameterValueDistribution").next() else {
        return Err(f.err(
            &root,
            "no <ParameterValueDistribution>: this is no parameter variation file (a scenario \
             declares its parameters; their variation is a separate file)",
        ));
    };
    let scenario_file = pvd
        .children_named("ScenarioFile")
        .next()
        .and_then(|s| s.attribute("filepath"))
        .map(String::from);
    let det = pvd.children_named("Deterministic").next();
    let stoch = pvd.children_named("Stochastic").next();
    let (variation, parameters) = match (det, stoch) {
        (Some(d), None) => (Variation::Deterministic, deterministic(&f, d)?),
        (None, Some(s)) => stochastic(&f, s)?,
        (Some(_), Some(s)) => {
            return Err(f.err(
                s,
                "a file is either <Deterministic> or <Stochastic>, not both",
            ))
        }
        (None, None) => {
            return Err(f.err(pvd, "neither <Deterministic> nor <Stochastic> inside"));
        }
    };
    // The first line of each name (a map: a search of the earlier parameters for each one
    // would take time quadratic in their number).
    let mut first_line: HashMap<&str, usize> = HashMap::with_capacity(parameters.len());
    for p in &parameters {
        if let Some(first) = first_line.insert(p.name.as_str(), p.line) {
            return Err(OpenScenarioError {
                file: name.to_string(),
                line: Some(p.line),
                element: Some(p.element.clone()),
                message: format!(
                    "parameter `{}` varies twice (first at line {first})",
                    p.name
                ),
            });
        }
    }
    Ok(ParameterDistribution {
        path: PathBuf::from(name),
        scenario_file,
        variation,
        parameters,
    })
}

/// `parameterName` of `e`, a leading `$` dropped.
fn parameter_name(f: &File, e: &Element) -> Result<String, OpenScenarioError> {
    let n = f.attribute(e, "parameterName")?.trim();
    let n = n.strip_prefix('$').unwrap_or(n);
    if n.is_empty() {
        return Err(f.err(e, "`parameterName` is empty"));
    }
    Ok(n.to_string())
}

/// The parameters of `<Deterministic>`.
fn deterministic(f: &File, det: &Element) -> Result<Vec<Parameter>, OpenScenarioError> {
    let mut out = Vec::new();
    for (k, c) in det.children.iter().enumerate() {
        f.check_stop(k)?;
        match c.name.as_str() {
            "DeterministicSingleParameterDistribution" => {
                let name = parameter_name(f, c)?;
                let d = f.only_child(c)?;
                let domain = match d.name.as_str() {
                    "DistributionSet" => Domain::Values(set_values(f, d)?),
                    "DistributionRange" => Domain::Values(grid(f, d)?),
                    "UserDefinedDistribution" => return Err(user_defined(f, d)),
                    other => {
                        return Err(f.err(d, format!("`{other}` is no deterministic distribution")))
                    }
                };
                out.push(checked(f, d, name, domain, Nominal::Uniform)?);
            }
            "DeterministicMultiParameterDistribution" => {
                return Err(f.err(
                    c,
                    "joint value sets (several parameters varied together) are not supported: \
                     savme's φ-space is a product of one variable per parameter; give each \
                     parameter its own DeterministicSingleParameterDistribution",
                ))
            }
            other => {
                return Err(f.err(
                    c,
                    format!("unexpected element `{other}` in <Deterministic>"),
                ))
            }
        }
    }
    if out.is_empty() {
        return Err(f.err(det, "no parameter varies"));
    }
    Ok(out)
}

/// The values of a `DistributionSet` (`<Element value>`s).
fn set_values(f: &File, d: &Element) -> Result<Vec<Value>, OpenScenarioError> {
    let texts: Vec<&str> = d
        .children_named("Element")
        .map(|e| f.attribute(e, "value"))
        .collect::<Result<_, _>>()?;
    if texts.is_empty() {
        return Err(f.err(d, "no <Element> inside"));
    }
    Ok(typed(&texts))
}

/// Values read alike: integers if every one is, else reals, else booleans, else labels.
fn typed(texts: &[&str]) -> Vec<Value> {
    let all = |ok: &dyn Fn(&str) -> bool| texts.iter().all(|t| ok(t.trim()));
    if all(&|t| t.parse::<i64>().is_ok()) {
        texts
            .iter()
            .map(|t| Value::Int(t.trim().parse().unwrap_or_default()))
            .collect()
    } else if all(&|t| number(t).is_some()) {
        texts
            .iter()
            .map(|t| Value::Real(number(t).unwrap_or_default()))
            .collect()
    } else if all(&|t| t == "true" || t == "false") {
        texts
            .iter()
            .map(|t| Value::Bool(t.trim() == "true"))
            .collect()
    } else {
        texts.iter().map(|t| Value::from(*t)).collect()
    }
}

/// The grid of a `DistributionRange`: `lower + k·stepWidth` up to `upper` (inclusive, to a
/// relative 1e-9 of a step).
fn grid(f: &File, d: &Element) -> Result<Vec<Value>, OpenScenarioError> {
    let step = f.number(d, "stepWidth")?;
    if step <= 0.0 {
        return Err(f.err(d, format!("stepWidth {step} is not positive")));
    }
    let (lo, hi) = f.range(d, true)?;
    let steps = ((hi - lo) / step + 1e-9).floor();
    if steps + 1.0 > MAX_ARMS as f64 {
        return Err(f.err(
            d,
            format!(
                "{} values (from {lo} to {hi} in steps of {step}): at most {MAX_ARMS} are supported",
                steps + 1.0
            ),
        ));
    }
    Ok((0..=steps as u64)
        .map(|k| Value::Real(lo + k as f64 * step))
        .collect())
}

fn user_defined(f: &File, d: &Element) -> OpenScenarioError {
    f.err(
        d,
        format!(
            "a user-defined distribution (type \"{}\") cannot be drawn from by savme; give a set, \
             a range or a standard distribution",
            d.attribute("type").unwrap_or("")
        ),
    )
}

/// The parameters of `<Stochastic>`, with its test runs and seed.
fn stochastic(f: &File, s: &Element) -> Result<(Variation, Vec<Parameter>), OpenScenarioError> {
    let runs = match s.attribute("numberOfTestRuns") {
        Some(t) => Some(t.trim().parse::<u64>().map_err(|_| {
            f.err(
                s,
                format!("`numberOfTestRuns` = \"{t}\" is not a whole number ≥ 0"),
            )
        })?),
        None => None,
    };
    let seed = match s.attribute("randomSeed") {
        Some(_) => Some(f.number(s, "randomSeed")?),
        None => None,
    };
    let mut out = Vec::new();
    for (k, c) in s.children.iter().enumerate() {
        f.check_stop(k)?;
        if c.name != "StochasticDistribution" {
            return Err(f.err(
                c,
                format!("unexpected element `{}` in <Stochastic>", c.name),
            ));
        }
        let name = parameter_name(f, c)?;
        let d = f.only_child(c)?;
        let (domain, nominal) = stochastic_distribution(f, d)?;
        out.push(checked(f, d, name, domain, nominal)?);
    }
    if out.is_empty() {
        return Err(f.err(s, "no parameter varies"));
    }
    Ok((Variation::Stochastic { runs, seed }, out))
}

/// A stochastic distribution element as a domain and a nominal.
fn stochastic_distribution(f: &File, d: &Element) -> Result<(Domain, Nominal), OpenScenarioError> {
    let bounded = |what: &str| {
        if d.children_named("Range").next().is_none() {
            Err(f.err(
                d,
                format!(
                    "{what} without a <Range>: savme's φ-space is bounded; add <Range \
                     lowerLimit=\"…\" upperLimit=\"…\"/> (the distribution is truncated to it)"
                ),
            ))
        } else {
            f.range(d, false)
        }
    };
    let positive = |name: &str| -> Result<f64, OpenScenarioError> {
        let x = f.number(d, name)?;
        if x > 0.0 {
            Ok(x)
        } else {
            Err(f.err(d, format!("`{name}` = {x} must be positive")))
        }
    };
    Ok(match d.name.as_str() {
        "UniformDistribution" => {
            let (lo, hi) = f.range(d, false)?;
            (Domain::Continuous { lo, hi }, Nominal::Uniform)
        }
        "NormalDistribution" => {
            let mean = f.number(d, "expectedValue")?;
            let variance = positive("variance")?;
            let (lo, hi) = bounded("a normal distribution")?;
            let sd = variance.sqrt();
            (Domain::Continuous { lo, hi }, Nominal::Normal { mean, sd })
        }
        "LogNormalDistribution" => {
            let mean = positive("expectedValue")?;
            let variance = positive("variance")?;
            let (lo, hi) = bounded("a log-normal distribution")?;
            // expectedValue and variance are those of the value itself (as the standard and
            // scenariogeneration describe them): the logarithm's σ² = ln(1 + v/m²), μ = ln m − σ²/2.
            let s2 = (1.0 + variance / (mean * mean)).ln();
            let nominal = Nominal::LogNormal {
                mu: mean.ln() - s2 / 2.0,
                sigma: s2.sqrt(),
            };
            (Domain::Continuous { lo, hi }, nominal)
        }
        "Histogram" => histogram(f, d)?,
        "ProbabilityDistributionSet" => {
            let mut texts = Vec::new();
            let mut weights = Vec::new();
            for e in d.children_named("Element") {
                texts.push(f.attribute(e, "value")?);
                weights.push(f.number(e, "weight")?);
            }
            if texts.is_empty() {
                return Err(f.err(d, "no <Element> inside"));
            }
            (Domain::Values(typed(&texts)), Nominal::Weights { weights })
        }
        "PoissonDistribution" => poisson(
            f,
            d,
            positive("expectedValue")?,
            bounded("a Poisson distribution")?,
        )?,
        "UserDefinedDistribution" => return Err(user_defined(f, d)),
        other => return Err(f.err(d, format!("`{other}` is no stochastic distribution"))),
    })
}

/// A `Histogram`'s bins (`<Bin weight><Range/></Bin>`, ascending, not overlapping; a gap
/// between two bins has no mass) as a continuous domain over them and its nominal.
fn histogram(f: &File, d: &Element) -> Result<(Domain, Nominal), OpenScenarioError> {
    let mut edges: Vec<f64> = Vec::new();
    let mut weights = Vec::new();
    for bin in d.children_named("Bin") {
        let weight = f.number(bin, "weight")?;
        let (lo, hi) = f.range(bin, false)?;
        match edges.last().copied() {
            Some(last) if lo < last => {
                return Err(f.err(
                    bin,
                    format!("bin [{lo}, {hi}] starts below the previous bin's end {last}: bins must ascend without overlapping"),
                ))
            }
            Some(last) if lo > last => {
                weights.push(0.0);
                edges.push(lo);
            }
            Some(_) => {}
            None => edges.push(lo),
        }
        weights.push(weight);
        edges.push(hi);
    }
    if weights.is_empty() {
        return Err(f.err(d, "no <Bin> inside"));
    }
    let domain = Domain::Continuous {
        lo: edges[0],
        hi: edges[edges.len() - 1],
    };
    Ok((domain, Nominal::Histogram { edges, weights }))
}

/// A Poisson distribution with mean `lambda` on the integers of `[lo, hi]`.
fn poisson(
    f: &File,
    d: &Element,
    lambda: f64,
    (lo, hi): (f64, f64),
) -> Result<(Domain, Nominal), OpenScenarioError> {
    let (first, last) = (lo.max(0.0).ceil(), hi.floor());
    if first > last {
        return Err(f.err(d, format!("the range [{lo}, {hi}] holds no count ≥ 0")));
    }
    if last - first + 1.0 > MAX_ARMS as f64 {
        return Err(f.err(
            d,
            format!("the range [{lo}, {hi}] holds more than {MAX_ARMS} counts"),
        ));
    }
    let ks: Vec<u64> = (first as u64..=last as u64).collect();
    // ln P(k) = k ln λ − λ − ln k!, normalised by the caller (the kernel); ln k! summed once
    // up to the first count, then one term per count (not a sum from 1 for each).
    let mut ln_fact = ln_factorial((first as u64).saturating_sub(1));
    let weights = ks
        .iter()
        .map(|&k| {
            if k > 0 {
                ln_fact += (k as f64).ln();
            }
            (k as f64 * lambda.ln() - lambda - ln_fact).exp()
        })
        .collect();
    let values = ks.iter().map(|&k| Value::Int(k as i64)).collect();
    Ok((Domain::Values(values), Nominal::Weights { weights }))
}

/// ln n!: summed up to 256, Stirling's series above (relative error below 1e-15 there), so that
/// a range far from 0 costs no more than one near it.
fn ln_factorial(n: u64) -> f64 {
    if n < 256 {
        return (2..=n).map(|i| (i as f64).ln()).sum();
    }
    let x = n as f64;
    x * x.ln() - x + 0.5 * (2.0 * std::f64::consts::PI * x).ln() + 1.0 / (12.0 * x)
        - 1.0 / (360.0 * x * x * x)
}

/// A parameter, its variable and nominal checked as the kernel and the estimator check them.
fn checked(
    f: &File,
    d: &Element,
    name: String,
    domain: Domain,
    nominal: Nominal,
) -> Result<Parameter, OpenScenarioError> {
    let p = Parameter {
        name,
        domain,
        nominal,
        element: d.name.clone(),
        line: d.line,
    };
    let var = p.variable(10);
    savme_kernel::Space::new(vec![var.clone()])
        .map_err(|e| f.err(d, format!("parameter `{}`: {e}", p.name)))?;
    p.nominal
        .check(&var)
        .map_err(|e| f.err(d, format!("parameter `{}`: {e}", p.name)))?;
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::ln_factorial;

    #[test]
    fn ln_factorial_sums_then_follows_stirling() {
        assert_eq!(ln_factorial(0), 0.0);
        assert_eq!(ln_factorial(1), 0.0);
        assert!((ln_factorial(5) - 120f64.ln()).abs() < 1e-12);
        let summed = |n: u64| (2..=n).map(|i| (i as f64).ln()).sum::<f64>();
        for n in [256, 300, 5000] {
            let (a, b) = (ln_factorial(n), summed(n));
            assert!((a - b).abs() <= 1e-12 * b, "{n}: {a} vs {b}");
        }
    }
}

//! How a run executes, from `[fmu]`: the step size (fixed, a fidelity rate or a fidelity
//! variable that drives it), the step count, the tolerance, the stop time, the cost source, the
//! FMU paths and the timeout — each checked at its key.

use super::*;

/// `[fmu] step`: a fixed positive step, or the rate a fidelity variable gives — or, without
/// it, the fidelity variable that `drives = "step_size"`.
pub(super) fn step(
    src: &Source,
    fmu: &Spanned<raw::FmuSection>,
    fidelity: &Fidelity,
) -> Result<StepSize, ConfigError> {
    let driver = fidelity.driver(Drives::StepSize);
    let Some(step) = &fmu.get_ref().step else {
        return match driver {
            Some((d, _, _)) => Ok(StepSize::Of(d.variable.clone())),
            None => Err(src.err(
                Some(src.line(fmu.span())),
                Some("fmu.step"),
                "no step size: give `step` (seconds, or { rate_of = \"…\" }) or a fidelity \
                 variable with drives = \"step_size\"",
            )),
        };
    };
    let line = Some(src.line(step.span()));
    if let Some((d, d_line, d_key)) = driver {
        return Err(src.err(
            line,
            Some("fmu.step"),
            format!(
                "the step size is the fidelity variable `{}` (`{d_key}`, line {d_line}): \
                 remove `step`",
                d.variable
            ),
        ));
    }
    match step.get_ref() {
        StepSection::Fixed(h) if !(*h > 0.0 && h.is_finite()) => Err(src.err(
            line,
            Some("fmu.step"),
            format!("step size {h} is not a positive number of seconds"),
        )),
        StepSection::Fixed(h) => Ok(StepSize::Fixed(*h)),
        StepSection::Rate { rate_of } if fidelity.space.variable(rate_of).is_none() => Err(src
            .err(
                line,
                Some("fmu.step.rate_of"),
                format!("`{rate_of}` is not a fidelity variable"),
            )),
        StepSection::Rate { rate_of } => Ok(StepSize::RateOf(rate_of.clone())),
    }
}

/// Refuses a step size that gives a run more than [`crate::simulator::MAX_STEPS`] steps (at
/// the largest rate, or the smallest step, its fidelity variable allows), naming the key.
pub(super) fn step_count(
    src: &Source,
    fmu: &Spanned<raw::FmuSection>,
    step: &StepSize,
    stop_time: f64,
    fidelity: &Fidelity,
) -> Result<(), ConfigError> {
    let at_step = || fmu.get_ref().step.as_ref().map(|s| src.line(s.span()));
    let (smallest, line, key) = match step {
        StepSize::Fixed(h) => (*h, at_step(), "fmu.step".to_string()),
        StepSize::RateOf(v) => {
            let most = fidelity.space.variable(v).and_then(extremes).map(|e| e.1);
            (
                1.0 / most.unwrap_or(0.0),
                at_step(),
                "fmu.step.rate_of".into(),
            )
        }
        StepSize::Of(v) => {
            let least = fidelity.space.variable(v).and_then(extremes).map(|e| e.0);
            let driver = fidelity.driver(Drives::StepSize);
            let (line, key) = driver.map_or((None, "fidelity".into()), |(_, line, key)| {
                (Some(line), key.to_string())
            });
            (least.unwrap_or(f64::INFINITY), line, key)
        }
    };
    match crate::simulator::too_many_steps(stop_time, smallest) {
        // A non-positive step is refused when the run reads it.
        Some(message) if smallest > 0.0 => Err(src.err(line, Some(&key), message)),
        _ => Ok(()),
    }
}

/// The least and the greatest value of a numeric variable.
pub(super) fn extremes(v: &Variable) -> Option<(f64, f64)> {
    let values = (0..v.arms()).flat_map(|a| match v.bin(a) {
        Some((lo, hi)) => [Some(lo), Some(hi)],
        None => [v.representative(a).as_f64(), None],
    });
    values.flatten().fold(None, |acc, x| match acc {
        None => Some((x, x)),
        Some((lo, hi)) => Some((lo.min(x), hi.max(x))),
    })
}

/// `[fmu] tolerance` (positive), or the fidelity variable that `drives = "tolerance"`, or
/// none (the FMU's own).
pub(super) fn tolerance(
    src: &Source,
    fixed: Option<&Spanned<f64>>,
    fidelity: &Fidelity,
) -> Result<Option<Tolerance>, ConfigError> {
    match (fixed, fidelity.driver(Drives::Tolerance)) {
        (None, None) => Ok(None),
        (None, Some((d, _, _))) => Ok(Some(Tolerance::Of(d.variable.clone()))),
        (Some(t), Some((d, d_line, d_key))) => Err(src.err(
            Some(src.line(t.span())),
            Some("fmu.tolerance"),
            format!(
                "the tolerance is the fidelity variable `{}` (`{d_key}`, line {d_line}): \
                 remove `tolerance`",
                d.variable
            ),
        )),
        (Some(t), None) if *t.get_ref() > 0.0 && t.get_ref().is_finite() => {
            Ok(Some(Tolerance::Fixed(*t.get_ref())))
        }
        (Some(t), None) => Err(src.err(
            Some(src.line(t.span())),
            Some("fmu.tolerance"),
            format!("tolerance {} is not a positive number", t.get_ref()),
        )),
    }
}

/// `[fmu] stop_time`: positive and finite.
pub(super) fn stop_time(src: &Source, t: &Spanned<f64>) -> Result<f64, ConfigError> {
    let s = *t.get_ref();
    if s > 0.0 && s.is_finite() {
        return Ok(s);
    }
    Err(src.err(
        Some(src.line(t.span())),
        Some("fmu.stop_time"),
        format!("stop time {s} is not a positive number of seconds"),
    ))
}

/// `[fmu] cost`: wall-clock (the default, or `"wall"`), else the output it names.
pub(super) fn cost_source(
    src: &Source,
    cost: Option<&Spanned<String>>,
    origins: &mut Origins,
) -> CostSource {
    match cost {
        Some(c) if c.get_ref() != "wall" => {
            origins.read(c.get_ref(), src.line(c.span()), "fmu.cost", Use::Cost);
            CostSource::Output(c.get_ref().clone())
        }
        _ => CostSource::Wall,
    }
}

/// An FMU path that is empty (`hf = ""`) is refused at its key (it resolved to the file's
/// own directory: "No such file or directory" without a name).
pub(super) fn no_empty_path(
    src: &Source,
    key: &str,
    path: &Spanned<String>,
) -> Result<(), ConfigError> {
    if path.get_ref().trim().is_empty() {
        return Err(src.err(
            Some(src.line(path.span())),
            Some(key),
            "is empty: give the path of an FMU (.fmu), relative to this file or absolute",
        ));
    }
    Ok(())
}

/// `[fmu] timeout_s`: a finite number of seconds > 0, default 60 s.
pub(super) fn timeout(src: &Source, t: Option<&Spanned<f64>>) -> Result<Duration, ConfigError> {
    let Some(t) = t else {
        return Ok(Duration::from_secs(60));
    };
    let s = *t.get_ref();
    Duration::try_from_secs_f64(s)
        .ok()
        .filter(|_| s > 0.0 && s.is_finite())
        .ok_or_else(|| {
            src.err(
                Some(src.line(t.span())),
                Some("fmu.timeout_s"),
                format!("must be a finite number of seconds > 0, got {s}"),
            )
        })
}

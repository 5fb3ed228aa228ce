//! What a failure is, from `[failure]`: a Boolean output (with, optionally, an output read as
//! the run's robustness), or a threshold on a real one with one side (`above` or `below`).

use super::*;

/// `[failure]`: a Boolean output (and its `robustness` output, if named), or an output against
/// a threshold.
pub(super) fn failure(
    src: &Source,
    section: &Spanned<raw::FailureSection>,
    origins: &mut Origins,
) -> Result<Failure, ConfigError> {
    let f = section.get_ref();
    match (&f.boolean, &f.threshold, &f.above, &f.below) {
        (Some(b), None, None, None) => {
            origins.read(
                b.get_ref(),
                src.line(b.span()),
                "failure.boolean",
                Use::Failure,
            );
            let robustness = f.robustness.as_ref().map(|r| {
                let line = src.line(r.span());
                origins.read(r.get_ref(), line, "failure.robustness", Use::Robustness);
                r.get_ref().clone()
            });
            Ok(Failure::Boolean {
                variable: b.get_ref().clone(),
                robustness,
            })
        }
        (None, Some(t), Some(value), None) | (None, Some(t), None, Some(value))
            if f.robustness.is_none() =>
        {
            if !value.get_ref().is_finite() {
                let side = if f.above.is_some() { "above" } else { "below" };
                return Err(src.err(
                    Some(src.line(value.span())),
                    Some(&format!("failure.{side}")),
                    format!(
                        "{} is not a finite number: no run (or every run) would fail",
                        value.get_ref()
                    ),
                ));
            }
            let line = src.line(t.span());
            origins.read(t.get_ref(), line, "failure.threshold", Use::Failure);
            Ok(Failure::Threshold {
                variable: t.get_ref().clone(),
                when: if f.above.is_some() {
                    Crossing::Above
                } else {
                    Crossing::Below
                },
                value: *value.get_ref(),
            })
        }
        _ => Err(failure_error(src, section)),
    }
}

/// The error of a `[failure]` section that is neither a Boolean output nor a one-sided
/// threshold: at the key that does not fit (a threshold next to a Boolean, a side next to a
/// Boolean, the second side; the threshold without a side), else at the section.
pub(super) fn failure_error(src: &Source, section: &Spanned<raw::FailureSection>) -> ConfigError {
    let f = section.get_ref();
    let above = f.above.as_ref().map(|a| ("failure.above", a.span()));
    let below = f.below.as_ref().map(|b| ("failure.below", b.span()));
    let robustness = f
        .robustness
        .as_ref()
        .map(|r| ("failure.robustness", r.span()));
    let culprit = match (&f.boolean, &f.threshold) {
        (Some(_), Some(t)) => Some(("failure.threshold", t.span())),
        (Some(_), None) => above.or(below),
        // A threshold's robustness is its margin; `robustness` goes with `boolean` only.
        (None, Some(_)) if robustness.is_some() => robustness,
        (None, Some(t)) => below
            .filter(|_| above.is_some())
            .or(Some(("failure.threshold", t.span()))),
        (None, None) => robustness,
    };
    let (key, span) = culprit.unwrap_or(("failure", section.span()));
    src.err(Some(src.line(span)), Some(key), FAILURE_FORMS)
}

/// What a `[failure]` section must be.
const FAILURE_FORMS: &str =
    "give `boolean = \"output\"` (and, if you like, `robustness = \"output\"`, \
     a Real or Integer output <= 0 on failure), or `threshold = \"output\"` with one of \
     `above` / `below` (its margin is the robustness)";

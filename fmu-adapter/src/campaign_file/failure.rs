//! What a failure is, from `[failure]`: a Boolean output, or a threshold on a real one with one
//! side (`above` or `below`).

use super::*;

/// `[failure]`: a Boolean output, or an output against a threshold.
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
            Ok(Failure::Boolean {
                variable: b.get_ref().clone(),
            })
        }
        (None, Some(t), Some(value), None) | (None, Some(t), None, Some(value)) => {
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
    let culprit = match (&f.boolean, &f.threshold) {
        (Some(_), Some(t)) => Some(("failure.threshold", t.span())),
        (Some(_), None) => above.or(below),
        (None, Some(t)) => below
            .filter(|_| above.is_some())
            .or(Some(("failure.threshold", t.span()))),
        (None, None) => None,
    };
    let (key, span) = culprit.unwrap_or(("failure", section.span()));
    src.err(Some(src.line(span)), Some(key), FAILURE_FORMS)
}

/// What a `[failure]` section must be.
const FAILURE_FORMS: &str =
    "give `boolean = \"output\"`, or `threshold = \"output\"` with one of `above` / `below`";

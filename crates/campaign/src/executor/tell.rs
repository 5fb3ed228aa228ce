//! Turning a stage's finished trial into a kernel tell and a stored line: the runs told (or
//! the trial withdrawn when a run failed), a screened trial's line, and on resume the logged
//! line checked against what the kernel asks and credits again.

use super::Slot;
use crate::log::{FailedLine, LogLine, RunLine, ScreenLine, TrialLine};
use crate::protocol::{Compact, Stage, StageId};
use crate::store::TrialStore;
use crate::CampaignError;
use savme_kernel::screening::{Economy, Screen};
use savme_kernel::{Assignment, CostMeasure, Kernel, SimError, SimResult, Trial};

pub(super) fn simulation_error(
    label: &str,
    trial: &Trial,
    run: &'static str,
    source: SimError,
) -> CampaignError {
    CampaignError::Simulation(Box::new(crate::error::SimulationError {
        stage: label.into(),
        trial: trial.id,
        scenario: trial.scenario.to_string(),
        phi: trial.phi.to_string(),
        run,
        source,
    }))
}

/// A logged trial must be the one the protocol asks for now; the error names the store, the
/// line `at` and the first field that differs (a φ or θ by its variable).
pub(super) fn check_logged(
    l: &LogLine,
    t: &Trial,
    expected: StageId,
    index: u64,
    at: (String, u64),
) -> Result<(), CampaignError> {
    let (stage, i, id, scenario, phi, theta) = match l {
        LogLine::Trial(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
        LogLine::Failed(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
        LogLine::Screen(l) => (&l.stage, l.index, l.id, &l.scenario, &l.phi, &l.theta_lf),
    };
    let show = |v: &dyn std::fmt::Display| v.to_string();
    let differs: Option<(String, String, String)> = if *stage != expected {
        Some(("stage".into(), show(stage), show(&expected)))
    } else if i != index {
        Some(("index".into(), show(&i), show(&index)))
    } else if id != t.id {
        Some(("id".into(), show(&id), show(&t.id)))
    } else if **scenario != *t.scenario {
        Some(("scenario".into(), show(scenario), t.scenario.to_string()))
    } else if *phi != t.phi {
        Some(assignment_difference("phi", phi, &t.phi))
    } else if *theta != t.theta_lf {
        Some(match (theta, &t.theta_lf) {
            (Some(a), Some(b)) => assignment_difference("theta_lf", a, b),
            (a, b) => ("theta_lf".into(), shown(a), shown(b)),
        })
    } else {
        None
    };
    match differs {
        None => Ok(()),
        Some((field, logged, asked)) => Err(CampaignError::Log {
            store: at.0,
            line: at.1 as usize,
            message: format!(
                "field `{field}` is {logged}, but the protocol asks {asked} here ({expected} trial {index}): the line was edited, or written by another campaign"
            ),
        }),
    }
}

/// A logged screening line must have run HF directly exactly when the screening's economy
/// says so now; the error names the store, the line and the field `screen`.
pub(super) fn check_direct(
    l: &LogLine,
    direct: bool,
    at: (String, u64),
) -> Result<(), CampaignError> {
    let LogLine::Screen(s) = l else {
        return Ok(());
    };
    if (s.screen == Screen::Direct) == direct {
        return Ok(());
    }
    let asked = if direct { "direct" } else { "an LF run first" };
    Err(CampaignError::Log {
        store: at.0,
        line: at.1 as usize,
        message: format!(
            "field `screen` is {}, but the screening's economy asks {asked} here: the line was edited, or written by another campaign",
            shown(&s.screen)
        ),
    })
}

/// Adds a told screening line to its scenario's economy.
pub(super) fn add_screened(e: &mut Economy, s: &ScreenLine) {
    let hf = s.hf.as_ref().map(RunLine::run);
    match &s.lf {
        Some(lf) => e.add_screened(&lf.run(), hf.as_ref()),
        None => {
            if let Some(hf) = &hf {
                e.add_direct(hf);
            }
        }
    }
}

/// A stored field's value as a message shows it: as the line has it (`FP`, `train`,
/// `{"fidelity":true,"scenario":null}`), `absent` for a missing (null) one, and numbers
/// compactly ([`Compact`]: `1e308`, not 309 digits). Never Rust's debug text.
fn shown<T: serde::Serialize + ?Sized>(v: &T) -> String {
    fn text(v: &serde_json::Value) -> String {
        use serde_json::Value;
        match v {
            Value::Null => "absent".into(),
            Value::String(s) => s.clone(),
            Value::Number(n) => match (n.as_i64(), n.as_u64(), n.as_f64()) {
                (Some(i), _, _) => i.to_string(),
                (_, Some(u), _) => u.to_string(),
                (_, _, Some(f)) => Compact(f).to_string(),
                _ => n.to_string(),
            },
            Value::Bool(b) => b.to_string(),
            Value::Array(a) => format!("[{}]", a.iter().map(text).collect::<Vec<_>>().join(", ")),
            Value::Object(m) => format!(
                "{{{}}}",
                m.iter()
                    .map(|(k, v)| format!("{k}: {}", text(v)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
    serde_json::to_value(v).map_or_else(|e| format!("(not shown: {e})"), |v| text(&v))
}

/// Values compared as the stored line holds them (JSON), whatever their Rust type.
mod erased {
    /// A serialisable value as JSON.
    pub(super) trait Json {
        fn value(&self) -> serde_json::Value;
    }
    impl<T: serde::Serialize> Json for T {
        fn value(&self) -> serde_json::Value {
            serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
        }
    }
}

/// A φ or θ value as a message shows it (reals compactly: [`Compact`]).
fn value_text(v: &savme_kernel::Value) -> String {
    match v {
        savme_kernel::Value::Real(x) => Compact(*x).to_string(),
        v => v.to_string(),
    }
}

/// The first variable in which two assignments differ: (`field.variable`, logged, asked).
fn assignment_difference(
    field: &str,
    logged: &Assignment,
    asked: &Assignment,
) -> (String, String, String) {
    let none = || "(none)".to_string();
    let names: std::collections::BTreeSet<&str> = logged
        .iter()
        .chain(asked.iter())
        .map(|(name, _)| name)
        .collect();
    for name in names {
        let (a, b) = (logged.get(name), asked.get(name));
        if a != b {
            let a = a.map_or_else(none, value_text);
            let b = b.map_or_else(none, value_text);
            return (format!("{field}.{name}"), a, b);
        }
    }
    (field.into(), logged.to_string(), asked.to_string())
}

/// Tells the kernel a trial whose runs are in: its logged line on resume (checked against
/// what the kernel credits), a withdrawal if a run failed, else its runs — storing the line
/// (with the kernel's outcome and credit) before the next trial is told.
pub(super) fn tell(
    kernel: &mut Kernel,
    mut slot: Slot,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
    store: &mut dyn TrialStore,
) -> Result<LogLine, CampaignError> {
    let cx = TellCx {
        label,
        stage,
        cost,
        index: slot.index,
        id: slot.trial.id,
    };
    match slot.logged.take() {
        Some((number, logged)) => cx.replay(kernel, &slot, number, logged, store),
        None => cx.tell_ran(kernel, slot, store),
    }
}

/// What telling one trial of a stage needs to know.
struct TellCx<'a> {
    label: &'a str,
    stage: &'a Stage,
    cost: CostMeasure,
    index: u64,
    id: u64,
}

impl TellCx<'_> {
    fn diverged(&self, message: String) -> CampaignError {
        CampaignError::Diverged {
            stage: self.label.into(),
            index: self.index,
            message,
        }
    }

    fn untellable(&self, e: savme_kernel::TellError) -> CampaignError {
        CampaignError::Untellable {
            stage: self.label.into(),
            index: self.index,
            message: e.to_string(),
        }
    }

    fn withdraw(&self, kernel: &mut Kernel) -> Result<(), CampaignError> {
        kernel
            .cancel(self.id)
            .map(|_| ())
            .map_err(|e| self.diverged(format!("the failed trial cannot be withdrawn: {e}")))
    }

    /// A stored line replayed on resume: told as logged, and refused (naming the store line
    /// and field) where replaying the trial gives something else.
    fn replay(
        &self,
        kernel: &mut Kernel,
        slot: &Slot,
        number: u64,
        logged: LogLine,
        store: &mut dyn TrialStore,
    ) -> Result<LogLine, CampaignError> {
        let tampered = |field: &str, logged: String, computed: String| {
            CampaignError::Log {
            store: store.location(),
            line: number as usize,
            message: format!(
                "field `{field}` is {logged} but replaying the trial gives {computed}: the line was edited, or written by another campaign"
            ),
        }
        };
        let cannot_tell = |e| self.diverged(format!("the logged outcome cannot be told: {e}"));
        match logged {
            LogLine::Failed(f) => {
                self.withdraw(kernel)?;
                Ok(LogLine::Failed(f))
            }
            LogLine::Screen(l) => {
                let expected = match &l.lf {
                    Some(lf) => {
                        savme_kernel::screening::decide(lf.failure, slot.audit == Some(true))
                    }
                    None => Screen::Direct,
                };
                let hf_expected = expected != Screen::Pass;
                if slot.audit.is_none()
                    || l.screen != expected
                    || l.hf.is_some() != hf_expected
                    || l.lf.is_none() != slot.direct
                {
                    return Err(tampered(
                        "screen",
                        format!("{} (HF run: {})", shown(&l.screen), l.hf.is_some()),
                        shown(&expected),
                    ));
                }
                tell_screened(kernel, self.id, l.lf.as_ref(), l.hf.as_ref())
                    .map_err(cannot_tell)?;
                Ok(LogLine::Screen(l))
            }
            LogLine::Trial(l) => {
                check_costs(&l, self.cost, &tampered)?;
                let record = kernel.tell(self.id, l.observation()).map_err(cannot_tell)?;
                let json = |v: &dyn erased::Json| v.value();
                let checks = [
                    ("phase", json(&l.phase), json(&slot.trial.phase)),
                    ("budget", json(&l.budget), json(&self.stage.budget)),
                    ("outcome", json(&l.outcome), json(&record.outcome)),
                    ("cost_ratio", json(&l.cost_ratio), json(&record.cost_ratio)),
                    ("credit", json(&l.credit), json(&record.credit)),
                ];
                match checks.into_iter().find(|(_, a, b)| a != b) {
                    Some((field, logged, computed)) => {
                        Err(tampered(field, shown(&logged), shown(&computed)))
                    }
                    None => Ok(LogLine::Trial(l)),
                }
            }
        }
    }

    /// A trial this process ran: withdrawn if a run failed, else told; its line stored.
    fn tell_ran(
        &self,
        kernel: &mut Kernel,
        slot: Slot,
        store: &mut dyn TrialStore,
    ) -> Result<LogLine, CampaignError> {
        let (label, stage, cost) = (self.label, self.stage, self.cost);
        let line = if let Some(error) = slot.error {
            self.withdraw(kernel)?;
            LogLine::Failed(FailedLine {
                stage: stage.id(),
                index: slot.index,
                id: slot.trial.id,
                scenario: slot.trial.scenario.to_string(),
                phi: slot.trial.phi.clone(),
                theta_lf: slot.trial.theta_lf.clone(),
                error,
            })
        } else if let Some(audit) = slot.audit {
            let l = screen_line(&slot, audit, label, stage, cost)?;
            tell_screened(kernel, self.id, l.lf.as_ref(), l.hf.as_ref())
                .map_err(|e| self.untellable(e))?;
            LogLine::Screen(l)
        } else {
            let mut line = trial_line(&slot, label, stage, cost)?;
            let record = kernel
                .tell(self.id, line.observation())
                .map_err(|e| self.untellable(e))?;
            line.cost_ratio = record.cost_ratio;
            line.outcome = record.outcome;
            line.credit = record.credit;
            LogLine::Trial(line)
        };
        store.append(&line)?;
        Ok(line)
    }
}

/// The line of a run of `slot`'s trial, with the protocol's cost.
fn run_line(
    r: &SimResult,
    which: &'static str,
    slot: &Slot,
    label: &str,
    cost: CostMeasure,
) -> Result<RunLine, CampaignError> {
    let run = r
        .run(cost)
        .map_err(|source| simulation_error(label, &slot.trial, which, source))?;
    Ok(RunLine::new(r, run.runtime))
}

/// Tells the kernel a screened trial: paired when both ran, LF or HF alone otherwise.
fn tell_screened(
    kernel: &mut Kernel,
    id: u64,
    lf: Option<&RunLine>,
    hf: Option<&RunLine>,
) -> Result<(), savme_kernel::TellError> {
    match (lf, hf) {
        (Some(lf), Some(hf)) => kernel
            .tell(
                id,
                savme_kernel::Observation::Paired {
                    hf: hf.run(),
                    lf: lf.run(),
                },
            )
            .map(|_| ()),
        (Some(lf), None) => kernel.tell_unconfirmed(id, lf.run()).map(|_| ()),
        (None, Some(hf)) => kernel.tell_direct(id, hf.run()).map(|_| ()),
        (None, None) => Err(savme_kernel::TellError::NoRun { id }),
    }
}

/// The line of a screened trial whose runs are in.
fn screen_line(
    slot: &Slot,
    audit: bool,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
) -> Result<ScreenLine, CampaignError> {
    let run_line = |r: &SimResult, which| run_line(r, which, slot, label, cost);
    let lf = match &slot.lf {
        Some(r) => Some(run_line(r, "LF")?),
        None if slot.direct => None,
        None => return Err(CampaignError::WorkersGone),
    };
    let hf = match &slot.hf {
        Some(r) => Some(run_line(r, "HF")?),
        None => None,
    };
    let outcome = hf
        .zip(lf)
        .map(|(h, l)| savme_kernel::Outcome::classify(h.failure, l.failure));
    let screen = match &lf {
        Some(lf) => savme_kernel::screening::decide(lf.failure, audit),
        None => Screen::Direct,
    };
    Ok(ScreenLine {
        stage: stage.id(),
        index: slot.index,
        id: slot.trial.id,
        budget: stage.budget,
        scenario: slot.trial.scenario.to_string(),
        phi: slot.trial.phi.clone(),
        theta_lf: slot.trial.theta_lf.clone(),
        screen,
        lf,
        hf,
        outcome,
    })
}

/// A stored trial's costs must be what the protocol's cost measure gives: its work units, or
/// its measured wall-clock seconds.
fn check_costs(
    l: &TrialLine,
    cost: CostMeasure,
    tampered: &dyn Fn(&str, String, String) -> CampaignError,
) -> Result<(), CampaignError> {
    for (name, run) in [("hf", Some(&l.hf)), ("lf", l.lf.as_ref())] {
        let Some(run) = run else { continue };
        let expected = match cost {
            CostMeasure::Work => run.work.map(|w| w as f64),
            CostMeasure::Wall => Some(run.wall_seconds),
        };
        if expected != Some(run.runtime) {
            return Err(tampered(
                &format!("{name}.runtime"),
                Compact(run.runtime).to_string(),
                expected.map_or("no cost".into(), |e| Compact(e).to_string()),
            ));
        }
    }
    Ok(())
}

/// The line of a trial whose runs are in (before the kernel's assessment).
fn trial_line(
    slot: &Slot,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
) -> Result<TrialLine, CampaignError> {
    let run_line = |r: &SimResult, which| run_line(r, which, slot, label, cost);
    let hf = run_line(slot.hf.as_ref().ok_or(CampaignError::WorkersGone)?, "HF")?;
    let lf = match &slot.lf {
        Some(r) => Some(run_line(r, "LF")?),
        None => None,
    };
    Ok(TrialLine {
        stage: stage.id(),
        index: slot.index,
        id: slot.trial.id,
        phase: slot.trial.phase,
        budget: stage.budget,
        scenario: slot.trial.scenario.to_string(),
        phi: slot.trial.phi.clone(),
        theta_lf: slot.trial.theta_lf.clone(),
        hf,
        lf,
        cost_ratio: None,
        outcome: None,
        credit: Default::default(),
    })
}

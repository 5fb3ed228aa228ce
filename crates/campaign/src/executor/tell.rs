//! Turning a stage's finished trial into a kernel tell and a stored line: the runs told (or
//! the trial withdrawn when a run failed), a screened trial's line, and on resume the logged
//! line checked against what the kernel asks and credits again.

use super::Slot;
use crate::log::{FailedLine, LogLine, RunLine, RungLine, ScreenLine, TrialLine};
use crate::protocol::{Compact, Stage, StageId};
use crate::store::TrialStore;
use crate::CampaignError;
use savme_kernel::screening::{Economy, Screen, Step};
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

/// Adds a told screening line to its scenario's economy, one per level of the ladder
/// (cheapest first): each level's LF run, or — for a level the trial passed by because it did
/// not pay (`plan`) — the run made in its place; the HF run to the last level's (which keeps
/// the HF pass cost). Without a ladder: the LF run and the HF run, or a direct HF run.
pub(super) fn add_screened(levels: &mut [Economy], s: &ScreenLine, plan: &[bool]) {
    let runs: Vec<Option<savme_kernel::Run>> = s
        .levels()
        .into_iter()
        .map(|r| r.map(RunLine::run))
        .collect();
    let hf = s.hf.as_ref().map(RunLine::run);
    for (i, e) in levels.iter_mut().enumerate() {
        match runs.get(i).copied().flatten() {
            Some(lf) => e.add_screened(&lf, None),
            None if !plan.get(i).copied().unwrap_or(true) => {
                // The run made in this level's place: the next level's that was made, or HF.
                let instead = runs.iter().skip(i + 1).flatten().next().copied().or(hf);
                // A level below that passed ended the trial: nothing was made in its place.
                let reached = runs[..i.min(runs.len())]
                    .iter()
                    .flatten()
                    .all(|r| r.failure);
                if let (Some(next), true) = (instead, reached) {
                    e.add_skipped(&next);
                }
            }
            None => {}
        }
    }
    if let (Some(top), Some(hf)) = (levels.last_mut(), &hf) {
        top.saw_hf(hf);
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
#[allow(clippy::too_many_arguments)]
pub(super) fn tell(
    kernel: &mut Kernel,
    mut slot: Slot,
    label: &str,
    stage: &Stage,
    cost: CostMeasure,
    rungs: &[(f64, Assignment)],
    store: &mut dyn TrialStore,
) -> Result<LogLine, CampaignError> {
    let cx = TellCx {
        label,
        stage,
        cost,
        rungs,
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
    /// A screening stage's ladder below its budget: each level's budget and θ_LF*.
    rungs: &'a [(f64, Assignment)],
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

    /// A stored screening line's ladder must be the one this stage screens down: the same
    /// levels (budgets) with the same θ_LF*; the error names the store line and field.
    fn check_ladder(
        &self,
        l: &ScreenLine,
        tampered: &dyn Fn(&str, String, String) -> CampaignError,
    ) -> Result<(), CampaignError> {
        let levels = |budgets: Vec<f64>| {
            budgets
                .iter()
                .map(|b| Compact(*b).to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if l.ladder.len() != self.rungs.len() {
            return Err(tampered(
                "ladder",
                format!("[{}]", levels(l.ladder.iter().map(|r| r.budget).collect())),
                format!("[{}]", levels(self.rungs.iter().map(|r| r.0).collect())),
            ));
        }
        for (i, (rung, (budget, theta))) in l.ladder.iter().zip(self.rungs).enumerate() {
            if rung.budget != *budget {
                let (a, b) = (Compact(rung.budget), Compact(*budget));
                return Err(tampered(
                    &format!("ladder[{i}].budget"),
                    a.to_string(),
                    b.to_string(),
                ));
            }
            if rung.theta_lf != *theta {
                let (field, a, b) =
                    assignment_difference(&format!("ladder[{i}].theta_lf"), &rung.theta_lf, theta);
                return Err(tampered(&field, a, b));
            }
        }
        Ok(())
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
                let audited = slot.audit == Some(true);
                let expected = final_screen(&l, audited);
                if slot.audit.is_none() || l.screen != expected || !walks(&l, &slot.plan, audited) {
                    return Err(tampered(
                        "screen",
                        format!("{} (HF run: {})", shown(&l.screen), l.hf.is_some()),
                        shown(&expected),
                    ));
                }
                self.check_ladder(&l, &tampered)?;
                tell_screened(kernel, self.id, l.lf_run(), l.hf.as_ref()).map_err(cannot_tell)?;
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
            let l = screen_line(&slot, audit, self.rungs, (label, stage, cost))?;
            tell_screened(kernel, self.id, l.lf_run(), l.hf.as_ref())
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

/// Tells the kernel a screened trial: paired when both ran, LF or HF alone otherwise. `lf`
/// is the ladder's LF side as one run ([`ScreenLine::lf_run`]).
fn tell_screened(
    kernel: &mut Kernel,
    id: u64,
    lf: Option<savme_kernel::Run>,
    hf: Option<&RunLine>,
) -> Result<(), savme_kernel::TellError> {
    match (lf, hf) {
        (Some(lf), Some(hf)) => kernel
            .tell(id, savme_kernel::Observation::Paired { hf: hf.run(), lf })
            .map(|_| ()),
        (Some(lf), None) => kernel.tell_unconfirmed(id, lf).map(|_| ()),
        (None, Some(hf)) => kernel.tell_direct(id, hf.run()).map(|_| ()),
        (None, None) => Err(savme_kernel::TellError::NoRun { id }),
    }
}

/// What a screened line's last LF run called for (`direct` without one).
fn final_screen(l: &ScreenLine, audited: bool) -> Screen {
    match l.levels().into_iter().flatten().last() {
        Some(lf) => savme_kernel::screening::decide(lf.failure, audited),
        None => Screen::Direct,
    }
}

/// Whether a screened line made exactly the runs the ladder's `plan` and the audit call for,
/// given the verdicts of the runs it made ([`savme_kernel::screening::next`]).
fn walks(l: &ScreenLine, plan: &[bool], audited: bool) -> bool {
    let runs = l.levels();
    if runs.len() != plan.len() {
        return false;
    }
    let mut made = vec![false; runs.len()];
    let mut last = None;
    loop {
        match savme_kernel::screening::next(plan, last, audited) {
            Step::Level(i) => match runs[i] {
                Some(r) => {
                    made[i] = true;
                    last = Some((i, r.failure));
                }
                None => return false,
            },
            Step::Hf => {
                break l.hf.is_some() && runs.iter().zip(&made).all(|(r, m)| r.is_some() == *m)
            }
            Step::Stop => {
                break l.hf.is_none() && runs.iter().zip(&made).all(|(r, m)| r.is_some() == *m)
            }
        }
    }
}

/// The line of a screened trial whose runs are in (`rungs`: the ladder's levels below the
/// stage's budget, each one's budget and θ_LF*).
fn screen_line(
    slot: &Slot,
    audit: bool,
    rungs: &[(f64, Assignment)],
    (label, stage, cost): (&str, &Stage, CostMeasure),
) -> Result<ScreenLine, CampaignError> {
    let run_line = |r: &SimResult, which| run_line(r, which, slot, label, cost);
    let made = |r: &Option<SimResult>, which| r.as_ref().map(|r| run_line(r, which)).transpose();
    let lf = made(&slot.lf, "LF")?;
    let hf = made(&slot.hf, "HF")?;
    let rungs = rungs.iter().zip(&slot.rungs);
    let ladder = rungs
        .map(|((budget, theta), r)| {
            Ok(RungLine {
                budget: *budget,
                theta_lf: theta.clone(),
                lf: made(r, "LF")?,
            })
        })
        .collect::<Result<Vec<_>, CampaignError>>()?;
    let mut line = ScreenLine {
        stage: stage.id(),
        index: slot.index,
        id: slot.trial.id,
        budget: stage.budget,
        scenario: slot.trial.scenario.to_string(),
        phi: slot.trial.phi.clone(),
        theta_lf: slot.trial.theta_lf.clone(),
        ladder,
        screen: Screen::Direct,
        lf,
        hf,
        outcome: None,
    };
    line.screen = final_screen(&line, audit);
    line.outcome = hf
        .zip(line.lf_run())
        .map(|(h, l)| savme_kernel::Outcome::classify(h.failure, l.failure));
    Ok(line)
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

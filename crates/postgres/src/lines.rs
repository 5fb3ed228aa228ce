//! A stored line as the typed columns of `savme.trials` (read from the typed record, a
//! campaign's `LogLine`), and the insert of lines in the caller's transaction.

use postgres::{GenericClient, Statement};
use savme_campaign::log::{LogLine, RunLine, TrialLine};
use savme_store::{Record, FORMAT};
use serde_json::Value;

/// A line's fields as the typed columns of `savme.trials`, read from the typed record (a
/// campaign's [`LogLine`]); any other record (a journal's event) fills none.
#[derive(Default)]
pub(crate) struct Columns {
    stage: Option<String>,
    idx: Option<i64>,
    trial_id: Option<i64>,
    phase: Option<String>,
    budget: Option<f64>,
    scenario: Option<String>,
    phi: Option<String>,
    theta_lf: Option<String>,
    hf: RunColumns,
    lf: RunColumns,
    cost_ratio: Option<f64>,
    outcome: Option<String>,
    credit_fidelity: Option<bool>,
    credit_scenario: Option<bool>,
    error: Option<String>,
}

#[derive(Default)]
struct RunColumns {
    failure: Option<bool>,
    runtime: Option<f64>,
    wall_seconds: Option<f64>,
    work: Option<i64>,
}

impl RunColumns {
    fn of(run: Option<&RunLine>) -> RunColumns {
        run.map_or_else(RunColumns::default, |r| RunColumns {
            failure: Some(r.failure),
            runtime: Some(r.runtime),
            wall_seconds: Some(r.wall_seconds),
            work: r.work.and_then(|w| i64::try_from(w).ok()),
        })
    }
}

/// A value's JSON text (an assignment for a `jsonb` column), or its name (a unit variant such
/// as a phase or an outcome, as the line stores it).
fn json<T: serde::Serialize>(value: &T) -> Option<String> {
    serde_json::to_string(value).ok()
}

fn name<T: serde::Serialize>(value: &T) -> Option<String> {
    match serde_json::to_value(value).ok()? {
        Value::String(s) => Some(s),
        _ => None,
    }
}

impl Columns {
    /// The columns of `record`: a trial line's fields, or none for any other record.
    pub(crate) fn of(record: &dyn Record) -> Columns {
        match record.as_any().downcast_ref::<LogLine>() {
            Some(LogLine::Trial(t)) => Columns::of_trial(t),
            Some(LogLine::Failed(f)) => Columns {
                stage: Some(f.stage.to_string()),
                idx: i64::try_from(f.index).ok(),
                trial_id: i64::try_from(f.id).ok(),
                scenario: Some(f.scenario.clone()),
                phi: json(&f.phi),
                theta_lf: f.theta_lf.as_ref().and_then(json),
                error: Some(f.error.clone()),
                ..Columns::default()
            },
            Some(LogLine::Screen(s)) => Columns {
                stage: Some(s.stage.to_string()),
                idx: i64::try_from(s.index).ok(),
                trial_id: i64::try_from(s.id).ok(),
                budget: s.budget,
                scenario: Some(s.scenario.clone()),
                phi: json(&s.phi),
                theta_lf: s.theta_lf.as_ref().and_then(json),
                hf: RunColumns::of(s.hf.as_ref()),
                lf: RunColumns::of(s.lf.as_ref()),
                outcome: s.outcome.as_ref().and_then(name),
                ..Columns::default()
            },
            None => Columns::default(),
        }
    }

    fn of_trial(t: &TrialLine) -> Columns {
        Columns {
            stage: Some(t.stage.to_string()),
            idx: i64::try_from(t.index).ok(),
            trial_id: i64::try_from(t.id).ok(),
            phase: name(&t.phase),
            budget: t.budget,
            scenario: Some(t.scenario.clone()),
            phi: json(&t.phi),
            theta_lf: t.theta_lf.as_ref().and_then(json),
            hf: RunColumns::of(Some(&t.hf)),
            lf: RunColumns::of(t.lf.as_ref()),
            cost_ratio: t.cost_ratio,
            outcome: t.outcome.as_ref().and_then(name),
            credit_fidelity: t.credit.fidelity,
            credit_scenario: t.credit.scenario,
            error: None,
        }
    }
}

pub(crate) const INSERT: &str =
    "INSERT INTO savme.trials (campaign_id, line, v, body, stage, idx, trial_id, phase,
    budget, scenario, phi, theta_lf, hf_failure, hf_runtime, hf_wall_seconds, hf_work,
    lf_failure, lf_runtime, lf_wall_seconds, lf_work, cost_ratio, outcome, credit_fidelity,
    credit_scenario, error)
  VALUES ($1, $2, $3, $4::text::json, $5, $6, $7, $8, $9, $10, $11::text::jsonb,
    $12::text::jsonb, $13, $14, $15, $16, $17, $18, $19, $20, $21, $22, $23, $24, $25)";

/// Inserts `rows` (text, fields) as lines `first..` with the prepared `statement` (in the
/// caller's transaction).
pub(crate) fn insert_lines(
    client: &mut impl GenericClient,
    statement: &Statement,
    campaign: i32,
    first: i64,
    rows: &[(String, Columns)],
) -> Result<(), postgres::Error> {
    for (k, (text, columns)) in rows.iter().enumerate() {
        insert_one(client, statement, campaign, first + k as i64, text, columns)?;
    }
    Ok(())
}

/// Inserts one line.
fn insert_one(
    client: &mut impl GenericClient,
    statement: &Statement,
    campaign: i32,
    line: i64,
    text: &String,
    c: &Columns,
) -> Result<(), postgres::Error> {
    let v = FORMAT as i32;
    client
        .execute(
            statement,
            &[
                &campaign,
                &line,
                &v,
                text,
                &c.stage,
                &c.idx,
                &c.trial_id,
                &c.phase,
                &c.budget,
                &c.scenario,
                &c.phi,
                &c.theta_lf,
                &c.hf.failure,
                &c.hf.runtime,
                &c.hf.wall_seconds,
                &c.hf.work,
                &c.lf.failure,
                &c.lf.runtime,
                &c.lf.wall_seconds,
                &c.lf.work,
                &c.cost_ratio,
                &c.outcome,
                &c.credit_fidelity,
                &c.credit_scenario,
                &c.error,
            ],
        )
        .map(|_| ())
}

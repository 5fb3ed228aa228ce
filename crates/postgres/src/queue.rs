//! The work queue in `savme.runs`: every statement the coordinator and the `savme worker`
//! processes run on it, in one place.
//!
//! - the coordinator **submits** the runs it asked for since it last waited, in one statement
//!   (an upsert on `(campaign, stage, trial, role)`: on
//!   `--resume` the same trials are asked again and find their rows — finished ones are used,
//!   not repeated) and `NOTIFY`s `savme_tasks_<campaign>`;
//! - a worker acts only through savme's server-side functions (`sql/v4.sql`), which check once
//!   per call that its session's role may work on the campaign: it **claims** the oldest run
//!   that is queued or whose lease has expired (`FOR UPDATE SKIP LOCKED`: two workers never get
//!   the same row), recording its role and its process's secret token, holding a lease (at
//!   most [`MAX_LEASE`]) it renews by **heartbeat**;
//! - it **finishes** the run only while its process still holds it (a worker whose lease
//!   expired and was taken over writes nothing); the server refuses a result that is not valid
//!   ([`REFUSED`]); the same call `NOTIFY`s `savme_done_<campaign>` and claims its next run
//!   (one round trip per run);
//! - the coordinator reads the **finished** rows of the runs it waits for, queues again a row
//!   it cannot use, and after a database restart reconciles the runs the crash orphaned.

use super::Conn;
use postgres::{Client, GenericClient};
use savme_campaign::executor::Task;
use savme_kernel::Role;
use savme_kernel::{Assignment, SimError, SimResult};
use std::time::Duration;

/// The channel workers listen on for new runs of campaign `id`.
pub fn tasks_channel(campaign: i32) -> String {
    format!("savme_tasks_{campaign}")
}

/// The channel the coordinator listens on for finished runs of campaign `id`.
pub fn done_channel(campaign: i32) -> String {
    format!("savme_done_{campaign}")
}

/// The upsert of a batch of runs (arrays of their fields), waking idle workers in the same
/// statement (identical notifications of one transaction are delivered once). A row that failed
/// before is queued again; a finished one is left as it is (on `--resume` its result is used).
pub(crate) const SUBMIT: &str = "WITH run AS (
    INSERT INTO savme.runs (campaign_id, stage, trial_id, role, scenario, phi, fidelity)
    SELECT $1, u.stage, u.trial, u.role, u.scenario, u.phi::json, u.fidelity::json
      FROM unnest($2::text[], $3::bigint[], $4::text[], $5::text[], $6::text[], $7::text[])
           AS u(stage, trial, role, scenario, phi, fidelity)
    ON CONFLICT (campaign_id, stage, trial_id, role) DO UPDATE
       SET state = CASE WHEN runs.state = 'failed' THEN 'queued' ELSE runs.state END,
           error = CASE WHEN runs.state = 'failed' THEN NULL ELSE runs.error END
    RETURNING id, stage, trial_id, role, state)
 SELECT id, stage, trial_id, role, CASE WHEN state = 'queued' THEN pg_notify($8, '') END IS NULL
   FROM run";

/// Submits `tasks` (each a distinct run) in one statement (`statement`: [`SUBMIT`] prepared on
/// the connection) and wakes the workers; returns each task's row id, in the order of `tasks`.
pub(crate) fn submit(
    c: &mut impl GenericClient,
    statement: &postgres::Statement,
    campaign: i32,
    tasks: &[Task],
) -> Result<Vec<i64>, postgres::Error> {
    if tasks.is_empty() {
        return Ok(Vec::new());
    }
    let json = |a: &Assignment| serde_json::to_string(a).unwrap_or_default();
    let stages: Vec<&str> = tasks.iter().map(|t| &*t.stage).collect();
    let trials: Vec<i64> = tasks.iter().map(|t| t.trial as i64).collect();
    let roles: Vec<&str> = tasks.iter().map(|t| t.which.key()).collect();
    let scenarios: Vec<&str> = tasks.iter().map(|t| &*t.scenario).collect();
    let phis: Vec<String> = tasks.iter().map(|t| json(&t.phi)).collect();
    let fidelities: Vec<String> = tasks.iter().map(|t| json(&t.fidelity)).collect();
    let rows = c.query(
        statement,
        &[
            &campaign,
            &stages,
            &trials,
            &roles,
            &scenarios,
            &phis,
            &fidelities,
            &tasks_channel(campaign),
        ],
    )?;
    // The rows come back in no promised order: match them to the tasks by their key.
    let ids: std::collections::HashMap<(String, i64, String), i64> = rows
        .iter()
        .map(|r| ((r.get(1), r.get(2), r.get(3)), r.get(0)))
        .collect();
    Ok(tasks
        .iter()
        .map(|t| {
            let key = (
                t.stage.to_string(),
                t.trial as i64,
                t.which.key().to_string(),
            );
            ids.get(&key).copied().unwrap_or(-1)
        })
        .collect())
}

/// Wakes the workers listening for runs of `campaign`.
pub fn wake_workers(client: &mut impl GenericClient, campaign: i32) -> Result<(), postgres::Error> {
    client
        .execute("SELECT pg_notify($1, '')", &[&tasks_channel(campaign)])
        .map(|_| ())
}

/// A finished run as the coordinator reads it.
#[derive(Debug)]
pub struct Finished {
    /// Its row id.
    pub id: i64,
    /// The result, or the simulator's error.
    pub result: Result<SimResult, SimError>,
}

/// A finished row the coordinator cannot use (written before the server checked results, or
/// by hand): it is queued again, or, after [`MAX_ATTEMPTS`], failed with the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct Unusable {
    /// Its row id.
    pub id: i64,
    /// The worker that wrote it.
    pub worker: String,
    /// How many times it was claimed.
    pub attempts: i32,
    /// What is wrong with it.
    pub reason: String,
}

/// How many claims of a run whose results the coordinator cannot use before it fails the run
/// (the campaign's `on_error` then applies) instead of queueing it again.
pub const MAX_ATTEMPTS: i32 = 3;

/// The finished runs among `ids`, and those whose rows hold no usable result.
pub fn finished(
    c: &mut Conn<'_>,
    ids: &[i64],
) -> Result<(Vec<Finished>, Vec<Unusable>), postgres::Error> {
    let statement = c.prepared(
        "SELECT r.id, r.state, r.failure, r.wall_seconds, r.work, r.error, r.robustness,
                coalesce(r.worker, 'unknown'), r.attempts, coalesce(c.protocol->>'cost' = 'work', false)
           FROM savme.runs r JOIN savme.campaigns c ON c.id = r.campaign_id
          WHERE r.id = ANY($1) AND r.state IN ('done', 'failed')",
    )?;
    let rows = c.query(&statement, &[&ids])?;
    let (mut good, mut bad) = (Vec::new(), Vec::new());
    for r in &rows {
        let id: i64 = r.get(0);
        match read_result(r) {
            Ok(result) => good.push(Finished { id, result }),
            Err(reason) => bad.push(Unusable {
                id,
                worker: r.get(7),
                attempts: r.get(8),
                reason,
            }),
        }
    }
    Ok((good, bad))
}

/// The result in a row of [`finished`]'s statement, or why it cannot be used (never a wrapped
/// or made-up value).
fn read_result(r: &postgres::Row) -> Result<Result<SimResult, SimError>, String> {
    if r.get::<_, &str>(1) != "done" {
        let error = r.get::<_, Option<String>>(5);
        return Ok(Err(SimError::Failed(error.unwrap_or_else(|| {
            "the run failed (its row gives no reason)".into()
        }))));
    }
    let failure: bool = r.get::<_, Option<bool>>(2).ok_or("failure is NULL")?;
    let wall = r.get::<_, Option<f64>>(3).ok_or("wall_seconds is NULL")?;
    if !(wall.is_finite() && wall >= 0.0) {
        return Err(format!(
            "wall_seconds = {wall} is not a finite number of seconds >= 0"
        ));
    }
    let work = match r.get::<_, Option<i64>>(4) {
        Some(w) => Some(u64::try_from(w).map_err(|_| format!("work = {w} is negative"))?),
        None if r.get::<_, bool>(9) => {
            return Err("work is NULL, but this campaign's cost is work units".into())
        }
        None => None,
    };
    let result = SimResult::new(failure, wall, work);
    Ok(Ok(match r.get::<_, Option<f64>>(6) {
        Some(rho) if rho.is_finite() => result.with_robustness(rho),
        Some(rho) => return Err(format!("robustness = {rho} is not finite")),
        None => result,
    }))
}

/// Queues the finished runs `ids` of `campaign` again (their rows held no usable result:
/// `reason` is kept in `error`) and wakes the workers.
pub fn requeue(
    c: &mut Conn<'_>,
    campaign: i32,
    ids: &[i64],
    reason: &str,
) -> Result<u64, postgres::Error> {
    let n = c.execute(
        "UPDATE savme.runs SET state = 'queued', lease_until = NULL, token = NULL,
                failure = NULL, wall_seconds = NULL, work = NULL, robustness = NULL,
                error = $3, finished_at = NULL
          WHERE id = ANY($1) AND campaign_id = $2 AND state IN ('done', 'failed')",
        &[&ids, &campaign, &reason],
    )?;
    wake_workers(&mut **c, campaign)?;
    Ok(n)
}

/// Queues again the runs among `ids` of `campaign` that are `running` but whose holder has not
/// shown itself alive since the database server started (a claim or lease renewal before a
/// restart, none after it): their worker's finish was lost with the server, or the worker is
/// gone. How many.
pub fn requeue_orphans(
    c: &mut Conn<'_>,
    campaign: i32,
    ids: &[i64],
) -> Result<u64, postgres::Error> {
    let n = c.execute(
        "UPDATE savme.runs SET state = 'queued', lease_until = NULL, token = NULL,
                started_at = NULL
          WHERE id = ANY($1) AND campaign_id = $2 AND state = 'running'
            AND (seen_at IS NULL OR seen_at < pg_postmaster_start_time())",
        &[&ids, &campaign],
    )?;
    if n > 0 {
        wake_workers(&mut **c, campaign)?;
    }
    Ok(n)
}

/// A result as the columns of its row, for [`write_back`].
#[derive(Debug, Clone)]
pub(crate) struct RowResult {
    id: i64,
    columns: Columns,
}

impl RowResult {
    /// Run `id`'s `result`.
    pub(crate) fn new(id: i64, result: &Result<SimResult, SimError>) -> RowResult {
        RowResult {
            id,
            columns: columns(result),
        }
    }
}

/// Writes `results` (runs whose results the coordinator read and told) back into rows that no
/// longer hold them — after a database crash lost a worker's finish (workers commit without
/// waiting for the disk) though the coordinator had read it. How many rows.
pub(crate) fn write_back(
    tx: &mut impl GenericClient,
    campaign: i32,
    results: &[RowResult],
) -> Result<u64, postgres::Error> {
    let ids: Vec<i64> = results.iter().map(|r| r.id).collect();
    let states: Vec<&str> = results.iter().map(|r| r.columns.0).collect();
    let failures: Vec<Option<bool>> = results.iter().map(|r| r.columns.1).collect();
    let walls: Vec<Option<f64>> = results.iter().map(|r| r.columns.2).collect();
    let works: Vec<Option<i64>> = results.iter().map(|r| r.columns.3).collect();
    let errors: Vec<Option<&str>> = results.iter().map(|r| r.columns.4.as_deref()).collect();
    let robustness: Vec<Option<f64>> = results.iter().map(|r| r.columns.5).collect();
    tx.execute(
        "UPDATE savme.runs r
            SET state = u.state, failure = u.failure, wall_seconds = u.wall, work = u.work,
                error = u.error, robustness = u.robustness, lease_until = NULL,
                finished_at = clock_timestamp()
           FROM unnest($2::bigint[], $3::text[], $4::boolean[], $5::float8[], $6::bigint[],
                       $7::text[], $8::float8[])
                AS u(id, state, failure, wall, work, error, robustness)
          WHERE r.id = u.id AND r.campaign_id = $1 AND r.state IN ('queued', 'running')",
        &[
            &campaign,
            &ids,
            &states,
            &failures,
            &walls,
            &works,
            &errors,
            &robustness,
        ],
    )
}

/// How many runs of `campaign` a worker has ever started (to tell a coordinator whose workers
/// never showed up).
pub fn started(client: &mut Client, campaign: i32) -> Result<i64, postgres::Error> {
    Ok(client
        .query_one(
            "SELECT count(*) FROM savme.runs WHERE campaign_id = $1 AND attempts > 0",
            &[&campaign],
        )?
        .get(0))
}

/// Marks the campaign running (`finished = false`) or finished, waking idle workers so that
/// they can exit.
pub fn set_finished(
    client: &mut Client,
    campaign: i32,
    finished: bool,
) -> Result<(), postgres::Error> {
    client.execute(
        "UPDATE savme.campaigns SET finished_at = CASE WHEN $2 THEN now() END WHERE id = $1",
        &[&campaign, &finished],
    )?;
    wake_workers(client, campaign)
}

/// A run a worker claimed.
#[derive(Debug, Clone)]
pub struct Claimed {
    /// Its row id.
    pub id: i64,
    /// The task, or why its row cannot be read (then the run fails with that message).
    pub task: Result<Task, String>,
    /// How many times it was claimed (this claim included).
    pub attempts: i32,
}

/// The longest lease a worker may take (the server refuses a longer one: a run cannot be held
/// forever by a worker that stopped renewing it).
pub const MAX_LEASE: Duration = Duration::from_secs(3600);

/// The SQLSTATE of a result the server refused (`savme.finish_and_claim`): not a result this
/// worker may write, or not a valid one; the message names the run and the worker.
pub const REFUSED: &str = "SV001";

/// Whether `e` is the server refusing a result ([`REFUSED`]).
pub fn refused(e: &postgres::Error) -> Option<String> {
    e.as_db_error()
        .filter(|db| db.code().code() == REFUSED)
        .map(|db| db.message().to_string())
}

/// Claims the oldest run of `campaign` that is queued or whose lease expired, for `worker` of
/// the process holding `token`, with a lease of `lease` (`savme.claim`: the server checks that
/// this session's role may work on the campaign).
pub fn claim(
    c: &mut Conn<'_>,
    campaign: i32,
    worker: &str,
    token: &str,
    lease: Duration,
) -> Result<Option<Claimed>, postgres::Error> {
    let statement = c.prepared("SELECT * FROM savme.claim($1, $2, $3, $4)")?;
    let row = c.query_opt(
        &statement,
        &[&campaign, &worker, &token, &lease.as_secs_f64()],
    )?;
    Ok(row.and_then(|r| claimed(&r, 0)))
}

/// The run claimed in columns `at..at + 8` of `r` (none if its id is NULL).
fn claimed(r: &postgres::Row, at: usize) -> Option<Claimed> {
    let id: i64 = r.get::<_, Option<i64>>(at)?;
    let parse = |column: usize, what: &str| -> Result<Assignment, String> {
        serde_json::from_str(r.get::<_, &str>(at + column))
            .map_err(|e| format!("savme.runs row {id}: `{what}` is not an assignment: {e}"))
    };
    let task = (|| {
        let key = r.get::<_, &str>(at + 3);
        let which = Role::from_key(key).ok_or_else(|| {
            format!("savme.runs row {id}: role {key:?} is neither \"hf\" nor \"lf\"")
        })?;
        let trial = r.get::<_, i64>(at + 2);
        Ok(Task {
            stage: r.get::<_, &str>(at + 1).into(),
            trial: u64::try_from(trial)
                .map_err(|_| format!("savme.runs row {id}: trial id {trial} is negative"))?,
            which,
            scenario: r.get::<_, &str>(at + 4).into(),
            phi: parse(5, "phi")?,
            fidelity: parse(6, "fidelity")?,
        })
    })();
    Some(Claimed {
        id,
        task,
        attempts: r.get(at + 7),
    })
}

/// Renews the leases of the runs `ids` of `campaign` that the worker process holding `token`
/// still holds (`savme.renew`); also what shows the server, after a restart, that the process
/// is alive.
pub fn heartbeat(
    client: &mut Client,
    campaign: i32,
    ids: &[i64],
    token: &str,
    lease: Duration,
) -> Result<i32, postgres::Error> {
    Ok(client
        .query_one(
            "SELECT savme.renew($1, $2, $3, $4)",
            &[&campaign, &ids, &token, &lease.as_secs_f64()],
        )?
        .get(0))
}

/// A result as the columns of `savme.runs` hold it: state, failure, wall seconds, work, error,
/// robustness.
type Columns = (
    &'static str,
    Option<bool>,
    Option<f64>,
    Option<i64>,
    Option<String>,
    Option<f64>,
);

/// `result` as the columns of its row (a work count beyond the column's range is a failed run
/// saying so).
fn columns(result: &Result<SimResult, SimError>) -> Columns {
    match result {
        Ok(r) => match r.work.map(i64::try_from).transpose() {
            Ok(work) => (
                "done",
                Some(r.failure),
                Some(r.wall_seconds),
                work,
                None,
                r.robustness,
            ),
            Err(_) => failed(format!(
                "the simulator counted {} work units, more than the database stores (at most {})",
                r.work.unwrap_or_default(),
                i64::MAX
            )),
        },
        // Read back as `SimError::Failed(error)`: its own message, not "simulation failed: …"
        // twice.
        Err(SimError::Failed(m)) => failed(m.clone()),
        Err(e) => failed(e.to_string()),
    }
}

fn failed(message: String) -> Columns {
    ("failed", None, None, None, Some(message), None)
}

/// Writes the result of run `id` if `worker` of the process holding `token` still holds it
/// (false: its lease expired and another worker took it over — the result is dropped), tells
/// the coordinator, and, if `next`, claims the worker's next run (as [`claim`], lease `lease`)
/// — one statement, one round trip per run (`savme.finish_and_claim`). The server refuses a
/// result that is not valid with SQLSTATE [`REFUSED`] ([`refused`] reads its message).
#[allow(clippy::too_many_arguments)]
pub fn finish_and_claim(
    c: &mut Conn<'_>,
    campaign: i32,
    id: i64,
    worker: &str,
    token: &str,
    result: &Result<SimResult, SimError>,
    lease: Duration,
    next: bool,
) -> Result<(bool, Option<Claimed>), postgres::Error> {
    let (state, failure, wall, work, error, robustness) = columns(result);
    let statement = c.prepared(
        "SELECT * FROM savme.finish_and_claim($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12)",
    )?;
    let row = c.query_one(
        &statement,
        &[
            &campaign,
            &id,
            &worker,
            &token,
            &state,
            &failure,
            &wall,
            &work,
            &error,
            &robustness,
            &lease.as_secs_f64(),
            &next,
        ],
    )?;
    Ok((row.get::<_, bool>(0), claimed(&row, 1)))
}

/// Queues run `id` again if `worker` of the process holding `token` still holds it (a stopping
/// worker hands back a run it claimed but did not start; the claim does not count as an
/// attempt).
pub fn release(
    c: &mut Conn<'_>,
    campaign: i32,
    id: i64,
    worker: &str,
    token: &str,
) -> Result<i32, postgres::Error> {
    let statement = c.prepared("SELECT savme.release($1, $2, $3, $4)")?;
    Ok(c.query_one(&statement, &[&campaign, &id, &worker, &token])?
        .get(0))
}

/// Starts listening on `channel` on this connection.
pub fn listen(client: &mut impl GenericClient, channel: &str) -> Result<(), postgres::Error> {
    // Channel names are savme's own (`savme_tasks_<id>`): safe to quote as identifiers.
    client.batch_execute(&format!("LISTEN \"{channel}\""))
}

/// Lets database role `role` work on `campaign` (false: there is no such role): lists it in
/// `savme.campaign_workers` and grants it the worker functions (`savme.grant_worker`: usage of
/// the schema, EXECUTE on the functions; no right on any table).
pub fn add_worker_role(
    client: &mut Client,
    campaign: i32,
    role: &str,
) -> Result<bool, postgres::Error> {
    let exists: bool = client
        .query_one(
            "SELECT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = $1)",
            &[&role],
        )?
        .get(0);
    if exists {
        client.execute(
            "INSERT INTO savme.campaign_workers (campaign_id, role) VALUES ($1, $2::text::name)
             ON CONFLICT DO NOTHING",
            &[&campaign, &role],
        )?;
        client.execute("SELECT savme.grant_worker($1::text::name)", &[&role])?;
    }
    Ok(exists)
}

/// Marks `campaign` as run through the queue by a live coordinator (not finished, seen now,
/// resumed by `resume`) and wakes its workers.
pub fn start_remote(
    client: &mut Client,
    campaign: i32,
    resume: &str,
) -> Result<(), postgres::Error> {
    client.execute(
        "UPDATE savme.campaigns SET finished_at = NULL, remote = true,
                coordinator_seen_at = clock_timestamp(), resume_command = $2
          WHERE id = $1",
        &[&campaign, &resume],
    )?;
    wake_workers(client, campaign)
}

/// Marks `campaign` as held by a coordinator that runs its trials itself (no `--remote`).
pub fn start_local(client: &mut Client, campaign: i32) -> Result<(), postgres::Error> {
    client
        .execute(
            "UPDATE savme.campaigns SET remote = false, coordinator_seen_at = NULL WHERE id = $1",
            &[&campaign],
        )
        .map(|_| ())
}

/// The coordinator's heartbeat (not waited for on disk: a lost stamp is harmless).
pub fn coordinator_seen(client: &mut Client, campaign: i32) -> Result<(), postgres::Error> {
    client.batch_execute("SET synchronous_commit = off")?;
    client
        .execute(
            "UPDATE savme.campaigns SET coordinator_seen_at = clock_timestamp() WHERE id = $1",
            &[&campaign],
        )
        .map(|_| ())
}

/// What a worker knows of its campaign's coordinator.
#[derive(Debug, Clone, PartialEq)]
pub struct Coordinator {
    /// The campaign is finished.
    pub finished: bool,
    /// A coordinator runs it through the queue (`--remote`).
    pub remote: bool,
    /// Seconds since the coordinator's last heartbeat (None: never).
    pub seen_ago: Option<f64>,
    /// A session holds the campaign's coordinator lock.
    pub locked: bool,
    /// The command that resumes it, as its coordinator stored it.
    pub resume_command: Option<String>,
}

/// The state of `campaign`'s coordinator (None: the campaign's row is gone, or this role may no
/// longer see it): `savme.coordinator_state`, whose lock check is the server's (a live session
/// holding the campaign's row of `savme.coordinators`).
pub fn coordinator(
    c: &mut Conn<'_>,
    campaign: i32,
) -> Result<Option<Coordinator>, postgres::Error> {
    let statement = c.prepared("SELECT * FROM savme.coordinator_state($1)")?;
    let row = c.query_opt(&statement, &[&campaign])?;
    Ok(row.map(|r| Coordinator {
        finished: r.get(0),
        remote: r.get(1),
        seen_ago: r.get(2),
        locked: r.get(3),
        resume_command: r.get(4),
    }))
}

/// Whether run `id` is finished and was last held by `worker` of the process holding `token`
/// (its result is the one stored: after a reconnect, the finish that seemed lost had
/// committed).
pub fn finished_by(
    c: &mut Conn<'_>,
    campaign: i32,
    id: i64,
    worker: &str,
    token: &str,
) -> Result<bool, postgres::Error> {
    let row = c.query_one(
        "SELECT savme.finished_by($1, $2, $3, $4)",
        &[&campaign, &id, &worker, &token],
    )?;
    Ok(row.get(0))
}

/// A campaign as a worker sees it (`savme.worker_campaign`).
#[derive(Debug, Clone, PartialEq)]
pub struct WorkerCampaign {
    /// Its id.
    pub id: i32,
    /// The simulator label of its stored protocol (None: not saved yet).
    pub simulator: Option<String>,
    /// The window of its stored protocol.
    pub window: Option<i64>,
}

/// Campaign `name` as a worker sees it — None while the database has no savme schema (or one
/// older than version 4, whose coordinator has not migrated it yet), no such campaign, or this
/// session's role may not work on it.
pub fn worker_campaign(
    client: &mut Client,
    name: &str,
) -> Result<Option<WorkerCampaign>, postgres::Error> {
    // (Lazily: without USAGE of the schema, even looking a function up in it is refused.)
    let ready: bool = client
        .query_one(
            "SELECT CASE WHEN to_regnamespace('savme') IS NULL
                           OR NOT has_schema_privilege('savme', 'USAGE') THEN false
                         WHEN to_regprocedure('savme.worker_campaign(text)') IS NULL THEN false
                         ELSE has_function_privilege('savme.worker_campaign(text)', 'EXECUTE') END",
            &[],
        )?
        .get(0);
    if !ready {
        return Ok(None);
    }
    Ok(client
        .query_opt(
            "SELECT id, simulator, \"window\" FROM savme.worker_campaign($1)",
            &[&name],
        )?
        .map(|r| WorkerCampaign {
            id: r.get(0),
            simulator: r.get(1),
            window: r.get(2),
        }))
}

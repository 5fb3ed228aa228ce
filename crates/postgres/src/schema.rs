//! The schema savme creates and migrates in its own PostgreSQL schema `savme` (documented in
//! `docs/DISTRIBUTED.md`). Each migration is one SQL script applied in one transaction, under
//! a transaction-scoped advisory lock so that two processes starting at once do not both
//! apply it; `savme.schema_version` records the versions applied.
//!
//! A database whose schema is newer than this savme knows is refused (an older savme must not
//! write into tables it does not understand). A process that finds the schema current
//! changes nothing, so a worker role without `CREATE` privileges can start.

use postgres::Client;

/// The schema version this savme writes.
pub const VERSION: i32 = 4;

/// The advisory-lock class of the migration lock (`pg_advisory_xact_lock(CLASS, 0)`): "sv" in
/// ASCII. (Before schema version 4 a coordinator also held `pg_try_advisory_lock(CLASS, campaign
/// id)`; any role can take an advisory lock, so the coordinator's lock is now a row of
/// `savme.coordinators`, which only a coordinator may write.)
pub const LOCK_CLASS: i32 = 0x7376;

/// The migrations, in order: migration `i` brings the schema to version `i + 1`.
const MIGRATIONS: &[&str] = &[
    r#"
CREATE SCHEMA IF NOT EXISTS savme;

-- One row per campaign (or `savme serve` journal), identified by its name.
CREATE TABLE savme.campaigns (
    id          serial PRIMARY KEY,
    name        text NOT NULL UNIQUE,
    -- The campaign's protocol (what `protocol.json` holds for a directory store); NULL for a
    -- journal or before the coordinator saved it.
    protocol    json,
    created_at  timestamptz NOT NULL DEFAULT now(),
    -- Set by the coordinator when the campaign is complete (idle workers then exit); NULL
    -- while it runs or after it was interrupted.
    finished_at timestamptz
);

-- The store lines: every told trial (and withdrawn one) of a campaign, in the order the
-- coordinator stored them. `body` is the line exactly as written; the other columns are
-- its fields, for SQL (NULL where the line has no such field).
CREATE TABLE savme.trials (
    campaign_id     integer NOT NULL REFERENCES savme.campaigns (id) ON DELETE CASCADE,
    line            bigint NOT NULL,          -- 1-based position in the store
    v               integer NOT NULL,         -- store format version of the line
    body            json NOT NULL,
    stored_at       timestamptz NOT NULL DEFAULT clock_timestamp(),
    stage           text,                     -- e.g. train@0.3
    idx             bigint,                   -- position within the stage
    trial_id        bigint,                   -- the kernel's trial id
    phase           text,
    budget          double precision,
    scenario        text,
    phi             jsonb,
    theta_lf        jsonb,
    hf_failure      boolean,
    hf_runtime      double precision,         -- the cost the kernel was told
    hf_wall_seconds double precision,
    hf_work         bigint,
    lf_failure      boolean,
    lf_runtime      double precision,
    lf_wall_seconds double precision,
    lf_work         bigint,
    cost_ratio      double precision,
    outcome         text,                     -- TP, TN, FP, FN
    credit_fidelity boolean,
    credit_scenario boolean,
    error           text,                     -- a withdrawn trial's error
    PRIMARY KEY (campaign_id, line)
);
CREATE INDEX trials_stage ON savme.trials (campaign_id, stage);

-- The work queue: one row per HF or LF run the coordinator wants, claimed by `savme worker`
-- processes with FOR UPDATE SKIP LOCKED under a lease they renew by heartbeat.
CREATE TABLE savme.runs (
    id            bigserial PRIMARY KEY,
    campaign_id   integer NOT NULL REFERENCES savme.campaigns (id) ON DELETE CASCADE,
    stage         text NOT NULL,
    trial_id      bigint NOT NULL,
    role          text NOT NULL CHECK (role IN ('hf', 'lf')),
    scenario      text NOT NULL,
    phi           json NOT NULL,
    fidelity      json NOT NULL,
    state         text NOT NULL DEFAULT 'queued'
                  CHECK (state IN ('queued', 'running', 'done', 'failed')),
    attempts      integer NOT NULL DEFAULT 0,
    worker        text,                       -- who holds (or last held) it
    lease_until   timestamptz,
    failure       boolean,                    -- the result: the SUT failed
    wall_seconds  double precision,
    work          bigint,
    error         text,                       -- or the simulator's error
    queued_at     timestamptz NOT NULL DEFAULT clock_timestamp(),
    started_at    timestamptz,
    finished_at   timestamptz,
    UNIQUE (campaign_id, stage, trial_id, role)
);
CREATE INDEX runs_open ON savme.runs (campaign_id, id) WHERE state IN ('queued', 'running');
"#,
    r#"
-- The coordinator's liveness, for its workers: whether it runs the campaign's runs through the
-- queue (--remote), when it was last seen (a heartbeat every few seconds), and the command that
-- resumes it (without a password), which a worker prints when it gives up waiting.
ALTER TABLE savme.campaigns
    ADD COLUMN remote              boolean NOT NULL DEFAULT false,
    ADD COLUMN coordinator_seen_at timestamptz,
    ADD COLUMN resume_command      text;

-- Which roles may work on which campaign. A role that may not write trials (a worker role)
-- sees and changes only the campaigns and runs of the campaigns it (or a role it belongs to)
-- is listed for here; a role that may write trials (a coordinator) sees them all.
CREATE TABLE savme.campaign_workers (
    campaign_id integer NOT NULL REFERENCES savme.campaigns (id) ON DELETE CASCADE,
    role        name NOT NULL,
    PRIMARY KEY (campaign_id, role)
);

CREATE FUNCTION savme.is_coordinator() RETURNS boolean LANGUAGE sql STABLE AS
  $$ SELECT has_table_privilege('savme.trials', 'INSERT') $$;
CREATE FUNCTION savme.worker_campaigns() RETURNS SETOF integer LANGUAGE sql STABLE AS
  $$ SELECT w.campaign_id FROM savme.campaign_workers w JOIN pg_roles r ON r.rolname = w.role
      WHERE pg_has_role(r.oid, 'MEMBER') $$;

ALTER TABLE savme.campaigns ENABLE ROW LEVEL SECURITY;
ALTER TABLE savme.runs ENABLE ROW LEVEL SECURITY;
ALTER TABLE savme.campaign_workers ENABLE ROW LEVEL SECURITY;
CREATE POLICY by_campaign ON savme.campaigns
  USING (savme.is_coordinator() OR id IN (SELECT savme.worker_campaigns()));
CREATE POLICY by_campaign ON savme.runs
  USING (savme.is_coordinator() OR campaign_id IN (SELECT savme.worker_campaigns()))
  WITH CHECK (savme.is_coordinator() OR campaign_id IN (SELECT savme.worker_campaigns()));
CREATE POLICY by_role ON savme.campaign_workers
  USING (savme.is_coordinator() OR pg_has_role((SELECT oid FROM pg_roles WHERE rolname = role), 'MEMBER'));
"#,
    r#"
-- Version 3: a run's robustness (how close it came to failing), when the simulator reports
-- one; the trial lines keep it in `body`.
ALTER TABLE savme.runs ADD COLUMN robustness double precision;
"#,
    // Version 4: workers act through functions that check their caller; the coordinator's lock
    // is a row naming its server session; results are checked by the server.
    include_str!("sql/v4.sql"),
];

/// Why the schema cannot be used.
#[derive(Debug)]
pub enum SchemaError {
    /// The database failed.
    Db(postgres::Error),
    /// The schema is newer than this savme.
    TooNew(i32),
}

impl From<postgres::Error> for SchemaError {
    fn from(e: postgres::Error) -> Self {
        SchemaError::Db(e)
    }
}

/// The version of the schema in the database (0: none).
fn current(client: &mut Client) -> Result<i32, postgres::Error> {
    let exists: bool = client
        .query_one(
            "SELECT to_regclass('savme.schema_version') IS NOT NULL",
            &[],
        )?
        .get(0);
    if !exists {
        return Ok(0);
    }
    let row = client.query_one(
        "SELECT coalesce(max(version), 0) FROM savme.schema_version",
        &[],
    )?;
    Ok(row.get(0))
}

/// Brings the schema to [`VERSION`], or refuses a newer one.
pub fn migrate(client: &mut Client) -> Result<(), SchemaError> {
    migrate_to(client, VERSION)
}

/// Brings the schema to `version` (at most [`VERSION`]), or refuses a newer one than this
/// savme's: [`migrate`] for the tests of a migration, which need a database as an older savme
/// left it.
#[doc(hidden)]
pub fn migrate_to(client: &mut Client, version: i32) -> Result<(), SchemaError> {
    let version = version.min(VERSION);
    let found = current(client)?;
    if found >= version && found <= VERSION {
        return Ok(());
    }
    if found > VERSION {
        return Err(SchemaError::TooNew(found));
    }
    let mut tx = client.transaction()?;
    tx.execute("SELECT pg_advisory_xact_lock($1, 0)", &[&LOCK_CLASS])?;
    tx.batch_execute(
        "CREATE SCHEMA IF NOT EXISTS savme;
         CREATE TABLE IF NOT EXISTS savme.schema_version (
             version    integer PRIMARY KEY,
             applied_at timestamptz NOT NULL DEFAULT now()
         );",
    )?;
    let row = tx.query_one(
        "SELECT coalesce(max(version), 0) FROM savme.schema_version",
        &[],
    )?;
    let found: i32 = row.get(0);
    if found > VERSION {
        return Err(SchemaError::TooNew(found));
    }
    let wanted = MIGRATIONS.iter().take(version.max(0) as usize);
    for (i, sql) in wanted.enumerate().skip(found.max(0) as usize) {
        tx.batch_execute(sql)?;
        let version = i as i32 + 1;
        tx.execute(
            "INSERT INTO savme.schema_version (version) VALUES ($1)",
            &[&version],
        )?;
    }
    tx.commit()?;
    Ok(())
}

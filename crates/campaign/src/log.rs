//! The lines of a campaign's trial store (`trials.jsonl` by default): every told trial, stored
//! as soon as the kernel has assessed it (its outcome and credit are part of the line) and
//! before the next one is told or any observer sees it, and every withdrawn one. A trial the
//! process dies before storing is asked and run again on resume. It is the campaign's journal:
//! `--resume` replays it.

use super::protocol::{StageId, StageKind};
use super::store::JsonlStore;
use super::store::StoredLine;
use super::{CampaignError, Protocol};
use savme_kernel::{Assignment, Credit, Outcome, Phase, SimResult};
use serde::{Deserialize, Serialize};

/// One simulator run of a trial.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunLine {
    /// The system under test failed.
    pub failure: bool,
    /// The cost the kernel was told (wall seconds or work units, per the protocol).
    pub runtime: f64,
    /// Measured wall-clock seconds.
    pub wall_seconds: f64,
    /// Work units, if the simulator counts them.
    pub work: Option<u64>,
    /// How close the run came to failing, if the simulator measures it (the kernel's
    /// [`savme_kernel::Run::robustness`]); left out of the line when absent, so trial stores
    /// written before it existed read the same.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robustness: Option<f64>,
}

impl RunLine {
    /// The line of a simulator result told with cost `runtime`.
    pub fn new(r: &SimResult, runtime: f64) -> Self {
        RunLine {
            failure: r.failure,
            runtime,
            wall_seconds: r.wall_seconds,
            work: r.work,
            robustness: r.robustness,
        }
    }

    /// The kernel's view of the run.
    pub fn run(&self) -> savme_kernel::Run {
        let run = savme_kernel::Run::new(self.failure, self.runtime);
        match self.robustness {
            Some(r) => run.with_robustness(r),
            None => run,
        }
    }
}

/// One told trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrialLine {
    /// The stage, stored as its label, e.g. `train@0.3` (see [`StageId`]).
    pub stage: StageId,
    /// Position of the trial within its stage, from 0.
    pub index: u64,
    /// The kernel's trial id.
    pub id: u64,
    /// The kernel phase.
    pub phase: Phase,
    /// The stage's budget (None for the baselines).
    pub budget: Option<f64>,
    /// Scenario name.
    pub scenario: String,
    /// Scenario parameters φ.
    pub phi: Assignment,
    /// Learned-fidelity settings θ_LF (None for HF-only trials).
    pub theta_lf: Option<Assignment>,
    /// The HF run.
    pub hf: RunLine,
    /// The LF run (None for HF-only trials).
    pub lf: Option<RunLine>,
    /// t_LF / t_HF.
    pub cost_ratio: Option<f64>,
    /// TP / TN / FP / FN.
    pub outcome: Option<Outcome>,
    /// What the kernel credited (Table I).
    pub credit: Credit,
}

impl TrialLine {
    /// What the trial's runs cost: HF, and LF if it ran.
    pub fn cost(&self) -> f64 {
        runs_cost(Some(&self.hf), self.lf.as_ref())
    }

    /// The observation the kernel was told.
    pub fn observation(&self) -> savme_kernel::Observation {
        match &self.lf {
            Some(lf) => savme_kernel::Observation::Paired {
                hf: self.hf.run(),
                lf: lf.run(),
            },
            None => savme_kernel::Observation::HfOnly(self.hf.run()),
        }
    }
}

/// A trial whose simulation failed and that was withdrawn (`on_error = "skip"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailedLine {
    /// The stage, stored as its label.
    pub stage: StageId,
    /// Position of the trial within its stage (failed ones included), from 0.
    pub index: u64,
    /// The kernel's trial id.
    pub id: u64,
    /// Scenario name.
    pub scenario: String,
    /// Scenario parameters φ.
    pub phi: Assignment,
    /// θ_LF (None for HF-only trials).
    pub theta_lf: Option<Assignment>,
    /// What failed.
    pub error: String,
}

/// A trial of an LF screening stage: the LF run, and the HF run when the screening made one
/// (to confirm an LF failure, or for the audit).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScreenLine {
    /// The stage, stored as its label, e.g. `screen@0.3`.
    pub stage: StageId,
    /// Position of the trial within its stage, from 0.
    pub index: u64,
    /// The kernel's trial id.
    pub id: u64,
    /// The stage's budget.
    pub budget: Option<f64>,
    /// Scenario name.
    pub scenario: String,
    /// Scenario parameters φ.
    pub phi: Assignment,
    /// θ_LF* (the evaluation's).
    pub theta_lf: Option<Assignment>,
    /// A fidelity ladder's levels below this stage's budget, cheapest first, each with its LF
    /// run if the trial made one (empty: the two-level screening, and not written).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ladder: Vec<RungLine>,
    /// What the last LF result called for (confirm, margin, audit or pass), or `direct`: no
    /// LF run, screening did not pay.
    pub screen: savme_kernel::screening::Screen,
    /// The LF run at this stage's budget (none for a direct trial, or when a lower level of
    /// the ladder passed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf: Option<RunLine>,
    /// The HF run (confirmations and audits only).
    pub hf: Option<RunLine>,
    /// TP / TN / FP / FN when HF ran.
    pub outcome: Option<Outcome>,
}

/// What runs cost in all (the runtimes told for them).
fn runs_cost(a: Option<&RunLine>, b: Option<&RunLine>) -> f64 {
    a.map_or(0.0, |r| r.runtime) + b.map_or(0.0, |r| r.runtime)
}

/// A lower level of a fidelity ladder in a screened trial ([`ScreenLine::ladder`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RungLine {
    /// The level's budget (its meta-training's).
    pub budget: f64,
    /// The level's θ_LF*.
    pub theta_lf: Assignment,
    /// Its LF run (none when the trial did not make it: the level did not pay, or a level
    /// below it passed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf: Option<RunLine>,
}

impl ScreenLine {
    /// What the screened trial's runs cost: every LF run of the ladder and the HF run, those
    /// that were made.
    pub fn cost(&self) -> f64 {
        let rungs: f64 = self
            .ladder
            .iter()
            .filter_map(|r| r.lf)
            .map(|r| r.runtime)
            .sum();
        rungs + runs_cost(self.hf.as_ref(), self.lf.as_ref())
    }

    /// The LF run of each level, cheapest first (this stage's own last); None where none was
    /// made. One level without a ladder.
    pub fn levels(&self) -> Vec<Option<&RunLine>> {
        let rungs = self.ladder.iter().map(|r| r.lf.as_ref());
        rungs.chain([self.lf.as_ref()]).collect()
    }

    /// The LF side of the trial as one run, as the kernel is told it: the last LF run's
    /// verdict and robustness, every LF run's cost (None without an LF run). Without a ladder,
    /// the LF run itself.
    pub fn lf_run(&self) -> Option<savme_kernel::Run> {
        let mut made = self.levels().into_iter().flatten().map(RunLine::run);
        let first = made.next()?;
        Some(made.fold(first, |sum, r| savme_kernel::Run {
            runtime: sum.runtime + r.runtime,
            ..r
        }))
    }
}

/// A line of `trials.jsonl`: a told trial, a screened one, or a withdrawn one.
/// Stored as its own line's fields (no tag: [`LineKind`] says how a stored line is read).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum LogLine {
    /// A told trial.
    Trial(TrialLine),
    /// A trial withdrawn after its simulation failed.
    Failed(FailedLine),
    /// A trial of a screening stage.
    Screen(ScreenLine),
}

impl LogLine {
    /// What the line's runs cost (every run made, HF and LF; 0 for a withdrawn trial).
    pub fn cost(&self) -> f64 {
        match self {
            LogLine::Trial(t) => t.cost(),
            LogLine::Screen(s) => s.cost(),
            LogLine::Failed(_) => 0.0,
        }
    }

    /// The stage.
    pub fn stage(&self) -> StageId {
        match self {
            LogLine::Trial(t) => t.stage,
            LogLine::Failed(f) => f.stage,
            LogLine::Screen(s) => s.stage,
        }
    }

    /// Its kind.
    pub fn kind(&self) -> LineKind {
        match self {
            LogLine::Trial(_) => LineKind::Trial,
            LogLine::Failed(_) => LineKind::Failed,
            LogLine::Screen(_) => LineKind::Screen,
        }
    }

    /// The told trial, if it is a paired or baseline one.
    pub fn trial(&self) -> Option<&TrialLine> {
        match self {
            LogLine::Trial(t) => Some(t),
            LogLine::Failed(_) | LogLine::Screen(_) => None,
        }
    }

    /// The screened trial, if it is one.
    pub fn screened(&self) -> Option<&ScreenLine> {
        match self {
            LogLine::Screen(s) => Some(s),
            _ => None,
        }
    }

    /// True for a told (or screened) trial, false for a withdrawn one.
    pub fn is_told(&self) -> bool {
        !matches!(self, LogLine::Failed(_))
    }
}

/// What a stored line is. The JSON-lines format has no kind field (lines are stored as savme
/// always wrote them), so the kind is read from what defines it, in this one place: a
/// withdrawn trial is the line that records its `error`; otherwise the line's stage says
/// whether it is a screened trial (a `screen@…` stage) or a told one. A line whose fields do
/// not fit its kind is refused, naming the field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineKind {
    /// A told trial ([`TrialLine`]).
    Trial,
    /// A withdrawn trial ([`FailedLine`]).
    Failed,
    /// A trial of a screening stage ([`ScreenLine`]).
    Screen,
}

impl LineKind {
    /// The kind of the stored object `value` (see [`LineKind`]); the error says what is wrong.
    pub fn of(value: &serde_json::Value) -> Result<LineKind, String> {
        if value.get("protocol").is_some() {
            return Err("a protocol record, which only a store's first line may be".into());
        }
        if value.get("error").is_some() {
            return Ok(LineKind::Failed);
        }
        let stage = value
            .get("stage")
            .ok_or("missing field `stage`")?
            .as_str()
            .ok_or("field `stage` is not a string")?;
        let stage: StageId = stage.parse().map_err(|e| format!("field `stage`: {e}"))?;
        Ok(match stage.kind {
            StageKind::Screen => LineKind::Screen,
            _ => LineKind::Trial,
        })
    }
}

impl LogLine {
    /// A stored line back as a trial line of its kind ([`LineKind::of`]); the error names the
    /// store, the line and what is wrong.
    pub fn from_stored(line: &StoredLine, store: &str) -> Result<LogLine, CampaignError> {
        let bad = |message: String| CampaignError::Log {
            store: store.to_string(),
            line: line.line as usize,
            message,
        };
        let value = line.value.clone();
        let parsed = match LineKind::of(&line.value).map_err(bad)? {
            LineKind::Failed => serde_json::from_value(value).map(LogLine::Failed),
            LineKind::Screen => serde_json::from_value(value).map(LogLine::Screen),
            LineKind::Trial => serde_json::from_value(value).map(LogLine::Trial),
        };
        parsed.map_err(|e| bad(e.to_string()))
    }
}

/// The first record of a campaign's store: the protocol the campaign runs, so that the store
/// alone resumes it (beside a directory's store, `protocol.json` is a copy for people). Stored
/// as `{"v":1,"protocol":{…},"c":"…"}`; a store written before it existed begins with a
/// trial, and its protocol is in `protocol.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProtocolLine {
    /// The protocol.
    pub protocol: Protocol,
}

impl ProtocolLine {
    /// The protocol of `line` if it is a protocol record (a store's first line), checked as
    /// `protocol.json` is; the error names the store, the line and the field.
    pub fn of(line: &StoredLine, store: &str) -> Result<Option<Protocol>, CampaignError> {
        if line.value.get("protocol").is_none() {
            return Ok(None);
        }
        let bad = |message: String| CampaignError::Log {
            store: store.to_string(),
            line: line.line as usize,
            message,
        };
        let record: ProtocolLine =
            serde_json::from_value(line.value.clone()).map_err(|e| bad(e.to_string()))?;
        let p = record.protocol;
        if p.format_version != super::protocol::FORMAT_VERSION {
            return Err(bad(format!(
                "protocol.format_version {}: this savme reads version {}",
                p.format_version,
                super::protocol::FORMAT_VERSION
            )));
        }
        match p.validate() {
            Ok(()) => Ok(Some(p)),
            Err(CampaignError::Protocol { field, message }) => {
                Err(bad(format!("`protocol.{field}`: {message}")))
            }
            Err(e) => Err(e),
        }
    }
}

/// A store's protocol record (its first line, when the store has one) and its trial lines
/// with their line numbers.
pub type StoredCampaign = (Option<Protocol>, Vec<(u64, LogLine)>);

/// A store's lines as its protocol record and its trial lines ([`StoredCampaign`]).
pub fn read_stored(lines: &[StoredLine], store: &str) -> Result<StoredCampaign, CampaignError> {
    let (protocol, rest) = match lines.split_first() {
        Some((first, rest)) => match ProtocolLine::of(first, store)? {
            Some(p) => (Some(p), rest),
            None => (None, lines),
        },
        None => (None, lines),
    };
    let trials = rest
        .iter()
        .map(|l| Ok((l.line, LogLine::from_stored(l, store)?)))
        .collect::<Result<_, CampaignError>>()?;
    Ok((protocol, trials))
}

/// Splits the logged lines into the protocol's stages (a prefix of each, in order); only the
/// last stage with lines may be incomplete. `numbers` are the lines' positions in `store`.
pub fn split_by_stage<'a>(
    p: &Protocol,
    lines: &'a [LogLine],
    numbers: &[u64],
    store: &str,
) -> Result<Vec<&'a [LogLine]>, CampaignError> {
    let line_at = |i: usize| numbers.get(i).map_or(i + 1, |&n| n as usize);
    let bad = |i: usize, message: String| CampaignError::Log {
        store: store.to_string(),
        line: line_at(i),
        message,
    };
    check_sequence(lines, numbers, store)?;
    let mut out = Vec::new();
    let mut at = 0usize;
    for stage in p.stages() {
        let (id, label) = (stage.id(), stage.label());
        let n = lines[at..].iter().take_while(|l| l.stage() == id).count();
        let told = lines[at..at + n].iter().filter(|l| l.is_told()).count();
        if told as u64 > stage.iterations {
            return Err(bad(
                at + n - 1,
                format!(
                    "stage `{label}` has {told} trials; the protocol runs {}",
                    stage.iterations
                ),
            ));
        }
        // A stage with a cost budget is complete once its runs have cost it (the stage asks
        // until then, and its last trials in flight are told too); otherwise at its trials.
        let complete = match stage.spend {
            Some(budget) => lines[at..at + n].iter().map(LogLine::cost).sum::<f64>() >= budget,
            None => told as u64 >= stage.iterations,
        };
        if n > 0 && !complete && at + n < lines.len() {
            return Err(bad(
                at + n,
                format!(
                    "stage `{}` begins before stage `{label}` is complete",
                    lines[at + n].stage()
                ),
            ));
        }
        out.push(&lines[at..at + n]);
        at += n;
    }
    if at < lines.len() {
        return Err(bad(
            at,
            format!(
                "stage `{}` is not where the protocol expects it (or not in the protocol)",
                lines[at].stage()
            ),
        ));
    }
    Ok(out)
}

impl LogLine {
    /// The trial's position within its stage.
    pub fn index(&self) -> u64 {
        match self {
            LogLine::Trial(t) => t.index,
            LogLine::Failed(f) => f.index,
            LogLine::Screen(s) => s.index,
        }
    }
}

/// Refuses lines whose trial indices do not count up by one within each stage (from 0),
/// naming the first line that breaks the count: a deleted line leaves a gap there, a
/// duplicated one repeats an index. `numbers` are the lines' positions in `store`.
pub fn check_sequence(
    lines: &[LogLine],
    numbers: &[u64],
    store: &str,
) -> Result<(), CampaignError> {
    let line_at = |i: usize| numbers.get(i).map_or(i as u64 + 1, |&n| n);
    let restore = |i: usize| {
        format!(
            "restore the file from a copy, or cut the store back to line {} and resume to run the rest again",
            line_at(i) - 1
        )
    };
    let mut previous: Option<(usize, StageId, u64)> = None;
    for (i, l) in lines.iter().enumerate() {
        let (stage, index) = (l.stage(), l.index());
        let message = match previous {
            Some((j, s, k)) if s == stage && index == k => Some(format!(
                "this line repeats line {}: trial index {index} of stage `{stage}` appears twice (lines {} and {}); remove the copy",
                line_at(j),
                line_at(j),
                line_at(i)
            )),
            Some((j, s, k)) if s == stage && index > k + 1 => Some(format!(
                "trial index {index} of stage `{stage}` follows index {k} (line {}): {} missing — {}",
                line_at(j),
                if index == k + 2 { "a line is" } else { "lines are" },
                restore(i)
            )),
            Some((j, s, k)) if s == stage && index < k => Some(format!(
                "trial index {index} of stage `{stage}` follows index {k} (line {}): the lines are out of order — {}",
                line_at(j),
                restore(i)
            )),
            Some((_, s, _)) if s == stage => None,
            _ if index > 0 => Some(format!(
                "trial index {index} is the first line of stage `{stage}`: the lines of its indices 0–{} are missing — {}",
                index - 1,
                restore(i)
            )),
            _ => None,
        };
        if let Some(message) = message {
            return Err(CampaignError::Log {
                store: store.to_string(),
                line: line_at(i) as usize,
                message,
            });
        }
        previous = Some((i, stage, index));
    }
    Ok(())
}

/// The trial lines of the campaign directory `dir` (its `trials.jsonl`), each with its
/// 1-based line number, read without its lock: a campaign still running may be read.
pub fn read_dir_lines(dir: &std::path::Path) -> Result<Vec<(u64, LogLine)>, CampaignError> {
    let path = dir.join("trials.jsonl");
    if !path.exists() {
        return Err(CampaignError::NothingToResume {
            path: dir.to_path_buf(),
        });
    }
    let name = path.display().to_string();
    let loaded = JsonlStore::read(&path)?;
    let (_, lines) = read_stored(&loaded.lines, &name)?;
    loaded.refuse_edits(&name)?;
    Ok(lines)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stored_line_with_an_unknown_key_names_the_store_line_and_key() {
        let good = r#"{"stage":"train@0.3","index":0,"id":0,"phase":"train","budget":0.3,"scenario":"s","phi":{},"theta_lf":{},"hf":{"failure":true,"runtime":1.0,"wall_seconds":1.0,"work":null},"lf":{"failure":true,"runtime":0.2,"wall_seconds":0.2,"work":null},"cost_ratio":0.2,"outcome":"TP","credit":{"fidelity":true,"scenario":true}}"#;
        let line = |text: &str| StoredLine {
            line: 7,
            value: serde_json::from_str(text).unwrap(),
        };
        assert!(LogLine::from_stored(&line(good), "t.jsonl").is_ok());
        let bad = good.replacen("\"index\"", "\"idx\":1,\"index\"", 1);
        let e = LogLine::from_stored(&line(&bad), "t.jsonl").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("t.jsonl, line 7: unknown field `idx`"),
            "{e}"
        );
        let failed = r#"{"stage":"train@0.3","index":0,"id":0,"scenario":"s","phi":{},"theta_lf":null,"error":"boom","eror":1}"#;
        let e = LogLine::from_stored(&line(failed), "t.jsonl").unwrap_err();
        assert!(e.to_string().contains("unknown field `eror`"), "{e}");
        // A bad stage label is refused naming the line and the field, saying what is wrong.
        for (label, reason) in [
            ("train@0.30", "savme writes it `train@0.3`"),
            ("trian@0.3", "`trian` is not a stage kind"),
        ] {
            let text = good.replacen("train@0.3", label, 1);
            let e = LogLine::from_stored(&line(&text), "t.jsonl").unwrap_err();
            let e = e.to_string();
            assert!(
                e.starts_with(&format!(
                    "t.jsonl, line 7: field `stage`: `{label}` is not a stage label"
                )) && e.contains(reason),
                "{e}"
            );
        }
        let e = LogLine::from_stored(&line(r#"{"index":0}"#), "t.jsonl").unwrap_err();
        assert!(
            e.to_string().contains("line 7: missing field `stage`"),
            "{e}"
        );
    }

    #[test]
    fn a_lines_kind_comes_from_its_stage_and_its_error() {
        let kind = |text: &str| LineKind::of(&serde_json::from_str(text).unwrap());
        assert_eq!(kind(r#"{"stage":"train@0.3"}"#), Ok(LineKind::Trial));
        assert_eq!(kind(r#"{"stage":"screen@0.3"}"#), Ok(LineKind::Screen));
        assert_eq!(
            kind(r#"{"stage":"screen@0.3","error":"x"}"#),
            Ok(LineKind::Failed)
        );
        // A trial line with a `screen` key is a told trial with an unknown field, not a
        // screened trial.
        let told = r#"{"stage":"evaluate@0.3","screen":"pass"}"#;
        assert_eq!(kind(told), Ok(LineKind::Trial));
        let line = StoredLine {
            line: 3,
            value: serde_json::from_str(told).unwrap(),
        };
        let e = LogLine::from_stored(&line, "t.jsonl")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3: unknown field `screen`"), "{e}");
    }
}

//! `phi.json` in a campaign's directory: each scenario's φ-space as the campaign file gave it
//! when the campaign started (its OpenSCENARIO files read). `run --resume` and
//! `estimate --config` compare the file's φ-spaces now with it, and refuse an edit (a
//! parameter's range changed in its `.xosc` after the campaign) naming the file, the scenario,
//! the parameter and both ranges — rather than an error in the trial store or, for an estimate,
//! a different P(failure) said nothing of.

use super::{usage, Failure};
use savme::kernel::{Domain, Space, Variable};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The file's name in the campaign's directory.
const FILE: &str = "phi.json";

/// The φ-spaces of a campaign, by scenario.
type Spaces = BTreeMap<String, Space>;

/// For a new campaign in directory `dir` (no `protocol.json` or `trials.jsonl` there yet),
/// writes its φ-spaces; another directory is left as it is (the campaign refuses it, or this
/// is a resumption, checked by [`check`]).
pub fn record(dir: &Path, spaces: &Spaces) -> Result<(), Failure> {
    if dir.join("protocol.json").exists() || dir.join("trials.jsonl").exists() {
        return Ok(());
    }
    // The campaign names a directory that cannot be made (a file in the way) itself.
    if std::fs::create_dir_all(dir).is_err() {
        return Ok(());
    }
    let path = dir.join(FILE);
    let json = serde_json::to_string_pretty(spaces)
        .map_err(|e| Failure::Runtime(format!("{}: {e}", path.display())))?;
    savme::store::safe_file::write_file(&path, (json + "\n").as_bytes())
        .map_err(|e| Failure::Runtime(format!("{}: {e}", path.display())))
}

/// Refuses φ-spaces (`spaces`, from `config`, their OpenSCENARIO files `openscenario` by
/// scenario) that differ from those campaign directory `dir` recorded when it started, naming
/// for each difference the file that gives the scenario's φ, the scenario, the variable and
/// both ranges. A directory without `phi.json` (a campaign written before it was kept) is not
/// checked.
pub fn check(
    dir: &Path,
    config: &Path,
    spaces: &Spaces,
    openscenario: &BTreeMap<String, PathBuf>,
) -> Result<(), Failure> {
    let path = dir.join(FILE);
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(());
    };
    let recorded: Spaces = serde_json::from_str(&text)
        .map_err(|e| Failure::Runtime(format!("{}: {e}", path.display())))?;
    let mut differs = Vec::new();
    for (scenario, then) in &recorded {
        let Some(now) = spaces.get(scenario) else {
            // A scenario gone: the protocol's scenario lists say so.
            continue;
        };
        let (file, what) = match openscenario.get(scenario) {
            Some(xosc) => (xosc.as_path(), "parameter"),
            None => (config, "φ variable"),
        };
        for v in then.variables() {
            match now.variable(&v.name) {
                Some(w) if w == v => {}
                Some(w) => differs.push(format!(
                    "{}: {what} `{}` of scenario `{scenario}` is {} now, but the campaign ran with {}",
                    file.display(),
                    v.name,
                    range(w),
                    range(v)
                )),
                None => differs.push(format!(
                    "{}: scenario `{scenario}` has no {what} `{}` now, but the campaign ran with it ({})",
                    file.display(),
                    v.name,
                    range(v)
                )),
            }
        }
        for w in now.variables() {
            if then.variable(&w.name).is_none() {
                differs.push(format!(
                    "{}: {what} `{}` of scenario `{scenario}` ({}) is new: the campaign ran without it",
                    file.display(),
                    w.name,
                    range(w)
                ));
            }
        }
    }
    if differs.is_empty() {
        return Ok(());
    }
    Err(usage(format!(
        "{} changed since the campaign in {} started ({}): {}; give the files as they were, or start a new campaign",
        if differs.len() == 1 { "a φ-space" } else { "φ-spaces" },
        dir.display(),
        path.display(),
        differs.join("; ")
    )))
}

/// A variable's values for a message: `[lo, hi]` (with its bins and scale), or the listed
/// values (the first 8, then how many).
fn range(v: &Variable) -> String {
    match &v.domain {
        Domain::Continuous {
            lo,
            hi,
            bins,
            scale,
        } => {
            format!("[{lo}, {hi}] in {bins} {} bins", scale.name())
        }
        Domain::Discrete { values } => {
            let shown: Vec<String> = values.iter().take(8).map(|x| x.to_string()).collect();
            let more = if values.len() > 8 {
                format!(", … ({} values)", values.len())
            } else {
                String::new()
            };
            format!("{{{}{more}}}", shown.join(", "))
        }
    }
}

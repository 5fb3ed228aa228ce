//! The composition layer: what the CLI and the Python package both assemble from a campaign's
//! description — the bundled simulator's presets, the simulator a protocol's label names, and
//! an FMU campaign from its campaign file. Front ends call these; they never assemble the
//! parts themselves.

use savme_campaign::config::{check_repeat, Overrides};
use savme_campaign::estimate::{
    EstimateError, EstimateOutcome, EstimateProgress, EstimateRun, EstimateSettings,
};
use savme_campaign::{CampaignError, Method, OnError, Problem, Protocol};
use savme_campaign_file::{CampaignFile, ConfigError};
use savme_kernel::Simulator;
use savme_sim::sim::DrivingSimulator;
use std::io::Write;
use std::path::Path;

/// The bundled simulator's labels (defined with its adapter).
pub use crate::adapter::{IDEAL, SENSORS};

/// Which preset of the bundled simulator's protocol.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Preset {
    /// The short preset (one budget, fewer iterations) instead of the paper's protocol.
    pub quick: bool,
    /// Idealised perception instead of camera + lidar.
    pub ideal: bool,
}

/// The protocol and problem of a campaign on the bundled driving simulator, validated.
///
/// ```
/// use savme::campaign::config::Overrides;
/// use savme::compose::{bundled, Preset};
/// let o = Overrides { seed: Some(3), train_scenarios: Some(vec!["7".into()]), ..Default::default() };
/// let (p, problem) = bundled(Preset { quick: true, ideal: false }, &o)?;
/// assert_eq!((p.seed, p.budgets.clone()), (3, vec![0.3]));
/// assert_eq!(p.train_scenarios, ["lead_vehicle_brakes"]);
/// assert!(problem.scenarios.contains_key("on_ramp_merge"));
/// assert!(bundled(Preset::default(), &Overrides { budgets: Some(vec![2.0]), ..Default::default() }).is_err());
/// # Ok::<(), savme::campaign::CampaignError>(())
/// ```
pub fn bundled(preset: Preset, o: &Overrides) -> Result<(Protocol, Problem), CampaignError> {
    let (train, test) = savme_sim::scenario::train_test_names();
    let simulator = if preset.ideal { IDEAL } else { SENSORS };
    let mut p = if preset.quick {
        Protocol::quick(simulator, train, test)
    } else {
        Protocol::paper(simulator, train, test)
    };
    let lookup = |k: &str| savme_sim::scenario::find(k).map(|s| s.name.to_string());
    o.apply(
        &mut p,
        &lookup,
        "1–10 or their names (see `savme scenarios`)",
    )?;
    p.validate()?;
    let problem = Problem::from(savme_sim::problem(p.fidelity_bins));
    Ok((p, problem))
}

/// The bundled simulator a protocol names (for `--resume`).
pub fn bundled_simulator(p: &Protocol) -> Result<DrivingSimulator, CampaignError> {
    match p.simulator.as_str() {
        SENSORS => Ok(DrivingSimulator::default()),
        IDEAL => Ok(DrivingSimulator::ideal()),
        other => Err(CampaignError::Protocol {
            field: "simulator".into(),
            message: format!("`{other}` is not the bundled simulator ({SENSORS} or {IDEAL})"),
        }),
    }
}

/// A campaign from a campaign file: its protocol and problem, and the file as its simulator
/// adapter read and checked it (for FMUs: the FMU paths, bindings, isolation).
#[derive(Debug)]
pub struct FileCampaign {
    /// The protocol: the paper's, the file's `[campaign]` section, then the flags.
    pub protocol: Protocol,
    /// The fidelity space with θ_HF and the scenario spaces of the file.
    pub problem: Problem,
    /// The file as its adapter read and checked it (the simulator it names: `file.simulator`).
    pub file: Box<dyn crate::adapter::FileSimulator>,
    /// The number of seeds (`repeat`: the file's, then the flags'; None: one campaign).
    pub repeat: Option<u32>,
}

/// Reads and checks the campaign file at `path` through the adapter whose sections it has
/// (with the bundled simulator's fidelity table for `[fidelity] paper = true`), then builds its
/// protocol: the paper's stages with savme's tuned search ([`Method::Tuned`]), the file's
/// `[campaign]` section, then `flags`, validated. An error in
/// a value the file gave names the file, line and key; one in a flag names the protocol field.
pub fn campaign_file(path: &Path, flags: &Overrides) -> Result<FileCampaign, CampaignError> {
    // A campaign stored with its FMUs' paths spelled otherwise (or before labels were
    // canonical) is the same campaign when they name the same files: for every resume of a
    // file's campaign, here or through the Python package.
    savme_campaign::protocol::set_simulator_matcher(crate::adapter::same_simulator);
    let paper = |bins| {
        (
            savme_sim::fidelity::space(bins),
            savme_sim::fidelity::theta_hf(),
        )
    };
    if flags.fidelity_bins.is_some() {
        return Err(CampaignError::Protocol {
            field: "fidelity_bins".into(),
            message: "a campaign file's fidelity space comes from the file: set `[campaign] fidelity_bins` there".into(),
        });
    }
    let file = file_adapter(path)?.read_file(path, &paper)?;
    let common = file.common();
    let scenarios = &common.scenarios;
    // `savme run` searches with savme's tuned method unless `method = "paper"` is given.
    let mut p = Protocol::paper(
        file.label(),
        scenarios.train.clone(),
        scenarios.test.clone(),
    )
    .with_method(Method::Tuned);
    p.weights = scenarios.weights.clone();
    p.on_error = if file.skip_failed_runs() {
        OnError::Skip
    } else {
        OnError::Abort
    };
    let known = scenarios
        .spaces
        .keys()
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    let lookup = |k: &str| scenarios.spaces.contains_key(k).then(|| k.to_string());
    let overrides =
        Overrides::from_section(&common.campaign, &common.path.display().to_string())?.then(flags);
    overrides.apply(&mut p, &lookup, &known)?;
    p.validate().map_err(|e| in_file(e, common, flags))?;
    check_repeat(overrides.repeat).map_err(|e| in_file(e, common, flags))?;
    let problem = Problem {
        fidelity: common.fidelity.space.clone(),
        theta_hf: common.fidelity.theta_hf.clone(),
        scenarios: scenarios.spaces.clone(),
    };
    Ok(FileCampaign {
        protocol: p,
        problem,
        repeat: overrides.repeat,
        file,
    })
}

/// The adapter that reads the campaign file at `path` (by the sections it has; the FMU adapter
/// is the only one that reads campaign files today). A file with no adapter's sections, or with
/// more than one's, is refused naming the adapters and their sections.
fn file_adapter(path: &Path) -> Result<&'static dyn crate::adapter::Adapter, CampaignError> {
    let src = savme_campaign_file::Source::read(path)?;
    let top: std::collections::BTreeMap<String, toml::Value> = src.parse()?;
    let sections: Vec<&str> = top.keys().map(String::as_str).collect();
    let found = crate::adapter::file_adapters(&sections);
    match found.as_slice() {
        [one] => Ok(*one),
        _ => {
            let offered: Vec<String> = (crate::adapter::ADAPTERS.iter())
                .filter(|a| !a.file_sections().is_empty())
                .map(|a| format!("{} ([{}])", a.name(), a.file_sections().join("], [")))
                .collect();
            let what = if found.is_empty() {
                "no"
            } else {
                "more than one"
            };
            Err(CampaignError::File(src.err(
                None,
                None,
                format!(
                    "{what} simulator adapter reads this file: give the sections of one of {}",
                    offered.join(", ")
                ),
            )))
        }
    }
}

/// A protocol error of a value the campaign file gave, as an error naming its key and line.
fn in_file(e: CampaignError, file: &CampaignFile, flags: &Overrides) -> CampaignError {
    let CampaignError::Protocol { field, message } = e else {
        return e;
    };
    let given_as_flag = flags.is_given(&field);
    if given_as_flag {
        return CampaignError::Protocol { field, message };
    }
    let (key, line, message) = match field.as_str() {
        given if file.campaign.lines.contains_key(given) => (
            format!("campaign.{given}"),
            file.campaign.lines.get(given).copied(),
            message,
        ),
        "train_scenarios" => missing_role(file, "train", message),
        "test_scenarios" => missing_role(file, "test", message),
        "weights" => bad_weight(file, message),
        other => (
            format!("campaign.{other}"),
            file.campaign.lines.get(other).copied(),
            message,
        ),
    };
    CampaignError::File(ConfigError {
        file: file.path.display().to_string(),
        line,
        key: Some(key),
        message,
    })
}

/// The key, line and message of a file without a scenario of `role`: at the role of its first
/// scenario (they all have the other role).
fn missing_role(
    file: &CampaignFile,
    role: &str,
    message: String,
) -> (String, Option<usize>, String) {
    let message = format!("no scenario has role \"{role}\": {message}");
    match file.scenarios.lines.first() {
        Some(s) => (format!("scenario[{}].role", s.index), Some(s.role), message),
        None => ("scenario".into(), None, message),
    }
}

/// The key, line and message of a weight the protocol refused: the weight of the first
/// scenario (by name, as [`Protocol::validate`] checks them) that is not positive and finite.
fn bad_weight(file: &CampaignFile, message: String) -> (String, Option<usize>, String) {
    let scenarios = &file.scenarios;
    let bad = (scenarios.weights.iter())
        .find(|(_, w)| !(**w > 0.0 && w.is_finite()))
        .and_then(|(name, _)| scenarios.lines.iter().find(|s| &s.name == name));
    match bad {
        Some(s) => (format!("scenario[{}].weight", s.index), s.weight, message),
        None => ("scenario.weight".into(), None, message),
    }
}

impl FileCampaign {
    /// The settings of the file's `[estimate]` section (None: the file has none), checked
    /// against the campaign before it runs; refused with `repeat` (the estimate reads one
    /// campaign). Errors name the file, line and key.
    pub fn estimate_settings(&self) -> Result<Option<EstimateSettings>, String> {
        let Some(section) = &self.file.common().estimate else {
            return Ok(None);
        };
        let settings = EstimateSettings::from_section(section, &self.file.common().path)
            .map_err(|e| e.to_string())?
            .with_declared(
                &self.file.common().scenarios.nominal,
                &self.protocol.train_scenarios,
            );
        let file = self.file.common().path.display();
        let at = |e: String| format!("{file}, line {}, [estimate]: {e}", section.line);
        if self.repeat.is_some() {
            return Err(at(
                "an estimate runs on one campaign: not with `repeat` (run `savme estimate` on a seed's directory)".into(),
            ));
        }
        settings
            .check(&self.protocol, &self.problem)
            .map_err(|e| match e {
                // A budget the campaign will not train: at the key's line, before it runs.
                EstimateError::UnknownBudget { .. } => format!(
                    "{file}, line {}, key `estimate.budget`: {e}",
                    section.line_of("budget")
                ),
                e => at(e.to_string()),
            })?;
        Ok(Some(settings))
    }
}

/// The `[estimate]` stage of a campaign file: after the campaign, on the campaign kept at
/// `campaign`, into `out/estimate-<budget>` (`out`: the campaign's output directory; a
/// resumed campaign resumes an estimate already started there). `savme run --config` and
/// `savme.campaign.load(...).run()` both run it through here.
pub struct EstimateStage {
    /// Where the campaign is kept.
    pub campaign: Place,
    /// The campaign's output directory.
    pub out: std::path::PathBuf,
    /// The campaign's problem.
    pub problem: Problem,
    /// The file's `[estimate]` settings.
    pub settings: EstimateSettings,
    /// Worker threads.
    pub jobs: usize,
    /// Asks the estimate to stop between runs.
    pub stop: savme_campaign::Stop,
}

impl EstimateStage {
    /// Runs (or resumes) the estimate on `sim`'s HF role.
    pub fn run<S>(
        self,
        progress: impl FnMut(&EstimateProgress<'_>) + 'static,
        sim: &S,
    ) -> Result<EstimateOutcome, EstimateError>
    where
        S: Simulator + Clone + Send,
    {
        let source = self.campaign.source();
        let protocol = source.protocol().map_err(EstimateError::Campaign)?;
        let budget = self.settings.budget.unwrap_or(protocol.budgets[0]);
        let run = EstimateRun::new(source, self.problem, self.settings)
            .out(self.out.join(format!(
                "estimate-{}",
                savme_campaign::protocol::Compact(budget)
            )))
            .stop_on(self.stop)
            .progress(progress);
        let resume = run
            .out_dir(&protocol)
            .is_ok_and(|dir| dir.join("estimate.json").exists());
        run.resume(resume).jobs(self.jobs).run(sim)
    }
}

/// Writes an estimate's progress line to standard error when it starts, then about every
/// 10 s (nothing if `quiet`).
pub fn estimate_progress_lines(quiet: bool) -> impl FnMut(&EstimateProgress<'_>) {
    let mut last: Option<std::time::Instant> = None;
    move |p: &EstimateProgress<'_>| {
        if quiet || last.is_some_and(|t| t.elapsed() < std::time::Duration::from_secs(10)) {
            return;
        }
        last = Some(std::time::Instant::now());
        // Progress is best effort: a closed pipe must not stop the estimate.
        let _ = writeln!(std::io::stderr(), "{}", p.line());
    }
}

/// Where a campaign is kept: its directory (the JSON-lines store), or a campaign in a
/// database. The one place that turns what a user names into a store to run with or a source
/// to read: a new kind of store is one variant and one arm in each method.
#[derive(Debug, Clone)]
pub enum Place {
    /// A campaign directory.
    Dir(std::path::PathBuf),
    /// Campaign `name` in a PostgreSQL database.
    #[cfg(feature = "postgres")]
    Database(Box<savme_postgres::Database>, String),
}

impl Place {
    /// The campaign read back without its lock (`savme estimate`, `savme failures`).
    pub fn source(&self) -> Box<dyn savme_campaign::source::CampaignSource> {
        match self {
            Place::Dir(dir) => Box::new(savme_campaign::source::DirSource::new(dir)),
            #[cfg(feature = "postgres")]
            Place::Database(db, name) => Box::new(savme_postgres::PostgresSource::new(
                (**db).clone(),
                name.clone(),
            )),
        }
    }

    /// The store a campaign runs with (locked): None for a directory (the campaign opens the
    /// directory's own JSON-lines store), the database's campaign otherwise.
    pub fn open_store(
        &self,
    ) -> Result<Option<Box<dyn savme_store::TrialStore>>, savme_store::StoreError> {
        match self {
            Place::Dir(_) => Ok(None),
            #[cfg(feature = "postgres")]
            Place::Database(db, name) => Ok(Some(Box::new(savme_postgres::PostgresStore::open(
                db, name,
            )?))),
        }
    }
}

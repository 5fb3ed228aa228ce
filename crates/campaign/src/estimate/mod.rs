//! `savme estimate`: the probability of failure under the nominal distribution of φ, by
//! importance sampling from a proposal frozen from a finished campaign's meta-training
//! posterior ([`savme_kernel::estimation`] holds the maths).
//!
//! [`EstimateRun`] reads the campaign directory (its `protocol.json` and `trials.jsonl`),
//! rebuilds each scenario's posterior p_ψ(φ | s) from the meta-training trials at the chosen
//! budget (exactly what the kernel learned: the logged scenario credits), and runs HF
//! simulations of φ ~ q until the total's 95 % interval is within ± `target_width` (with at
//! least `min_failures` failures) or `max_runs` runs are made. Trials run in parallel and are
//! told in ask order, and the stopping rule is checked after each tell, so the result does not
//! depend on `jobs`. Output directory (default `CAMPAIGN/estimate-<budget>/`):
//! `estimate.json` (the settings), `trials.jsonl` (one line per HF run with q(φ), p(φ) and the
//! weight; resume replays it), `summary.json`, `table.md`.
//!
//! ```no_run
//! use savme_campaign::estimate::{EstimateRun, EstimateSettings};
//! use savme_campaign::source::DirSource;
//! use savme_campaign::Problem;
//! use savme_sim::sim::DrivingSimulator;
//! let settings = EstimateSettings { target_width: Some(0.1), ..EstimateSettings::default() };
//! let problem = Problem::from(savme_sim::problem(10));
//! let outcome = EstimateRun::new(DirSource::new("results"), problem, settings)
//!     .jobs(2)
//!     .run(&DrivingSimulator::ideal())?;
//! println!("{}", outcome.table_md);
//! # Ok::<(), savme_campaign::estimate::EstimateError>(())
//! ```

mod output;
mod posterior;
mod running;

use running::{replay, stop_reason, Reporter, Running};
mod settings;

pub use output::{ControlOutcome, EstimateLine, EstimateOutcome, EstimateSummary, StopReason};
pub use settings::{
    resumed as settings_on_resume, EstimateError, EstimateSettings, MAX_RUNS, STOPPING_RULES,
};

use super::executor::with_pool;
use super::store::JsonlStore;
use super::{CampaignError, Problem, Protocol};
use crate::source::CampaignSource;
use savme_kernel::estimation::{Estimation, Nominal};
use savme_kernel::Simulator;
use std::path::{Path, PathBuf};

/// An estimate to run on a finished campaign.
pub struct EstimateRun<'p> {
    campaign: Box<dyn CampaignSource + 'p>,
    settings: EstimateSettings,
    out: Option<PathBuf>,
    problem: Problem,
    jobs: usize,
    resume: bool,
    given: Option<Vec<String>>,
    progress: Option<ProgressFn<'p>>,
    stop: super::Stop,
}

/// A progress callback ([`EstimateRun::progress`]).
type ProgressFn<'p> = Box<dyn FnMut(&EstimateProgress<'_>) + 'p>;

/// Where a running estimate stands: once after the stored runs were replayed, then after
/// each HF run told.
#[derive(Debug)]
pub struct EstimateProgress<'a> {
    /// HF runs told, pilot and estimate together (replayed ones included).
    pub told: u64,
    /// Of which replayed from `trials.jsonl`.
    pub replayed: u64,
    /// The most HF runs the estimate may make.
    pub max_runs: u64,
    /// The refinement round under way, and how many there are (None: the estimate itself).
    pub round: Option<(u32, u32)>,
    /// Whether the control variates' calibration pairs are under way (after the pilot).
    pub calibrating: bool,
    /// The estimate from the runs after the pilot (and the pilot rounds it reuses).
    pub estimate: &'a savme_kernel::estimation::Estimate,
    /// Seconds since this process started the estimate.
    pub elapsed_seconds: f64,
}

impl EstimateProgress<'_> {
    /// One line: runs, the pilot round or the estimate with its ± and failures, elapsed time.
    ///
    /// ```
    /// use savme_campaign::estimate::EstimateProgress;
    /// use savme_kernel::estimation::{Estimate, Interval};
    /// let estimate = Estimate {
    ///     scenarios: vec![],
    ///     total: Interval::from_mean_and_error(0.002, 0.0001),
    ///     runs: 5000,
    ///     failures: 400,
    /// };
    /// let p = EstimateProgress {
    ///     told: 17000, replayed: 0, max_runs: 200000, round: None, calibrating: false,
    ///     estimate: &estimate, elapsed_seconds: 12.5,
    /// };
    /// assert_eq!(
    ///     p.line(),
    ///     "estimate: 17000 of at most 200000 HF runs; P(failure) = 0.0020 ± 9.8 % from 5000 runs (400 failures); 12 s elapsed"
    /// );
    /// ```
    pub fn line(&self) -> String {
        let e = self.estimate;
        let stand = match self.round {
            Some((r, rounds)) => format!("cross-entropy pilot round {} of {rounds}", r + 1),
            None if self.calibrating => "control-variate calibration pairs".to_string(),
            None if e.failures == 0 => format!("no failure yet in {} runs", e.runs),
            None => format!(
                "P(failure) = {} ± {:.1} % from {} runs ({} failures)",
                crate::report::format_probability(e.total.mean),
                100.0 * e.total.relative_half_width(),
                e.runs,
                e.failures
            ),
        };
        format!(
            "estimate: {} of at most {} HF runs; {stand}; {:.0} s elapsed",
            self.told, self.max_runs, self.elapsed_seconds
        )
    }
}

/// What [`EstimateRun::run`] checked and built before running anything.
struct Prepared {
    protocol: Protocol,
    out: PathBuf,
    settings: EstimateSettings,
    /// The stopping rules changed on resume, in words.
    changed: Vec<String>,
    trained: posterior::Trained,
    estimation: Estimation,
}

/// A resumed estimate must be allowed at least the runs it already holds.
fn fits_max_runs(
    replayed: u64,
    settings: &EstimateSettings,
    out: &Path,
) -> Result<(), EstimateError> {
    if replayed <= settings.max_runs {
        return Ok(());
    }
    Err(EstimateError::Setting {
        key: "max_runs".into(),
        message: format!(
            "{} already holds {replayed} runs; a resumed estimate needs max_runs ≥ {replayed}, got {}",
            out.display(),
            settings.max_runs
        ),
    })
}

impl<'p> EstimateRun<'p> {
    /// An estimate of `campaign` (a directory: [`DirSource`](crate::source::DirSource); or
    /// any [`CampaignSource`]), whose problem is `problem`, with `settings` (one worker).
    pub fn new(
        campaign: impl CampaignSource + 'p,
        problem: Problem,
        settings: EstimateSettings,
    ) -> Self {
        EstimateRun {
            campaign: Box::new(campaign),
            settings,
            out: None,
            problem,
            jobs: 1,
            resume: false,
            given: None,
            progress: None,
            stop: super::Stop::new(),
        }
    }

    /// Calls `progress` once after the stored runs were replayed (resume), then after each HF
    /// run told.
    pub fn progress(mut self, progress: impl FnMut(&EstimateProgress<'_>) + 'p) -> Self {
        self.progress = Some(Box::new(progress));
        self
    }

    /// Stops between runs once `stop` is requested (e.g. by Ctrl-C or SIGTERM): the runs in
    /// flight are told and stored, then [`run`](EstimateRun::run) returns
    /// [`EstimateError::Stopped`]; a resume continues where it stopped.
    pub fn stop_on(mut self, stop: super::Stop) -> Self {
        self.stop = stop;
        self
    }

    /// The output directory (default `CAMPAIGN/estimate-<budget>`).
    pub fn out(mut self, dir: impl Into<PathBuf>) -> Self {
        self.out = Some(dir.into());
        self
    }

    /// Worker threads (the result does not depend on it).
    pub fn jobs(mut self, jobs: usize) -> Self {
        self.jobs = jobs.max(1);
        self
    }

    /// Continue the estimate in the output directory with its stored settings. A given
    /// setting that differs from the stored one is refused naming both values
    /// ([`EstimateError::ChangedOnResume`]), except the stopping rules (`max_runs`,
    /// `target_width`, `min_failures`), which do not change the runs drawn: those are applied,
    /// stored, and listed in [`EstimateOutcome::changed_on_resume`].
    pub fn resume(mut self, resume: bool) -> Self {
        self.resume = resume;
        self
    }

    /// The names of the settings the caller gave (flags, a file's keys), compared with the
    /// stored ones on resume; the others are taken from the stored estimate. Default: every
    /// setting counts as given (a campaign file's `[estimate]` section, with its defaults).
    pub fn given(mut self, names: impl IntoIterator<Item = impl Into<String>>) -> Self {
        self.given = Some(names.into_iter().map(Into::into).collect());
        self
    }

    /// The output directory these settings write to (default: `estimate-<budget>` in the
    /// campaign's directory; a campaign without one needs [`EstimateRun::out`]).
    pub fn out_dir(&self, protocol: &Protocol) -> Result<PathBuf, EstimateError> {
        if let Some(out) = &self.out {
            return Ok(out.clone());
        }
        let b = self.settings.budget.unwrap_or(protocol.budgets[0]);
        match self.campaign.dir() {
            Some(dir) => Ok(dir.join(format!("estimate-{}", crate::protocol::Compact(b)))),
            None => Err(EstimateError::NoOutputDirectory {
                campaign: self.campaign.location(),
            }),
        }
    }

    /// Runs (or resumes) the estimate on `sim` (its HF role) and writes the outputs. Every
    /// setting, the campaign and the stored trials are checked before any simulation runs.
    pub fn run<S>(mut self, sim: &S) -> Result<EstimateOutcome, EstimateError>
    where
        S: Simulator + Clone + Send,
    {
        let Prepared {
            protocol,
            out,
            settings,
            changed,
            trained,
            mut estimation,
        } = self.prepare()?;
        if !self.resume {
            create(&out, &settings)?;
        }
        let mut store = JsonlStore::open(&out.join("trials.jsonl")).map_err(CampaignError::from)?;
        let started = std::time::Instant::now();
        let mut lines = replay(&mut store, &mut estimation)?;
        let replayed = lines.len() as u64;
        fits_max_runs(replayed, &settings, &out)?;
        if !changed.is_empty() {
            create(&out, &settings)?;
        }
        let mut report = Reporter {
            callback: self.progress.take(),
            started,
            replayed,
            max_runs: settings.max_runs,
            rounds: settings.refine_rounds,
        };
        report.call(&estimation);
        let reason = match stop_reason(&estimation, &settings) {
            Some(r) => r,
            None => {
                let mut run = Running {
                    estimation: &mut estimation,
                    settings: &settings,
                    store: &mut store,
                    lines: &mut lines,
                    cost: protocol.cost.measure(),
                    theta_hf: &self.problem.theta_hf,
                    theta_lf: trained.theta_lf.as_ref(),
                    report: &mut report,
                    stop: &self.stop,
                };
                with_pool(sim, self.jobs, |pool| run.run(pool, 2 * self.jobs))?
            }
        };
        drop(store);
        let mut outcome = output::EstimateOutcome::new(
            &estimation,
            &settings,
            &trained,
            lines,
            reason,
            replayed,
            started.elapsed().as_secs_f64(),
            out,
        );
        outcome.changed_on_resume = changed;
        outcome.write()?;
        Ok(outcome)
    }

    /// Everything checked before a run: the campaign's protocol, the output directory, the
    /// settings (stored ones on resume), the trained posteriors and the estimation.
    fn prepare(&self) -> Result<Prepared, EstimateError> {
        let protocol = self.campaign.protocol()?;
        let out = self.out_dir(&protocol)?;
        super::outputs::usable_dir(&out)?;
        let (settings, changed) = self.settings_for(&out)?;
        settings.validate()?;
        let budget = settings.budget.unwrap_or(protocol.budgets[0]);
        let lines = self.campaign.lines()?;
        let (location, at) = (self.campaign.location(), self.campaign.lines_location());
        let problem = self.problem.binned_for(&protocol)?;
        let trained = posterior::trained(
            &location,
            (&at, &lines),
            &protocol,
            &problem,
            budget,
            &settings,
        )?;
        let config = settings.config(settings.seed.unwrap_or_else(|| {
            protocol.kernel_seed(&format!("estimate@{}", crate::protocol::Compact(budget)))
        }));
        let estimation = Estimation::new(&trained.scenarios, &config)?;
        Ok(Prepared {
            protocol,
            out,
            settings,
            changed,
            trained,
            estimation,
        })
    }

    /// The settings to run with: the stored ones on resume (with the given stopping rules
    /// that differ, listed), else the given ones (refusing a directory that already holds an
    /// estimate). Creates nothing.
    fn settings_for(&self, out: &Path) -> Result<(EstimateSettings, Vec<String>), EstimateError> {
        let path = out.join("estimate.json");
        match (self.resume, path.exists()) {
            (false, true) => Err(EstimateError::Exists {
                dir: out.to_path_buf(),
            }),
            (true, false) => Err(EstimateError::NothingToResume {
                dir: out.to_path_buf(),
            }),
            (true, true) => {
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| EstimateError::Campaign(CampaignError::io(&path, e)))?;
                let stored = serde_json::from_str(&text).map_err(|e| {
                    EstimateError::Campaign(CampaignError::Log {
                        store: path.display().to_string(),
                        line: e.line(),
                        message: e.to_string(),
                    })
                })?;
                settings_on_resume(&path, stored, &self.settings, self.given.as_deref())
            }
            (false, false) => Ok((self.settings.clone(), Vec::new())),
        }
    }
}

/// Creates the output directory of a new estimate with its `estimate.json`.
fn create(out: &Path, settings: &EstimateSettings) -> Result<(), EstimateError> {
    let path = out.join("estimate.json");
    std::fs::create_dir_all(out).map_err(|e| CampaignError::io(out, e))?;
    let json = serde_json::to_string_pretty(settings).unwrap_or_default();
    savme_store::safe_file::write_file(&path, (json + "\n").as_bytes())
        .map_err(|e| CampaignError::io(&path, e))?;
    Ok(())
}

/// Parses a `--nominal` declaration `SCENARIO.VARIABLE=uniform`, `=normal:MEAN,SD`,
/// `=lognormal:MU,SIGMA` (the mean and standard deviation of ln φ) or `=weights:W1,W2,…`.
///
/// ```
/// use savme_campaign::estimate::parse_nominal;
/// use savme_kernel::estimation::Nominal;
/// let (s, v, n) = parse_nominal("lead_vehicle_brakes.ego_speed=normal:12,2")?;
/// assert_eq!((s.as_str(), v.as_str()), ("lead_vehicle_brakes", "ego_speed"));
/// assert_eq!(n, Nominal::Normal { mean: 12.0, sd: 2.0 });
/// assert!(parse_nominal("ego_speed=normal:12").is_err());
/// # Ok::<(), savme_campaign::estimate::EstimateError>(())
/// ```
pub fn parse_nominal(given: &str) -> Result<(String, String, Nominal), EstimateError> {
    let bad = |message: &str| EstimateError::NominalSyntax {
        given: given.to_string(),
        message: message.to_string(),
    };
    let (name, dist) = given
        .split_once('=')
        .ok_or_else(|| bad("expected SCENARIO.VARIABLE=DISTRIBUTION"))?;
    let (scenario, variable) = name
        .split_once('.')
        .filter(|(s, v)| !s.is_empty() && !v.is_empty())
        .ok_or_else(|| bad("expected SCENARIO.VARIABLE before `=`"))?;
    let (kind, args) = dist.split_once(':').unwrap_or((dist, ""));
    let numbers = || {
        args.split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|_| bad("the parameters must be numbers separated by commas"))
    };
    let nominal = match kind {
        "uniform" if args.is_empty() => Nominal::Uniform,
        "normal" => match numbers()?.as_slice() {
            [mean, sd] => Nominal::Normal {
                mean: *mean,
                sd: *sd,
            },
            _ => return Err(bad("normal takes two numbers: normal:MEAN,SD")),
        },
        "lognormal" => match numbers()?.as_slice() {
            [mu, sigma] => Nominal::LogNormal {
                mu: *mu,
                sigma: *sigma,
            },
            _ => {
                return Err(bad(
                    "lognormal takes two numbers: lognormal:MU,SIGMA (of ln φ)",
                ))
            }
        },
        "weights" => Nominal::Weights {
            weights: numbers()?,
        },
        _ => return Err(bad(
            "the distribution is uniform, normal:MEAN,SD, lognormal:MU,SIGMA or weights:W1,W2,…",
        )),
    };
    Ok((scenario.to_string(), variable.to_string(), nominal))
}

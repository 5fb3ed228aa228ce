//! [`Repeated`]: one protocol run with N seeds (`seed`, `seed + 1`, …), several campaigns in
//! parallel, each in its own directory `seed-<s>/`; then the results over the seeds with their
//! intervals ([`RepeatedReport`]) in the parent directory.

use super::report::repeated::RepeatedReport;
use super::{outputs, Campaign, CampaignError, CampaignOutcome, Observer, Problem, Protocol};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// The most seeds one repeated campaign runs.
pub const MAX_REPEAT: u32 = 1000;

/// Makes the observers of the campaign of one seed.
pub type ObserverFactory<'f> = &'f (dyn Fn(u64) -> Vec<Box<dyn Observer + Send>> + Sync);

/// What `repeat.json` holds: the seeds' common protocol (with the first seed) and how many.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RepeatFile {
    /// Seeds run: `protocol.seed` … `protocol.seed + repeat − 1`.
    pub repeat: u32,
    /// The protocol of the first seed.
    pub protocol: Protocol,
}

/// A protocol repeated with N seeds.
///
/// ```no_run
/// use savme_campaign::{Problem, Protocol, Repeated};
/// use savme_sim::sim::DrivingSimulator;
///
/// let (train, test) = savme_sim::scenario::train_test_names();
/// let protocol = Protocol::quick("savme-sim/ideal", train, test);
/// let outcome = Repeated::new(protocol, Problem::from(savme_sim::problem(10)), 5)
///     .out("results-5-seeds")
///     .run(&DrivingSimulator::ideal())?;
/// println!("{}", outcome.report.table_md());
/// # Ok::<(), savme_campaign::CampaignError>(())
/// ```
pub struct Repeated<'f> {
    protocol: Protocol,
    problem: Problem,
    repeat: u32,
    out: PathBuf,
    resume: bool,
    jobs: usize,
    observers: Option<ObserverFactory<'f>>,
    stop: super::Stop,
}

/// What a finished repeated campaign returns.
#[derive(Debug, Clone)]
pub struct RepeatedOutcome {
    /// The results over the seeds.
    pub report: RepeatedReport,
    /// Each seed's campaign, in seed order.
    pub runs: Vec<CampaignOutcome>,
    /// The parent directory.
    pub out: PathBuf,
    /// Wall-clock seconds this process spent.
    pub elapsed_seconds: f64,
}

impl<'f> Repeated<'f> {
    /// `protocol` with seeds `protocol.seed` … `+ repeat − 1`, into `savme-results/`, one
    /// worker per core in all.
    pub fn new(protocol: Protocol, problem: Problem, repeat: u32) -> Self {
        Repeated {
            protocol,
            problem,
            repeat,
            out: PathBuf::from("savme-results"),
            resume: false,
            jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
            observers: None,
            stop: super::Stop::new(),
        }
    }

    /// The parent output directory.
    pub fn out(mut self, dir: impl Into<PathBuf>) -> Self {
        self.out = dir.into();
        self
    }

    /// Continue the repeated campaign in the output directory (its `repeat.json` must match):
    /// finished seeds are replayed, interrupted ones resumed, missing ones started.
    pub fn resume(mut self, resume: bool) -> Self {
        self.resume = resume;
        self
    }

    /// Worker threads in all (at least 1): min(jobs, N) campaigns run at once, sharing them.
    pub fn jobs(mut self, jobs: usize) -> Self {
        self.jobs = jobs.max(1);
        self
    }

    /// The observers of each seed's campaign (they run on that campaign's thread).
    pub fn observers(mut self, f: ObserverFactory<'f>) -> Self {
        self.observers = Some(f);
        self
    }

    /// Stops every seed's campaign between trials when `stop` is requested (see
    /// [`Campaign::stop_on`]); seeds not yet started are not started.
    pub fn stop_on(mut self, stop: super::Stop) -> Self {
        self.stop = stop;
        self
    }

    /// The protocol of each seed, validated; an error names the field (or `repeat`).
    fn seed_protocols(&self) -> Result<Vec<Protocol>, CampaignError> {
        if self.repeat == 0 || self.repeat > MAX_REPEAT {
            return Err(CampaignError::Protocol {
                field: "repeat".into(),
                message: format!("{} is not between 1 and {MAX_REPEAT}", self.repeat),
            });
        }
        self.protocol.validate()?;
        (0..u64::from(self.repeat))
            .map(|i| {
                let seed =
                    self.protocol
                        .seed
                        .checked_add(i)
                        .ok_or_else(|| CampaignError::Protocol {
                            field: "seed".into(),
                            message: format!(
                                "{} + {} seeds passes the largest seed",
                                self.protocol.seed, self.repeat
                            ),
                        })?;
                Ok(Protocol {
                    seed,
                    ..self.protocol.clone()
                })
            })
            .collect()
    }

    /// Runs every seed's campaign (min(jobs, N) at once) and writes the results over the
    /// seeds: `table.md`, `summary.json`, `breakeven.png`, `meta_testing.png`. A campaign that
    /// fails stops new ones from starting; the error names its seed.
    pub fn run<S>(self, sim: &S) -> Result<RepeatedOutcome, CampaignError>
    where
        S: savme_kernel::Simulator + Clone + Send,
    {
        let clock = Instant::now();
        let protocols = self.seed_protocols()?;
        self.prepare()?;
        let parallel = protocols.len().min(self.jobs).max(1);
        let jobs_each = (self.jobs / parallel).max(1);
        let next = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        let results: Mutex<Vec<Option<Result<CampaignOutcome, CampaignError>>>> =
            Mutex::new((0..protocols.len()).map(|_| None).collect());
        std::thread::scope(|scope| {
            for _ in 0..parallel {
                let sim = sim.clone();
                let (next, stop, results, protocols, this) =
                    (&next, &stop, &results, &protocols, &self);
                scope.spawn(move || loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    if i >= protocols.len()
                        || stop.load(Ordering::SeqCst)
                        || this.stop.is_requested()
                    {
                        break;
                    }
                    let r = this.run_seed(&protocols[i], jobs_each, &sim);
                    if r.is_err() {
                        stop.store(true, Ordering::SeqCst);
                    }
                    if let Ok(mut all) = results.lock() {
                        all[i] = Some(r);
                    }
                });
            }
        });
        let results = results.into_inner().unwrap_or_default();
        let mut runs = Vec::with_capacity(results.len());
        let mut not_started = None;
        for (r, p) in results.into_iter().zip(&protocols) {
            match r {
                Some(Ok(o)) => runs.push(o),
                Some(Err(e)) => return Err(self.in_seed(p.seed, e)),
                // Not started: another seed failed, or a stop was requested.
                None => not_started = not_started.or(Some(p)),
            }
        }
        if let Some(p) = not_started {
            if !self.stop.is_requested() {
                return Err(CampaignError::WorkersGone);
            }
            let stopped = CampaignError::Stopped {
                stage: "its first stage (not started)".into(),
                told: 0,
                planned: p
                    .stages()
                    .first()
                    .map_or("0 trials".into(), crate::stage::Stage::planned),
            };
            return Err(self.in_seed(p.seed, stopped));
        }
        let reports: Vec<_> = runs.iter().map(|r| r.report.clone()).collect();
        let report = RepeatedReport::from_reports(&reports);
        let lines: Vec<&[super::log::TrialLine]> = runs.iter().map(|r| &r.trials[..]).collect();
        outputs::write_repeated(&report, &lines, &self.out, clock.elapsed().as_secs_f64())?;
        Ok(RepeatedOutcome {
            report,
            runs,
            out: self.out,
            elapsed_seconds: clock.elapsed().as_secs_f64(),
        })
    }

    /// The directory of seed `seed`'s campaign.
    pub fn seed_dir(out: &Path, seed: u64) -> PathBuf {
        out.join(format!("seed-{seed}"))
    }

    /// Creates the parent directory and `repeat.json` (a new run: refused where one exists),
    /// or checks it (resume).
    fn prepare(&self) -> Result<(), CampaignError> {
        outputs::usable_dir(&self.out)?;
        let path = self.out.join("repeat.json");
        let file = RepeatFile {
            repeat: self.repeat,
            protocol: self.protocol.clone(),
        };
        if self.resume {
            let stored = load(&self.out)?;
            if stored.repeat != file.repeat || !stored.protocol.same_campaign(&file.protocol) {
                return Err(CampaignError::Protocol {
                    field: "repeat.json".into(),
                    message: "differs from the protocol and repeat given to resume".into(),
                });
            }
            return Ok(());
        }
        if path.exists() || self.out.join("protocol.json").exists() {
            return Err(CampaignError::OutputExists {
                path: self.out.clone(),
            });
        }
        std::fs::create_dir_all(&self.out).map_err(|e| CampaignError::io(&self.out, e))?;
        let json = serde_json::to_string_pretty(&file).unwrap_or_default();
        super::store::safe_file::write_file(&path, (json + "\n").as_bytes())
            .map_err(|e| CampaignError::io(&path, e))
    }

    fn run_seed<S>(
        &self,
        p: &Protocol,
        jobs: usize,
        sim: &S,
    ) -> Result<CampaignOutcome, CampaignError>
    where
        S: savme_kernel::Simulator + Clone + Send,
    {
        let dir = Self::seed_dir(&self.out, p.seed);
        // On resume a seed that never started (no protocol.json) starts now.
        let resume = self.resume && dir.join("protocol.json").exists();
        let mut c = Campaign::new(p.clone(), self.problem.clone())
            .out(&dir)
            .resume(resume)
            .jobs(jobs)
            .stop_on(self.stop.clone());
        if let Some(f) = self.observers {
            for o in f(p.seed) {
                c = c.boxed_observer(o);
            }
        }
        c.run(sim)
    }

    fn in_seed(&self, seed: u64, e: CampaignError) -> CampaignError {
        CampaignError::Seed {
            seed,
            dir: Self::seed_dir(&self.out, seed),
            source: Box::new(e),
        }
    }
}

/// Reads `repeat.json` of the repeated campaign in `dir` (for `--resume`); None when `dir`
/// holds no repeated campaign.
pub fn load_repeat(dir: &Path) -> Result<Option<RepeatFile>, CampaignError> {
    if !dir.join("repeat.json").exists() {
        return Ok(None);
    }
    load(dir).map(Some)
}

fn load(dir: &Path) -> Result<RepeatFile, CampaignError> {
    let path = dir.join("repeat.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(CampaignError::NothingToResume {
                path: dir.to_path_buf(),
            })
        }
        Err(e) => return Err(CampaignError::io(&path, e)),
    };
    serde_json::from_str(&text).map_err(|e| CampaignError::Log {
        store: path.display().to_string(),
        line: e.line(),
        message: e.to_string(),
    })
}

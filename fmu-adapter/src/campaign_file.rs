//! The FMU adapter's part of a campaign file (`savme run --config`): which FMUs, how runs
//! execute (`[fmu]`), what a failure is (`[failure]`), and the FMU variable each savme variable
//! of the campaign's part (read by `savme_campaign_file`: `[campaign]`, `[estimate]`, the
//! fidelity space and the scenarios) is bound to.
//!
//! [`FmuCampaignFile::load`] reads and checks a file: the campaign's part, the run
//! specification, then both FMUs (opened, every binding and signal type-checked against both).
//! Every error is a [`ConfigError`] naming the file and, where known, the line and the key
//! (an error that names a key always names a line: of the part of a table it is about) — also
//! for an FMU variable that does not fit, by remembering where each FMU variable name came from
//! and checking the FMUs one use at a time (failure signal, its robustness, cost, fidelity, each
//! scenario). Two
//! bindings that would set one FMU variable in the same run (a scenario's φ and fixed
//! parameters, the fidelity settings) are refused, naming both.
//!
//! ```toml
//! [fmu]
//! hf = "hf.fmu"                  # paths relative to the campaign file
//! lf = "lf.fmu"                  # optional: the HF FMU with other settings
//! stop_time = 12.0
//! step = { rate_of = "rate" }    # or a fixed step: step = 0.1 (or a fidelity variable with
//!                                # drives = "step_size")
//! tolerance = 1e-6               # optional: passed to fmi2SetupExperiment
//! stop_on_failure = true         # default true
//! cost = "wall"                  # or the name of an output counting work units
//! isolate = false                # run every evaluation in a worker process (forced for an FMU
//!                                # with canBeInstantiatedOnlyOncePerProcess="true")
//! timeout_s = 60.0               # per run, with isolation
//! on_error = "abort"             # or "skip"
//! log = false                    # print every FMU log message (errors always carry the last ones)
//! record = ["distance"]          # outputs the trial recordings show over time (`--record`)
//!
//! [failure]
//! boolean = "collision"          # or: threshold = "distance" with above = … / below = …
//!                                #   (a threshold also gives each run a robustness: its
//!                                #   smallest margin to the threshold, ≤ 0 = failed)
//! robustness = "distance"        # optional, with `boolean`: a Real or Integer output whose
//!                                #   smallest value is the run's robustness (≤ 0 on failure;
//!                                #   the flag alone decides the verdict)
//!
//! # … and the campaign's sections: [campaign], [estimate], [fidelity], [[scenario]]
//! # (see savme_campaign_file), every savme variable bound to the FMU variable of its name
//! # unless `fmu = "…"` names another.
//! ```

mod bindings;
mod failure;
mod label;
mod raw;
mod run_spec;
mod spaces;
#[cfg(test)]
mod tests;

pub use savme_campaign_file::{
    CampaignFile, CampaignSection, ConfigError, EstimateSection, ScenarioLines,
};

use crate::worker::WorkerInit;
use crate::{
    Binding, CostSource, Crossing, Failure, Fixed, RunSpec, ScenarioSpec, StepSize, Tolerance,
};
use bindings::{Origins, Use};
use failure::failure;
use raw::StepSection;
use run_spec::{cost_source, no_empty_path, step, step_count, stop_time, timeout, tolerance};
use savme_campaign_file::{resolve, Bound, Drives, Fidelity, Source};
use savme_kernel::{Assignment, Space, Variable};
use spaces::{fidelity_bindings, scenario_specs};
use std::path::Path;
use std::time::Duration;
use toml::Spanned;

/// The sections the FMU adapter reads.
pub const SECTIONS: [&str; 2] = ["fmu", "failure"];

/// A campaign file of FMUs, read and checked against them.
#[derive(Debug, Clone)]
pub struct FmuCampaignFile {
    /// The campaign's part: `[campaign]`, `[estimate]`, the fidelity space with θ_HF, the
    /// scenarios.
    pub common: CampaignFile,
    /// What the simulator (in-process or in workers) is built from: the FMU paths (resolved
    /// relative to the file), the run specification, the spaces and θ_HF.
    pub init: WorkerInit,
    /// `[fmu] isolate`: run each evaluation in a worker process — also when an FMU declares
    /// `canBeInstantiatedOnlyOncePerProcess`. Without isolation the FMUs' libraries were
    /// loaded by [`FmuCampaignFile::load`] (as a check); with it nothing was loaded.
    pub isolate: bool,
    /// `[fmu] timeout_s`: per-run timeout with isolation (default 60 s).
    pub timeout: Duration,
    /// `[fmu] on_error = "skip"` (true) or `"abort"` (false, the default).
    pub skip_failed_runs: bool,
    /// `fmu:<hf path>|<lf path>`: which simulator ran the trials.
    pub label: String,
    /// `[fmu] record`: the outputs (of both FMUs) that recorded trials show as time series
    /// (`savme run --record …`), checked to be outputs of both FMUs.
    pub record: Vec<String>,
}

/// The FMU sections of a file.
#[derive(Debug, serde::Deserialize)]
struct Sections {
    fmu: Spanned<raw::FmuSection>,
    failure: Spanned<raw::FailureSection>,
}

impl FmuCampaignFile {
    /// Reads and checks `path`: the campaign's part, then the FMU sections, then both FMUs
    /// (opened, every binding and signal type-checked against both). `paper(bins)` gives the
    /// fidelity space and θ_HF of `[fidelity] paper = true` (called with `[campaign]
    /// fidelity_bins`, between 1 and [`savme_kernel::MAX_ARMS`]), each setting bound to the
    /// FMU variable of its name. Bindings that would set one FMU variable twice in a run (a
    /// scenario's φ and fixed parameters, the fidelity settings) are refused.
    ///
    /// ```no_run
    /// use savme_fmu::campaign_file::FmuCampaignFile;
    /// use savme_kernel::{Assignment, Space, Variable};
    ///
    /// // The caller's "paper" fidelity table (savme passes the bundled simulator's Table II).
    /// let file = FmuCampaignFile::load("campaign.toml".as_ref(), &|_bins| {
    ///     let space = Space::new(vec![Variable::discrete("rate_hz", [2, 10])]).expect("valid");
    ///     (space, Assignment::new().with("rate_hz", 10))
    /// })?;
    /// println!("{}: {} scenarios", file.label, file.common.scenarios.spaces.len());
    /// # Ok::<(), savme_fmu::campaign_file::ConfigError>(())
    /// ```
    pub fn load(
        path: &Path,
        paper: &dyn Fn(u32) -> (Space, Assignment),
    ) -> Result<FmuCampaignFile, ConfigError> {
        let src = Source::read(path)?;
        let common = CampaignFile::parse(&src, path, &SECTIONS, paper)?;
        let f: Sections = src.parse()?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut origins = Origins::default();
        let fidelity = fidelity_bindings(&src, &common.fidelity, &mut origins)?;
        let scenarios = scenario_specs(&src, &common, &mut origins)?;
        let fmu = f.fmu.get_ref();
        let step = step(&src, &f.fmu, &common.fidelity)?;
        let tolerance = tolerance(&src, fmu.tolerance.as_ref(), &common.fidelity)?;
        let stop_time = stop_time(&src, &fmu.stop_time)?;
        step_count(&src, &f.fmu, &step, stop_time, &common.fidelity)?;
        let failure = failure(&src, &f.failure, &mut origins)?;
        let cost = cost_source(&src, fmu.cost.as_ref(), &mut origins);
        let timeout = timeout(&src, fmu.timeout_s.as_ref())?;
        no_empty_path(&src, "fmu.hf", &fmu.hf)?;
        if let Some(lf) = &fmu.lf {
            no_empty_path(&src, "fmu.lf", lf)?;
        }
        let hf = resolve(base, fmu.hf.get_ref());
        let lf = fmu
            .lf
            .as_ref()
            .map_or(hf.clone(), |l| resolve(base, l.get_ref()));
        let init = WorkerInit {
            hf,
            lf,
            spec: RunSpec {
                stop_time,
                step,
                tolerance,
                failure,
                stop_on_failure: fmu.stop_on_failure,
                cost,
                fidelity,
                scenarios,
                fmu_log: fmu.log,
            },
            fidelity: Some(common.fidelity.space.clone()),
            phi: common.scenarios.spaces.clone(),
        };
        let (hf, lf) = bindings::check_fmus(&src, &init, &f.fmu, &origins)?;
        let record = bindings::check_record(&src, &hf, &lf, fmu.record.as_ref())?;
        // An FMU that can be instantiated only once per process runs in workers only.
        let isolate = fmu.isolate || hf.only_once_per_process() || lf.only_once_per_process();
        if !isolate {
            bindings::load_fmus(&src, &init, &f.fmu)?;
        }
        Ok(FmuCampaignFile {
            common,
            label: label(&init.hf, &init.lf),
            init,
            isolate,
            timeout,
            skip_failed_runs: fmu.on_error == raw::OnError::Skip,
            record,
        })
    }
}

pub use label::{label, same_label};

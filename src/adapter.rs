//! Simulator adapters: how savme builds the simulator a campaign names. Each adapter registers
//! itself in [`ADAPTERS`] with its name, the protocol labels it builds a simulator from (what a
//! `savme worker`, `savme toy` and `--resume` need: the label alone) and the campaign-file
//! sections it reads (an FMU campaign's `[fmu]` and `[failure]`). An adapter that reads
//! campaign files builds their simulator itself ([`Adapter::read_file`] → a [`FileSimulator`]),
//! so that the composition layer reads any adapter's file the same way. A new adapter is one
//! type implementing [`Adapter`] and one entry in [`ADAPTERS`]; nothing else lists simulators.
//!
//! ```
//! use savme::adapter::{adapter_of_label, simulator_of_label};
//! use savme::kernel::{Assignment, Role, Simulator};
//! let mut sim = simulator_of_label("savme-null").expect("the null simulator");
//! let r = sim.simulate_as(Role::High, "any", &Assignment::new(), &Assignment::new())?;
//! assert!(!r.failure);
//! assert_eq!(adapter_of_label("savme-sim/ideal").map(|a| a.name()), Some("savme-sim"));
//! assert!(simulator_of_label("my-fmu-campaign").is_none());
//! # Ok::<(), savme::kernel::SimError>(())
//! ```

use savme_campaign::config::{NULL, TOY};
use savme_campaign::toy::{NullSimulator, Sleeping, ToySimulator};
use savme_campaign::CampaignError;
use savme_campaign_file::CampaignFile;
use savme_fmu::campaign_file::FmuCampaignFile;
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator, Space};
use savme_sim::sim::DrivingSimulator;
use savme_viewer::Frames;
use std::any::Any;
use std::path::Path;

/// The simulator label of the bundled simulator with camera + lidar perception.
pub const SENSORS: &str = "savme-sim/sensors";
/// The simulator label of the bundled simulator with idealised perception.
pub const IDEAL: &str = "savme-sim/ideal";

/// A simulator adapter: a kind of simulator savme can build.
pub trait Adapter: Sync {
    /// Its short name (`savme-sim`, `savme-toy`, `savme-null`, `fmu`).
    fn name(&self) -> &'static str;
    /// One line on what it runs (for docs and messages).
    fn about(&self) -> &'static str;
    /// The simulator a protocol's `label` names, if this adapter builds it from the label
    /// alone (None: not its label, or it needs a campaign file).
    fn simulator(&self, label: &str) -> Option<AnySimulator>;
    /// Reads and checks the campaign file at `path`, which has this adapter's sections
    /// ([`Adapter::file_sections`]): its campaign part (`[campaign]`, `[estimate]`, the fidelity
    /// space — the bundled simulator's table from `paper` where the file asks — and the
    /// scenarios) and the simulator it names. Errors name the file, line and key. The default:
    /// this adapter reads no campaign file.
    fn read_file(
        &self,
        path: &Path,
        paper: Paper<'_>,
    ) -> Result<Box<dyn FileSimulator>, CampaignError> {
        let _ = paper;
        Err(CampaignError::File(savme_campaign_file::ConfigError {
            file: path.display().to_string(),
            line: None,
            key: None,
            message: format!(
                "the {} simulator adapter reads no campaign file",
                self.name()
            ),
        }))
    }
    /// The top-level sections of a campaign file this adapter reads (none: it reads no
    /// campaign file).
    fn file_sections(&self) -> &'static [&'static str] {
        &[]
    }
    /// What a recorded trial of the simulator `label` names shows in the rerun viewer
    /// (default: nothing but its outcome). A simulator offers frames by implementing
    /// `savme_viewer::TrialFrames` and returning it with `Frames::new` (feature `rerun`).
    fn frames(&self, _label: &str) -> Frames {
        Frames::none()
    }
}

/// The paper's fidelity table for `bins` bins per continuous setting (space and θ_HF): what a
/// campaign file's `[fidelity] paper = true` stands for.
pub type Paper<'a> = &'a dyn Fn(u32) -> (Space, Assignment);

/// A campaign file as the adapter whose sections it has read and checked it: the campaign's
/// part and the simulator it names. Front ends ask it for the simulator; nothing above the
/// adapter knows which kind of simulator it is.
pub trait FileSimulator: std::fmt::Debug + Send + Sync {
    /// The campaign's part of the file.
    fn common(&self) -> &CampaignFile;
    /// The protocol's simulator label for this file's simulator.
    fn label(&self) -> &str;
    /// Whether a failed simulation withdraws its trial (`on_error = "skip"`) instead of
    /// stopping the campaign.
    fn skip_failed_runs(&self) -> bool;
    /// The simulator, ready to run. `worker` gives the command of a worker process, for an
    /// adapter that runs simulations in other processes (asked only then).
    fn simulator(
        &self,
        worker: &dyn Fn() -> Result<Vec<String>, String>,
    ) -> Result<AnySimulator, String>;
    /// What a recorded trial of the file's simulator shows in the rerun viewer (default:
    /// nothing but its outcome); `worker` as for [`FileSimulator::simulator`].
    fn frames(&self, _worker: &dyn Fn() -> Result<Vec<String>, String>) -> Result<Frames, String> {
        Ok(Frames::none())
    }
    /// The adapter's own reading of the file (to read what only it has).
    fn as_any(&self) -> &dyn Any;
    /// The adapter's own reading of the file (to set an option only it has).
    fn as_any_mut(&mut self) -> &mut dyn Any;
    /// The same, owned.
    fn into_any(self: Box<Self>) -> Box<dyn Any>;
}

/// Every adapter savme has, in the order they are asked.
pub static ADAPTERS: &[&dyn Adapter] = &[&Bundled, &Toy, &Null, &Fmu];

/// The simulator a protocol's label names, from the first adapter that builds it from the
/// label alone.
pub fn simulator_of_label(label: &str) -> Option<AnySimulator> {
    ADAPTERS.iter().find_map(|a| a.simulator(label))
}

/// The frames recorded trials of a protocol's `label` show (none for a label no adapter
/// builds alone: an FMU campaign's frames come from its file).
pub fn frames_of_label(label: &str) -> Frames {
    adapter_of_label(label).map_or_else(Frames::none, |a| a.frames(label))
}

/// Whether a stored campaign's simulator label `stored` names the simulator a campaign file
/// now gives (`given`): the same label, or an FMU campaign's label naming the same files
/// however their paths were spelled ([`savme_fmu::campaign_file::same_label`]: a campaign run
/// with `--config ./ref.toml` resumes and estimates from any directory).
pub fn same_simulator(stored: &str, given: &str) -> bool {
    stored == given || savme_fmu::campaign_file::same_label(stored, given)
}

/// The adapter that builds a protocol's label's simulator from the label alone.
pub fn adapter_of_label(label: &str) -> Option<&'static dyn Adapter> {
    ADAPTERS
        .iter()
        .copied()
        .find(|a| a.simulator(label).is_some())
}

/// The adapters that read a campaign file with these top-level `sections` (each adapter
/// whose sections the file has), and every adapter's sections (to name in an error).
pub fn file_adapters(sections: &[&str]) -> Vec<&'static dyn Adapter> {
    ADAPTERS
        .iter()
        .copied()
        .filter(|a| a.file_sections().iter().any(|s| sections.contains(s)))
        .collect()
}

/// Any simulator an adapter built, as one type: the campaign copies it to each worker thread.
pub struct AnySimulator(Box<dyn DynSimulator>);

impl AnySimulator {
    /// Wraps `sim`.
    pub fn new<S: Simulator + Clone + Send + 'static>(sim: S) -> AnySimulator {
        AnySimulator(Box::new(sim))
    }
}

impl Clone for AnySimulator {
    fn clone(&self) -> AnySimulator {
        AnySimulator(self.0.box_clone())
    }
}

impl std::fmt::Debug for AnySimulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("AnySimulator")
    }
}

impl Simulator for AnySimulator {
    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        self.0.dyn_simulate(role, scenario, phi, fidelity)
    }
}

/// A simulator behind a box: [`Simulator`] with a clone that keeps the box.
trait DynSimulator: Send {
    fn dyn_simulate(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError>;
    fn box_clone(&self) -> Box<dyn DynSimulator>;
}

impl<S: Simulator + Clone + Send + 'static> DynSimulator for S {
    fn dyn_simulate(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        self.simulate_as(role, scenario, phi, fidelity)
    }

    fn box_clone(&self) -> Box<dyn DynSimulator> {
        Box::new(self.clone())
    }
}

/// The bundled driving simulator: `savme-sim/sensors` (camera + lidar) and `savme-sim/ideal`.
struct Bundled;

impl Adapter for Bundled {
    fn name(&self) -> &'static str {
        "savme-sim"
    }
    fn about(&self) -> &'static str {
        "the bundled driving simulator (savme-sim/sensors: camera + lidar; savme-sim/ideal)"
    }
    fn simulator(&self, label: &str) -> Option<AnySimulator> {
        match label {
            SENSORS => Some(AnySimulator::new(DrivingSimulator::default())),
            IDEAL => Some(AnySimulator::new(DrivingSimulator::ideal())),
            _ => None,
        }
    }
    fn frames(&self, label: &str) -> Frames {
        match label {
            SENSORS => Frames::driving(DrivingSimulator::default()),
            IDEAL => Frames::driving(DrivingSimulator::ideal()),
            _ => Frames::none(),
        }
    }
}

/// The toy simulator, optionally sleeping before each run: `savme-toy`,
/// `savme-toy/sleep=20ms`.
struct Toy;

impl Adapter for Toy {
    fn name(&self) -> &'static str {
        "savme-toy"
    }
    fn about(&self) -> &'static str {
        "the toy simulator (savme-toy, or savme-toy/sleep=<ms>ms: sleeping before each run)"
    }
    fn simulator(&self, label: &str) -> Option<AnySimulator> {
        let ms = if label == TOY {
            0
        } else {
            label
                .strip_prefix("savme-toy/sleep=")?
                .strip_suffix("ms")?
                .parse()
                .ok()?
        };
        Some(AnySimulator::new(Sleeping {
            inner: ToySimulator,
            sleep: std::time::Duration::from_millis(ms),
        }))
    }
}

/// The null simulator (`savme-null`): every run passes at once.
struct Null;

impl Adapter for Null {
    fn name(&self) -> &'static str {
        "savme-null"
    }
    fn about(&self) -> &'static str {
        "the null simulator (savme-null: every run passes at once; overhead benchmarks)"
    }
    fn simulator(&self, label: &str) -> Option<AnySimulator> {
        (label == NULL).then(|| AnySimulator::new(NullSimulator))
    }
}

/// FMUs named by a campaign file (`[fmu]`, `[failure]`): built from the file
/// ([`Adapter::read_file`]: a checked `FmuCampaignFile`), never from a label alone.
struct Fmu;

impl Adapter for Fmu {
    fn name(&self) -> &'static str {
        "fmu"
    }
    fn about(&self) -> &'static str {
        "FMI 2.0 / 3.0 co-simulation FMUs named by a campaign file ([fmu], [failure])"
    }
    fn simulator(&self, _label: &str) -> Option<AnySimulator> {
        None
    }
    fn file_sections(&self) -> &'static [&'static str] {
        &savme_fmu::campaign_file::SECTIONS
    }
    fn read_file(
        &self,
        path: &Path,
        paper: Paper<'_>,
    ) -> Result<Box<dyn FileSimulator>, CampaignError> {
        Ok(Box::new(FmuCampaignFile::load(path, paper)?))
    }
}

impl FileSimulator for FmuCampaignFile {
    fn common(&self) -> &CampaignFile {
        &self.common
    }
    fn label(&self) -> &str {
        &self.label
    }
    fn skip_failed_runs(&self) -> bool {
        self.skip_failed_runs
    }
    /// The FMU back end: in this process, or (`[fmu] isolate`) in `worker` processes.
    fn simulator(
        &self,
        worker: &dyn Fn() -> Result<Vec<String>, String>,
    ) -> Result<AnySimulator, String> {
        let worker = if self.isolate { Some(worker()?) } else { None };
        let backend = savme_fmu::FmuBackend::new(&self.init, worker, self.timeout)
            .map_err(|e| format!("{}: {e}", self.common.path.display()))?;
        Ok(AnySimulator::new(backend))
    }
    /// The outputs `[fmu] record` lists, re-run on an FMU back end of its own (in a worker
    /// process too with `isolate`); nothing when it lists none.
    fn frames(&self, worker: &dyn Fn() -> Result<Vec<String>, String>) -> Result<Frames, String> {
        if self.record.is_empty() {
            return Ok(Frames::none());
        }
        let worker = if self.isolate { Some(worker()?) } else { None };
        let backend = savme_fmu::FmuBackend::new(&self.init, worker, self.timeout)
            .map_err(|e| format!("{}: {e}", self.common.path.display()))?;
        Ok(Frames::series(
            FmuRerun(backend),
            self.record.clone(),
            signal(&self.init.spec.failure),
        ))
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
    fn into_any(self: Box<Self>) -> Box<dyn Any> {
        self
    }
}

/// An FMU campaign's back end re-running trials for the viewer's time-series frames.
struct FmuRerun(savme_fmu::FmuBackend);

impl savme_viewer::Rerun for FmuRerun {
    fn rerun(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
        record: &[String],
    ) -> Result<(SimResult, savme_viewer::Series), String> {
        let (result, trace) = self
            .0
            .run_traced(role, scenario, phi, theta, record)
            .map_err(|e| e.to_string())?;
        let series = savme_viewer::Series {
            names: trace.names,
            times: trace.times,
            values: trace.values,
            failure_time: trace.failure_time,
        };
        Ok((result, series))
    }
}

/// The campaign file's failure signal as the viewer shows it.
fn signal(failure: &savme_fmu::Failure) -> savme_viewer::Signal {
    match failure {
        savme_fmu::Failure::Boolean {
            variable,
            robustness,
        } => savme_viewer::Signal::Flag {
            variable: variable.clone(),
            robustness: robustness.clone(),
        },
        savme_fmu::Failure::Threshold {
            variable,
            when,
            value,
        } => savme_viewer::Signal::Threshold {
            variable: variable.clone(),
            above: matches!(when, savme_fmu::Crossing::Above),
            value: *value,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_viewer_shows_a_flags_robustness_output() {
        let flag = |robustness: Option<&str>| savme_fmu::Failure::Boolean {
            variable: "collision".into(),
            robustness: robustness.map(str::to_string),
        };
        let with = signal(&flag(Some("distance")));
        assert_eq!(with.text(), "`collision` (robustness `distance`)");
        assert_eq!(with.line(), Some(("distance", 0.0, "robustness 0")));
        let alone = signal(&flag(None));
        assert_eq!(alone.text(), "`collision`");
        assert_eq!(alone.line(), None);
    }

    #[test]
    fn every_label_savme_writes_finds_its_adapter() {
        let toy = savme_campaign::config::toy_label(20);
        for (label, name) in [
            (SENSORS, "savme-sim"),
            (IDEAL, "savme-sim"),
            (TOY, "savme-toy"),
            (toy.as_str(), "savme-toy"),
            (NULL, "savme-null"),
        ] {
            assert_eq!(
                adapter_of_label(label).map(|a| a.name()),
                Some(name),
                "{label}"
            );
        }
        for label in ["fmu:a.fmu|b.fmu", "savme-toy/sleep=xms", "savme-sim", ""] {
            assert!(simulator_of_label(label).is_none(), "{label}");
        }
    }

    #[test]
    fn the_bundled_adapter_offers_its_trial_view_the_others_none() {
        for label in [SENSORS, IDEAL] {
            // In a build without `rerun`, nothing is recorded, so no frames at all.
            assert_eq!(frames_of_label(label).is_none(), !cfg!(feature = "rerun"));
        }
        for label in [TOY, NULL, "fmu:a.fmu|b.fmu"] {
            assert!(frames_of_label(label).is_none(), "{label}");
        }
    }

    #[test]
    fn names_are_unique_and_the_fmu_adapter_reads_its_sections() {
        let mut names: Vec<&str> = ADAPTERS.iter().map(|a| a.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), ADAPTERS.len());
        let found: Vec<&str> = file_adapters(&["fmu", "campaign"])
            .iter()
            .map(|a| a.name())
            .collect();
        assert_eq!(found, ["fmu"]);
        assert!(file_adapters(&["campaign", "scenario"]).is_empty());
    }

    #[test]
    fn an_adapter_without_campaign_files_refuses_one_naming_itself_and_the_file() {
        let paper = |bins| {
            (
                savme_sim::fidelity::space(bins),
                savme_sim::fidelity::theta_hf(),
            )
        };
        let e = Toy
            .read_file(Path::new("c.toml"), &paper)
            .unwrap_err()
            .to_string();
        assert!(e.contains("c.toml") && e.contains("savme-toy"), "{e}");
    }

    #[test]
    fn a_boxed_simulator_keeps_its_behaviour_and_its_clones_are_independent() {
        let (_, theta) = savme_campaign::toy::fidelity();
        let phi = Assignment::new().with("gap", 20.0).with("ego_speed", 15.0);
        let mut direct = ToySimulator;
        let mut boxed = simulator_of_label(TOY).expect("toy");
        let mut copy = boxed.clone();
        let want = direct
            .simulate_as(Role::High, "stopped_obstacle", &phi, &theta)
            .expect("runs");
        for sim in [&mut boxed, &mut copy] {
            let got = sim
                .simulate_as(Role::High, "stopped_obstacle", &phi, &theta)
                .expect("runs");
            assert_eq!((got.failure, got.work), (want.failure, want.work));
        }
    }
}

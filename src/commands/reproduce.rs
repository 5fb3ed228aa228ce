//! `savme reproduce`: the paper's protocol on the bundled driving simulator.

use super::{config_failure, run_campaign, usage, Failure, ProtocolArgs, RunnerArgs, Target};
use savme::campaign::config::{self, Preset};
use savme::campaign::{load_protocol, Problem};
use savme::viewer::Frames;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output directory (created if missing; must not hold a campaign already).
    #[arg(long, default_value = "savme-results")]
    out: PathBuf,
    /// Continue the campaign in DIR after an interruption (even `kill -9`).
    #[arg(long, value_name = "DIR", conflicts_with = "out")]
    resume: Option<PathBuf>,
    /// A short preset: one budget, fewer iterations (860 trials, about 100 CPU-seconds).
    #[arg(long)]
    quick: bool,
    /// Perception of the system under test: camera + lidar (the paper's), or idealised
    /// (fast, blind to the sensor settings).
    #[arg(long, value_enum, default_value = "sensors")]
    perception: Perception,
    #[command(flatten)]
    protocol: ProtocolArgs,
    #[command(flatten)]
    runner: RunnerArgs,
}

#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
enum Perception {
    Sensors,
    Ideal,
}

pub fn run(a: Args) -> Result<(), Failure> {
    let overrides = a.protocol.overrides();
    let preset = Preset {
        quick: a.quick,
        ideal: a.perception == Perception::Ideal,
    };
    let (protocol, problem, target) = match a.resume {
        Some(dir) => {
            if overrides.any() || preset != Preset::default() {
                return Err(usage("protocol: `--resume`: a resumed campaign keeps its protocol (protocol.json); give only --resume, --jobs and --quiet"));
            }
            let p = load_protocol(&dir).map_err(|e| e.to_string())?;
            let problem = Problem::driving(p.fidelity_bins);
            (
                p,
                problem,
                Target {
                    out: dir,
                    resume: true,
                },
            )
        }
        None => {
            let (p, problem) = config::bundled(preset, &overrides).map_err(config_failure)?;
            (
                p,
                problem,
                Target {
                    out: a.out,
                    resume: false,
                },
            )
        }
    };
    let sim = config::bundled_simulator(&protocol).map_err(|e| e.to_string())?;
    run_campaign(
        protocol,
        problem,
        target,
        &a.runner,
        Frames::Driving(sim),
        &sim,
    )
}

//! `savme simulate`: one run of the bundled driving simulator, described or as JSON, optionally
//! recorded to the viewer.

use super::{usage, Failure};
use savme::kernel::{Assignment, Domain, Value};
use savme_sim::fidelity;
use savme_sim::scenario;
use savme_sim::sim::{DrivingSimulator, RunResult};

#[derive(clap::Args)]
pub struct Args {
    /// Scenario number (1–10) or name.
    #[arg(long)]
    scenario: String,
    /// Scenario parameters: name=value,name=value,… (see `savme scenarios`).
    #[arg(long)]
    phi: String,
    /// Fidelity: `hf`, or name=value,… overriding θ_HF (e.g. simulation_rate_hz=2).
    #[arg(long, default_value = "hf")]
    fidelity: String,
    /// Perception of the system under test: camera + lidar (the paper's), or idealised (blind
    /// to every fidelity setting but simulation_rate_hz; what `--perception ideal` campaigns
    /// run).
    #[arg(long, value_enum, default_value = "sensors")]
    perception: Perception,
    /// Print the result as JSON (schema: docs/schemas/simulate.schema.json).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    record: super::RecordArgs,
}

#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
enum Perception {
    Sensors,
    Ideal,
}

/// Runs the simulation once — with recording on when a recording is asked for (then the HF
/// run is recorded beside an LF one) — and prints it. Bad arguments and a recording that
/// cannot be made are refused before anything runs.
pub fn run(a: Args) -> Result<(), Failure> {
    let request = a.record.request();
    let record = request.check().map_err(usage)?;
    let info = scenario::find(&a.scenario).ok_or_else(|| {
        usage(format!(
            "unknown scenario `{}`: give 1–10 or a name from `savme scenarios`",
            a.scenario
        ))
    })?;
    let phi = parse_assignment(&a.phi).map_err(|e| usage(format!("--phi: {e}")))?;
    let theta = parse_fidelity(&a.fidelity).map_err(|e| usage(format!("--fidelity: {e}")))?;
    scenario::phi_space(info)
        .arms_of(&phi)
        .map_err(|e| usage(format!("--phi: scenario {} ({}): {e}", info.id, info.name)))?;
    let sim = match a.perception {
        Perception::Sensors => DrivingSimulator::default(),
        Perception::Ideal => DrivingSimulator::ideal(),
    };
    if record && a.perception == Perception::Ideal {
        return Err(usage(
            "--perception ideal has no sensor frames to record: record with the default perception (sensors)",
        ));
    }
    let r = if record {
        savme::viewer::record_run(&request, info.name, &phi, &theta).map_err(|e| e.to_string())?
    } else {
        sim.run(info.name, &phi, &theta, false)
            .map_err(|e| format!("scenario {} ({}): {e}", info.id, info.name))?
    };
    let run = Described {
        info,
        sim: &sim,
        phi: &phi,
        theta: &theta,
        result: &r,
    };
    Ok(super::print(&if a.json { run.json() } else { run.text() })?)
}

/// Parses `name=value,name=value` into an assignment. Values read as integers, then reals,
/// then booleans, else labels.
fn parse_assignment(text: &str) -> Result<Assignment, String> {
    let mut out = Assignment::new();
    for (i, item) in text.split(',').map(str::trim).enumerate() {
        if item.is_empty() {
            continue;
        }
        let (name, value) = item
            .split_once('=')
            .ok_or_else(|| format!("item {} `{item}`: expected name=value", i + 1))?;
        let (name, value) = (name.trim(), value.trim());
        if name.is_empty() {
            return Err(format!("item {} `{item}`: empty name", i + 1));
        }
        if out.get(name).is_some() {
            return Err(format!("`{name}` is given twice"));
        }
        let v = if let Ok(n) = value.parse::<i64>() {
            Value::Int(n)
        } else if let Ok(x) = value.parse::<f64>() {
            Value::Real(x)
        } else if let Ok(b) = value.parse::<bool>() {
            Value::Bool(b)
        } else {
            Value::from(value)
        };
        out.set(name, v);
    }
    Ok(out)
}

/// θ from `hf` or a list of overrides of θ_HF; continuous settings given as integers are
/// read as reals.
fn parse_fidelity(text: &str) -> Result<Assignment, String> {
    let mut theta = fidelity::theta_hf();
    if text.trim() == "hf" {
        return Ok(theta);
    }
    let space = fidelity::space(1);
    for (name, value) in parse_assignment(text.trim_start_matches("hf,"))?.iter() {
        let var = space.variable(name).ok_or_else(|| {
            let names: Vec<&str> = space.variables().iter().map(|v| &*v.name).collect();
            format!(
                "unknown fidelity setting `{name}` (known: {})",
                names.join(", ")
            )
        })?;
        let value = match (&var.domain, value) {
            (Domain::Continuous { .. }, Value::Int(n)) => Value::Real(*n as f64),
            _ => value.clone(),
        };
        theta.set(name, value);
    }
    space.arms_of(&theta).map_err(|e| e.to_string())?;
    Ok(theta)
}

/// A run to print.
struct Described<'a> {
    info: &'a scenario::ScenarioInfo,
    sim: &'a DrivingSimulator,
    phi: &'a Assignment,
    theta: &'a Assignment,
    result: &'a RunResult,
}

impl Described<'_> {
    /// `savme simulate --json` ([`savme::json::Simulation`]).
    fn json(&self) -> String {
        let r = self.result;
        let doc = savme::json::Simulation {
            format_version: savme::json::FORMAT_VERSION,
            scenario: self.info.name.to_string(),
            perception: self.sim.perception_name().to_string(),
            phi: self.phi.clone(),
            fidelity: self.theta.clone(),
            ignored_settings: self.sim.ignored_settings(),
            failure: r.failure,
            collision_time_s: r.collision_time,
            min_distance_m: r.min_distance,
            steps: r.steps,
            work: r.work,
            wall_seconds: r.wall_seconds,
        };
        serde_json::to_string(&doc).unwrap_or_default() + "\n"
    }

    /// The text: scenario, perception, fidelity, outcome, cost.
    fn text(&self) -> String {
        let (r, info) = (self.result, self.info);
        let outcome = match r.collision_time {
            Some(t) => format!("COLLISION at {t:.2} s"),
            None => format!("no collision, minimum distance {:.2} m", r.min_distance),
        };
        let perception = match self.sim.perception_name() {
            "ideal" => {
                "idealised (ground truth; ignores every fidelity setting but simulation_rate_hz)"
            }
            _ => "camera + lidar",
        };
        format!(
            "scenario {} {}: {}\nperception: {perception}\nfidelity: {}\noutcome: {outcome}\n\
             cost: {:.3} ms wall-clock, {} work units ({} steps)\n",
            info.id,
            info.name,
            self.phi,
            self.theta,
            r.wall_seconds * 1e3,
            r.work,
            r.steps
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignments_parse_by_type_and_bad_items_are_named() {
        let a = parse_assignment("ego_speed=12.5,rate=2,flag=true,level=low").unwrap();
        assert_eq!(a.get_f64("ego_speed"), Some(12.5));
        assert_eq!(
            a.to_string(),
            "ego_speed=12.5, rate=2, flag=true, level=low"
        );
        assert!(parse_assignment("ego_speed")
            .unwrap_err()
            .contains("item 1"));
        assert!(parse_assignment("a=1,a=2")
            .unwrap_err()
            .contains("`a` is given twice"));
    }

    #[test]
    fn fidelity_overrides_hf_and_unknown_settings_are_named() {
        let t = parse_fidelity("simulation_rate_hz=2").unwrap();
        assert_eq!(t.get_f64("simulation_rate_hz"), Some(2.0));
        assert_eq!(parse_fidelity("hf").unwrap(), fidelity::theta_hf());
        let e = parse_fidelity("rate=2").unwrap_err();
        assert!(e.contains("unknown fidelity setting `rate`"), "{e}");
    }
}

//! The parts of the `savme` command line that are worth testing without a process: parsing
//! `name=value` lists and the bundled simulator's `scenarios` and `simulate` commands.

use savme_kernel::{Assignment, Domain, Value};
use savme_sim::fidelity;
use savme_sim::scenario::{self, SCENARIOS};
use savme_sim::sim::DrivingSimulator;

/// Parses `name=value,name=value` into an assignment. Values read as integers, then reals,
/// then booleans, else labels.
///
/// ```
/// let a = savme::cli::parse_assignment("ego_speed=12.5,rate=2,flag=true,level=low").unwrap();
/// assert_eq!(a.get_f64("ego_speed"), Some(12.5));
/// assert_eq!(a.to_string(), "ego_speed=12.5, rate=2, flag=true, level=low");
/// assert!(savme::cli::parse_assignment("ego_speed").is_err());
/// ```
pub fn parse_assignment(text: &str) -> Result<Assignment, String> {
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
pub fn parse_fidelity(text: &str) -> Result<Assignment, String> {
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

/// `savme fidelity`: the 16 fidelity settings of Table I with their θ_HF values.
pub fn fidelity_text() -> String {
    use std::fmt::Write;
    let mut out = String::from(
        "setting                           type        values / range              θ_HF\n",
    );
    let hf = fidelity::theta_hf();
    for v in fidelity::space(10).variables() {
        let (kind, range) = match &v.domain {
            Domain::Discrete { values } => (
                "discrete",
                format!(
                    "{{{}}}",
                    values
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            Domain::Continuous { lo, hi, bins, .. } => {
                ("continuous", format!("[{lo}, {hi}] m, {bins} log bins"))
            }
        };
        let hf_value = hf.get(&v.name).map_or(String::new(), ToString::to_string);
        let _ = writeln!(out, "{:<33} {kind:<11} {range:<27} {hf_value}", v.name);
    }
    out
}

/// `savme scenarios`: the listing.
pub fn scenarios_text() -> String {
    use std::fmt::Write;
    let mut out = String::new();
    for info in &SCENARIOS {
        let phase = if info.training() {
            "meta-training"
        } else {
            "meta-testing"
        };
        let _ = writeln!(
            out,
            "{:>2}  {}  ({phase}, {} s)",
            info.id, info.name, info.duration
        );
        let _ = writeln!(out, "    {}", info.description);
        for v in scenario::phi_space(info).variables() {
            if let Domain::Continuous { lo, hi, bins, .. } = v.domain {
                let _ = writeln!(out, "    {:<18} [{lo}, {hi}] in {bins} bins", v.name);
            }
        }
    }
    out
}

/// [`simulate`], also recording the run to the rerun viewer when `record` asks for it.
pub fn simulate_recorded(
    scenario: &str,
    phi: &str,
    fidelity: &str,
    json: bool,
    record: &crate::recording::RecordRequest,
) -> Result<String, String> {
    let text = simulate(scenario, phi, fidelity, json)?;
    if record.wanted() {
        // `simulate` checked the arguments.
        let info = scenario::find(scenario).ok_or("unknown scenario")?;
        let phi = parse_assignment(phi).map_err(|e| format!("--phi: {e}"))?;
        let theta = parse_fidelity(fidelity).map_err(|e| format!("--fidelity: {e}"))?;
        crate::recording::record_run(record, info.name, &phi, &theta)
            .map_err(|e| format!("{text}{e}"))?;
    }
    Ok(text)
}

/// Runs one simulation and describes it (or gives it as JSON).
pub fn simulate(scenario: &str, phi: &str, fidelity: &str, json: bool) -> Result<String, String> {
    let info = scenario::find(scenario).ok_or_else(|| {
        format!("unknown scenario `{scenario}`: give 1–10 or a name from `savme scenarios`")
    })?;
    let phi = parse_assignment(phi).map_err(|e| format!("--phi: {e}"))?;
    let theta = parse_fidelity(fidelity).map_err(|e| format!("--fidelity: {e}"))?;
    let r = DrivingSimulator::default()
        .run(info.name, &phi, &theta, false)
        .map_err(|e| format!("scenario {} ({}): {e}", info.id, info.name))?;
    if json {
        let out = serde_json::json!({
            "scenario": info.name,
            "phi": phi,
            "fidelity": theta,
            "failure": r.failure,
            "collision_time_s": r.collision_time,
            "min_distance_m": r.min_distance,
            "steps": r.steps,
            "work": r.work,
            "wall_seconds": r.wall_seconds,
        });
        return Ok(format!("{out}\n"));
    }
    let outcome = match r.collision_time {
        Some(t) => format!("COLLISION at {t:.2} s"),
        None => format!("no collision, minimum distance {:.2} m", r.min_distance),
    };
    Ok(format!(
        "scenario {} {}: {phi}\nfidelity: {theta}\noutcome: {outcome}\n\
         cost: {:.3} ms wall-clock, {} work units ({} steps)\n",
        info.id,
        info.name,
        r.wall_seconds * 1e3,
        r.work,
        r.steps
    ))
}

//! The bundled driving simulator as a JSON-lines process, for the peer benchmark
//! (`benches/peers/run.py`): one request a line on standard input, one answer a line on
//! standard output, in order.
//!
//! ```text
//! {"scenario": "lead_vehicle_brakes", "phi": {"ego_speed": 20.0, …}}          # θ_HF
//! {"scenario": 7, "phi": {…}, "fidelity": {"simulation_rate_hz": 2.0}}       # θ_HF overridden
//! → {"scenario": "lead_vehicle_brakes", "arms": [6, 3, 0, 9, 2], "failure": false, "rho": 3.1, "min_distance_m": 3.1,
//!    "collision_time_s": null, "work": 26800000, "steps": 180, "wall_seconds": 0.09}
//! {"op": "space", "scenario": 7}                 → {"scenario": …, "id": 7, "variables": [{"name": …, "lo": …, "hi": …, "bins": 10, …}]}
//! {"op": "arms", "scenario": 7, "phi": {…}}      → {"arms": […]}  (savme's bins of φ, nothing run)
//! {"op": "scenarios"}                            → {"train": ["1", …, "8"], "test": ["9", "10"], "label": …, "rho": …}
//! ```
//!
//! Camera + lidar perception (the simulator's default, as in `savme reproduce`), or idealised
//! perception with `--ideal`. An invalid request gets `{"error": "…"}` and the process goes on.
//!
//! `cargo run --release -p savme-peers --bin peers_sim`

use std::io::{BufRead, Write};

use savme::kernel::{Assignment, Value};
use savme_sim::fidelity;
use savme_sim::scenario;
use savme_sim::sim::DrivingSimulator;
use serde_json::{json, Value as Json};

fn assignment(object: &Json, base: Assignment) -> Result<Assignment, String> {
    let mut out = base;
    let map = object
        .as_object()
        .ok_or("expected an object of name: number")?;
    for (name, value) in map {
        let x = value
            .as_f64()
            .ok_or_else(|| format!("`{name}`: expected a number"))?;
        out.set(name.as_str(), Value::Real(x));
    }
    Ok(out)
}

fn answer(sim: &DrivingSimulator, ideal: bool, line: &str) -> Result<Json, String> {
    let request: Json = serde_json::from_str(line).map_err(|e| e.to_string())?;
    if request.get("op").and_then(Json::as_str) == Some("scenarios") {
        return Ok(scenarios(ideal));
    }
    let key = match &request["scenario"] {
        Json::String(s) => s.clone(),
        Json::Number(n) => n.to_string(),
        _ => return Err("`scenario`: expected a name or a number".into()),
    };
    let info = scenario::find(&key).ok_or_else(|| format!("unknown scenario `{key}`"))?;
    let space = scenario::phi_space(info);
    let op = request.get("op").and_then(Json::as_str).unwrap_or("run");
    if op == "space" {
        let variables = serde_json::to_value(space.variables()).map_err(|e| e.to_string())?;
        return Ok(json!({ "scenario": info.name, "id": info.id, "variables": variables }));
    }
    let phi = assignment(&request["phi"], Assignment::new())?;
    let arms = space.arms_of(&phi).map_err(|e| format!("phi: {e}"))?;
    match op {
        "arms" => return Ok(json!({ "scenario": info.name, "arms": arms })),
        "run" => {}
        other => return Err(format!("unknown op `{other}` (run, space or arms)")),
    }
    let theta = match request.get("fidelity") {
        None | Some(Json::Null) => fidelity::theta_hf(),
        Some(over) => assignment(over, fidelity::theta_hf())?,
    };
    let r = sim
        .run(info.name, &phi, &theta, false)
        .map_err(|e| e.to_string())?;
    Ok(json!({
        "scenario": info.name,
        "arms": arms,
        "failure": r.failure,
        // The robustness the peers get: −1 on a collision (the simulator reports 0 there), else
        // the minimum distance — ρ < 0 exactly on a failure.
        "rho": if r.failure { -1.0 } else { r.min_distance },
        "min_distance_m": r.min_distance,
        "collision_time_s": r.collision_time,
        "work": r.work,
        "steps": r.steps,
        "wall_seconds": r.wall_seconds,
    }))
}

/// The meta-training and meta-testing scenarios (their numbers, as `savme reproduce
/// --train-scenarios` takes them) and how ρ is made.
fn scenarios(ideal: bool) -> Json {
    let ids = |train: bool| -> Vec<String> {
        (scenario::SCENARIOS.iter())
            .filter(|s| s.training() == train)
            .map(|s| s.id.to_string())
            .collect()
    };
    let label = if ideal {
        savme::compose::IDEAL
    } else {
        savme::compose::SENSORS
    };
    json!({
        "train": ids(true),
        "test": ids(false),
        "label": label,
        "rho": "−1 on a collision, else the run's minimum distance (m)",
    })
}

fn main() -> std::io::Result<()> {
    let ideal = std::env::args().any(|a| a == "--ideal");
    let sim = if ideal {
        DrivingSimulator::ideal()
    } else {
        DrivingSimulator::default()
    };
    let stdin = std::io::stdin();
    let mut out = std::io::stdout().lock();
    for line in stdin.lock().lines() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        let reply = answer(&sim, ideal, &line).unwrap_or_else(|e| json!({ "error": e }));
        writeln!(out, "{reply}")?;
        out.flush()?;
    }
    Ok(())
}

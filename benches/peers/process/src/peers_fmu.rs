//! An FMU campaign file's HF simulator as a JSON-lines process, for the peer benchmark
//! (`benches/peers/run.py --campaign FILE`): the same requests and answers as `peers_sim`
//! (the bundled simulator), on the FMU the file names, at its θ_HF, with its cost counter and
//! its φ boxes — read by savme's own campaign-file loading (`compose::campaign_file`, the FMU
//! adapter), so that the peers run exactly what a `savme run --config FILE` campaign runs.
//!
//! ```text
//! peers_fmu examples/fmu/braking/campaign.toml --rho-output distance
//! {"op": "scenarios"}                          → {"train": ["dry_road", "wet_road"], "test": ["icy_road"], "label": "fmu:…", "rho": "…"}
//! {"op": "space", "scenario": "dry_road"}      → {"scenario": "dry_road", "id": 1, "variables": [{"name": "speed0", "type": "continuous", "lo": 8.0, "hi": 25.0, "bins": 10, "scale": "linear"}, …]}
//! {"op": "arms", "scenario": "dry_road", "phi": {"speed0": 20.0, "gap": 30.0}}   → {"scenario": …, "arms": [7, 4]}
//! {"scenario": "dry_road", "phi": {"speed0": 20.0, "gap": 30.0}}                  # an HF run
//! → {"scenario": "dry_road", "arms": [7, 4], "failure": true, "rho": -1.0, "robustness": null,
//!    "rho_output_min": -0.12, "work": 231, "wall_seconds": 0.0004}
//! ```
//!
//! **Robustness ρ for the peers** (VerifAI counts ρ < 0 as a counterexample): −1 on a failure;
//! on a pass, the run's own robustness when the campaign's `[failure]` is a threshold (its
//! smallest margin, > 0 on a pass), else — a Boolean failure signal, as the braking example's
//! `collision` — the smallest value of the output `--rho-output NAME` over the run's
//! communication points (for the braking FMU: `distance`, the clearance to the obstacle in
//! metres), clamped at 0. Either way ρ < 0 exactly on a failure. Without `--rho-output` a
//! Boolean failure signal is refused at start, naming the flag.
//!
//! A bad request gets `{"error": "…"}` naming the scenario, variable or value at fault, and the
//! process goes on; a bad campaign file or flag ends it at start with the message on standard
//! error (exit status 2).
//!
//! `cargo run --release -p savme-peers --bin peers_fmu -- examples/fmu/braking/campaign.toml --rho-output distance`

use savme::campaign::config::Overrides;
use savme::compose;
use savme::kernel::{Assignment, Role, Simulator, Space, Value};
use savme_fmu::campaign_file::FmuCampaignFile;
use savme_fmu::simulator::{recordable, Failure};
use savme_fmu::{FmuBackend, FmuDescription};
use serde_json::{json, Value as Json};
use std::collections::BTreeMap;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// What goes wrong, at start or in a request.
#[derive(Debug, thiserror::Error)]
enum PeersError {
    #[error("usage: peers_fmu CAMPAIGN.toml [--rho-output OUTPUT]")]
    Usage,
    #[error("{0}")]
    Campaign(String),
    #[error("{file}: [failure] is a Boolean signal and gives no robustness: name one in the file (`robustness = \"OUTPUT\"` under [failure]) or start peers_fmu with --rho-output OUTPUT (an output whose smallest value measures how close a run came, e.g. distance)")]
    NoRobustness { file: String },
    #[error("--rho-output `{name}`: {message}")]
    RhoOutput { name: String, message: String },
    #[error("not JSON: {0}")]
    Json(String),
    #[error("`scenario`: expected a scenario name")]
    ScenarioKey,
    #[error("unknown scenario `{name}` (the campaign's: {known})")]
    UnknownScenario { name: String, known: String },
    #[error("`phi` of {scenario}: {message}")]
    Phi { scenario: String, message: String },
    #[error("unknown op `{0}` (run, space, arms or scenarios)")]
    Op(String),
    #[error("the HF run of {scenario}: {message}")]
    Run { scenario: String, message: String },
}

/// Where ρ comes from on a pass.
#[derive(Debug, Clone, PartialEq)]
enum Rho {
    /// The run's robustness (a threshold failure signal's smallest margin).
    Margin,
    /// The smallest value of this output over the run, clamped at 0.
    MinOf(String),
}

/// The campaign file's HF simulator, its scenarios and θ_HF.
struct Bench {
    label: String,
    spaces: BTreeMap<String, Space>,
    train: Vec<String>,
    test: Vec<String>,
    theta_hf: Assignment,
    backend: FmuBackend,
    rho: Rho,
}

/// Reads the campaign file (savme's own loading: the adapter, the protocol with its
/// `[campaign]` section) and builds its FMU simulator, in this process — or, when the file asks
/// for isolation, in `savme fmu-worker` processes of the `savme` binary next to this example's
/// directory (target/release/savme).
fn open(config: &Path, rho_output: Option<&str>) -> Result<Bench, PeersError> {
    let c = compose::campaign_file(config, &Overrides::default())
        .map_err(|e| PeersError::Campaign(e.to_string()))?;
    let (protocol, problem) = (c.protocol, c.problem);
    let file = c
        .file
        .into_any()
        .downcast::<FmuCampaignFile>()
        .map_err(|_| PeersError::Campaign(format!("{}: names no FMU ([fmu])", config.display())))?;
    let rho = rho_source(&file, rho_output)?;
    let worker = file.isolate.then(worker_command).transpose()?;
    let backend = FmuBackend::new(&file.init, worker, file.timeout)
        .map_err(|e| PeersError::Campaign(format!("{}: {e}", config.display())))?;
    Ok(Bench {
        label: file.label.clone(),
        spaces: problem.scenarios,
        train: protocol.train_scenarios,
        test: protocol.test_scenarios,
        theta_hf: problem.theta_hf,
        backend,
        rho,
    })
}

/// ρ's source: `--rho-output` (an output of the HF FMU), else the `[failure] robustness`
/// output of a Boolean signal (the same as `--rho-output` naming it), else the threshold's
/// margin; a Boolean failure signal without either is refused.
fn rho_source(file: &FmuCampaignFile, rho_output: Option<&str>) -> Result<Rho, PeersError> {
    match (rho_output, &file.init.spec.failure) {
        (Some(name), _) => {
            let bad = |message: String| PeersError::RhoOutput {
                name: name.to_string(),
                message,
            };
            let hf = FmuDescription::read(&file.init.hf).map_err(|e| bad(e.to_string()))?;
            recordable(&hf, name).map_err(|e| bad(e.to_string()))?;
            Ok(Rho::MinOf(name.to_string()))
        }
        (None, Failure::Threshold { .. }) => Ok(Rho::Margin),
        (
            None,
            Failure::Boolean {
                robustness: Some(name),
                ..
            },
        ) => Ok(Rho::MinOf(name.clone())),
        (
            None,
            Failure::Boolean {
                robustness: None, ..
            },
        ) => Err(PeersError::NoRobustness {
            file: file.common.path.display().to_string(),
        }),
    }
}

/// `savme fmu-worker` of the `savme` binary built next to this example.
fn worker_command() -> Result<Vec<String>, PeersError> {
    let exe = std::env::current_exe().map_err(|e| PeersError::Campaign(e.to_string()))?;
    let savme = exe
        .parent()
        .and_then(Path::parent)
        .map(|d| d.join("savme"))
        .filter(|p| p.exists())
        .ok_or_else(|| {
            PeersError::Campaign(
                "the campaign isolates its runs ([fmu] isolate): build the `savme` binary next to this example (cargo build --release --bin savme)".into(),
            )
        })?;
    Ok(vec![savme.display().to_string(), "fmu-worker".into()])
}

/// φ of a request, as numbers.
fn phi_of(scenario: &str, object: &Json) -> Result<Assignment, PeersError> {
    let bad = |message: String| PeersError::Phi {
        scenario: scenario.to_string(),
        message,
    };
    let map = object
        .as_object()
        .ok_or_else(|| bad("expected an object of name: number".into()))?;
    let mut out = Assignment::new();
    for (name, value) in map {
        let x = value
            .as_f64()
            .ok_or_else(|| bad(format!("`{name}`: expected a number, got {value}")))?;
        out.set(name.as_str(), Value::Real(x));
    }
    Ok(out)
}

impl Bench {
    /// The answer to one request line.
    fn answer(&mut self, line: &str) -> Result<Json, PeersError> {
        let request: Json =
            serde_json::from_str(line).map_err(|e| PeersError::Json(e.to_string()))?;
        let op = request.get("op").and_then(Json::as_str).unwrap_or("run");
        if op == "scenarios" {
            return Ok(self.scenarios());
        }
        let name = request["scenario"]
            .as_str()
            .ok_or(PeersError::ScenarioKey)?
            .to_string();
        let (id, space) = self.space(&name)?;
        if op == "space" {
            return Ok(json!({ "scenario": name, "id": id, "variables": space.variables() }));
        }
        let phi = phi_of(&name, &request["phi"])?;
        let arms = space.arms_of(&phi).map_err(|e| PeersError::Phi {
            scenario: name.clone(),
            message: e.to_string(),
        })?;
        match op {
            "arms" => Ok(json!({ "scenario": name, "arms": arms })),
            "run" => self.run(&name, &phi, arms),
            other => Err(PeersError::Op(other.to_string())),
        }
    }

    fn scenarios(&self) -> Json {
        let rho = match &self.rho {
            Rho::Margin => "−1 on a failure, else the run's robustness (the [failure] threshold's smallest margin)".to_string(),
            Rho::MinOf(name) => format!("−1 on a failure, else the smallest `{name}` over the run (clamped at 0)"),
        };
        json!({ "train": self.train, "test": self.test, "label": self.label, "rho": rho })
    }

    /// The scenario's number (1-based, in name order) and φ space.
    fn space(&self, name: &str) -> Result<(usize, Space), PeersError> {
        let found = self
            .spaces
            .iter()
            .enumerate()
            .find(|(_, (n, _))| *n == name);
        let Some((k, (_, space))) = found else {
            let known = self.spaces.keys().cloned().collect::<Vec<_>>().join(", ");
            return Err(PeersError::UnknownScenario {
                name: name.to_string(),
                known,
            });
        };
        Ok((k + 1, space.clone()))
    }

    /// An HF run (θ_HF), with ρ.
    fn run(&mut self, name: &str, phi: &Assignment, arms: Vec<usize>) -> Result<Json, PeersError> {
        let record: Vec<String> = match &self.rho {
            Rho::MinOf(output) => vec![output.clone()],
            Rho::Margin => Vec::new(),
        };
        let bad = |message: String| PeersError::Run {
            scenario: name.to_string(),
            message,
        };
        let (r, trace) = if record.is_empty() {
            let r = (self.backend)
                .simulate_as(Role::High, name, phi, &self.theta_hf)
                .map_err(|e| bad(e.to_string()))?;
            (r, None)
        } else {
            let (r, t) = (self.backend)
                .run_traced(Role::High, name, phi, &self.theta_hf, &record)
                .map_err(|e| bad(e.to_string()))?;
            (r, Some(t))
        };
        let output_min = trace.and_then(|t| {
            let series = t.series(&record[0])?;
            series
                .iter()
                .copied()
                .filter(|x| !x.is_nan())
                .reduce(f64::min)
        });
        let pass_rho = match &self.rho {
            Rho::Margin => r.robustness.map(|m| m.max(0.0)),
            Rho::MinOf(_) => output_min.map(|m| m.max(0.0)),
        };
        let rho = if r.failure { Some(-1.0) } else { pass_rho };
        let rho = rho.ok_or_else(|| bad("the run gave no robustness to make ρ of".into()))?;
        Ok(json!({
            "scenario": name,
            "arms": arms,
            "failure": r.failure,
            "rho": rho,
            "robustness": r.robustness,
            "rho_output_min": output_min,
            "work": r.work,
            "wall_seconds": r.wall_seconds,
        }))
    }
}

/// Answers every request line of `input` on `output`, in order (an error as `{"error": …}`).
fn serve(bench: &mut Bench, input: impl BufRead, mut output: impl Write) -> std::io::Result<()> {
    for line in input.lines() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        let reply = bench
            .answer(&line)
            .unwrap_or_else(|e| json!({ "error": e.to_string() }));
        writeln!(output, "{reply}")?;
        output.flush()?;
    }
    Ok(())
}

/// `CAMPAIGN.toml [--rho-output OUTPUT]`.
fn parse_args(args: &[String]) -> Result<(PathBuf, Option<String>), PeersError> {
    match args {
        [config] => Ok((PathBuf::from(config), None)),
        [config, flag, name] if flag == "--rho-output" => {
            Ok((PathBuf::from(config), Some(name.clone())))
        }
        [flag, name, config] if flag == "--rho-output" => {
            Ok((PathBuf::from(config), Some(name.clone())))
        }
        _ => Err(PeersError::Usage),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let bench = parse_args(&args).and_then(|(config, rho)| open(&config, rho.as_deref()));
    let mut bench = match bench {
        Ok(b) => b,
        Err(e) => {
            eprintln!("peers_fmu: {e}");
            std::process::exit(2);
        }
    };
    let stdin = std::io::stdin();
    if let Err(e) = serve(&mut bench, stdin.lock(), std::io::stdout().lock()) {
        eprintln!("peers_fmu: {e}");
        std::process::exit(1);
    }
}

#[cfg(test)]
mod tests {
    //! The braking example, compiled with the system C compiler (`$CC`, else `cc`) and packed
    //! into a scratch directory with its campaign file.
    use super::*;

    /// A scratch copy of examples/fmu/braking: braking.fmu and campaign.toml (with `failure`
    /// as its `[failure]` section).
    fn braking(name: &str, failure: &str) -> PathBuf {
        let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../examples/fmu/braking");
        let dir =
            std::env::temp_dir().join(format!("savme-peers-fmu-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let lib = dir.join("braking.so");
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let status = std::process::Command::new(&cc)
            .args(["-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-o"])
            .arg(&lib)
            .arg(example.join("braking.c"))
            .arg("-lm")
            .status()
            .unwrap_or_else(|e| panic!("the C compiler `{cc}` (set CC): {e}"));
        assert!(status.success(), "compiling braking.c");
        let xml = std::fs::read_to_string(example.join("modelDescription.xml")).unwrap();
        let friction = std::fs::read(example.join("resources/friction.txt")).unwrap();
        let resources: &[(&str, &[u8])] = &[("resources/friction.txt", &friction)];
        savme_fmi_export::pack_with(&xml, "braking", &lib, resources, &dir.join("braking.fmu"))
            .unwrap();
        let toml = std::fs::read_to_string(example.join("campaign.toml")).unwrap();
        // The example names a robustness beside its flag; `failure` replaces both.
        let toml = toml
            .replace("robustness = \"distance\"\n", "")
            .replace("boolean = \"collision\"", failure);
        std::fs::write(dir.join("campaign.toml"), toml).unwrap();
        dir
    }

    fn ask(bench: &mut Bench, request: Json) -> Json {
        let mut out = Vec::new();
        serve(bench, format!("{request}\n").as_bytes(), &mut out).unwrap();
        serde_json::from_slice(&out).unwrap()
    }

    /// Fast and close on a dry road: a collision, ρ = −1 (the answer returned).
    fn collides(b: &mut Bench) -> Json {
        let hit = ask(
            b,
            json!({"scenario": "dry_road", "phi": {"speed0": 25.0, "gap": 10.0}}),
        );
        assert_eq!(
            (hit["failure"].as_bool(), hit["rho"].as_f64()),
            (Some(true), Some(-1.0)),
            "{hit}"
        );
        hit
    }

    fn error_of(bench: &mut Bench, request: Json) -> String {
        let a = ask(bench, request);
        a["error"]
            .as_str()
            .unwrap_or_else(|| panic!("no error: {a}"))
            .to_string()
    }

    #[test]
    fn the_braking_campaign_answers_like_peers_sim_and_names_bad_input() {
        let dir = braking("answers", "boolean = \"collision\"");
        let config = dir.join("campaign.toml");
        let e = open(&config, None).err().unwrap().to_string();
        assert!(
            e.contains("--rho-output") && e.contains("campaign.toml"),
            "{e}"
        );
        let e = open(&config, Some("gap")).err().unwrap().to_string();
        assert!(e.contains("--rho-output `gap`"), "{e}");
        let mut b = open(&config, Some("distance")).unwrap();
        let s = ask(&mut b, json!({"op": "scenarios"}));
        assert_eq!(s["train"], json!(["dry_road", "wet_road"]));
        assert_eq!(s["test"], json!(["icy_road"]));
        let sp = ask(&mut b, json!({"op": "space", "scenario": "wet_road"}));
        assert_eq!(
            (
                sp["variables"][1]["name"].as_str(),
                sp["variables"][1]["hi"].as_f64()
            ),
            (Some("gap"), Some(80.0))
        );
        let a = ask(
            &mut b,
            json!({"op": "arms", "scenario": "dry_road", "phi": {"speed0": 25.0, "gap": 10.0}}),
        );
        assert_eq!(a["arms"], json!([9, 0]));
        // Fast and close: a collision, ρ = −1; slow and far: a pass, ρ = the clearance left.
        let hit = collides(&mut b);
        assert!(hit["rho_output_min"].as_f64().unwrap() <= 0.0, "{hit}");
        let pass = ask(
            &mut b,
            json!({"scenario": "dry_road", "phi": {"speed0": 8.0, "gap": 60.0}}),
        );
        assert_eq!(pass["failure"].as_bool(), Some(false), "{pass}");
        let rho = pass["rho"].as_f64().unwrap();
        assert!(rho > 0.0 && rho < 60.0, "{pass}");
        // θ_HF = a 0.01 s step over 8 s: a pass takes 800 Euler steps, a collision fewer.
        assert_eq!(pass["work"].as_u64(), Some(800), "{pass}");
        assert!(hit["work"].as_u64().unwrap() < 800, "{hit}");
        for (request, named) in [
            (
                json!({"scenario": "snowy_road", "phi": {}}),
                "unknown scenario `snowy_road` (the campaign's: dry_road, icy_road, wet_road)",
            ),
            (
                json!({"scenario": "dry_road", "phi": {"speed0": 20.0}}),
                "gap",
            ),
            (
                json!({"scenario": "dry_road", "phi": {"speed0": 30.0, "gap": 20.0}}),
                "speed0",
            ),
            (
                json!({"scenario": "dry_road", "phi": {"speed0": 20.0, "gap": 20.0, "mu": 1.0}}),
                "mu",
            ),
            (
                json!({"scenario": "dry_road", "phi": {"speed0": "fast", "gap": 20.0}}),
                "`speed0`: expected a number",
            ),
            (
                json!({"op": "teleport", "scenario": "dry_road", "phi": {"speed0": 20.0, "gap": 20.0}}),
                "unknown op `teleport`",
            ),
            (json!({"phi": {}}), "`scenario`"),
        ] {
            let e = error_of(&mut b, request.clone());
            assert!(e.contains(named), "{request} → {e}");
        }
        let mut out = Vec::new();
        serve(
            &mut b,
            "{not json\n\n{\"op\": \"scenarios\"}\n".as_bytes(),
            &mut out,
        )
        .unwrap();
        let lines: Vec<&str> = std::str::from_utf8(&out).unwrap().lines().collect();
        assert!(
            lines.len() == 2 && lines[0].contains("not JSON") && lines[1].contains("train"),
            "{lines:?}"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_threshold_failure_gives_its_margin_as_rho() {
        let dir = braking("threshold", "threshold = \"distance\"\nbelow = 0.0");
        let mut b = open(&dir.join("campaign.toml"), None).unwrap();
        let pass = ask(
            &mut b,
            json!({"scenario": "dry_road", "phi": {"speed0": 8.0, "gap": 60.0}}),
        );
        assert_eq!(pass["failure"].as_bool(), Some(false), "{pass}");
        assert_eq!(pass["rho"].as_f64(), pass["robustness"].as_f64(), "{pass}");
        assert!(pass["rho"].as_f64().unwrap() > 0.0, "{pass}");
        collides(&mut b);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_boolean_failures_robustness_output_is_rho_without_rho_output() {
        let dir = braking(
            "robustness",
            "boolean = \"collision\"\nrobustness = \"distance\"",
        );
        let mut b = open(&dir.join("campaign.toml"), None).unwrap();
        let pass = ask(
            &mut b,
            json!({"scenario": "dry_road", "phi": {"speed0": 8.0, "gap": 60.0}}),
        );
        assert_eq!(pass["failure"].as_bool(), Some(false), "{pass}");
        assert!(pass["rho"].as_f64().is_some_and(|r| r > 0.0), "{pass}");
        let hit = ask(
            &mut b,
            json!({"scenario": "dry_road", "phi": {"speed0": 25.0, "gap": 10.0}}),
        );
        assert_eq!(hit["failure"].as_bool(), Some(true), "{hit}");
        assert!(hit["rho"].as_f64().is_some_and(|r| r <= 0.0), "{hit}");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn arguments_are_checked() {
        let args = |a: &[&str]| parse_args(&a.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        assert_eq!(args(&["c.toml"]).unwrap(), (PathBuf::from("c.toml"), None));
        assert_eq!(
            args(&["c.toml", "--rho-output", "d"]).unwrap().1.as_deref(),
            Some("d")
        );
        assert!(matches!(args(&[]), Err(PeersError::Usage)));
        assert!(matches!(
            args(&["c.toml", "--rho", "d"]),
            Err(PeersError::Usage)
        ));
        let e = open(Path::new("/nonexistent/c.toml"), None)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("/nonexistent/c.toml"), "{e}");
    }
}

//! The bundled driving simulator as an FMI 2.0 and FMI 3.0 co-simulation FMU (one library
//! exporting both C APIs; [`model_description`] and [`model_description3`]).
//!
//! Parameters: `scenario` (1–10), `perception` (0 camera + lidar, 1 idealised), the scenario
//! parameters φ of all ten scenarios (each scenario reads its own), and the 16 fidelity
//! settings of Table II (`camera_bloom_level` as an Integer: 0 = high, 1 = low — a label's
//! position in the setting's list of values, savme's rule for labels). Outputs: `collision`,
//! `min_distance`, `collision_time` (−1 without a collision), `work` and `steps`.
//!
//! The FMU steps the very same [`savme_sim::sim::Stepper`] that `DrivingSimulator` runs
//! in-process, so the two give identical outcomes. `savme fmu pack` zips
//! [`model_description`] and the shared library built from this crate into an `.fmu`.
//!
//! ```
//! let xml = savme_sim_fmu::model_description();
//! // Every fidelity setting of the paper's Table II is a parameter of the FMU.
//! for setting in savme_sim::fidelity::space(10).variables() {
//!     assert!(xml.contains(&format!(r#"name="{}""#, setting.name)), "{}", setting.name);
//! }
//! assert!(xml.contains(r#"name="collision""#));
//! ```

use savme_fmi_export::{Model, Scalar, Variable};
use savme_kernel::{Assignment, Domain, Value};
use savme_sim::fidelity;
use savme_sim::scenario::{find, phi_space, SCENARIOS};
use savme_sim::sim::{DrivingSimulator, Perceiver, Stepper};
use std::sync::OnceLock;

/// The model: a run in progress.
#[derive(Debug, Clone)]
pub struct DrivingFmu {
    run: Stepper<Perceiver>,
}

/// Indices of the fixed variables.
mod vr {
    pub const SCENARIO: usize = 0;
    pub const PERCEPTION: usize = 1;
}

/// The output variables, after the parameters.
const OUTPUTS: [&str; 5] = [
    "collision",
    "min_distance",
    "collision_time",
    "work",
    "steps",
];

fn phi_names() -> &'static [(String, f64, f64, f64)] {
    // (name, union lo, union hi, start = middle of the first scenario's range)
    static NAMES: OnceLock<Vec<(String, f64, f64, f64)>> = OnceLock::new();
    NAMES.get_or_init(|| {
        let mut out: Vec<(String, f64, f64, f64)> = Vec::new();
        for info in &SCENARIOS {
            for v in phi_space(info).variables() {
                if let Domain::Continuous { lo, hi, .. } = v.domain {
                    match out.iter_mut().find(|(n, ..)| **n == *v.name) {
                        Some(e) => {
                            e.1 = e.1.min(lo);
                            e.2 = e.2.max(hi);
                        }
                        None => out.push((v.name.to_string(), lo, hi, 0.5 * (lo + hi))),
                    }
                }
            }
        }
        out
    })
}

/// The model's variables, in value-reference order: the fixed parameters, φ, the fidelity
/// settings, then the outputs.
fn variables() -> Vec<Variable> {
    let mut v = fixed_parameters();
    v.extend(phi_parameters());
    v.extend(fidelity_parameters());
    v.extend(outputs());
    v
}

/// `scenario` and `perception` (value references [`vr::SCENARIO`] and [`vr::PERCEPTION`]).
fn fixed_parameters() -> Vec<Variable> {
    vec![
        Variable::parameter(
            "scenario",
            Scalar::Integer(7),
            "scenario number, 1-10 (see `savme scenarios`)",
        )
        .range(1.0, 10.0),
        Variable::parameter(
            "perception",
            Scalar::Integer(0),
            "0 = camera + lidar, 1 = idealised (ground truth + noise)",
        )
        .range(0.0, 1.0),
    ]
}

/// The scenario parameters φ of all scenarios, over the union of their ranges.
fn phi_parameters() -> Vec<Variable> {
    phi_names()
        .iter()
        .map(|(name, lo, hi, start)| {
            Variable::parameter(
                name,
                Scalar::Real(*start),
                "scenario parameter (each scenario checks its own range)",
            )
            .range(*lo, *hi)
        })
        .collect()
}

/// The fidelity settings of Table II, starting at θ_HF.
fn fidelity_parameters() -> Vec<Variable> {
    let hf = fidelity::theta_hf();
    let space = fidelity::space(10);
    space
        .variables()
        .iter()
        .map(|var| fidelity_parameter(var, &hf))
        .collect()
}

/// One fidelity setting, starting at its θ_HF value: an Integer has the range of its values,
/// a Real its interval (in metres).
fn fidelity_parameter(var: &savme_kernel::Variable, hf: &Assignment) -> Variable {
    let name: &str = &var.name;
    let start = hf.get(name).cloned().unwrap_or(Value::Bool(false));
    let scalar = fidelity_scalar(&var.domain, &start);
    let variable = Variable::parameter(name, scalar, "fidelity setting (Table II)");
    match &var.domain {
        Domain::Continuous { lo, hi, .. } => variable.range(*lo, *hi).unit("m"),
        Domain::Discrete { values } => {
            if let Scalar::Integer(_) = scalar {
                let (lo, hi) = discrete_range(values);
                variable.range(lo, hi)
            } else {
                variable
            }
        }
    }
}

/// A setting's value as an FMI scalar: a Boolean, a label as its position in the setting's
/// list of values, an Integer, or a Real.
fn fidelity_scalar(domain: &Domain, start: &Value) -> Scalar {
    match (domain, start) {
        (_, Value::Bool(b)) => Scalar::Boolean(*b),
        (Domain::Discrete { values }, Value::Label(l)) => Scalar::Integer(
            values
                .iter()
                .position(|x| x.as_label() == Some(&**l))
                .unwrap_or(0) as i32,
        ),
        (_, Value::Int(i)) => Scalar::Integer(*i as i32),
        (_, other) => Scalar::Real(other.as_f64().unwrap_or(0.0)),
    }
}

/// The range of an Integer setting: its smallest and largest number, or the positions of its
/// labels.
fn discrete_range(values: &[Value]) -> (f64, f64) {
    let nums: Vec<f64> = values.iter().filter_map(Value::as_f64).collect();
    if nums.is_empty() {
        (0.0, (values.len() - 1) as f64)
    } else {
        (
            nums.iter().copied().fold(f64::INFINITY, f64::min),
            nums.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }
}

/// The outputs, in the order of [`OUTPUTS`].
fn outputs() -> Vec<Variable> {
    vec![
        Variable::output("collision", Scalar::Boolean(false), "the ego collided"),
        Variable::output(
            "min_distance",
            Scalar::Real(1e6),
            "smallest distance between the two bodies so far (1e6 before the first check)",
        )
        .unit("m"),
        Variable::output(
            "collision_time",
            Scalar::Real(-1.0),
            "time of the collision, -1 without one",
        )
        .unit("s"),
        Variable::output(
            "work",
            Scalar::Real(0.0),
            "deterministic work units so far (steps, checks, pixels, rays)",
        ),
        Variable::output("steps", Scalar::Integer(0), "simulation steps taken"),
    ]
}

/// Value references of [`OUTPUTS`], looked up once.
fn output_refs() -> &'static [usize; 5] {
    static REFS: OnceLock<[usize; 5]> = OnceLock::new();
    REFS.get_or_init(|| {
        OUTPUTS.map(|name| {
            DrivingFmu::variables()
                .iter()
                .position(|v| v.name == name)
                .unwrap_or(usize::MAX)
        })
    })
}

impl DrivingFmu {
    fn write_outputs(&self, values: &mut [Scalar]) {
        let refs = output_refs();
        let set = |values: &mut [Scalar], k: usize, s: Scalar| {
            if let Some(slot) = values.get_mut(refs[k]) {
                *slot = s;
            }
        };
        set(values, 0, Scalar::Boolean(self.run.failure()));
        set(values, 1, Scalar::Real(self.run.min_distance().min(1e6)));
        set(
            values,
            2,
            Scalar::Real(self.run.collision_time().unwrap_or(-1.0)),
        );
        set(values, 3, Scalar::Real(self.run.work() as f64));
        set(
            values,
            4,
            Scalar::Integer(i32::try_from(self.run.steps_taken()).unwrap_or(i32::MAX)),
        );
    }
}

/// The φ and θ assignments a parameter vector stands for (in the kernel's variable order, so
/// that the noise seed — a hash of φ — is the in-process one).
pub fn assignments(
    values: &[Scalar],
) -> Result<(&'static str, Assignment, Assignment, bool), String> {
    let vars = DrivingFmu::variables();
    let get = |name: &str| -> Result<Scalar, String> {
        vars.iter()
            .position(|v| v.name == name)
            .and_then(|i| values.get(i).copied())
            .ok_or_else(|| format!("no variable `{name}`"))
    };
    let scenario = match values.get(vr::SCENARIO) {
        Some(Scalar::Integer(i)) => *i,
        _ => return Err("`scenario` is not set".into()),
    };
    let info = find(&scenario.to_string())
        .ok_or_else(|| format!("`scenario` = {scenario}: expected 1-10"))?;
    let ideal = match values.get(vr::PERCEPTION) {
        Some(Scalar::Integer(0)) => false,
        Some(Scalar::Integer(1)) => true,
        other => return Err(format!("`perception` = {other:?}: expected 0 or 1")),
    };
    let mut phi = Assignment::new();
    for v in phi_space(info).variables() {
        phi.set(&v.name, get(&v.name)?.as_f64());
    }
    let mut theta = Assignment::new();
    for v in fidelity::space(10).variables() {
        let s = get(&v.name)?;
        let value = match (&v.domain, s) {
            (_, Scalar::Boolean(b)) => Value::Bool(b),
            (Domain::Discrete { values }, Scalar::Integer(i)) => {
                if values.iter().all(|x| x.as_label().is_some()) {
                    values
                        .get(usize::try_from(i).unwrap_or(usize::MAX))
                        .cloned()
                        .ok_or_else(|| {
                            format!("`{}` = {i}: expected 0..{}", v.name, values.len() - 1)
                        })?
                } else {
                    Value::Int(i64::from(i))
                }
            }
            (_, other) => Value::Real(other.as_f64()),
        };
        theta.set(&v.name, value);
    }
    Ok((info.name, phi, theta, ideal))
}

impl Model for DrivingFmu {
    const MODEL_NAME: &'static str = "savme_sim";
    const MODEL_IDENTIFIER: &'static str = "savme_sim_fmu";
    const GUID: &'static str = "{5a1e5100-7e57-4d0c-9a1b-0000000000a1}";
    const DESCRIPTION: &'static str =
        "savme's bundled driving simulator: ten AV pre-crash scenarios, camera + lidar with the 16 fidelity settings of SAVME's Table II";
    const DEFAULT_EXPERIMENT: (f64, f64) = (12.0, 0.1);

    fn variables() -> &'static [Variable] {
        static VARS: OnceLock<Vec<Variable>> = OnceLock::new();
        VARS.get_or_init(variables)
    }

    fn initialize(values: &mut [Scalar], _start: f64) -> Result<Self, String> {
        let (scenario, phi, theta, ideal) = assignments(values)?;
        let sim = if ideal {
            DrivingSimulator::ideal()
        } else {
            DrivingSimulator::default()
        };
        let run = sim
            .stepper(scenario, &phi, &theta, false)
            .map_err(|e| format!("scenario {scenario}: {e}"))?;
        let m = DrivingFmu { run };
        m.write_outputs(values);
        Ok(m)
    }

    fn do_step(&mut self, values: &mut [Scalar], time: f64, step: f64) -> Result<(), String> {
        let end = time + step;
        // Every simulation step that starts before the end of the communication step.
        while !self.run.finished() && self.run.time() < end - 1e-9 {
            self.run.step();
        }
        self.write_outputs(values);
        Ok(())
    }
}

// The library exports both C APIs; the model description packed with it picks one.
savme_fmi_export::export_fmi2!(DrivingFmu);
savme_fmi_export::export_fmi3!(DrivingFmu);

/// The FMU's `modelDescription.xml` (FMI 2.0).
pub fn model_description() -> String {
    savme_fmi_export::model_description::<DrivingFmu>()
}

/// The FMU's FMI 3.0 `modelDescription.xml` (the same library: it exports the FMI 3.0 API
/// too).
pub fn model_description3() -> String {
    savme_fmi_export::model_description3::<DrivingFmu>()
}

/// The model identifier (the library's file stem inside the `.fmu`).
pub const MODEL_IDENTIFIER: &str = <DrivingFmu as Model>::MODEL_IDENTIFIER;

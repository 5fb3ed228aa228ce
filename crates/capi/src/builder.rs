//! A kernel built variable by variable, for the common case (no JSON to write): fidelity
//! settings with their θ_HF values, scenarios with their parameters φ, a seed and a budget.
//! The method's settings are savme's tuned ones (θ_LF* from evidence, the elite search, an
//! adaptive deployment, scenarios by cost rate — `savme example-config`'s and Python's
//! `Kernel`'s, one [`Preset`]) unless `savme_builder_method` picks the paper's;
//! `savme_builder_estimator` overrides θ_LF*'s choice alone. For the rest, write the JSON
//! configuration (`savme_builder_config` prints what a builder holds).

use crate::kernel::{register_plain, savme_kernel};
use crate::registry::{Kind, Registry};
use crate::status::*;
use crate::strings::give_string;
use crate::values::{lock, lookup_failure};
use ::savme_kernel::{Assignment, Estimator, Kernel, Preset, Scale, Space, Value, Variable};
use std::ffi::c_char;

/// A kernel configuration being put together (`savme_builder_new`), turned into a kernel by
/// `savme_builder_build` (or into JSON by `savme_builder_config`), freed with
/// `savme_builder_free`. Thread-safety: as every handle (calls serialised by a lock).
#[allow(non_camel_case_types)]
pub struct savme_builder {
    _private: [u8; 0],
}

struct Builder {
    seed: u64,
    budget: f64,
    fidelity: Vec<Variable>,
    theta_hf: Assignment,
    scenarios: Vec<(String, Vec<Variable>, f64)>,
    preset: Preset,
    /// θ_LF*'s choice when not the preset's.
    estimator: Option<Estimator>,
}

/// Which method's settings a builder's kernel starts from (`savme_builder_method`).
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum savme_method {
    /// savme's (the builder's default): θ_LF* from evidence, the elite search, a deployment that
    /// keeps learning, scenarios by cost rate — `savme example-config`'s and Python's.
    SAVME_METHOD_TUNED = 0,
    /// The paper's SAVME: θ_LF* = MAP, independent bins, a frozen deployment, scenarios from
    /// p(s) (`savme example-config --method paper`, Python's `method="paper"`).
    SAVME_METHOD_PAPER = 1,
}

static BUILDERS: Registry<Builder> = Registry::new(Kind::Builder);

fn with_builder(
    function: &str,
    b: *const savme_builder,
    body: impl FnOnce(&mut Builder) -> Outcome,
) -> savme_status {
    guard(function, || {
        let held = BUILDERS
            .get(b as usize)
            .map_err(|l| lookup_failure(l, "b", "savme_builder"))?;
        let mut state = lock(&held);
        body(&mut state)
    })
}

/// `variable` checked on its own (a space of one), so that a bad one is refused where it is
/// added, named.
fn checked(variable: Variable) -> Outcome<Variable> {
    Space::new(vec![variable.clone()])
        .map_err(|e| Failure::new(SAVME_ERROR_CONFIG, e.to_string()))?;
    Ok(variable)
}

unsafe fn labels(values: *const *const c_char, n: usize) -> Outcome<Vec<Value>> {
    if values.is_null() {
        return Err(Failure::new(SAVME_ERROR_NULL, "`values` is NULL"));
    }
    // SAFETY: the caller promises `n` readable pointers at `values`.
    let values = unsafe { std::slice::from_raw_parts(values, n) };
    values
        .iter()
        .enumerate()
        .map(|(i, v)| text(*v, &format!("values[{i}]")).map(Value::from))
        .collect()
}

unsafe fn ints(values: *const i64, n: usize) -> Outcome<Vec<Value>> {
    if values.is_null() {
        return Err(Failure::new(SAVME_ERROR_NULL, "`values` is NULL"));
    }
    // SAFETY: the caller promises `n` readable integers at `values`.
    let values = unsafe { std::slice::from_raw_parts(values, n) };
    Ok(values.iter().map(|v| Value::Int(*v)).collect())
}

fn scale(log: bool) -> Scale {
    if log {
        Scale::Log
    } else {
        Scale::Linear
    }
}

impl Builder {
    fn add_fidelity(&mut self, variable: Variable, hf: Value) -> Outcome {
        let name = variable.name.to_string();
        if self.fidelity.iter().any(|v| *v.name == *name) {
            return Err(Failure::new(
                SAVME_ERROR_CONFIG,
                format!("fidelity variable `{name}` was added before"),
            ));
        }
        self.fidelity.push(checked(variable)?);
        self.theta_hf.set(&name, hf);
        Ok(())
    }

    fn add_phi(&mut self, scenario: &str, variable: Variable) -> Outcome {
        let names: Vec<String> = self.scenarios.iter().map(|s| s.0.clone()).collect();
        let found = self.scenarios.iter_mut().find(|s| s.0 == scenario);
        let Some((_, space, _)) = found else {
            return Err(Failure::new(
                SAVME_ERROR_NOT_FOUND,
                format!(
                    "no scenario `{scenario}`: add it with savme_builder_scenario first (there are: {})",
                    if names.is_empty() { "none".to_string() } else { names.join(", ") }
                ),
            ));
        };
        space.push(checked(variable)?);
        Ok(())
    }

    fn kernel(&self) -> Outcome<Kernel> {
        let invalid = |e: String| Failure::new(SAVME_ERROR_CONFIG, e);
        if self.fidelity.is_empty() {
            return Err(invalid(
                "no fidelity setting: add one with savme_builder_fidelity_*".into(),
            ));
        }
        if self.scenarios.is_empty() {
            return Err(invalid(
                "no scenario: add one with savme_builder_scenario".into(),
            ));
        }
        let fidelity = Space::new(self.fidelity.clone()).map_err(|e| invalid(e.to_string()))?;
        let mut builder = Kernel::builder(fidelity, self.theta_hf.clone())
            .seed(self.seed)
            .budget(self.budget)
            .preset(self.preset);
        if let Some(estimator) = self.estimator {
            builder = builder.estimator(estimator);
        }
        for (name, space, weight) in &self.scenarios {
            let space = Space::new(space.clone())
                .map_err(|e| invalid(format!("scenario `{name}`: {e}")))?;
            builder = builder.scenario(name, space, *weight);
        }
        builder.build().map_err(|e| invalid(e.to_string()))
    }
}

/// Starts a configuration with the kernel's `seed` and compute `budget` (the largest
/// t_LF / t_HF a fidelity may cost and still be credited, e.g. 0.3) into `*out`.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_new(
    seed: u64,
    budget: f64,
    out: *mut *mut savme_builder,
) -> savme_status {
    guard("savme_builder_new", || {
        let out = required(out, "out")?;
        let handle = BUILDERS.insert(Builder {
            seed,
            budget,
            fidelity: Vec::new(),
            theta_hf: Assignment::new(),
            scenarios: Vec::new(),
            preset: Preset::Tuned,
            estimator: None,
        });
        *out = std::ptr::without_provenance_mut(handle);
        Ok(())
    })
}

/// Frees a builder. NULL does nothing; a handle that is not live is refused with
/// `SAVME_ERROR_HANDLE`.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_free(b: *mut savme_builder) -> savme_status {
    guard("savme_builder_free", || {
        if b.is_null() {
            return Ok(());
        }
        BUILDERS
            .remove(b as usize)
            .map_err(|l| lookup_failure(l, "b", "savme_builder"))
    })
}

/// Picks the method whose settings the kernel starts from: a `savme_method`
/// (`SAVME_METHOD_TUNED`, the default, or `SAVME_METHOD_PAPER`). It sets θ_LF*'s choice too
/// unless `savme_builder_estimator` set it.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_method(b: *mut savme_builder, method: i32) -> savme_status {
    with_builder("savme_builder_method", b, |s| {
        s.preset = match method {
            0 => Preset::Tuned,
            1 => Preset::Paper,
            _ => {
                return Err(Failure::new(
                    SAVME_ERROR_ARGUMENT,
                    format!("`method` must be a savme_method (0 or 1), got {method}"),
                ))
            }
        };
        Ok(())
    })
}

/// Picks how θ_LF* is read off the fidelity posterior: a `savme_estimator`
/// (`SAVME_ESTIMATOR_MAP` for the paper's with the tuned method's other settings,
/// `SAVME_ESTIMATOR_MEAN`, `SAVME_ESTIMATOR_EVIDENCE`; `SAVME_ESTIMATOR_CONFIGURED`: the
/// method's again) — the configuration's `"estimator"`, Python's `estimator=`.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_estimator(
    b: *mut savme_builder,
    estimator: i32,
) -> savme_status {
    with_builder("savme_builder_estimator", b, |s| {
        s.estimator = match estimator {
            0 => None,
            e => Some(crate::kernel::estimator_of(e)?),
        };
        Ok(())
    })
}

/// Adds a fidelity setting taking the `n` integers at `values` (e.g. a rate in Hz), `hf`
/// being its θ_HF value. `SAVME_ERROR_CONFIG` names a bad variable (no values, repeated ones).
#[no_mangle]
pub unsafe extern "C" fn savme_builder_fidelity_ints(
    b: *mut savme_builder,
    name: *const c_char,
    values: *const i64,
    n: usize,
    hf: i64,
) -> savme_status {
    with_builder("savme_builder_fidelity_ints", b, |s| {
        let name = text(name, "name")?;
        let values = ints(values, n)?;
        s.add_fidelity(Variable::discrete(name, values), Value::Int(hf))
    })
}

/// Adds a fidelity setting taking the `n` labels at `values` (e.g. `"low"`, `"high"`), `hf`
/// being its θ_HF label.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_fidelity_labels(
    b: *mut savme_builder,
    name: *const c_char,
    values: *const *const c_char,
    n: usize,
    hf: *const c_char,
) -> savme_status {
    with_builder("savme_builder_fidelity_labels", b, |s| {
        let name = text(name, "name")?;
        let hf = text(hf, "hf")?;
        let values = labels(values, n)?;
        s.add_fidelity(Variable::discrete(name, values), Value::from(hf))
    })
}

/// Adds a boolean fidelity setting (e.g. "disable shadows"), `hf` being its θ_HF value.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_fidelity_bool(
    b: *mut savme_builder,
    name: *const c_char,
    hf: bool,
) -> savme_status {
    with_builder("savme_builder_fidelity_bool", b, |s| {
        let name = text(name, "name")?;
        s.add_fidelity(Variable::boolean(name), Value::Bool(hf))
    })
}

/// Adds a continuous fidelity setting on `[lo, hi]` in `bins` bins (log-spaced if `log_scale`;
/// then `0 < lo`), `hf` being its θ_HF value.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_fidelity_continuous(
    b: *mut savme_builder,
    name: *const c_char,
    lo: f64,
    hi: f64,
    bins: u32,
    log_scale: bool,
    hf: f64,
) -> savme_status {
    with_builder("savme_builder_fidelity_continuous", b, |s| {
        let name = text(name, "name")?;
        let v = Variable::continuous(name, lo, hi, bins, scale(log_scale));
        s.add_fidelity(v, Value::Real(hf))
    })
}

/// Adds scenario `name` with `weight` in p(s) (> 0); add its parameters with
/// `savme_builder_phi_*`.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_scenario(
    b: *mut savme_builder,
    name: *const c_char,
    weight: f64,
) -> savme_status {
    with_builder("savme_builder_scenario", b, |s| {
        let name = text(name, "name")?;
        if s.scenarios.iter().any(|sc| sc.0 == name) {
            return Err(Failure::new(
                SAVME_ERROR_CONFIG,
                format!("scenario `{name}` was added before"),
            ));
        }
        s.scenarios.push((name.to_string(), Vec::new(), weight));
        Ok(())
    })
}

/// Adds a continuous parameter to scenario `scenario` on `[lo, hi]` in `bins` bins
/// (log-spaced if `log_scale`). `SAVME_ERROR_NOT_FOUND` for a scenario not added yet.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_phi_continuous(
    b: *mut savme_builder,
    scenario: *const c_char,
    name: *const c_char,
    lo: f64,
    hi: f64,
    bins: u32,
    log_scale: bool,
) -> savme_status {
    with_builder("savme_builder_phi_continuous", b, |s| {
        let scenario = text(scenario, "scenario")?;
        let name = text(name, "name")?;
        s.add_phi(
            scenario,
            Variable::continuous(name, lo, hi, bins, scale(log_scale)),
        )
    })
}

/// Adds a parameter taking the `n` integers at `values` to scenario `scenario`.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_phi_ints(
    b: *mut savme_builder,
    scenario: *const c_char,
    name: *const c_char,
    values: *const i64,
    n: usize,
) -> savme_status {
    with_builder("savme_builder_phi_ints", b, |s| {
        let scenario = text(scenario, "scenario")?;
        let name = text(name, "name")?;
        s.add_phi(scenario, Variable::discrete(name, ints(values, n)?))
    })
}

/// Adds a parameter taking the `n` labels at `values` to scenario `scenario`.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_phi_labels(
    b: *mut savme_builder,
    scenario: *const c_char,
    name: *const c_char,
    values: *const *const c_char,
    n: usize,
) -> savme_status {
    with_builder("savme_builder_phi_labels", b, |s| {
        let scenario = text(scenario, "scenario")?;
        let name = text(name, "name")?;
        s.add_phi(scenario, Variable::discrete(name, labels(values, n)?))
    })
}

/// Adds a boolean parameter to scenario `scenario`.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_phi_bool(
    b: *mut savme_builder,
    scenario: *const c_char,
    name: *const c_char,
) -> savme_status {
    with_builder("savme_builder_phi_bool", b, |s| {
        let scenario = text(scenario, "scenario")?;
        let name = text(name, "name")?;
        s.add_phi(scenario, Variable::boolean(name))
    })
}

/// The configuration the builder holds, as JSON (what `savme_kernel_new`,
/// `savme_kernel_open_journal` and `savme serve --config` read), into `*json`; free it with
/// `savme_string_free`. `SAVME_ERROR_CONFIG` names what is missing or wrong.
#[no_mangle]
pub unsafe extern "C" fn savme_builder_config(
    b: *const savme_builder,
    json: *mut *mut c_char,
) -> savme_status {
    with_builder("savme_builder_config", b, |s| {
        let json = required(json, "json")?;
        let kernel = s.kernel()?;
        let text = serde_json::to_string_pretty(kernel.config())
            .map_err(|e| Failure::new(SAVME_ERROR_INTERNAL, e.to_string()))?;
        *json = give_string(text);
        Ok(())
    })
}

/// Builds a kernel (in memory) from the builder into `*out`; the builder stays usable (and
/// must still be freed). `SAVME_ERROR_CONFIG` names what is missing or wrong (no fidelity
/// setting, no scenario, a θ_HF value outside its variable's values, a budget outside (0, 1]).
#[no_mangle]
pub unsafe extern "C" fn savme_builder_build(
    b: *const savme_builder,
    out: *mut *mut savme_kernel,
) -> savme_status {
    with_builder("savme_builder_build", b, |s| {
        let out = required(out, "out")?;
        let kernel = s.kernel()?;
        register_plain(kernel, out);
        Ok(())
    })
}

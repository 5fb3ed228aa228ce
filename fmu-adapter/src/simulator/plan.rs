//! A run specification resolved against one FMU's model description: each binding's FMU
//! variable checked (exists, settable before initialisation, a type its savme values fit, the
//! declared bounds and items) and the failure and cost outputs found — the [`Plan`] every run
//! of that FMU then follows without a lookup.

use super::*;

/// What a savme variable's values need of an FMU variable.
fn needed(space: &Space, name: &str) -> Option<&'static [VarType]> {
    let v = space.variable(name)?;
    Some(match &v.domain {
        Domain::Continuous { .. } => &[VarType::Real],
        Domain::Discrete { values } => {
            if values.iter().all(|x| matches!(x, Value::Bool(_))) {
                &[VarType::Boolean]
            } else if values.iter().all(|x| x.as_label().is_some()) {
                &[VarType::Integer, VarType::Enumeration]
            } else if values
                .iter()
                .all(|x| x.as_f64().is_some_and(|f| f.fract() == 0.0))
            {
                &[VarType::Integer, VarType::Real, VarType::Enumeration]
            } else {
                &[VarType::Real]
            }
        }
    })
}

/// A variable's type in an error: its kind (Real, Integer, …), or for one savme does not bind
/// its FMI 3.0 type (Binary, Clock), an array marked as such.
pub(super) fn shown_type(v: &VarInfo) -> String {
    let name = if v.kind == VarType::Other {
        format!("{:?}", v.repr)
    } else {
        format!("{:?}", v.kind)
    };
    if v.array {
        format!("an array of {name}")
    } else {
        name
    }
}

/// A binding resolved against one FMU.
#[derive(Debug, Clone)]
pub(super) struct Resolved {
    pub(super) variable: String,
    pub(super) var: VarInfo,
    pub(super) labels: Option<Vec<String>>,
}

/// Variable `name` of `file`, refused if it is an FMI 3.0 array (savme binds scalars).
fn scalar(file: &FmuDescription, name: &str) -> Result<VarInfo, FmuError> {
    let v = file.variable(name)?.clone();
    if v.array {
        return Err(FmuError::WrongType {
            fmu: file.path.display().to_string(),
            variable: name.into(),
            found: "an array (it has Dimension elements)".into(),
            expected: "a scalar variable".into(),
        });
    }
    Ok(v)
}

/// Variable `name` of `file`, if savme can set it before initialisation: a parameter, an
/// FMI 3.0 structural parameter (set in configuration mode), an input, or — as FMI allows and
/// FMPy does — any variable with a settable start value (`initial="exact"` or `"approx"`, not
/// constant: the start value of a state, a counter, …).
fn settable(file: &FmuDescription, name: &str) -> Result<VarInfo, FmuError> {
    let v = scalar(file, name)?;
    let start_settable =
        v.variability != "constant" && matches!(v.initial.as_deref(), Some("exact" | "approx"));
    let structural =
        v.causality == VarCausality::StructuralParameter && v.variability != "constant";
    if !(matches!(v.causality, VarCausality::Parameter | VarCausality::Input)
        || structural
        || start_settable)
    {
        return Err(FmuError::WrongCausality {
            fmu: file.path.display().to_string(),
            variable: name.into(),
            expected: "a parameter, a structural parameter, an input, or a variable whose start \
                       value can be set (initial=\"exact\" or \"approx\")"
                .into(),
        });
    }
    Ok(v)
}

/// Binding `b` resolved against `file`: a settable variable of a type that takes the savme
/// variable's values (`role`: φ or θ), each inside its declared bounds or items.
fn resolve(
    file: &FmuDescription,
    b: &Binding,
    space: Option<&Space>,
    role: &str,
) -> Result<Resolved, FmuError> {
    let var = settable(file, &b.fmu_variable)?;
    if let Some(allowed) = space.and_then(|s| needed(s, &b.variable)) {
        let continuous = space
            .and_then(|s| s.variable(&b.variable))
            .is_some_and(|v| matches!(v.domain, Domain::Continuous { .. }));
        if continuous && matches!(var.kind, VarType::Integer | VarType::Enumeration) {
            return Err(FmuError::WrongType {
                fmu: file.path.display().to_string(),
                variable: b.fmu_variable.clone(),
                found: shown_type(&var),
                expected: format!(
                    "a Real for `{}`, which ranges continuously: give an {} variable its values as a list (`values = [1, 2, 3]`, not `range`)",
                    b.variable,
                    shown_type(&var)
                ),
            });
        }
        if !allowed.contains(&var.kind) {
            return Err(FmuError::WrongType {
                fmu: file.path.display().to_string(),
                variable: b.fmu_variable.clone(),
                found: shown_type(&var),
                expected: format!(
                    "{} (for `{}`)",
                    allowed
                        .iter()
                        .map(|k| format!("{k:?}"))
                        .collect::<Vec<_>>()
                        .join(" or "),
                    b.variable
                ),
            });
        }
    }
    if let Some(v) = space.and_then(|s| s.variable(&b.variable)) {
        declared::check_domain(file, &var, v, b.labels.as_deref(), role)?;
    }
    Ok(Resolved {
        variable: b.variable.clone(),
        var,
        labels: b.labels.clone(),
    })
}

/// A fixed value resolved against `file`: a settable variable of a type that takes it, inside
/// its declared bounds or items.
fn resolve_fixed(file: &FmuDescription, f: &Fixed) -> Result<(VarInfo, Value), FmuError> {
    let v = settable(file, &f.fmu_variable)?;
    let fits = matches!(
        (&f.value, v.kind),
        (Value::Bool(_), VarType::Boolean)
            | (
                Value::Int(_),
                VarType::Integer | VarType::Real | VarType::Enumeration
            )
            | (Value::Real(_), VarType::Real)
            | (Value::Label(_), VarType::String | VarType::Enumeration)
    );
    if !fits {
        return Err(FmuError::WrongType {
            fmu: file.path.display().to_string(),
            variable: f.fmu_variable.clone(),
            found: shown_type(&v),
            expected: format!("a variable that takes the value {}", f.value),
        });
    }
    declared::check_value(
        file,
        &v,
        &f.value,
        None,
        &format!("the fixed value {}", f.value),
    )?;
    Ok((v, f.value.clone()))
}

/// A scenario's name, φ bindings and fixed values, resolved.
pub(super) type ScenarioPlan = (String, Vec<Resolved>, Vec<(VarInfo, Value)>);

/// The outputs and bindings of a spec resolved against one FMU.
#[derive(Debug, Clone)]
pub(super) struct Plan {
    pub(super) failure: VarInfo,
    /// A Boolean failure signal's robustness output.
    pub(super) robustness: Option<VarInfo>,
    pub(super) cost: Option<VarInfo>,
    pub(super) fidelity: Vec<Resolved>,
    pub(super) scenarios: Vec<ScenarioPlan>,
    /// Some binding or fixed value sets a structural parameter (set in configuration mode).
    pub(super) structural: bool,
}

pub(super) fn output(
    file: &FmuDescription,
    name: &str,
    kinds: &[VarType],
) -> Result<VarInfo, FmuError> {
    let v = scalar(file, name)?;
    if v.causality != VarCausality::Output {
        return Err(FmuError::WrongCausality {
            fmu: file.path.display().to_string(),
            variable: name.into(),
            expected: "an output".into(),
        });
    }
    if !kinds.contains(&v.kind) {
        return Err(FmuError::WrongType {
            fmu: file.path.display().to_string(),
            variable: name.into(),
            found: shown_type(&v),
            expected: kinds
                .iter()
                .map(|k| format!("{k:?}"))
                .collect::<Vec<_>>()
                .join(" or "),
        });
    }
    Ok(v)
}

impl Plan {
    fn new(
        file: &FmuDescription,
        spec: &RunSpec,
        fidelity: Option<&Space>,
        phi: &dyn Fn(&str) -> Option<Space>,
    ) -> Result<Plan, FmuError> {
        let failure = match &spec.failure {
            Failure::Boolean { variable, .. } => output(file, variable, &[VarType::Boolean])?,
            Failure::Threshold { variable, .. } => output(
                file,
                variable,
                &[VarType::Real, VarType::Integer, VarType::Enumeration],
            )?,
        };
        let robustness = match &spec.failure {
            Failure::Boolean {
                robustness: Some(v),
                ..
            } => Some(output(file, v, &[VarType::Real, VarType::Integer])?),
            _ => None,
        };
        let cost = match &spec.cost {
            CostSource::Wall => None,
            CostSource::Output(v) => Some(output(file, v, &[VarType::Real, VarType::Integer])?),
        };
        let fidelity: Vec<Resolved> = spec
            .fidelity
            .iter()
            .map(|b| resolve(file, b, fidelity, "θ"))
            .collect::<Result<_, _>>()?;
        let scenarios = spec
            .scenarios
            .iter()
            .map(|s| {
                let space = phi(&s.name);
                let bindings = s
                    .phi
                    .iter()
                    .map(|b| resolve(file, b, space.as_ref(), "φ"))
                    .collect::<Result<Vec<_>, _>>()?;
                let fixed = s
                    .fixed
                    .iter()
                    .map(|f| resolve_fixed(file, f))
                    .collect::<Result<Vec<_>, _>>()?;
                Ok((s.name.clone(), bindings, fixed))
            })
            .collect::<Result<Vec<ScenarioPlan>, FmuError>>()?;
        let is_structural = |v: &VarInfo| v.causality == VarCausality::StructuralParameter;
        let structural = fidelity.iter().any(|b: &Resolved| is_structural(&b.var))
            || scenarios.iter().any(|(_, bound, fixed): &ScenarioPlan| {
                bound.iter().any(|b| is_structural(&b.var))
                    || fixed.iter().any(|(v, _)| is_structural(v))
            });
        Ok(Plan {
            failure,
            robustness,
            cost,
            fidelity,
            scenarios,
            structural,
        })
    }
}

/// The run settings checked and the bindings resolved against the HF and the LF FMU.
pub(super) fn plans(
    hf: &FmuDescription,
    lf: &FmuDescription,
    spec: &RunSpec,
    fidelity: Option<&Space>,
    phi: &dyn Fn(&str) -> Option<Space>,
) -> Result<[Plan; 2], FmuError> {
    if !(spec.stop_time > 0.0 && spec.stop_time.is_finite()) {
        return Err(FmuError::Spec(format!(
            "stop time {} is not positive",
            spec.stop_time
        )));
    }
    if let StepSize::Fixed(h) = spec.step {
        if !(h > 0.0 && h.is_finite()) {
            return Err(FmuError::Spec(format!("step size {h} is not positive")));
        }
        if let Some(message) = too_many_steps(spec.stop_time, h) {
            return Err(FmuError::Spec(message));
        }
    }
    if let Some(Tolerance::Fixed(t)) = spec.tolerance {
        if !(t > 0.0 && t.is_finite()) {
            return Err(FmuError::Spec(format!("tolerance {t} is not positive")));
        }
    }
    for file in [hf, lf] {
        let start = start_time(file);
        if spec.stop_time <= start {
            return Err(FmuError::Spec(format!(
                "{}: the stop time {} s is not after the FMU's start time (DefaultExperiment startTime = {start} s)",
                file.path.display(),
                spec.stop_time
            )));
        }
        for h in step_sizes(&spec.step, fidelity) {
            fixed_step_fits(file, h, spec.stop_time)?;
        }
    }
    Ok([
        Plan::new(hf, spec, fidelity, phi)?,
        Plan::new(lf, spec, fidelity, phi)?,
    ])
}

/// The step sizes a run can take, as far as known before any run: the fixed step, or those of
/// a fidelity variable with listed values (a continuous one is checked run by run).
fn step_sizes(step: &StepSize, fidelity: Option<&Space>) -> Vec<f64> {
    let values = |var: &str| -> Vec<f64> {
        match fidelity.and_then(|s| s.variable(var)).map(|v| &v.domain) {
            Some(Domain::Discrete { values }) => values.iter().filter_map(Value::as_f64).collect(),
            _ => Vec::new(),
        }
    };
    match step {
        StepSize::Fixed(h) => vec![*h],
        StepSize::Of(var) => values(var).into_iter().filter(|h| *h > 0.0).collect(),
        StepSize::RateOf(var) => values(var)
            .into_iter()
            .filter(|r| *r > 0.0)
            .map(|r| 1.0 / r)
            .collect(),
    }
}

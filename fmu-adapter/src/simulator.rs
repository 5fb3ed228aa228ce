//! Running a scenario on a pair of FMUs: how savme's variables map to FMU variables, what
//! counts as a failure, how long to simulate, what a run costs.
//!
//! ~690 lines (the resolution against a model description is in `simulator/plan.rs`): the
//! run specification types and the run loop stay together because every field of
//! [`RunSpec`] is read by the loop, and FMPy's communication grid (`steps`) is only meaningful
//! beside it.

mod plan;

use plan::{output, plans, Plan};

use crate::declared;
use crate::description::{VarCausality, VarInfo, VarType};
use crate::file::{FmuDescription, FmuFile};
use crate::instance::{Instance, Step};
use crate::FmuError;
use savme_kernel::{Assignment, Domain, Role, SimError, SimResult, Simulator, Space, Value};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;

/// A savme variable (φ or θ) and the FMU variable it sets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Binding {
    /// The savme variable.
    pub variable: String,
    /// The FMU variable (a parameter, an input, or a variable whose start value can be set).
    pub fmu_variable: String,
    /// For a variable with label values: the labels, in order — a label is set as its position
    /// (an FMU Integer).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub labels: Option<Vec<String>>,
}

/// A value set on every run of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fixed {
    /// The FMU variable.
    pub fmu_variable: String,
    /// Its value.
    pub value: Value,
}

/// What counts as a failure of the system under test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Failure {
    /// A Boolean output is true.
    Boolean {
        /// The output.
        variable: String,
        /// A Real or Integer output reported as the run's robustness ρ (`≤ 0` = failed, as
        /// the output reports it): its smallest value over the communication points read.
        /// The flag alone decides the verdict; a run whose flag and ρ disagree keeps both as
        /// reported.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        robustness: Option<String>,
    },
    /// A Real (or Integer) output crosses a threshold.
    Threshold {
        /// The output.
        variable: String,
        /// `above`: failure when the output is ≥ `value`; `below`: when ≤ `value`.
        when: Crossing,
        /// The threshold.
        value: f64,
    },
}

/// Direction of a threshold failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Crossing {
    /// At or above.
    Above,
    /// At or below.
    Below,
}

/// The communication step size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StepSize {
    /// A fixed step, seconds.
    Fixed(f64),
    /// 1 / (a fidelity variable in Hz), e.g. the simulation rate.
    RateOf(String),
    /// A fidelity variable's value, seconds: the step size is itself the fidelity (the
    /// variable is bound to no FMU variable).
    Of(String),
}

/// The `tolerance` passed to `fmi2SetupExperiment` (none: `toleranceDefined = false`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Tolerance {
    /// The same tolerance for every run.
    Fixed(f64),
    /// A fidelity variable's value (bound to no FMU variable).
    Of(String),
}

/// What a run costs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CostSource {
    /// Measured wall-clock time (always measured; also reported as work if nothing else).
    #[default]
    Wall,
    /// An output of the FMU read at the end of the run, reported as work units.
    Output(String),
}

/// The outputs a run recorded (`[fmu] record`): their values at every communication point,
/// from the initialised state at the start time (`DefaultExperiment startTime`, else 0) to the
/// end of the run.
///
/// ```
/// use savme_fmu::simulator::Trace;
/// let t = Trace {
///     names: vec!["x".into()],
///     times: vec![0.0, 0.1],
///     values: vec![vec![0.0, 0.25]],
///     failure_time: None,
/// };
/// assert_eq!(t.series("x"), Some(&[0.0, 0.25][..]));
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Trace {
    /// The recorded variables, in the order asked for.
    pub names: Vec<String>,
    /// The communication points, simulated seconds.
    pub times: Vec<f64>,
    /// One series per variable (`values[k][i]`: `names[k]` at `times[i]`; a Boolean as 0 or 1,
    /// an Integer or enumeration as its number).
    pub values: Vec<Vec<f64>>,
    /// The first communication point at which the failure signal held, if it did.
    pub failure_time: Option<f64>,
}

impl Trace {
    /// The series of variable `name`.
    pub fn series(&self, name: &str) -> Option<&[f64]> {
        let k = self.names.iter().position(|n| n == name)?;
        self.values.get(k).map(Vec::as_slice)
    }
}

/// The recorded variables of a run, resolved, and what they recorded so far.
struct Tracer {
    vars: Vec<VarInfo>,
    trace: Trace,
}

impl Tracer {
    fn new(file: &FmuDescription, names: &[String]) -> Result<Tracer, FmuError> {
        let vars = names
            .iter()
            .map(|n| recordable(file, n))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Tracer {
            trace: Trace {
                names: names.to_vec(),
                values: vec![Vec::new(); vars.len()],
                ..Trace::default()
            },
            vars,
        })
    }

    /// Reads every recorded variable at time `t` (and the failure, the first time it holds).
    fn sample(&mut self, inst: &mut Instance, t: f64, failure: bool) -> Result<(), FmuError> {
        self.trace.times.push(t);
        for (v, series) in self.vars.iter().zip(&mut self.trace.values) {
            // Through the getter of the variable's C type (an FMI 3.0 Int64 or enumeration
            // through fmi3GetInt64, not fmi3GetInt32).
            series.push(match v.kind {
                VarType::Boolean => f64::from(u8::from(inst.boolean(v.vr)?)),
                _ => inst.number(v)?,
            });
        }
        if failure && self.trace.failure_time.is_none() {
            self.trace.failure_time = Some(t);
        }
        Ok(())
    }
}

/// The variable `name` of `file` as something a run can record (`[fmu] record`): an output of
/// type Real, Integer, Boolean or enumeration.
pub fn recordable(file: &FmuDescription, name: &str) -> Result<VarInfo, FmuError> {
    output(
        file,
        name,
        &[
            VarType::Real,
            VarType::Integer,
            VarType::Boolean,
            VarType::Enumeration,
        ],
    )
}

/// A scenario: its φ bindings and fixed values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioSpec {
    /// The scenario name (as the kernel knows it).
    pub name: String,
    /// Its parameters φ → FMU variables.
    pub phi: Vec<Binding>,
    /// Values set on every run.
    #[serde(default)]
    pub fixed: Vec<Fixed>,
}

/// Everything about how a trial's run executes on an FMU.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// Simulated time, seconds.
    pub stop_time: f64,
    /// Communication step size.
    pub step: StepSize,
    /// The solver tolerance handed to the FMU, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<Tolerance>,
    /// The failure signal.
    pub failure: Failure,
    /// Stop as soon as the failure is reached.
    pub stop_on_failure: bool,
    /// The cost of a run.
    pub cost: CostSource,
    /// Fidelity settings θ → FMU variables (the same names in the HF and LF FMU).
    pub fidelity: Vec<Binding>,
    /// The scenarios.
    pub scenarios: Vec<ScenarioSpec>,
    /// Print every FMU log message to standard error (the instances are created with
    /// `loggingOn`); errors carry the last messages of their run either way.
    #[serde(default)]
    pub fmu_log: bool,
}

/// Labels of a discrete variable with label values (for [`Binding::labels`]).
pub fn labels_of(space: &Space, name: &str) -> Option<Vec<String>> {
    let v = space.variable(name)?;
    match &v.domain {
        Domain::Discrete { values } if values.iter().all(|x| x.as_label().is_some()) => Some(
            values
                .iter()
                .filter_map(|x| x.as_label().map(String::from))
                .collect(),
        ),
        _ => None,
    }
}

/// A pair of FMUs (HF and LF; may be the same file) as a savme [`Simulator`]. Clones share the
/// loaded libraries and make their own instances (one per worker thread), reused across runs
/// with `fmi2Reset`.
pub struct FmuSimulator {
    files: [Arc<FmuFile>; 2],
    plans: Arc<[Plan; 2]>,
    spec: Arc<RunSpec>,
    instances: [Option<Instance>; 2],
}

impl Clone for FmuSimulator {
    fn clone(&self) -> Self {
        FmuSimulator {
            files: self.files.clone(),
            plans: self.plans.clone(),
            spec: self.spec.clone(),
            instances: [None, None],
        }
    }
}

impl std::fmt::Debug for FmuSimulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmuSimulator")
            .field("hf", &self.files[0].path)
            .field("lf", &self.files[1].path)
            .finish()
    }
}

impl FmuSimulator {
    /// Checks every binding and output of `spec` against both FMUs (types, causalities) and
    /// builds the simulator. `fidelity` and `phi` give the savme variables' domains for the
    /// type checks. Each run names its role ([`Simulator::simulate_as`]): HF runs the `hf` FMU,
    /// LF runs the `lf` one.
    pub fn new(
        hf: Arc<FmuFile>,
        lf: Arc<FmuFile>,
        spec: RunSpec,
        fidelity: Option<&Space>,
        phi: &dyn Fn(&str) -> Option<Space>,
    ) -> Result<FmuSimulator, FmuError> {
        let plans = plans(&hf, &lf, &spec, fidelity, phi)?;
        Ok(FmuSimulator {
            files: [hf, lf],
            plans: Arc::new(plans),
            spec: Arc::new(spec),
            instances: [None, None],
        })
    }

    /// The checks of [`FmuSimulator::new`] on the FMUs' descriptions alone — nothing loaded
    /// (what `savme run` does before it starts FMU workers, and `savme fmu validate`).
    pub fn check(
        hf: &FmuDescription,
        lf: &FmuDescription,
        spec: &RunSpec,
        fidelity: Option<&Space>,
        phi: &dyn Fn(&str) -> Option<Space>,
    ) -> Result<(), FmuError> {
        plans(hf, lf, spec, fidelity, phi).map(|_| ())
    }

    /// The run specification.
    pub fn spec(&self) -> &RunSpec {
        &self.spec
    }

    fn set(
        inst: &mut Instance,
        var: &VarInfo,
        value: &Value,
        labels: Option<&[String]>,
    ) -> Result<(), FmuError> {
        let bad = |expected: &str| FmuError::WrongType {
            fmu: inst.file().path.display().to_string(),
            variable: var.name.clone(),
            found: format!("value {value}"),
            expected: expected.into(),
        };
        match var.kind {
            VarType::Real => inst.set_number(var, value.as_f64().ok_or_else(|| bad("a number"))?),
            VarType::Integer | VarType::Enumeration => {
                let i = declared::integer_of(var, value, labels)
                    .ok_or_else(|| bad("an integer, a label or an enumeration item"))?;
                inst.set_int(var, i)
            }
            VarType::Boolean => {
                inst.set_boolean(var.vr, value.as_bool().ok_or_else(|| bad("a boolean"))?)
            }
            VarType::String => {
                inst.set_string(var.vr, value.as_label().ok_or_else(|| bad("a string"))?)
            }
            VarType::Other => Err(bad("a Float, Integer, Boolean, String or Enumeration")),
        }
    }

    /// Sets the fixed values and the values of the bindings on `inst`: those of structural
    /// parameters (`structural`), or all the others.
    fn set_values(
        inst: &mut Instance,
        fixed: &[(VarInfo, Value)],
        bound: &[(&Vec<plan::Resolved>, &Assignment)],
        structural: bool,
    ) -> Result<(), FmuError> {
        let wanted = |v: &VarInfo| (v.causality == VarCausality::StructuralParameter) == structural;
        for (var, value) in fixed.iter().filter(|(v, _)| wanted(v)) {
            Self::set(inst, var, value, None)?;
        }
        for (bindings, values) in bound {
            for b in bindings.iter().filter(|b| wanted(&b.var)) {
                let value = values
                    .get(&b.variable)
                    .ok_or_else(|| FmuError::MissingValue {
                        variable: b.variable.clone(),
                    })?;
                Self::set(inst, &b.var, value, b.labels.as_deref())?;
            }
        }
        Ok(())
    }

    /// Whether the failure signal says failed now, and its robustness: for a threshold its
    /// margin, how far the output is from the threshold on the passing side (`≤ 0` = failed);
    /// for a Boolean the value of its `robustness` output, if it names one.
    fn failed(&self, inst: &mut Instance, plan: &Plan) -> Result<(bool, Option<f64>), FmuError> {
        Ok(match &self.spec.failure {
            Failure::Boolean { .. } => {
                let failed = inst.boolean(plan.failure.vr)?;
                let rho = match &plan.robustness {
                    Some(v) => Some(inst.number(v)?),
                    None => None,
                };
                (failed, rho)
            }
            Failure::Threshold { when, value, .. } => {
                let x = inst.number(&plan.failure)?;
                match when {
                    Crossing::Above => (x >= *value, Some(*value - x)),
                    Crossing::Below => (x <= *value, Some(x - *value)),
                }
            }
        })
    }

    /// Runs `scenario` with `phi` and `fidelity` on the HF (`role` = High) or LF FMU.
    pub fn run(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, FmuError> {
        self.run_with(role, scenario, phi, fidelity, None)
    }

    /// [`FmuSimulator::run`], recording the outputs `record` at every communication point
    /// (each must be [`recordable`]).
    pub fn run_traced(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
        record: &[String],
    ) -> Result<(SimResult, Trace), FmuError> {
        let k = usize::from(role == Role::Learned);
        let mut tracer = Tracer::new(&self.files[k], record)?;
        let result = self.run_with(role, scenario, phi, fidelity, Some(&mut tracer))?;
        Ok((result, tracer.trace))
    }

    fn run_with(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
        tracer: Option<&mut Tracer>,
    ) -> Result<SimResult, FmuError> {
        let k = usize::from(role == Role::Learned);
        // The plans are shared (an Arc): no copy of the bindings per evaluation.
        let plans = self.plans.clone();
        let clock = Instant::now();
        if self.files[k].only_once_per_process() && Arc::ptr_eq(&self.files[0], &self.files[1]) {
            // One instance per process: the other role's instance goes first.
            self.instances[1 - k] = None;
        }
        let mut inst = match self.instances[k].take() {
            Some(mut i) => {
                i.clear_log();
                i.reset()?;
                i
            }
            None => Instance::with_log(
                self.files[k].clone(),
                &format!("savme-{}", ["hf", "lf"][k]),
                self.spec.fmu_log,
            )?,
        };
        let ran = self.run_on(&mut inst, &plans[k], (scenario, phi, fidelity), tracer)?;
        if !ran.stopped {
            // Only a healthy instance is reused: a failed one is freed, and so is one whose FMU
            // asked to end the simulation (some keep that request across a reset, which would
            // end every later run at once, judged on its initial state).
            self.instances[k] = Some(inst);
        }
        let result = SimResult::new(ran.failure, clock.elapsed().as_secs_f64(), ran.work);
        Ok(match ran.robustness {
            Some(r) => result.with_robustness(r),
            None => result,
        })
    }

    /// One run on `inst`, from set-up to terminate in the order FMI prescribes: its verdict,
    /// its work and whether the FMU asked to end the simulation (the instance is then not
    /// reused: some FMUs keep that request across `fmi2Reset` / `fmi3Reset`).
    fn run_on(
        &self,
        inst: &mut Instance,
        plan: &Plan,
        (scenario, phi, fidelity): (&str, &Assignment, &Assignment),
        tracer: Option<&mut Tracer>,
    ) -> Result<Ran, FmuError> {
        let spec = &self.spec;
        let (_, phi_bindings, fixed) = plan
            .scenarios
            .iter()
            .find(|(n, _, _)| n == scenario)
            .ok_or_else(|| FmuError::Spec(format!("unknown scenario `{scenario}`")))?;
        let stop = spec.stop_time;
        let tolerance = match &spec.tolerance {
            None => None,
            Some(Tolerance::Fixed(t)) => Some(*t),
            Some(Tolerance::Of(var)) => Some(positive(fidelity, var, "tolerance")?),
        };
        let start = start_time(inst.file());
        inst.setup(start, Some(stop), tolerance)?;
        let values = [(phi_bindings, phi), (&plan.fidelity, fidelity)];
        // Structural parameters first, in configuration mode (FMI 3.0), then the others.
        if plan.structural {
            inst.configure(|inst| Self::set_values(inst, fixed, &values, true))?;
        }
        Self::set_values(inst, fixed, &values, false)?;
        inst.initialize()?;
        let h = step_size(&spec.step, fidelity)?;
        if let Some(message) = too_many_steps(stop - start, h) {
            return Err(FmuError::Spec(message));
        }
        fixed_step_fits(inst.file(), h, stop)?;
        let mut ran = self.steps(inst, plan, (start, h), tracer)?;
        let work = match &plan.cost {
            Some(v) => inst.number(v)?.max(0.0).round() as u64,
            None => ran.work.unwrap_or(0),
        };
        // A run is at least one unit of work, even one judged at initialisation (a failure at
        // t = 0 with stop_on_failure, a stop request at the first step): the kernel takes no
        // zero cost.
        ran.work = Some(work.max(1));
        inst.terminate()?;
        Ok(ran)
    }

    /// The communication steps of a run, on the grid t = start + n·h (as FMPy computes it: no drift
    /// from accumulating t + h). A communication point within a relative 1e-9 of the target
    /// counts as reached — an FMI 3.0 early return a few ulps before the point does not leave
    /// a near-zero step. After a stop request (`fmi2Discard`, `fmi3Discard`,
    /// `terminateSimulation`) the signals are read at the FMU's last successful time, so that
    /// an FMU that stops *because* of the failure is judged failed. The work is the number of
    /// `doStep` calls that advanced time.
    fn steps(
        &self,
        inst: &mut Instance,
        plan: &Plan,
        (start, h): (f64, f64),
        mut tracer: Option<&mut Tracer>,
    ) -> Result<Ran, FmuError> {
        let (stop, stop_on_failure) = (self.spec.stop_time, self.spec.stop_on_failure);
        let (mut failure, mut margin) = self.failed(inst, plan)?;
        let (mut t, mut n, mut k) = (start, 0u64, 0u64);
        if let Some(tr) = tracer.as_deref_mut() {
            tr.sample(inst, t, failure)?;
        }
        let mut stopped = false;
        while !(failure && stop_on_failure) && t < stop && !close(t, stop) {
            let mut goal = start + (n + 1) as f64 * h;
            if goal > stop && !close(goal, stop) {
                goal = stop;
            }
            match inst.step(t, goal - t)? {
                Step::Completed => t = goal,
                Step::EarlyReturn { time } if time > t => t = time.min(goal),
                Step::EarlyReturn { time } => {
                    return Err(FmuError::Spec(format!(
                        "{}: fmi3DoStep returned early at {time} s, not after the communication point {t} s",
                        inst.file().path.display()
                    )))
                }
                Step::StopRequested { reached, .. } => {
                    if let Some(r) = reached {
                        t = r;
                        k += 1;
                    }
                    stopped = true;
                }
            }
            if !stopped {
                k += 1;
            }
            if close(t, goal) {
                n += 1;
            }
            let (failed, m) = self.failed(inst, plan)?;
            failure |= failed;
            margin = min_margin(margin, m);
            if let Some(tr) = tracer.as_deref_mut() {
                tr.sample(inst, t, failure)?;
            }
            if stopped {
                break;
            }
        }
        Ok(Ran {
            failure,
            work: Some(k),
            stopped,
            robustness: margin,
        })
    }
}

/// What a run found.
struct Ran {
    failure: bool,
    work: Option<u64>,
    /// The FMU asked to end the simulation.
    stopped: bool,
    /// The smallest margin of a threshold failure signal over the communication points
    /// (`≤ 0` = failed), or the smallest value of a Boolean signal's `robustness` output; none
    /// for a Boolean signal without one.
    robustness: Option<f64>,
}

/// The smaller of two margins (a NaN reading leaves the other).
fn min_margin(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, y) => x.or(y),
    }
}

/// `a` and `b` equal within a relative 1e-9 (Python's `math.isclose`, as FMPy compares
/// communication points).
fn close(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// The communication step size of a run.
fn step_size(step: &StepSize, fidelity: &Assignment) -> Result<f64, FmuError> {
    Ok(match step {
        StepSize::Fixed(h) => *h,
        StepSize::RateOf(var) => 1.0 / positive(fidelity, var, "rate")?,
        StepSize::Of(var) => positive(fidelity, var, "step size")?,
    })
}

/// An FMU that declares `canHandleVariableCommunicationStepSize="false"` takes steps of one
/// size only: the stop time must be a whole number of steps `h` (else the last step would be
/// shorter), refused naming the FMU, the step and the stop time.
pub fn fixed_step_fits(file: &FmuDescription, h: f64, stop: f64) -> Result<(), FmuError> {
    let variable = file
        .model
        .co_simulation
        .as_ref()
        .is_none_or(|c| c.can_handle_variable_communication_step_size);
    let start = start_time(file);
    let span = stop - start;
    let steps = (span / h).round();
    if variable || (steps >= 1.0 && close(start + steps * h, stop)) {
        return Ok(());
    }
    let from = if start == 0.0 {
        String::new()
    } else {
        format!(" from the start time {start} s")
    };
    Err(FmuError::Spec(format!(
        "{}: the FMU declares canHandleVariableCommunicationStepSize=\"false\" (one step size only), \
         but the stop time {stop} s is not a whole number of steps of {h} s{from}: \
         choose a step that divides the stop time (e.g. {}) or a stop time that is a multiple of it (e.g. {})",
        file.path.display(),
        round12(span / (span / h).ceil()),
        round12(start + steps.max(1.0) * h),
    )))
}

/// Where a run of `file` starts: its `DefaultExperiment startTime` (as in FMPy), else 0.
pub fn start_time(file: &FmuDescription) -> f64 {
    file.model
        .default_experiment
        .start_time
        .filter(|t| t.is_finite())
        .unwrap_or(0.0)
}

/// `x` to 12 significant digits, for a suggestion a user can type (9.9, not 9.899999999999999).
fn round12(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(11 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// The most communication steps one run may take: 10⁹ (a smaller step, e.g. `step = 1e-300`
/// with `stop_time = 12`, gives a run that never ends).
pub const MAX_STEPS: f64 = 1e9;

/// Why a run of `stop_time` seconds in steps of `step` seconds cannot finish (more than
/// [`MAX_STEPS`] steps), if it cannot.
pub fn too_many_steps(stop_time: f64, step: f64) -> Option<String> {
    let steps = stop_time / step;
    (steps > MAX_STEPS || steps.is_nan()).then(|| {
        format!(
            "step size {step:e} s makes {steps:.3e} steps to the stop time {stop_time} s, more than the \
             maximum of {MAX_STEPS:e} steps a run may take: a run that cannot finish"
        )
    })
}

/// The positive, finite value of fidelity variable `var` (a `what`: rate, step size, …).
fn positive(fidelity: &Assignment, var: &str, what: &str) -> Result<f64, FmuError> {
    let x = fidelity
        .get_f64(var)
        .ok_or_else(|| FmuError::MissingValue {
            variable: var.into(),
        })?;
    if x > 0.0 && x.is_finite() {
        Ok(x)
    } else {
        Err(FmuError::Spec(format!(
            "`{var}` = {x} is not a positive {what}"
        )))
    }
}

impl Simulator for FmuSimulator {
    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        self.run(role, scenario, phi, fidelity)
            .map_err(|e| SimError::Failed(e.to_string()))
    }
}

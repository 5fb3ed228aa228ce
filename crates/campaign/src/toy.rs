//! A small paired simulator for trying savme out in seconds: an ego vehicle closing on an
//! obstacle, an emergency-braking system under test, and four fidelity settings that really
//! change both the work done and the result.
//!
//! It is the simulator `savme example-config` and the `serve` examples use, and a fast,
//! deterministic workload for tests (the paper's camera/lidar driving simulator is the
//! `savme-sim` crate). The physics is one-dimensional:
//!
//! * `stopped_obstacle` — the ego drives at `ego_speed` towards a standing obstacle `gap`
//!   metres ahead.
//! * `braking_lead` — a lead vehicle driving at the ego's speed, `headway` metres ahead, brakes
//!   at `lead_decel` after one second.
//!
//! The system under test measures the gap at every simulation step (with range noise), estimates
//! the time to collision from the last two measurements, and brakes at 7 m/s² once it falls
//! below 2 s. A collision (gap ≤ 0) within the horizon is a failure.
//!
//! Fidelity settings (θ_HF marked with a star): `rate_hz` {5, 10, 20, 50, 100\*} — the step;
//! `integrator` {euler, rk4\*} — explicit Euler overshoots while braking; `disable_sensor_noise`
//! {true, false\*}; `horizon_s` in 3–15 s, 15\* — shorter runs miss late collisions.
//! Work units = force evaluations + noise samples.

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;
use savme_kernel::{
    Assignment, KernelBuilder, Role, Scale, SimError, SimResult, Simulator, Space, Variable,
};
use std::time::Instant;

/// The toy's scenarios, in order.
pub const SCENARIOS: [&str; 2] = ["stopped_obstacle", "braking_lead"];

/// The fidelity space and θ_HF.
pub fn fidelity() -> (Space, Assignment) {
    let space = Space::new(vec![
        Variable::discrete("rate_hz", [5, 10, 20, 50, 100]),
        Variable::discrete("integrator", ["euler", "rk4"]),
        Variable::boolean("disable_sensor_noise"),
        Variable::continuous("horizon_s", 3.0, 15.0, 4, Scale::Linear),
    ])
    .expect("valid fidelity space");
    let hf = Assignment::new()
        .with("rate_hz", 100)
        .with("integrator", "rk4")
        .with("disable_sensor_noise", false)
        .with("horizon_s", 15.0);
    (space, hf)
}

/// The φ-space of a scenario.
pub fn phi_space(scenario: &str) -> Option<Space> {
    let lin = |n: &str, lo, hi| Variable::continuous(n, lo, hi, 6, Scale::Linear);
    let vars = match scenario {
        "stopped_obstacle" => vec![lin("ego_speed", 5.0, 35.0), lin("gap", 10.0, 120.0)],
        "braking_lead" => vec![
            lin("ego_speed", 10.0, 35.0),
            lin("headway", 8.0, 60.0),
            lin("lead_decel", 1.0, 9.0),
        ],
        _ => return None,
    };
    Some(Space::new(vars).expect("valid φ-space"))
}

/// A kernel builder with the toy's fidelity space and both scenarios at equal weight.
pub fn kernel_builder() -> KernelBuilder {
    let (space, hf) = fidelity();
    SCENARIOS
        .iter()
        .fold(savme_kernel::Kernel::builder(space, hf), |b, s| {
            b.scenario(s, phi_space(s).expect("known scenario"), 1.0)
        })
}

/// The toy simulator. Stateless; cheap to create one per thread.
#[derive(Debug, Clone, Copy, Default)]
pub struct ToySimulator;

const EGO_DECEL: f64 = 7.0;
const TTC_THRESHOLD: f64 = 2.0;
const NOISE_SD: f64 = 0.02;

fn number(a: &Assignment, name: &str) -> Result<f64, SimError> {
    let v = a.get(name).ok_or_else(|| SimError::MissingVariable {
        variable: name.into(),
    })?;
    v.as_f64().ok_or_else(|| SimError::BadValue {
        variable: name.into(),
        value: v.to_string(),
        expected: "a number".into(),
    })
}

/// A run's scenario inputs: the ego's initial speed, the initial gap and, for `braking_lead`,
/// the lead's deceleration.
struct Scenario {
    v0: f64,
    gap0: f64,
    lead_decel: Option<f64>,
}

impl Scenario {
    /// Reads φ of `scenario` (unknown scenarios and missing or non-numeric values are errors).
    fn read(scenario: &str, phi: &Assignment) -> Result<Scenario, SimError> {
        let v0 = number(phi, "ego_speed")?;
        let (gap0, lead_decel) = match scenario {
            "stopped_obstacle" => (number(phi, "gap")?, None),
            "braking_lead" => (number(phi, "headway")?, Some(number(phi, "lead_decel")?)),
            other => return Err(SimError::UnknownScenario(other.into())),
        };
        Ok(Scenario {
            v0,
            gap0,
            lead_decel,
        })
    }
}

/// The fidelity effects: the step, the number of steps in the horizon, the integrator and
/// whether the range measurements are noisy.
struct Fidelity {
    dt: f64,
    steps: u64,
    rk4: bool,
    noise: bool,
}

impl Fidelity {
    /// Reads and checks θ.
    fn read(fidelity: &Assignment) -> Result<Fidelity, SimError> {
        let rate = number(fidelity, "rate_hz")?;
        let horizon = number(fidelity, "horizon_s")?;
        let rk4 = match fidelity.get("integrator").and_then(|v| v.as_label()) {
            Some("rk4") => true,
            Some("euler") => false,
            _ => {
                return Err(SimError::BadValue {
                    variable: "integrator".into(),
                    value: fidelity
                        .get("integrator")
                        .map_or("nothing".into(), ToString::to_string),
                    expected: "euler or rk4".into(),
                })
            }
        };
        let noise = !fidelity.get_bool("disable_sensor_noise").ok_or_else(|| {
            SimError::MissingVariable {
                variable: "disable_sensor_noise".into(),
            }
        })?;
        if !(rate > 0.0 && horizon > 0.0) {
            return Err(SimError::BadValue {
                variable: "rate_hz/horizon_s".into(),
                value: format!("{rate}/{horizon}"),
                expected: "positive numbers".into(),
            });
        }
        Ok(Fidelity {
            dt: 1.0 / rate,
            steps: (horizon * rate).round() as u64,
            rk4,
            noise,
        })
    }
}

/// The system under test: brakes (for good) once the time to collision estimated from the
/// last two measured gaps falls below [`TTC_THRESHOLD`].
#[derive(Default)]
struct Braking {
    braking: bool,
    last_measure: Option<f64>,
}

impl Braking {
    /// Takes the gap measured at this step; returns whether the ego brakes.
    fn decide(&mut self, measured: f64, dt: f64) -> bool {
        if let Some(prev) = self.last_measure {
            let closing = (prev - measured) / dt;
            if closing > 0.0 && measured / closing < TTC_THRESHOLD {
                self.braking = true;
            }
        }
        self.last_measure = Some(measured);
        self.braking
    }
}

/// Advances a vehicle at position `x` and speed `v` by one step `dt` under the constant
/// acceleration `a`; a speed never goes below zero. Returns the work (force evaluations).
fn integrate(x: &mut f64, v: &mut f64, a: f64, dt: f64, rk4: bool) -> u64 {
    if rk4 {
        // Four evaluations of the (constant) force: exact for a constant acceleration.
        let stop = if a < 0.0 { (*v / -a).min(dt) } else { dt };
        *x += *v * stop + 0.5 * a * stop * stop;
        *v = (*v + a * stop).max(0.0);
        4
    } else {
        // Explicit Euler: position from the speed at the start of the step.
        *x += *v * dt;
        *v = (*v + a * dt).max(0.0);
        1
    }
}

/// Runs the scenario to the horizon or the first collision; returns whether it collided and
/// the work (force evaluations + noise samples).
fn collides(s: &Scenario, f: &Fidelity, rng: &mut Pcg64, normal: &Normal<f64>) -> (bool, u64) {
    let dt = f.dt;
    // State: ego position and speed, lead position and speed.
    let (mut xe, mut ve) = (0.0, s.v0);
    let (mut xl, mut vl) = (s.gap0, if s.lead_decel.is_some() { s.v0 } else { 0.0 });
    let mut sut = Braking::default();
    let mut work = 0u64;
    for k in 0..f.steps {
        let t = k as f64 * dt;
        // Perception and decision at every step.
        let measured = (xl - xe) + if f.noise { normal.sample(rng) } else { 0.0 };
        work += u64::from(f.noise);
        let braking = sut.decide(measured, dt);
        // Accelerations during this step (piecewise constant).
        let ae = if braking && ve > 0.0 { -EGO_DECEL } else { 0.0 };
        let al = match s.lead_decel {
            Some(d) if t >= 1.0 && vl > 0.0 => -d,
            _ => 0.0,
        };
        work += integrate(&mut xe, &mut ve, ae, dt, f.rk4);
        work += integrate(&mut xl, &mut vl, al, dt, f.rk4);
        if xl - xe <= 0.0 {
            return (true, work);
        }
    }
    (false, work)
}

impl Simulator for ToySimulator {
    fn simulate_as(
        &mut self,
        _role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        let start = Instant::now();
        let s = Scenario::read(scenario, phi)?;
        let f = Fidelity::read(fidelity)?;
        // Same φ, same noise: a trial's HF and LF runs see one random stream.
        let mut rng = Pcg64::seed_from_u64(phi.stable_hash(scenario));
        let normal = Normal::new(0.0, NOISE_SD).map_err(|e| SimError::Failed(e.to_string()))?;
        let (failure, work) = collides(&s, &f, &mut rng, &normal);
        Ok(SimResult::new(
            failure,
            start.elapsed().as_secs_f64(),
            Some(work.max(1)),
        ))
    }
}

/// A simulator that sleeps for a fixed time, then runs `inner`: a stand-in for a vendor
/// simulator whose runs take long but use no CPU (for trying and benchmarking distribution).
/// The sleep counts in the measured wall-clock time, not in the work units.
#[derive(Debug, Clone, Copy, Default)]
pub struct Sleeping<S> {
    /// The simulator run after the sleep.
    pub inner: S,
    /// How long each run sleeps first.
    pub sleep: std::time::Duration,
}

impl<S: Simulator> Simulator for Sleeping<S> {
    fn simulate_as(
        &mut self,
        role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        let start = Instant::now();
        std::thread::sleep(self.sleep);
        let mut r = self.inner.simulate_as(role, scenario, phi, fidelity)?;
        r.wall_seconds = start.elapsed().as_secs_f64();
        Ok(r)
    }
}

/// A simulator that does nothing: every run passes, costs one work unit and no time (to
/// measure what savme itself costs per trial).
#[derive(Debug, Clone, Copy, Default)]
pub struct NullSimulator;

impl Simulator for NullSimulator {
    fn simulate_as(
        &mut self,
        _role: Role,
        _scenario: &str,
        _phi: &Assignment,
        _fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        Ok(SimResult::new(false, 0.0, Some(1)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(scenario: &str, phi: &Assignment, theta: &Assignment) -> SimResult {
        ToySimulator
            .simulate_as(Role::High, scenario, phi, theta)
            .unwrap()
    }

    #[test]
    fn fast_approach_collides_and_slow_one_stops() {
        let (_, hf) = fidelity();
        let fast = Assignment::new().with("ego_speed", 34.0).with("gap", 100.0);
        let slow = Assignment::new().with("ego_speed", 10.0).with("gap", 100.0);
        assert!(run("stopped_obstacle", &fast, &hf).failure);
        assert!(!run("stopped_obstacle", &slow, &hf).failure);
    }

    #[test]
    fn every_fidelity_setting_changes_work_and_some_outcome() {
        let (space, hf) = fidelity();
        let cheap = [
            ("rate_hz", savme_kernel::Value::Int(5)),
            ("integrator", "euler".into()),
            ("disable_sensor_noise", true.into()),
            ("horizon_s", 3.0.into()),
        ];
        // Fine in speed: some settings shift the failure boundary by centimetres per second.
        let grid: Vec<Assignment> = (0..600)
            .flat_map(|i| {
                [15.0, 40.0, 80.0, 110.0].map(move |gap| {
                    Assignment::new()
                        .with("ego_speed", 5.0 + 0.05 * i as f64)
                        .with("gap", gap)
                })
            })
            .collect();
        for (name, value) in cheap {
            let lf = hf.clone().with(name, value);
            assert!(space.arms_of(&lf).is_ok());
            let mut work_changed = false;
            let mut outcome_changed = false;
            for phi in &grid {
                let a = run("stopped_obstacle", phi, &hf);
                let b = run("stopped_obstacle", phi, &lf);
                work_changed |= a.work != b.work;
                outcome_changed |= a.failure != b.failure;
            }
            assert!(work_changed, "{name} does not change the work");
            assert!(outcome_changed, "{name} never changes the outcome");
        }
    }

    #[test]
    fn bad_inputs_are_named() {
        let (_, hf) = fidelity();
        let phi = Assignment::new().with("ego_speed", 10.0);
        let e = ToySimulator
            .simulate_as(Role::High, "stopped_obstacle", &phi, &hf)
            .unwrap_err();
        assert!(e.to_string().contains("gap"), "{e}");
        let e = ToySimulator
            .simulate_as(Role::High, "nope", &phi, &hf)
            .unwrap_err();
        assert!(matches!(e, SimError::UnknownScenario(_)));
        let bad = hf.clone().with("integrator", "leapfrog");
        let full = phi.with("gap", 50.0);
        let e = ToySimulator
            .simulate_as(Role::High, "stopped_obstacle", &full, &bad)
            .unwrap_err();
        assert!(e.to_string().contains("integrator"), "{e}");
    }
}

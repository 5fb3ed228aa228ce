//! One simulation run: the ego (Stanley + PI + the system under test) and the scripted intruder,
//! stepped at the simulation rate, with swept box-collision checks between steps.

use crate::control::{SpeedPi, Stanley};
use crate::scenario::{self, ScenarioInfo, Setup};
use crate::sut::{IdealPerception, Perception, Planner, Sensing};
use crate::vehicle::{self, VehicleState};
use savme_kernel::{paper, Assignment, SimError, SimResult, Simulator};
use std::time::Instant;

/// Deceleration of the ego's emergency braking (a constant braking force), m/s².
pub const BRAKE_DECEL: f64 = 8.0;
/// Largest relative displacement between two collision checks, metres.
const SWEEP_STEP: f64 = 0.5;

/// The settings of a run that come from θ. The sensor settings of Table I are validated but
/// act only through a sensor-based perception.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fidelity {
    /// Physics, control and perception rate, Hz.
    pub rate_hz: f64,
}

impl Fidelity {
    /// Reads θ: a complete assignment of the paper's 16 fidelity settings, each in range.
    pub fn from_assignment(theta: &Assignment) -> Result<Fidelity, SimError> {
        paper::fidelity_space(1)
            .arms_of(theta)
            .map_err(|e| SimError::BadValue {
                variable: "fidelity".into(),
                value: theta.to_string(),
                expected: e.to_string(),
            })?;
        let rate_hz =
            theta
                .get_f64("simulation_rate_hz")
                .ok_or_else(|| SimError::MissingVariable {
                    variable: "simulation_rate_hz".into(),
                })?;
        Ok(Fidelity { rate_hz })
    }
}

/// One recorded step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Time, s.
    pub time: f64,
    /// The ego.
    pub ego: VehicleState,
    /// The intruder.
    pub intruder: VehicleState,
    /// The ego was braking during the step.
    pub braking: bool,
    /// The obstacle position the perception reported, if any.
    pub measured: Option<nalgebra::Point2<f64>>,
}

/// The outcome of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// The ego and the intruder collided.
    pub failure: bool,
    /// Smallest distance between the two bodies, metres (0 on a collision).
    pub min_distance: f64,
    /// When they collided, seconds.
    pub collision_time: Option<f64>,
    /// Simulation steps taken.
    pub steps: u64,
    /// Deterministic work units: steps + collision checks + perception work.
    pub work: u64,
    /// Measured wall-clock time, seconds.
    pub wall_seconds: f64,
    /// Every step, when asked for.
    pub trajectory: Option<Vec<Frame>>,
}

fn intruder_at(setup: &Setup, t: f64) -> VehicleState {
    let (s, v) = setup.intruder_profile.at(t);
    let s = setup.intruder_start + s;
    VehicleState::from_center(
        setup.intruder_path.point_at(s),
        setup.intruder_path.heading_at(s),
        v,
    )
}

/// Runs scenario `info` with parameters `phi` under `fidelity`, perceiving with `perception`.
/// `record` keeps every step in [`RunResult::trajectory`]; it costs nothing when false.
pub fn run(
    info: &'static ScenarioInfo,
    phi: &Assignment,
    fidelity: Fidelity,
    perception: &mut dyn Perception,
    record: bool,
) -> Result<RunResult, SimError> {
    let clock = Instant::now();
    let setup = scenario::setup(info, phi)?;
    if !(fidelity.rate_hz > 0.0 && fidelity.rate_hz.is_finite()) {
        return Err(SimError::BadValue {
            variable: "simulation_rate_hz".into(),
            value: fidelity.rate_hz.to_string(),
            expected: "a positive rate".into(),
        });
    }
    let dt = 1.0 / fidelity.rate_hz;
    let steps = (info.duration * fidelity.rate_hz).ceil() as u64;
    let start = setup.ego_path.point_at(setup.ego_start);
    let mut ego = VehicleState::from_center(
        start,
        setup.ego_path.heading_at(setup.ego_start),
        setup.ego_speed,
    );
    let (mut stanley, mut pi, mut planner) =
        (Stanley::default(), SpeedPi::default(), Planner::default());
    let mut trajectory = record.then(Vec::new);
    let mut min_distance = f64::INFINITY;
    let mut collision_time = None;
    let mut checks = 0u64;
    let mut taken = 0u64;
    'run: for k in 0..steps {
        taken += 1;
        let t = k as f64 * dt;
        let intruder = intruder_at(&setup, t);
        let measured = perception.perceive(&Sensing {
            time: t,
            ego: &ego,
            obstacle: &intruder,
        });
        let braking = planner.decide(t, &ego, measured);
        let steer = stanley.steer(&ego, &setup.ego_path, dt);
        let accel = if braking {
            -BRAKE_DECEL
        } else {
            pi.accel(setup.ego_speed, ego.speed, dt)
        };
        if let Some(tr) = trajectory.as_mut() {
            tr.push(Frame {
                time: t,
                ego,
                intruder,
                braking,
                measured,
            });
        }
        // Advance, checking for contact along the way: the ego's motion is re-integrated
        // exactly to each check point, the intruder's read from its script.
        let mut after = ego;
        after.step(steer, accel, dt);
        let next_intruder = intruder_at(&setup, t + dt);
        let relative =
            ((after.center() - ego.center()) - (next_intruder.center() - intruder.center())).norm()
                + (after.heading - ego.heading).abs() * vehicle::LENGTH;
        let n = ((relative / SWEEP_STEP).ceil() as u64).max(1);
        for j in 1..=n {
            let f = j as f64 / n as f64;
            let (e, i) = if j == n {
                (after, next_intruder)
            } else {
                let mut e = ego;
                e.step(steer, accel, dt * f);
                (e, intruder_at(&setup, t + dt * f))
            };
            checks += 1;
            let d = vehicle::distance(&e, &i);
            min_distance = min_distance.min(d);
            if d <= 0.0 || vehicle::collide(&e, &i) {
                min_distance = 0.0;
                collision_time = Some(t + dt * f);
                if let Some(tr) = trajectory.as_mut() {
                    tr.push(Frame {
                        time: t + dt * f,
                        ego: e,
                        intruder: i,
                        braking,
                        measured: None,
                    });
                }
                break 'run;
            }
        }
        ego = after;
    }
    Ok(RunResult {
        failure: collision_time.is_some(),
        min_distance,
        collision_time,
        steps: taken,
        work: taken + checks + perception.work(),
        wall_seconds: clock.elapsed().as_secs_f64(),
        trajectory,
    })
}

/// The bundled driving simulator with idealised perception (position noise of `noise_sd`
/// metres), as a [`Simulator`] for the kernel. Scenario names are those of
/// [`scenario::SCENARIOS`] (or their numbers).
#[derive(Debug, Clone, Copy)]
pub struct DrivingSimulator {
    /// Perception noise, metres (standard deviation per axis).
    pub noise_sd: f64,
}

impl Default for DrivingSimulator {
    fn default() -> Self {
        DrivingSimulator { noise_sd: 0.1 }
    }
}

impl DrivingSimulator {
    /// Runs one scenario and returns the full result.
    pub fn run(
        &self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
        record: bool,
    ) -> Result<RunResult, SimError> {
        let info =
            scenario::find(scenario).ok_or_else(|| SimError::UnknownScenario(scenario.into()))?;
        let fidelity = Fidelity::from_assignment(fidelity)?;
        let mut perception = IdealPerception::new()
            .with_noise(self.noise_sd, phi.stable_hash(info.name))
            .with_occlusion(crate::world::World::shared(info.layout));
        run(info, phi, fidelity, &mut perception, record)
    }
}

impl Simulator for DrivingSimulator {
    fn simulate(
        &mut self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        let r = DrivingSimulator::run(self, scenario, phi, fidelity, false)?;
        Ok(SimResult::new(r.failure, r.wall_seconds, Some(r.work)))
    }
}

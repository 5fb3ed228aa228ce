//! One simulation run: the ego (Stanley + PI + the system under test) and the scripted intruder,
//! stepped at the simulation rate, with swept box-collision checks between steps.

use crate::control::{SpeedPi, Stanley};
use crate::perception::{SensorFrame, SensorPerception};
use crate::scenario::{self, ScenarioInfo, Setup};
use crate::settings::Settings;
use crate::sut::{IdealPerception, Perception, Planner, Sensing};
use crate::vehicle::{self, VehicleState};
use savme_kernel::{Assignment, Role, SimError, SimResult, Simulator};
use std::time::Instant;

/// Deceleration of the ego's emergency braking (a constant braking force), m/s².
pub const BRAKE_DECEL: f64 = 8.0;
/// Half the diagonal of a vehicle's footprint, metres.
const HALF_DIAGONAL: f64 = 2.66;
/// Largest relative displacement between two collision checks, metres.
const SWEEP_STEP: f64 = 0.5;

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
    /// The planner's predicted closest approach, if it had a detection.
    pub predicted: Option<crate::sut::Prediction>,
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
    /// Every step's camera image, lidar cloud and detection, when asked for (sensor perception
    /// only).
    pub sensor_frames: Option<Vec<SensorFrame>>,
    /// Where [`RunResult::min_distance`] was measured (the swept contact check's sample, which
    /// may fall between two steps; the collision itself on a collision), when recording.
    pub closest: Option<Closest>,
}

/// The closest approach of a run: the sample of the swept contact check at which the bodies
/// were nearest (see [`RunResult::closest`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// Time, s.
    pub time: f64,
    /// Distance between the bodies there, metres (0 on a collision).
    pub distance: f64,
    /// The ego there.
    pub ego: VehicleState,
    /// The intruder there.
    pub intruder: VehicleState,
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

/// What the ego does during a step: steering, acceleration, and whether it brakes.
#[derive(Debug, Clone, Copy)]
struct Control {
    steer: f64,
    accel: f64,
    braking: bool,
}

/// A run in progress, advanced one simulation step at a time (what the FMU export drives);
/// [`run`] steps it to the end.
#[derive(Debug, Clone)]
pub struct Stepper<P: Perception> {
    setup: Setup,
    perception: P,
    dt: f64,
    steps: u64,
    ego: VehicleState,
    stanley: Stanley,
    pi: SpeedPi,
    planner: Planner,
    trajectory: Option<Vec<Frame>>,
    min_distance: f64,
    closest: Option<Closest>,
    collision_time: Option<f64>,
    checks: u64,
    taken: u64,
    finished: bool,
    busy_seconds: f64,
}

impl<P: Perception> Stepper<P> {
    /// Sets up scenario `info` with parameters `phi` at `rate_hz`, perceiving with
    /// `perception`; `record` keeps every step (see [`RunResult::trajectory`]).
    pub fn new(
        info: &'static ScenarioInfo,
        phi: &Assignment,
        rate_hz: f64,
        perception: P,
        record: bool,
    ) -> Result<Self, SimError> {
        let clock = Instant::now();
        let setup = scenario::setup(info, phi)?;
        if !(rate_hz > 0.0 && rate_hz.is_finite()) {
            return Err(SimError::BadValue {
                variable: "simulation_rate_hz".into(),
                value: rate_hz.to_string(),
                expected: "a positive rate".into(),
            });
        }
        let start = setup.ego_path.point_at(setup.ego_start);
        let ego = VehicleState::from_center(
            start,
            setup.ego_path.heading_at(setup.ego_start),
            setup.ego_speed,
        );
        Ok(Stepper {
            dt: 1.0 / rate_hz,
            steps: (info.duration * rate_hz).ceil() as u64,
            ego,
            setup,
            perception,
            stanley: Stanley::default(),
            pi: SpeedPi::default(),
            planner: Planner::default(),
            trajectory: record.then(Vec::new),
            min_distance: f64::INFINITY,
            closest: None,
            collision_time: None,
            checks: 0,
            taken: 0,
            finished: false,
            busy_seconds: clock.elapsed().as_secs_f64(),
        })
    }

    /// Simulated time reached, seconds.
    pub fn time(&self) -> f64 {
        self.taken as f64 * self.dt
    }

    /// The simulation step, seconds.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The run has ended (collision, or the scenario's duration reached).
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// Collided so far.
    pub fn failure(&self) -> bool {
        self.collision_time.is_some()
    }

    /// Smallest body distance so far (infinite before the first check).
    pub fn min_distance(&self) -> f64 {
        self.min_distance
    }

    /// When the collision happened.
    pub fn collision_time(&self) -> Option<f64> {
        self.collision_time
    }

    /// Work units so far.
    pub fn work(&self) -> u64 {
        self.taken + self.checks + self.perception.work()
    }

    /// Steps taken so far.
    pub fn steps_taken(&self) -> u64 {
        self.taken
    }

    /// The perception.
    pub fn perception(&self) -> &P {
        &self.perception
    }

    /// The perception, mutably (to take recorded frames).
    pub fn perception_mut(&mut self) -> &mut P {
        &mut self.perception
    }

    /// One simulation step: perceive, plan, control, advance with swept collision checks.
    /// Does nothing once finished; returns whether the run is finished.
    pub fn step(&mut self) -> bool {
        if self.finished {
            return true;
        }
        let clock = Instant::now();
        self.advance();
        self.busy_seconds += clock.elapsed().as_secs_f64();
        self.finished
    }

    /// One step: decide ([`Self::perceive_plan_control`]), then move with the swept contact
    /// checks ([`Self::sweep`]); the run finishes on a collision or at its last step.
    fn advance(&mut self) {
        let k = self.taken;
        if k >= self.steps {
            self.finished = true;
            return;
        }
        self.taken += 1;
        let t = k as f64 * self.dt;
        let ego = self.ego;
        let intruder = intruder_at(&self.setup, t);
        let control = self.perceive_plan_control(t, ego, intruder);
        let collided = self.sweep(t, ego, intruder, control);
        if collided || self.taken >= self.steps {
            self.finished = true;
        }
    }

    /// The step's decision at time `t`: perceive the intruder, plan (brake or not), steer and
    /// set the speed; records the step's frame when recording.
    #[inline]
    fn perceive_plan_control(
        &mut self,
        t: f64,
        ego: VehicleState,
        intruder: VehicleState,
    ) -> Control {
        let (dt, setup) = (self.dt, &self.setup);
        let measured = self.perception.perceive(&Sensing {
            time: t,
            ego: &ego,
            obstacle: &intruder,
        });
        let braking = self.planner.decide(t, &ego, measured);
        let predicted = self.planner.prediction();
        let steer = self.stanley.steer(&ego, &setup.ego_path, dt);
        let accel = if braking {
            -BRAKE_DECEL
        } else {
            self.pi.accel(setup.ego_speed, ego.speed, dt)
        };
        if let Some(tr) = self.trajectory.as_mut() {
            tr.push(Frame {
                time: t,
                ego,
                intruder,
                braking,
                measured,
                predicted,
            });
        }
        Control {
            steer,
            accel,
            braking,
        }
    }

    /// Advances the ego from `ego` under `control` over the step from `t`, checking for contact
    /// along the way: the ego's motion is re-integrated exactly to each check point, the
    /// intruder's read from its script. Returns whether they collided (the run then ends there);
    /// otherwise the ego has moved to the end of the step.
    #[inline]
    fn sweep(
        &mut self,
        t: f64,
        ego: VehicleState,
        intruder: VehicleState,
        control: Control,
    ) -> bool {
        let (dt, setup) = (self.dt, &self.setup);
        let Control {
            steer,
            accel,
            braking,
        } = control;
        let mut after = ego;
        after.step(steer, accel, dt);
        let next_intruder = intruder_at(setup, t + dt);
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
                (e, intruder_at(setup, t + dt * f))
            };
            self.checks += 1;
            // Bodies are at least (centre distance − two half-diagonals) apart: only a sample
            // that could lower the minimum needs the exact (GJK) distance.
            let centres = (e.center() - i.center()).norm();
            if centres - 2.0 * HALF_DIAGONAL >= self.min_distance {
                continue;
            }
            let d = vehicle::distance(&e, &i);
            let time = t + dt * f;
            if d < self.min_distance && self.trajectory.is_some() {
                self.closest = Some(Closest {
                    time,
                    distance: d,
                    ego: e,
                    intruder: i,
                });
            }
            self.min_distance = self.min_distance.min(d);
            if d <= 0.0 || vehicle::collide(&e, &i) {
                self.min_distance = 0.0;
                if self.trajectory.is_some() {
                    self.closest = Some(Closest {
                        time,
                        distance: 0.0,
                        ego: e,
                        intruder: i,
                    });
                }
                self.collision_time = Some(time);
                if let Some(tr) = self.trajectory.as_mut() {
                    tr.push(Frame {
                        time,
                        ego: e,
                        intruder: i,
                        braking,
                        measured: None,
                        predicted: None,
                    });
                }
                return true;
            }
        }
        self.ego = after;
        false
    }

    /// The result so far (of the whole run once finished); the wall time counts set-up and
    /// steps only.
    pub fn result(&mut self) -> RunResult {
        RunResult {
            failure: self.collision_time.is_some(),
            min_distance: self.min_distance,
            collision_time: self.collision_time,
            steps: self.taken,
            work: self.work(),
            wall_seconds: self.busy_seconds,
            trajectory: self.trajectory.take(),
            sensor_frames: None,
            closest: self.closest,
        }
    }
}

/// Runs scenario `info` with parameters `phi` at `rate_hz`, perceiving with `perception`.
/// `record` keeps every step in [`RunResult::trajectory`]; it costs nothing when false.
pub fn run(
    info: &'static ScenarioInfo,
    phi: &Assignment,
    rate_hz: f64,
    perception: &mut dyn Perception,
    record: bool,
) -> Result<RunResult, SimError> {
    let clock = Instant::now();
    let mut s = Stepper::new(info, phi, rate_hz, perception, record)?;
    while !s.step() {}
    let mut r = s.result();
    r.wall_seconds = clock.elapsed().as_secs_f64();
    Ok(r)
}

/// Which perception the system under test uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PerceptionMode {
    /// Camera + lidar with the 16 fidelity settings (the paper's stack).
    Sensors,
    /// Ground truth with Gaussian noise of this many metres, field of view and occlusion; the
    /// sensor settings have no effect.
    Ideal {
        /// Noise standard deviation per axis, metres.
        noise_sd: f64,
    },
}

/// The bundled driving simulator as a [`Simulator`] for the kernel. Scenario names are those of
/// [`scenario::SCENARIOS`] (or their numbers).
#[derive(Debug, Clone, Copy)]
pub struct DrivingSimulator {
    /// The perception of the system under test.
    pub perception: PerceptionMode,
}

impl Default for DrivingSimulator {
    /// Camera + lidar perception.
    fn default() -> Self {
        DrivingSimulator {
            perception: PerceptionMode::Sensors,
        }
    }
}

impl DrivingSimulator {
    /// With idealised perception (noise 0.1 m): fast, and blind to the sensor settings.
    pub fn ideal() -> Self {
        DrivingSimulator {
            perception: PerceptionMode::Ideal { noise_sd: 0.1 },
        }
    }

    /// The perception's name as the CLI and the outputs give it: `sensors` or `ideal`.
    pub fn perception_name(&self) -> &'static str {
        match self.perception {
            PerceptionMode::Sensors => "sensors",
            PerceptionMode::Ideal { .. } => "ideal",
        }
    }

    /// The fidelity settings this simulator's perception never reads: with idealised
    /// perception every camera and lidar setting (only `simulation_rate_hz` changes a run);
    /// none with sensors.
    ///
    /// ```
    /// use savme_sim::sim::DrivingSimulator;
    /// assert!(DrivingSimulator::default().ignored_settings().is_empty());
    /// let ignored = DrivingSimulator::ideal().ignored_settings();
    /// assert_eq!(ignored.len(), 15);
    /// assert!(!ignored.contains(&"simulation_rate_hz".to_string()));
    /// assert!(ignored.contains(&"camera_disable_shadows".to_string()));
    /// ```
    pub fn ignored_settings(&self) -> Vec<String> {
        match self.perception {
            PerceptionMode::Sensors => Vec::new(),
            PerceptionMode::Ideal { .. } => crate::fidelity::space(1)
                .variables()
                .iter()
                .map(|v| v.name.to_string())
                .filter(|n| n != "simulation_rate_hz")
                .collect(),
        }
    }

    /// The run of one scenario, ready to step (what [`DrivingSimulator::run`] and the FMU
    /// export drive): the same set-up, perception and noise seed either way.
    pub fn stepper(
        &self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
        record: bool,
    ) -> Result<Stepper<Perceiver>, SimError> {
        let info =
            scenario::find(scenario).ok_or_else(|| SimError::UnknownScenario(scenario.into()))?;
        let settings = Settings::from_assignment(fidelity)?;
        let world = crate::world::World::shared(info.layout);
        let seed = phi.stable_hash(info.name);
        let perceiver = match self.perception {
            PerceptionMode::Ideal { noise_sd } => Perceiver::Ideal(
                IdealPerception::new()
                    .with_noise(noise_sd, seed)
                    .with_occlusion(world),
            ),
            PerceptionMode::Sensors => {
                let p = SensorPerception::new(world, settings, seed);
                Perceiver::Sensors(if record { p.recording() } else { p })
            }
        };
        Stepper::new(info, phi, settings.rate_hz, perceiver, record)
    }

    /// Runs one scenario and returns the full result; `record` keeps the trajectory (and, with
    /// sensors, every frame).
    pub fn run(
        &self,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
        record: bool,
    ) -> Result<RunResult, SimError> {
        let clock = Instant::now();
        let mut s = self.stepper(scenario, phi, fidelity, record)?;
        while !s.step() {}
        let mut r = s.result();
        if let Perceiver::Sensors(p) = s.perception_mut() {
            r.sensor_frames = p.frames.take();
        }
        r.wall_seconds = clock.elapsed().as_secs_f64();
        Ok(r)
    }
}

/// The perception of a [`DrivingSimulator`] run.
#[derive(Debug, Clone)]
pub enum Perceiver {
    /// Camera + lidar.
    Sensors(SensorPerception),
    /// Ground truth + noise.
    Ideal(IdealPerception),
}

impl Perception for Perceiver {
    fn perceive(&mut self, sensing: &Sensing) -> Option<nalgebra::Point2<f64>> {
        match self {
            Perceiver::Sensors(p) => p.perceive(sensing),
            Perceiver::Ideal(p) => p.perceive(sensing),
        }
    }

    fn work(&self) -> u64 {
        match self {
            Perceiver::Sensors(p) => p.work(),
            Perceiver::Ideal(p) => p.work(),
        }
    }
}

impl Simulator for DrivingSimulator {
    fn simulate_as(
        &mut self,
        _role: Role,
        scenario: &str,
        phi: &Assignment,
        fidelity: &Assignment,
    ) -> Result<SimResult, SimError> {
        let r = DrivingSimulator::run(self, scenario, phi, fidelity, false)?;
        // Robustness: the run's smallest clearance in metres (0 at a collision).
        Ok(SimResult::new(r.failure, r.wall_seconds, Some(r.work)).with_robustness(r.min_distance))
    }
}

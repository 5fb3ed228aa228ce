//! The ten AV pre-crash scenarios of the paper's figure (1–8 meta-training, 9–10 meta-testing):
//! their φ-spaces and how a φ becomes a concrete set-up (paths, speeds, timing).
//!
//! Timing convention: every scenario has a *conflict point* where the two paths meet (or, for
//! car-following scenarios, the lead's position). The ego starts `CONFLICT_TIME` seconds of
//! travel before it; φ shifts the intruder's arrival relative to the ego's (`time_offset`,
//! positive = the intruder arrives later) or sets the initial gap.

use crate::path::Path;
use crate::world::{lanes, Layout, LANE};
use nalgebra::Point2;
use savme_kernel::{Assignment, Scale, SimError, Space, Variable};
use std::collections::BTreeMap;
use std::f64::consts::FRAC_PI_2;
use std::sync::OnceLock;

/// Seconds of travel from the ego's start to the conflict point.
pub const CONFLICT_TIME: f64 = 5.0;

/// One of the ten scenarios.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScenarioInfo {
    /// Number in the paper's figure, 1–10.
    pub id: u8,
    /// Short name, used as the kernel's scenario name.
    pub name: &'static str,
    /// What happens.
    pub description: &'static str,
    /// The road layout.
    pub layout: Layout,
    /// Simulated duration, seconds.
    pub duration: f64,
}

impl ScenarioInfo {
    /// True for the meta-training scenarios (1–8).
    pub fn training(&self) -> bool {
        self.id <= 8
    }
}

/// The ten scenarios, in the paper's order.
pub const SCENARIOS: [ScenarioInfo; 10] = [
    ScenarioInfo {
        id: 1,
        name: "intruder_turns_left_into_lane",
        description: "ego drives straight through the intersection; the intruder, coming from \
                      the left, turns left into the ego's lane",
        layout: Layout::Intersection,
        duration: 9.0,
    },
    ScenarioInfo {
        id: 2,
        name: "ego_turns_left_intruder_straight",
        description: "ego turns left at the intersection into the lane of an intruder crossing \
                      straight from the right",
        layout: Layout::Intersection,
        duration: 9.0,
    },
    ScenarioInfo {
        id: 3,
        name: "intruder_turns_left_across_ego",
        description: "the oncoming intruder turns left across the path of the ego going straight",
        layout: Layout::Intersection,
        duration: 9.0,
    },
    ScenarioInfo {
        id: 4,
        name: "ego_turns_left_across_intruder",
        description: "ego turns left across the path of the oncoming intruder going straight",
        layout: Layout::Intersection,
        duration: 9.0,
    },
    ScenarioInfo {
        id: 5,
        name: "intruder_cuts_in",
        description: "on a two-lane one-way road the intruder changes from the left lane into \
                      the ego's lane ahead of it",
        layout: Layout::OneWay,
        duration: 10.0,
    },
    ScenarioInfo {
        id: 6,
        name: "ego_changes_lane",
        description: "on a two-lane one-way road the ego changes into the left lane, where the \
                      intruder drives",
        layout: Layout::OneWay,
        duration: 10.0,
    },
    ScenarioInfo {
        id: 7,
        name: "lead_vehicle_brakes",
        description: "the ego approaches a lead vehicle in its lane, which brakes",
        layout: Layout::OneWay,
        duration: 10.0,
    },
    ScenarioInfo {
        id: 8,
        name: "parking_pull_out",
        description: "a vehicle pulls out of a parking spot into the road in front of the ego",
        layout: Layout::ParkingLot,
        duration: 9.0,
    },
    ScenarioInfo {
        id: 9,
        name: "lead_vehicle_two_way",
        description: "on a two-lane two-way road the ego approaches a slower lead vehicle that \
                      brakes",
        layout: Layout::TwoWay,
        duration: 10.0,
    },
    ScenarioInfo {
        id: 10,
        name: "on_ramp_merge",
        description: "the ego merges from an on-ramp into the right lane beside the intruder",
        layout: Layout::OnRamp,
        duration: 12.0,
    },
];

/// The scenario with number `id` (1–10) or name.
pub fn find(key: &str) -> Option<&'static ScenarioInfo> {
    SCENARIOS
        .iter()
        .find(|s| s.name == key || key.parse::<u8>().is_ok_and(|n| n == s.id))
}

/// The scenario names in [`SCENARIOS`] order: meta-training (1–8) and meta-testing (9–10).
///
/// ```
/// let (train, test) = savme_sim::scenario::train_test_names();
/// assert_eq!((train.len(), test.len()), (8, 2));
/// assert_eq!(test, ["lead_vehicle_two_way", "on_ramp_merge"]);
/// ```
pub fn train_test_names() -> (Vec<String>, Vec<String>) {
    let names = |train: bool| {
        SCENARIOS
            .iter()
            .filter(|s| s.training() == train)
            .map(|s| s.name.to_string())
            .collect()
    };
    (names(true), names(false))
}

/// Every scenario's φ-space ([`phi_space`]), by name.
///
/// ```
/// let spaces = savme_sim::scenario::spaces();
/// assert_eq!(spaces.len(), 10);
/// let merge = savme_sim::scenario::find("on_ramp_merge").unwrap();
/// assert_eq!(spaces["on_ramp_merge"], savme_sim::scenario::phi_space(merge));
/// ```
pub fn spaces() -> BTreeMap<String, Space> {
    SCENARIOS
        .iter()
        .map(|s| (s.name.to_string(), phi_space(s)))
        .collect()
}

fn lin(name: &str, lo: f64, hi: f64) -> Variable {
    Variable::continuous(name, lo, hi, 10, Scale::Linear)
}

/// The φ-space of scenario `id` (10 linear bins per variable).
pub fn phi_space(info: &ScenarioInfo) -> Space {
    let vars = match info.id {
        1 => vec![
            lin("ego_speed", 12.0, 24.0),
            lin("intruder_speed", 8.0, 14.0),
            lin("time_offset", -0.5, 1.5),
        ],
        2 => vec![
            lin("ego_speed", 4.0, 9.0),
            lin("intruder_speed", 6.0, 14.0),
            lin("time_offset", -8.0, 8.0),
        ],
        3 => vec![
            lin("ego_speed", 10.0, 20.0),
            lin("intruder_speed", 5.0, 10.0),
            lin("time_offset", -1.0, 1.0),
        ],
        4 => vec![
            lin("ego_speed", 7.0, 12.0),
            lin("intruder_speed", 10.0, 18.0),
            lin("time_offset", -0.8, 0.8),
        ],
        5 => vec![
            lin("ego_speed", 10.0, 25.0),
            lin("intruder_speed", 6.0, 20.0),
            lin("gap", 2.0, 8.0),
            lin("cut_in_time", 0.5, 4.0),
        ],
        6 => vec![
            lin("ego_speed", 10.0, 25.0),
            lin("intruder_speed", 10.0, 28.0),
            lin("offset", -30.0, 10.0),
            lin("lane_change_time", 0.5, 3.0),
        ],
        7 => vec![
            lin("ego_speed", 10.0, 25.0),
            lin("lead_speed", 5.0, 20.0),
            lin("gap", 8.0, 28.0),
            lin("lead_decel", 4.0, 9.0),
            lin("brake_time", 0.5, 4.0),
        ],
        8 => vec![
            lin("ego_speed", 8.0, 18.0),
            lin("intruder_accel", 1.5, 4.0),
            lin("time_offset", -1.5, 1.5),
        ],
        9 => vec![
            lin("ego_speed", 10.0, 22.0),
            lin("lead_speed", 3.0, 14.0),
            lin("gap", 6.0, 25.0),
            lin("lead_decel", 4.0, 9.5),
        ],
        _ => vec![
            lin("ego_speed", 12.0, 22.0),
            lin("intruder_speed", 12.0, 26.0),
            lin("time_offset", -3.0, 3.0),
        ],
    };
    Space::new(vars).expect("scenario spaces are valid")
}

/// The unit of a scenario parameter (an empty string for an unknown name).
///
/// ```
/// assert_eq!(savme_sim::scenario::unit("ego_speed"), "m/s");
/// assert_eq!(savme_sim::scenario::unit("lead_decel"), "m/s²");
/// ```
pub fn unit(parameter: &str) -> &'static str {
    match parameter {
        p if p.ends_with("_speed") => "m/s",
        "lead_decel" | "intruder_accel" => "m/s²",
        "gap" | "offset" => "m",
        "time_offset" | "cut_in_time" | "lane_change_time" | "brake_time" => "s",
        _ => "",
    }
}

/// A speed profile: an initial speed and phases of constant acceleration, with a speed floor of
/// 0 and a cap.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// Speed at t = 0, m/s.
    pub v0: f64,
    /// `(start time, acceleration)` phases in time order; the acceleration holds until the
    /// next phase.
    pub phases: Vec<(f64, f64)>,
    /// Speed cap, m/s.
    pub v_max: f64,
}

impl Profile {
    /// A constant speed.
    pub fn constant(v: f64) -> Self {
        Profile {
            v0: v,
            phases: Vec::new(),
            v_max: v,
        }
    }

    /// `(distance travelled, speed)` at time `t`, exact for the piecewise-constant
    /// acceleration with the speed held inside [0, cap].
    pub fn at(&self, t: f64) -> (f64, f64) {
        let cap = self.v_max.max(self.v0);
        let (mut s, mut v, mut now) = (0.0, self.v0, 0.0);
        let mut accel = 0.0;
        let mut phases = self.phases.iter().peekable();
        while now < t {
            while let Some(&&(start, a)) = phases.peek() {
                if start <= now {
                    accel = a;
                    phases.next();
                } else {
                    break;
                }
            }
            let end = phases.peek().map_or(t, |p| p.0.min(t));
            let h = end - now;
            // Time until the speed reaches a bound, after which it stays there.
            let free = if accel > 0.0 {
                ((cap - v) / accel).clamp(0.0, h)
            } else if accel < 0.0 {
                (v / -accel).clamp(0.0, h)
            } else {
                h
            };
            s += v * free + 0.5 * accel * free * free;
            v = (v + accel * free).clamp(0.0, cap);
            s += v * (h - free);
            now = end;
        }
        (s, v)
    }
}

/// A concrete set-up: what both vehicles do.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The scenario.
    pub info: &'static ScenarioInfo,
    /// The ego's desired lateral path.
    pub ego_path: Path,
    /// Where on it the ego starts (arc length of its body centre).
    pub ego_start: f64,
    /// The ego's desired (and initial) speed.
    pub ego_speed: f64,
    /// The intruder's scripted path.
    pub intruder_path: Path,
    /// Where on it the intruder starts (arc length of its body centre).
    pub intruder_start: f64,
    /// Its scripted speed.
    pub intruder_profile: Profile,
}

/// The paths of the intersection scenarios (1–4) and where they cross, computed once.
fn intersection_paths(id: u8) -> &'static (Path, Path, f64, f64) {
    static CACHE: [OnceLock<(Path, Path, f64, f64)>; 4] = [const { OnceLock::new() }; 4];
    CACHE[usize::from(id - 1)].get_or_init(|| {
        let (ego, intruder) = match id {
            1 => (lanes::northbound(-FAR), lanes::east_then_north(-FAR)),
            2 => (lanes::north_then_west(-FAR), lanes::westbound(FAR)),
            3 => (lanes::northbound(-FAR), lanes::south_then_east(FAR)),
            _ => (lanes::north_then_west(-FAR), lanes::southbound(FAR)),
        };
        let (se, si) = crossing(&ego, &intruder);
        (ego, intruder, se, si)
    })
}

/// Arc lengths `(on a, on b)` where two paths come closest (where they cross).
fn crossing(a: &Path, b: &Path) -> (f64, f64) {
    let mut best = (f64::INFINITY, 0.0, 0.0);
    let mut s = 0.0;
    while s <= a.length() {
        let p = a.point_at(s);
        let q = b.project(p, None);
        let d = (b.point_at(q.s) - p).norm();
        if d < best.0 && q.s > 0.0 && q.s < b.length() {
            best = (d, s, q.s);
        }
        s += 0.5;
    }
    (best.1, best.2)
}

fn value(phi: &Assignment, name: &str, space: &Space) -> Result<f64, SimError> {
    let v = phi.get(name).ok_or_else(|| SimError::MissingVariable {
        variable: name.into(),
    })?;
    let x = v.as_f64().ok_or_else(|| SimError::BadValue {
        variable: name.into(),
        value: v.to_string(),
        expected: "a number".into(),
    })?;
    let var = space
        .variable(name)
        .expect("asked for a variable of the space");
    if var.arm_of(v).is_none() {
        let (lo, hi) = match var.domain {
            savme_kernel::Domain::Continuous { lo, hi, .. } => (lo, hi),
            savme_kernel::Domain::Discrete { .. } => (f64::NAN, f64::NAN),
        };
        return Err(SimError::BadValue {
            variable: name.into(),
            value: v.to_string(),
            expected: format!("a number in [{lo}, {hi}]"),
        });
    }
    Ok(x)
}

/// Where the straight roads start (x = −`FAR`), metres.
const FAR: f64 = 120.0;
/// The ego's start on the straight road of the same-direction scenarios (x = −`FAR` + this).
const EGO_X: f64 = 10.0;

/// Turns a φ into a set-up. φ must name exactly the scenario's variables, each in range.
pub fn setup(info: &'static ScenarioInfo, phi: &Assignment) -> Result<Setup, SimError> {
    let space = phi_space(info);
    if let Some((name, _)) = phi.iter().find(|(n, _)| space.variable(n).is_none()) {
        return Err(SimError::BadValue {
            variable: name.into(),
            value: phi.get(name).map_or(String::new(), ToString::to_string),
            expected: format!(
                "no such parameter in scenario {} (it has: {})",
                info.id,
                space
                    .variables()
                    .iter()
                    .map(|v| v.name.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    }
    let get = |name: &str| value(phi, name, &space);
    let ego_speed = get("ego_speed")?;
    // Paths, then timing.
    match info.id {
        1..=4 => intersection(info, ego_speed, &get),
        5 => cut_in(info, ego_speed, &get),
        6 => ego_lane_change(info, ego_speed, &get),
        7 | 9 => lead_brakes(info, ego_speed, &get),
        8 => pull_out(info, ego_speed, &get),
        _ => on_ramp_merge(info, ego_speed, &get),
    }
}

/// Scenarios 1–4: both reach the crossing of their paths `CONFLICT_TIME` (+ the intruder's
/// `time_offset`) from the start.
fn intersection(
    info: &'static ScenarioInfo,
    ego_speed: f64,
    get: &impl Fn(&str) -> Result<f64, SimError>,
) -> Result<Setup, SimError> {
    let (ego_path, intruder_path, se, si) = intersection_paths(info.id);
    let profile = Profile::constant(get("intruder_speed")?);
    let late = get("time_offset")?;
    let (travel, _) = profile.at((CONFLICT_TIME + late).max(0.0));
    Ok(Setup {
        info,
        ego_path: ego_path.clone(),
        ego_start: se - ego_speed * CONFLICT_TIME,
        ego_speed,
        intruder_path: intruder_path.clone(),
        intruder_start: si - travel,
        intruder_profile: profile,
    })
}

/// Scenario 8: pull out forward from a spot south of the road, turn right into the eastbound
/// lane. The intruder starts from rest 2 s before the ego is `CONFLICT_TIME` (+ `time_offset`)
/// from where the intruder joins the lane.
fn pull_out(
    info: &'static ScenarioInfo,
    ego_speed: f64,
    get: &impl Fn(&str) -> Result<f64, SimError>,
) -> Result<Setup, SimError> {
    let spot_y = -(LANE + 1.5 + 2.4);
    let r = 4.0;
    let path = Path::start(Point2::new(0.0, spot_y), FRAC_PI_2)
        .line((-LANE / 2.0 - r - spot_y).max(0.1))
        .arc(r, -FRAC_PI_2)
        .line(150.0);
    let accel = get("intruder_accel")?;
    let start = (CONFLICT_TIME + get("time_offset")? - 2.0).max(0.0);
    Ok(Setup {
        info,
        ego_path: lanes::eastbound(-FAR),
        ego_start: FAR + r - ego_speed * CONFLICT_TIME,
        ego_speed,
        intruder_path: path,
        intruder_start: 0.0,
        intruder_profile: Profile {
            v0: 0.0,
            phases: vec![(start, accel)],
            v_max: 7.0,
        },
    })
}

/// Scenario 5: the intruder starts `gap` metres (bumper to bumper) ahead in the left lane and
/// moves into the right lane over 2.5 s of travel.
fn cut_in(
    info: &'static ScenarioInfo,
    ego_speed: f64,
    get: &impl Fn(&str) -> Result<f64, SimError>,
) -> Result<Setup, SimError> {
    let v = get("intruder_speed")?;
    let gap = get("gap")?;
    let t_cut = get("cut_in_time")?;
    let start_x = -FAR + EGO_X + crate::vehicle::LENGTH + gap;
    let cut_at = start_x + v * t_cut;
    let path = lanes::lane_change(start_x, LANE / 2.0, cut_at, (v * 2.5).max(8.0), false);
    Ok(Setup {
        info,
        ego_path: lanes::eastbound(-FAR),
        ego_start: EGO_X,
        ego_speed,
        intruder_path: path,
        intruder_start: 0.0,
        intruder_profile: Profile::constant(v),
    })
}

/// Scenario 6: the ego changes into the left lane, where the intruder drives `offset` metres
/// from the ego's start.
fn ego_lane_change(
    info: &'static ScenarioInfo,
    ego_speed: f64,
    get: &impl Fn(&str) -> Result<f64, SimError>,
) -> Result<Setup, SimError> {
    let v = get("intruder_speed")?;
    let offset = get("offset")?;
    let t_lc = get("lane_change_time")?;
    let start = -FAR + EGO_X;
    let path = lanes::lane_change(
        start,
        -LANE / 2.0,
        start + ego_speed * t_lc,
        (ego_speed * 3.0).max(10.0),
        true,
    );
    Ok(Setup {
        info,
        ego_path: path,
        ego_start: 0.0,
        ego_speed,
        intruder_path: lanes::eastbound_left(start + offset),
        intruder_start: 0.0,
        intruder_profile: Profile::constant(v),
    })
}

/// Scenarios 7 and 9: a lead `gap` metres ahead brakes at `lead_decel` (at `brake_time` in 7,
/// at 1.5 s in 9).
fn lead_brakes(
    info: &'static ScenarioInfo,
    ego_speed: f64,
    get: &impl Fn(&str) -> Result<f64, SimError>,
) -> Result<Setup, SimError> {
    let v = get("lead_speed")?;
    let gap = get("gap")?;
    let decel = get("lead_decel")?;
    let t_brake = if info.id == 7 {
        get("brake_time")?
    } else {
        1.5
    };
    Ok(Setup {
        info,
        ego_path: lanes::eastbound(-FAR),
        ego_start: EGO_X,
        ego_speed,
        intruder_path: lanes::eastbound(-FAR + EGO_X + crate::vehicle::LENGTH + gap),
        intruder_start: 0.0,
        intruder_profile: Profile {
            v0: v,
            phases: vec![(t_brake, -decel)],
            v_max: v,
        },
    })
}

/// Scenario 10: merge from the on-ramp; the conflict point is where the merge ends.
fn on_ramp_merge(
    info: &'static ScenarioInfo,
    ego_speed: f64,
    get: &impl Fn(&str) -> Result<f64, SimError>,
) -> Result<Setup, SimError> {
    let ramp = lanes::on_ramp();
    let road = lanes::eastbound(-250.0);
    let merge_end = ramp.project(Point2::new(20.0, -LANE / 2.0), None).s;
    let road_at = road.project(Point2::new(20.0, -LANE / 2.0), None).s;
    let v = get("intruder_speed")?;
    let late = get("time_offset")?;
    Ok(Setup {
        info,
        ego_path: ramp,
        ego_start: merge_end - ego_speed * CONFLICT_TIME,
        ego_speed,
        intruder_path: road,
        intruder_start: road_at - v * (CONFLICT_TIME + late),
        intruder_profile: Profile::constant(v),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scenario_parameter_has_a_unit() {
        for info in &SCENARIOS {
            for v in phi_space(info).variables() {
                assert!(!unit(&v.name).is_empty(), "{}: {}", info.name, v.name);
            }
        }
    }

    #[test]
    fn profiles_integrate_braking_and_acceleration() {
        let brake = Profile {
            v0: 10.0,
            phases: vec![(1.0, -5.0)],
            v_max: 10.0,
        };
        let (s, v) = brake.at(5.0);
        assert!((s - (10.0 + 10.0)).abs() < 1e-9 && v == 0.0, "{s} {v}");
        let go = Profile {
            v0: 0.0,
            phases: vec![(0.5, 2.0)],
            v_max: 4.0,
        };
        let (s, v) = go.at(4.5);
        // 2 s to reach 4 m/s (4 m), then 2 s at 4 m/s (8 m).
        assert!(
            (s - 12.0).abs() < 1e-9 && (v - 4.0).abs() < 1e-12,
            "{s} {v}"
        );
    }

    #[test]
    fn every_scenario_builds_from_the_middle_of_its_space() {
        for info in &SCENARIOS {
            let space = phi_space(info);
            assert!((3..=5).contains(&space.len()), "{}", info.name);
            let mut phi = Assignment::new();
            for v in space.variables() {
                phi.set(&v.name, v.representative(v.arms() / 2));
            }
            let s = setup(info, &phi).unwrap();
            assert!(
                s.ego_start >= 0.0,
                "{}: ego starts before its path",
                info.name
            );
            assert!(
                s.intruder_start >= 0.0,
                "{}: intruder starts before its path",
                info.name
            );
        }
    }
}

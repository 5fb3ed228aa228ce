"""highway-env (Farama's gymnasium driving environments) as a savme problem.

Four of highway-env's environments are scenarios — "highway", "merge", "roundabout",
"intersection" — each with its φ-space of traffic parameters (other vehicles' count, density
and speed, the IDM time gap and MOBIL politeness of their drivers, the initial spacing, …).
The fidelity θ is what highway-env really lets you trade for speed: the simulation frequency,
the policy (decision) frequency, the lidar's cells and maximum range, and how many vehicles
are simulated around the ego vehicle. θ_HF is highway-env's default or finer.

The system under test, `LidarDriver`, is a rule-based driver that sees the other vehicles only
through highway-env's lidar observation (and knows its own speed and heading): it keeps a
time gap, brakes on a short time-to-collision, and changes lane when the lane ahead is
blocked and a side is free. A coarse lidar or a slow policy therefore changes what it does.
A run fails when the ego vehicle crashes; its robustness is the smallest bumper gap seen
(negative for a crash), and its cost is the measured runtime and a deterministic work count.

    import savme
    from savme.integrations import highway_env as hw
    run = hw.simulate("highway", {"vehicles": 20, ...}, theta=None)   # θ_HF
    run["failure"], run["robustness"], run["min_ttc"], run["work"], run["wall_seconds"]
    problem = hw.problem()                                           # savme.Problem
    protocol = savme.Protocol(["highway", "merge", "roundabout"], ["intersection"],
                              preset="quick", cost="work", simulator="highway-env")
    savme.Campaign(protocol, problem, out="hw-results", jobs=1).run(hw.campaign_simulator())

highway-env is imported when a simulation first runs (`pip install highway-env`); without it,
`simulate` raises `MissingDependency` saying what to install. Spaces and the problem are
built without it.
"""

from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple

from .._savme import Continuous, Discrete, Problem, Space, Variable

__all__ = [
    "FIDELITY_VARIABLES",
    "THETA_HF",
    "SCENARIOS",
    "MissingDependency",
    "LidarDriver",
    "fidelity_space",
    "phi_space",
    "problem",
    "simulate",
    "campaign_simulator",
    "nominal_phi",
]


class MissingDependency(ImportError):
    """highway-env (or gymnasium) is not installed in this Python."""


def _highway_env() -> Tuple[Any, Any]:
    """(gymnasium, highway_env), imported on first use."""
    try:
        gym = importlib.import_module("gymnasium")
        hwe = importlib.import_module("highway_env")
    except ImportError as e:
        raise MissingDependency(
            f"savme.integrations.highway_env needs highway-env and gymnasium ({e}): "
            "pip install 'highway-env>=1.12'"
        ) from e
    return gym, hwe


# --- θ: the fidelity settings highway-env has ------------------------------------------------

FIDELITY_VARIABLES: List[Tuple[str, List[float], float, str]] = [
    ("simulation_frequency", [5, 10, 15], 15, "Hz of the physics and collision checks (default 15)"),
    ("policy_frequency", [1, 2, 5], 5, "Hz at which the driver decides (default 1; HF finer)"),
    ("lidar_cells", [8, 16, 32], 32, "angular cells of the lidar (default 16; HF finer)"),
    ("lidar_range", [30, 60], 60, "lidar maximum range in m (default 60)"),
    ("simulated_vehicles", [4, 8, 64], 64, "vehicles simulated: the ego's nearest N (HF: all)"),
]
"""(name, values, θ_HF value, meaning) of every fidelity variable."""

THETA_HF: Dict[str, float] = {name: hf for name, _, hf, _ in FIDELITY_VARIABLES}
"""The high-fidelity settings: highway-env's defaults, or finer."""


def fidelity_space() -> Space:
    """The fidelity space θ (one discrete variable per setting of FIDELITY_VARIABLES)."""
    return Space([Discrete(name, values) for name, values, _, _ in FIDELITY_VARIABLES])


# --- φ: the scenarios ------------------------------------------------------------------------


@dataclass(frozen=True)
class Scenario:
    """One highway-env environment as a savme scenario."""

    env_id: str
    config: Mapping[str, Any]
    """Fixed environment configuration (over highway-env's defaults)."""
    variables: Sequence[Tuple[str, float, float, bool, str]]
    """φ: (name, lo, hi, integer, meaning)."""
    lane_changes: bool
    """Whether the driver may change lanes (highway, merge)."""
    nominal: Mapping[str, float]
    """highway-env's own values of φ (its defaults), e.g. for a nominal run."""
    frame_vehicle_us: int = 53
    """Work weight of one vehicle in one physics frame (µs; the road network's size sets it)."""
    cone_deg: float = 12.0
    """The driver's look-ahead half-angle: wider at junctions, where traffic crosses."""


_BEHAVIOUR = [
    ("time_gap", 0.5, 2.5, False, "other drivers' IDM desired time gap, s (default 1.5)"),
    ("politeness", 0.0, 1.0, False, "other drivers' MOBIL politeness (default 0)"),
]

SCENARIOS: Dict[str, Scenario] = {
    "highway": Scenario(
        "highway-v0",
        {"lanes_count": 3, "duration": 12},
        [
            ("vehicles", 5, 25, True, "other vehicles on the road (default 50 on 4 lanes)"),
            ("density", 0.8, 3.0, False, "vehicles_density: traffic density factor (default 1)"),
            ("ego_spacing", 0.5, 3.0, False, "ego_spacing: room in front of the ego (default 2)"),
            ("others_speed", 10.0, 30.0, False, "other vehicles' target speed, m/s (default 20-30)"),
            *_BEHAVIOUR,
        ],
        True,
        {"vehicles": 30, "density": 1.0, "ego_spacing": 2.0, "others_speed": 25.0,
         "time_gap": 1.5, "politeness": 0.0},
    ),
    "merge": Scenario(
        "merge-v1",
        {"duration": 15},
        [
            ("ego_speed", 20.0, 32.0, False, "ego vehicle's initial speed, m/s (default 30)"),
            ("merging_speed", 10.0, 30.0, False, "merging vehicle's initial speed, m/s (default 20)"),
            ("others_speed", 15.0, 32.0, False, "other vehicles' target speed, m/s (default ~30)"),
            *_BEHAVIOUR,
        ],
        True,
        {"ego_speed": 30.0, "merging_speed": 20.0, "others_speed": 30.0, "time_gap": 1.5,
         "politeness": 0.0},
        frame_vehicle_us=105,
    ),
    "roundabout": Scenario(
        "roundabout-v1",
        {"duration": 12},
        [
            ("ego_speed", 4.0, 16.0, False, "ego vehicle's initial speed, m/s (default 8)"),
            ("others_speed", 6.0, 20.0, False, "other vehicles' speed, m/s (default 16)"),
            *_BEHAVIOUR,
        ],
        False,
        {"ego_speed": 8.0, "others_speed": 16.0, "time_gap": 1.5, "politeness": 0.0},
        frame_vehicle_us=258,
        cone_deg=40.0,
    ),
    "intersection": Scenario(
        "intersection-v2",
        {"duration": 13},
        [
            ("vehicles", 2, 15, True, "initial_vehicle_count (default 10)"),
            ("spawn_probability", 0.0, 1.0, False, "spawn_probability per decision (default 0.6)"),
            ("others_speed", 4.0, 12.0, False, "other vehicles' speed, m/s (default ~8)"),
            *_BEHAVIOUR,
        ],
        False,
        {"vehicles": 10, "spawn_probability": 0.6, "others_speed": 8.0, "time_gap": 1.5,
         "politeness": 0.0},
        frame_vehicle_us=408,
        cone_deg=40.0,
    ),
}
"""The four environments as scenarios."""


def _scenario(name: str) -> Scenario:
    try:
        return SCENARIOS[name]
    except KeyError:
        raise KeyError(f"unknown highway-env scenario {name!r} (known: {', '.join(SCENARIOS)})") from None


def phi_space(scenario: str, bins: int = 6) -> Space:
    """The φ-space of `scenario`: integer parameters as discrete values, the others as
    continuous variables cut into `bins` arms."""
    variables: List[Variable] = []
    for name, lo, hi, integer, _ in _scenario(scenario).variables:
        if integer:
            step = max(1, round((hi - lo) / max(bins - 1, 1)))
            values = list(range(int(lo), int(hi) + 1, step))
            variables.append(Discrete(name, values))
        else:
            variables.append(Continuous(name, lo, hi, bins=bins))
    return Space(variables)


def nominal_phi(scenario: str) -> Dict[str, float]:
    """highway-env's own value of each φ variable of `scenario`."""
    return dict(_scenario(scenario).nominal)


def problem(scenarios: Optional[Sequence[str]] = None, bins: int = 6) -> Problem:
    """The savme problem: the fidelity space with θ_HF, and each scenario's φ-space (all four
    by default)."""
    names = list(SCENARIOS) if scenarios is None else list(scenarios)
    return Problem(
        fidelity=fidelity_space(),
        theta_hf=dict(THETA_HF),
        scenarios={name: phi_space(name, bins) for name in names},
    )


# --- the system under test -------------------------------------------------------------------


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


class LidarDriver:
    """A rule-based driver on highway-env's lidar observation (cells × [distance, relative
    speed along the ray], in world-frame sectors) and its own speed and heading.

    It looks into a ±`cone` around its heading: it brakes when the time-to-collision with the
    nearest return falls below `brake_ttc` or the gap below half its desired gap (`standstill`
    m + `headway` s × speed), holds its speed below the desired gap, changes lane (when allowed)
    to a side with no return within `side_clearance` m, and speeds up otherwise."""

    def __init__(self, headway: float = 0.8, standstill: float = 4.0, brake_ttc: float = 2.0,
                 cone: float = math.radians(12), side_clearance: float = 10.0) -> None:
        self.headway, self.standstill, self.brake_ttc = headway, standstill, brake_ttc
        self.cone, self.side_clearance = cone, side_clearance

    @staticmethod
    def _sectors(cells: int, heading: float) -> List[float]:
        """Each cell's centre direction relative to the heading."""
        return [_wrap(i * 2 * math.pi / cells - heading) for i in range(cells)]

    def _nearest(self, obs: Any, rel: List[float], lo: float, hi: float, half: float) -> Tuple[float, float]:
        """(distance, closing speed) of the nearest return of the cells overlapping [lo, hi]."""
        best = (math.inf, 0.0)
        for i, a in enumerate(rel):
            if a + half >= lo and a - half <= hi and obs[i][0] < best[0]:
                best = (float(obs[i][0]), -float(obs[i][1]))
        return best

    def decide(self, obs: Any, speed: float, heading: float, available: Sequence[str] = ()) -> str:
        """The meta-action ("SLOWER", "IDLE", "FASTER", "LANE_LEFT", "LANE_RIGHT") for lidar
        returns `obs` at the ego's `speed` and `heading`; lane changes only among `available`
        (the road's lanes: highway-env's available actions)."""
        cells = len(obs)
        rel, half = self._sectors(cells, heading), math.pi / cells
        gap, closing = self._nearest(obs, rel, -self.cone, self.cone, half)
        ttc = gap / closing if closing > 0.1 else math.inf
        desired = self.standstill + self.headway * max(speed, 0.0)
        if gap < desired / 2 or ttc < self.brake_ttc:
            return "SLOWER"
        if gap < desired or ttc < 2 * self.brake_ttc:
            # y grows to the right in highway-env: the left side is at negative angles.
            for action, lo, hi in (("LANE_LEFT", -2.4, -0.4), ("LANE_RIGHT", 0.4, 2.4)):
                if action in available and self._nearest(obs, rel, lo, hi, half)[0] > self.side_clearance:
                    return action
            return "IDLE"
        return "FASTER"


# --- one run ---------------------------------------------------------------------------------

_EGO_SPEEDS = {"highway": [0, 5, 10, 15, 20, 25, 30], "merge": [0, 5, 10, 15, 20, 25, 30],
               "roundabout": [0, 4, 8, 12, 16], "intersection": [0, 3, 6, 9]}


def _theta(theta: Optional[Mapping[str, Any]]) -> Dict[str, float]:
    full = dict(THETA_HF)
    if theta is not None:
        unknown = set(theta) - set(full)
        if unknown:
            raise KeyError(f"unknown fidelity setting(s) {sorted(unknown)} (known: {', '.join(full)})")
        full.update(theta)
    for name, value in full.items():
        if not isinstance(value, (int, float)) or not value > 0:
            raise ValueError(f"fidelity setting {name} must be a positive number, got {value!r}")
    return full


def _phi(spec: Scenario, scenario: str, phi: Mapping[str, Any]) -> Dict[str, float]:
    names = [v[0] for v in spec.variables]
    missing, unknown = set(names) - set(phi), set(phi) - set(names)
    if missing or unknown:
        raise KeyError(
            f"scenario {scenario!r}: φ must set exactly {names}; "
            f"missing {sorted(missing)}, unknown {sorted(unknown)}"
        )
    values = {}
    for name, lo, hi, integer, _ in spec.variables:
        value = phi[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"scenario {scenario!r}: φ {name} must be a finite number, got {value!r}")
        values[name] = round(value) if integer else float(value)
    return values


def _config(spec: Scenario, scenario: str, phi: Dict[str, float], theta: Dict[str, float]) -> Dict[str, Any]:
    config: Dict[str, Any] = {
        **spec.config,
        "simulation_frequency": int(theta["simulation_frequency"]),
        "policy_frequency": theta["policy_frequency"],
        "observation": {"type": "LidarObservation", "cells": int(theta["lidar_cells"]),
                        "maximum_range": float(theta["lidar_range"]), "normalize": False},
        "action": {"type": "DiscreteMetaAction", "target_speeds": _EGO_SPEEDS[scenario],
                   "lateral": spec.lane_changes, "longitudinal": True},
        "offscreen_rendering": True,
    }
    if scenario == "highway":
        config.update(vehicles_count=int(phi["vehicles"]), vehicles_density=phi["density"],
                      ego_spacing=phi["ego_spacing"])
    elif scenario == "intersection":
        config.update(initial_vehicle_count=int(phi["vehicles"]),
                      spawn_probability=phi["spawn_probability"])
    return config


class _Traffic:
    """Applies φ to the other vehicles (also to those spawned later) and culls all but the
    ego's `keep` nearest (θ simulated_vehicles)."""

    def __init__(self, env: Any, phi: Dict[str, float], keep: int) -> None:
        self.env, self.phi, self.keep = env, phi, keep

    def apply(self, first: bool) -> None:
        road, ego = self.env.road, self.env.vehicle
        for v in road.vehicles:
            if v is ego or getattr(v, "_savme_phi", False):
                continue
            v._savme_phi = True  # (not an id() set: ids of removed vehicles are reused)
            v.TIME_WANTED = self.phi["time_gap"]
            v.POLITENESS = self.phi["politeness"]
            if "others_speed" in self.phi and hasattr(v, "target_speed"):
                v.target_speed = self.phi["others_speed"]
                if first:
                    v.speed = self.phi["others_speed"]
            if first and "merging_speed" in self.phi and v.lane_index[0] == "j":
                v.speed = self.phi["merging_speed"]
        if first and "ego_speed" in self.phi:
            ego.speed = self.phi["ego_speed"]
            ego.speed_index = ego.speed_to_index(ego.speed)
            ego.target_speed = ego.index_to_speed(ego.speed_index)
        others = [v for v in road.vehicles if v is not ego]
        if len(others) > self.keep:
            others.sort(key=lambda v: float(((v.position - ego.position) ** 2).sum()))
            for v in others[self.keep:]:
                road.vehicles.remove(v)


def _gap_and_ttc(env: Any) -> Tuple[float, float]:
    """The smallest bumper gap to any other vehicle, in the ego's frame (m; negative when the
    boxes overlap), and the time-to-collision with the vehicle ahead in its path (s)."""
    ego = env.vehicle
    c, s = math.cos(ego.heading), math.sin(ego.heading)
    gap, ttc = math.inf, math.inf
    ego_long = ego.speed
    for v in env.road.vehicles:
        if v is ego:
            continue
        dx, dy = float(v.position[0] - ego.position[0]), float(v.position[1] - ego.position[1])
        lon, lat = c * dx + s * dy, -s * dx + c * dy
        g = max(abs(lon) - (ego.LENGTH + v.LENGTH) / 2, abs(lat) - (ego.WIDTH + v.WIDTH) / 2)
        gap = min(gap, g)
        if lon > 0 and abs(lat) < (ego.WIDTH + v.WIDTH) / 2:
            other_long = v.speed * math.cos(v.heading - ego.heading)
            closing = ego_long - other_long
            if closing > 1e-6:
                ttc = min(ttc, max(lon - (ego.LENGTH + v.LENGTH) / 2, 0.0) / closing)
    return gap, ttc


WORK_WEIGHTS: Dict[str, int] = {
    "runs": 18800, "frame_pairs": 6, "decision_vehicles": 246, "lidar_cells": 9,
}
"""The work count's terms and weights, in µs of CPU (least squares over 30 runs of all four
scenarios at random φ and θ, measured on the development machine; docs/RESULTS.md): making and
resetting the environment, a pair of vehicles in a physics frame (neighbour and collision
checks), a vehicle seen by a decision (lidar trace, robustness), a lidar cell of a decision.
A vehicle in a physics frame costs per scenario: `Scenario.frame_vehicle_us`."""


def simulate(scenario: str, phi: Mapping[str, Any], theta: Optional[Mapping[str, Any]] = None,
             *, driver: Optional[LidarDriver] = None, seed: int = 0) -> Dict[str, Any]:
    """One run of `scenario` with parameters `phi` at fidelity `theta` (θ_HF when None).

    Returns {"failure": the ego crashed, "robustness": the smallest bumper gap in m (a crash:
    −1 or less), "min_gap", "min_ttc" (s, inf when never closing), "work" (deterministic cost in ≈ µs of
    CPU: the counts of WORK_WEIGHTS' terms, weighted), "counts" (those counts), "wall_seconds",
    "steps" (decisions), "time" (simulated s)}. Deterministic for given arguments (traffic drawn from
    `seed`). Raises KeyError/ValueError naming a bad scenario, φ or θ variable, and
    MissingDependency without highway-env."""
    spec = _scenario(scenario)
    values, th = _phi(spec, scenario, phi), _theta(theta)
    gym, _ = _highway_env()
    driver = driver or LidarDriver(cone=math.radians(spec.cone_deg))
    start = time.perf_counter()
    env = gym.make(spec.env_id, config=_config(spec, scenario, values, th)).unwrapped
    try:
        obs, _ = env.reset(seed=seed)
        traffic = _Traffic(env, values, int(th["simulated_vehicles"]))
        traffic.apply(first=True)
        obs = env.observation_type.observe()
        frames = max(int(th["simulation_frequency"] // th["policy_frequency"]), 1)
        cells, steps = int(th["lidar_cells"]), 0
        counts = dict(dict.fromkeys(WORK_WEIGHTS, 0), runs=1, frame_vehicles=0)
        weights = dict(WORK_WEIGHTS, frame_vehicles=spec.frame_vehicle_us)
        min_gap, min_ttc = _gap_and_ttc(env)
        done = False
        while not done:
            n = len(env.road.vehicles)
            available = [env.action_type.actions[a] for a in env.action_type.get_available_actions()]
            action = driver.decide(obs, env.vehicle.speed, env.vehicle.heading, available)
            obs, _, terminated, truncated, _ = env.step(env.action_type.actions_indexes[action])
            steps += 1
            for key, value in (("frame_vehicles", frames * n), ("frame_pairs", frames * n * n),
                               ("decision_vehicles", n), ("lidar_cells", cells)):
                counts[key] += value
            traffic.apply(first=False)
            gap, ttc = _gap_and_ttc(env)
            min_gap, min_ttc = min(min_gap, gap), min(min_ttc, ttc)
            done = terminated or truncated or env.vehicle.crashed
        crashed = bool(env.vehicle.crashed)
        sim_time = env.time
    finally:
        env.close()
    wall = time.perf_counter() - start
    robustness = min(min_gap, 0.0) - 1.0 if crashed else max(min_gap, 0.0)
    return {"failure": crashed, "robustness": robustness, "min_gap": min_gap, "min_ttc": min_ttc,
            "work": sum(weights[k] * v for k, v in counts.items()), "counts": counts,
            "wall_seconds": wall, "steps": steps, "time": sim_time}


def campaign_simulator(cost: str = "work", seed: int = 0,
                       driver: Optional[LidarDriver] = None) -> Callable[[str, Dict[str, Any], Dict[str, Any]], Any]:
    """A simulator for `savme.Campaign.run`: (scenario, φ, θ) → (failure, work units) with
    cost="work" (a protocol with cost="work"), or the failure flag alone with cost="wall"
    (the campaign then measures each call's wall-clock time)."""
    if cost not in ("work", "wall"):
        raise ValueError(f"cost must be 'work' or 'wall', got {cost!r}")

    def run(scenario: str, phi: Dict[str, Any], theta: Dict[str, Any]) -> Any:
        r = simulate(scenario, phi, theta, driver=driver, seed=seed)
        return (r["failure"], max(int(r["work"]), 1)) if cost == "work" else r["failure"]

    return run

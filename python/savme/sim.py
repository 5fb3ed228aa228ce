"""The bundled driving simulator (the paper's ten scenarios, camera + lidar, Table I).

    sim = savme.sim.Driving()                    # or Driving("ideal"): fast, sensor-blind
    r = sim.simulate("lead_vehicle_brakes", {"ego_speed": 20, ...}, theta=None)  # θ_HF
    savme.Campaign(protocol, savme.Problem.driving()).run(sim=sim)
"""

from ._savme import Driving

__all__ = ["Driving"]

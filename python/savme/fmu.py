"""FMI 2.0 co-simulation FMUs as simulators, from a campaign file (TOML, as `savme run
--config` reads): the HF and LF FMUs, the failure signal, the bindings of every variable.

    sim = savme.fmu.Simulator("examples/fmu/campaign.toml")
    sim.simulate("lead_brakes", {"gap": 8.0, ...}, theta=None, role="hf")

`isolate = true` files run every evaluation in a worker process: `$SAVME_FMU_WORKER` (e.g.
"path/to/savme fmu-worker"), else `savme-fmu-worker` on the PATH.
"""

from ._savme import Simulator

__all__ = ["Simulator"]

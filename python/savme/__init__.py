"""savme: find the failures of an autonomous system in simulation fast.

The SAVME ask/tell kernel (Schlichting et al., ITSC 2023) as a native Python package: it learns
where the system under test fails and which cheap simulator fidelity settings still agree with
the high-fidelity simulator, within a compute budget.

    import savme
    fidelity = savme.Space([savme.Discrete("rate_hz", [2, 5, 10])])
    phi = savme.Space([savme.Continuous("gap_m", 5, 50, bins=9)])
    kernel = savme.Kernel(fidelity=fidelity, theta_hf={"rate_hz": 10},
                          scenarios={"lead_brakes": phi}, budget=0.3, seed=1)
    trial = kernel.ask()
    record = kernel.tell(trial, hf=(True, 1.0), lf=(True, 0.2))
"""

from ._savme import (
    Boolean,
    Campaign,
    CampaignError,
    CampaignResult,
    Continuous,
    Discrete,
    Estimation,
    JournalError,
    Kernel,
    PROTOCOL_VALUES,
    Posterior,
    Problem,
    Protocol,
    Record,
    Space,
    TellError,
    Trial,
    Variable,
    __version__,
)
from . import campaign, executors, fmu, history, integrations, openscenario, sim
from .executors import RayExecutor

__all__ = [
    "Boolean",
    "Campaign",
    "CampaignError",
    "CampaignResult",
    "Continuous",
    "Discrete",
    "Estimation",
    "JournalError",
    "Kernel",
    "PROTOCOL_VALUES",
    "Posterior",
    "Problem",
    "Protocol",
    "RayExecutor",
    "Record",
    "Space",
    "TellError",
    "Trial",
    "Variable",
    "__version__",
    "campaign",
    "executors",
    "fmu",
    "history",
    "integrations",
    "openscenario",
    "sim",
]

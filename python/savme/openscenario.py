"""OpenSCENARIO 1.x parameter variations (`ParameterValueDistribution` files) as savme
scenarios: each varied parameter a φ variable, each stochastic distribution its nominal.

    v = savme.openscenario.read("cut_in_variation.xosc")
    kernel = savme.Kernel(fidelity=..., theta_hf=..., scenarios={"cut_in": v.space()})
    ...
    est = kernel.estimation(nominal={"cut_in": v.nominal})

Sets and step ranges become discrete variables (uniform nominal); uniform, normal,
log-normal and histogram distributions continuous ones over their range (normal, log-normal
and Poisson need a <Range>); probability sets and Poisson counts discrete ones with their
weights. A bad file raises ValueError naming the file, line and element.
"""

from ._savme import ParameterVariation
from ._savme import read_openscenario as read

__all__ = ["ParameterVariation", "read"]

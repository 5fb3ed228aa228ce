"""Adapters that plug savme into other tools' loops. Each lives in its own module, named after
the tool, so that `import savme` needs none of them installed:

- `savme.verifai`: `SavmeSampler`, a VerifAI `FeatureSampler` that VerifAI's own falsifiers
  run (φ from a `FeatureSpace`, ρ as failure and robustness, θ as extra features).
- `savme.scenic`: `ScenicSearch`, the paired HF/LF search on a Scenic program.
- `savme.openscenario`: OpenSCENARIO parameter variations as φ-spaces and nominals.
- `savme.integrations.highway_env`: highway-env environments as a savme problem (scenarios,
  fidelity settings, a lidar driver under test, one paired run).

(The VerifAI-shaped `FalsificationSampler` that lived here became `savme.verifai.SavmeSampler`.)
"""

__all__: list = []

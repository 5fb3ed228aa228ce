"""Campaigns: the paper's protocol (baseline, meta-training, evaluation, meta-testing) run by
savme's Rust campaign loop, with `savme run`'s outputs (`table.md`, `fidelity.md`,
`summary.json`, `trials.jsonl`, plots) and resume.

    protocol = savme.Protocol(["cut_in"], ["lead_brakes"], preset="quick", cost="work")
    result = savme.Campaign(protocol, problem, out="results").run(hf=run_hf, lf=run_lf)

Python simulators are called from the campaign's worker threads, each call holding the GIL
(the Rust work between calls runs without it). A CPU-bound simulator written in Python
therefore runs one call at a time: give it `jobs=1`, or make each call hand the work to a
process pool (`concurrent.futures.ProcessPoolExecutor`) and wait for it — the wait releases
the GIL, so other workers' calls proceed. Simulators that release the GIL themselves (native
code, subprocesses, sockets to CARLA) run in parallel as they are.

`load(path)` reads a campaign file on FMUs and binds them: `savme.campaign.load(path).run()`.
"""

from ._savme import Campaign, CampaignError, CampaignResult, Problem, Protocol
from ._savme import load_campaign as load

__all__ = ["Campaign", "CampaignError", "CampaignResult", "Problem", "Protocol", "load"]

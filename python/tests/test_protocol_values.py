"""Every protocol value is declared once in savme (savme.PROTOCOL_VALUES) and reachable under
the same name from the command line (`savme run`/`savme reproduce` flags), a campaign file's
`[campaign]` section (savme.campaign.load) and Python (savme.Protocol keywords), with the same
default (the paper's stages with savme's tuned search when the value is not given)."""

import json
import os
import shutil
import subprocess

import pytest

import savme
from conftest import REPO

# A value for each declared name, written to the protocol when given (and valid together).
SAMPLES = {
    "seed": 11,
    "cost": "work",
    "budgets": [0.25, 0.5],
    "train_iterations": 9,
    "eval_iterations": 3,
    "test_iterations": 4,
    "baseline_train_iterations": 5,
    "baseline_test_iterations": 6,
    "train_scenarios": ["lead_vehicle_brakes"],
    "test_scenarios": ["on_ramp_merge"],
    "fidelity_bins": 4,
    "log_bins": "paper",
    "prior_strength": 0.5,
    "window": 2,
    "prior_strengths": [0.0, 0.3],
    "screen_iterations": 7,
    "audit_fraction": 0.2,
    "search": "elite",
    # Every parameter: the protocol stores them all (those not given at their defaults).
    "elite": {"explore": 0.2, "bandwidth": 0.06, "jump": 0.1, "near_miss": 0.0,
              "near_miss_weight": 0.5, "near_miss_until": 20, "spread": 1.0, "tries": 8,
              "archive": 4096, "per_cost": True, "crowding": 0.0, "rho_model": True,
              "rho_start": 3, "parzen_points": 32768, "hf_cost": True},
    "pair_fraction": 0.25,
    "pair_settle": 12,
    "deployment": "adaptive",
    "screen_lf": "where-it-pays",
    "method": "paper",
    "allocation": "cost-rate",
    "coverage_floor": 0.5,
    "search_budget": 1e9,
    "deploy_budget": 2e8,
    "theta_lf_choice": "evidence",
    "transfer": "auto",
    "ladder": [0.25, 0.5],
    "ladder_training": "shared",
    "repeat": 2,
}

# Values that mean something only with another one (audit_fraction audits the screening, the
# elite parameters the elite search, pair_settle a pairing of fewer than every trial).
COMPANIONS = {"audit_fraction": {"screen_iterations": 7}, "elite": {"search": "elite"},
              "pair_settle": {"pair_fraction": 0.5}, "deployment": {"search": "elite"},
              "screen_lf": {"screen_iterations": 7},
              "ladder": {"budgets": [0.25, 0.5], "screen_iterations": 7},
              "ladder_training": {"budgets": [0.5], "ladder": [0.25, 0.5], "screen_iterations": 7}}
# Values that set another one: the elite search stores its default parameters.
DERIVED = {"search": {"elite"}, "deployment": {"elite"}}


def toml_value(v):
    if isinstance(v, dict):  # an inline table
        return "{" + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + "}"
    return json.dumps(v)  # numbers, strings and lists of them are the same in TOML


def test_the_declared_values_are_the_samples_here():
    names = [v["name"] for v in savme.PROTOCOL_VALUES]
    assert sorted(names) == sorted(SAMPLES), "a protocol value was added: give it a sample here"
    for v in savme.PROTOCOL_VALUES:
        assert v["flag"] == "--" + v["name"].replace("_", "-")
        assert v["help"] and v["stages"]


def test_each_value_is_a_flag_of_run_and_reproduce(savme_bin):
    for command in ("run", "reproduce", "toy"):
        help_text = subprocess.run([savme_bin, command, "--help"], check=True, capture_output=True,
                                   text=True).stdout
        for v in savme.PROTOCOL_VALUES:
            assert v["flag"] in help_text, f"savme {command} has no {v['flag']}"


def test_each_value_is_a_protocol_keyword_with_the_papers_default():
    paper = savme.Protocol(["a"], ["b"]).to_dict()
    for v in savme.PROTOCOL_VALUES:
        name = v["name"]
        if name in ("train_scenarios", "test_scenarios", "repeat"):
            continue  # positional arguments of Protocol; repeat belongs to the campaign
        if name == "method":  # not stored: it sets the search values it names
            given = savme.Protocol(["a"], ["b"], method="paper").to_dict()
            assert (paper["search"], paper["allocation"], paper["deployment"]) == (
                "elite", "cost-rate-scout", "adaptive")
            assert not {"search", "allocation", "deployment", "elite"} & set(given)
            continue
        with_ = COMPANIONS.get(name, {})
        given = savme.Protocol(["a"], ["b"], **{name: SAMPLES[name]}, **with_).to_dict()
        assert given[name] == SAMPLES[name], name
        changed = {name, *with_, *DERIVED.get(name, ())}
        assert {k: x for k, x in given.items() if k not in changed} == {
            k: x for k, x in paper.items() if k not in changed}
        # None is "not given": the paper's default.
        assert savme.Protocol(["a"], ["b"], **{name: None}).to_dict() == paper
    with pytest.raises(TypeError, match="`train_iteration`: not a protocol value .*train_iterations"):
        savme.Protocol(["a"], ["b"], train_iteration=5)
    with pytest.raises(ValueError, match="`seed`"):
        savme.Protocol(["a"], ["b"], seed="one")


@pytest.fixture
def fmu_campaign(savme_bin, tmp_path):
    fmu = tmp_path / "savme-sim.fmu"
    packed = os.environ.get("SAVME_SIM_FMU")
    if packed:
        shutil.copy(packed, fmu)
    else:
        subprocess.run([savme_bin, "fmu", "pack", "--out", str(fmu)], check=True, capture_output=True)
    text = (REPO / "tests" / "fixtures" / "fmu-tiny-campaign.toml").read_text()
    return text.replace('hf = "FMU"', f'hf = "{fmu}"')


def test_each_value_is_a_campaign_file_key_with_the_same_meaning(fmu_campaign, tmp_path):
    base = fmu_campaign.split("[campaign]")[0] + "[campaign]\n"
    rest = "[fidelity]" + fmu_campaign.split("[fidelity]")[1]
    plain = tmp_path / "plain.toml"
    plain.write_text(base + rest)
    default = savme.campaign.load(plain).protocol.to_dict()
    assert default["seed"] == savme.Protocol(["a"], ["b"]).to_dict()["seed"]
    for v in savme.PROTOCOL_VALUES:
        name = v["name"]
        cfg = tmp_path / f"{name}.toml"
        companions = "".join(f"{k} = {toml_value(x)}\n" for k, x in COMPANIONS.get(name, {}).items())
        cfg.write_text(base + f"{name} = {toml_value(SAMPLES[name])}\n{companions}\n" + rest)
        c = savme.campaign.load(cfg)
        got = c.protocol.to_dict()
        if name == "repeat":
            assert c.repeat == SAMPLES[name]
            assert got == default
            continue
        if name == "method":  # the paper's SAVME: its search values are the defaults, not written
            assert default["search"] == "elite"
            assert not {"search", "allocation", "deployment", "elite"} & set(got)
            continue
        assert got[name] == SAMPLES[name], name
    bad = tmp_path / "bad.toml"
    bad.write_text(base + "train_iteration = 5\n\n" + rest)
    with pytest.raises(ValueError, match=r"bad.toml, line \d+, key `campaign.train_iteration`: not a protocol value"):
        savme.campaign.load(bad)
    # audit_fraction without screening would do nothing: refused, in a file as from Python.
    alone = tmp_path / "alone.toml"
    alone.write_text(base + "audit_fraction = 0.5\n\n" + rest)
    with pytest.raises(ValueError, match=r"`audit_fraction`: 0.5 would do nothing.*screen_iterations is 0"):
        savme.campaign.load(alone)


def test_an_audit_fraction_without_screening_is_refused():
    with pytest.raises(ValueError, match=r"`audit_fraction`: 0.5 would do nothing.*screen_iterations is 0"):
        savme.Protocol(["a"], ["b"], audit_fraction=0.5)
    p = savme.Protocol(["a"], ["b"], audit_fraction=0.5, screen_iterations=3).to_dict()
    assert (p["audit_fraction"], p["screen_iterations"]) == (0.5, 3)


def without_wall(value):
    """`value` without its measured wall-clock fields, at any depth."""
    if isinstance(value, dict):
        return {k: without_wall(v) for k, v in value.items() if "wall" not in k and k != "elapsed_seconds"}
    if isinstance(value, list):
        return [without_wall(v) for v in value]
    return value


def strip_wall(path):
    """A work-cost campaign's trial lines without the measured wall-clock fields (and the
    store's checksum, which covers them)."""
    return [{k: x for k, x in without_wall(json.loads(line)).items() if k != "c"} for line in open(path)]


def test_load_runs_what_savme_run_config_runs(savme_bin, fmu_campaign, tmp_path):
    """savme.campaign.load(file).run() and `savme run --config file`: the same trials and the
    same [estimate] — one composition layer behind both."""
    text = fmu_campaign.replace("isolate = true", "isolate = false") + (
        "\n[estimate]\nmax_runs = 12\ntarget_width = 0.9\n"
    )
    cfg = tmp_path / "campaign.toml"
    cfg.write_text(text)
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run([savme_bin, "run", "--config", str(cfg), "--out", str(cli_out), "--jobs", "2", "--quiet"],
                   check=True, capture_output=True)
    result = savme.campaign.load(cfg, out=py_out, jobs=2).run()
    assert strip_wall(py_out / "trials.jsonl") == strip_wall(cli_out / "trials.jsonl")
    (cli_est,) = cli_out.glob("estimate-*")
    py_est = py_out / cli_est.name
    assert strip_wall(py_est / "trials.jsonl") == strip_wall(cli_est / "trials.jsonl")
    cli_summary = json.loads((cli_est / "summary.json").read_text())
    assert result.estimate["estimate"] == cli_summary["estimate"]
    assert 0 < result.estimate["estimate_hf_runs"] <= 12

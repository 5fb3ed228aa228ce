"""Arguments that overflowed, were negative, were misspelt or were the wrong shape: each is
refused with an error naming the argument and the value (PyO3's "can't convert negative int
to unsigned", serde's "expected value at line 1 column 2" and "Can't extract `str` to `Vec`"
named nothing, and a misspelt scenario weight was taken and ignored)."""

import math

import pytest

import savme
from test_kernel import kernel


def test_negative_and_too_large_ints_are_named_with_their_range():
    u64 = "from 0 to 18446744073709551615"
    for kw, shown in [({"seed": -1}, "-1"), ({"seed": 2**70}, str(2**70)), ({"pair_settle": -1}, "-1")]:
        name = next(iter(kw))
        with pytest.raises(ValueError, match=f"^{name} must be a whole number {u64}, got {shown}$"):
            kernel(**kw)
    with pytest.raises(ValueError, match=r"^continuous variable `gap`: bins must be a whole number from 0 to 4294967295, got -3$"):
        savme.Continuous("gap", 1, 5, bins=-3)
    with pytest.raises(ValueError, match=f"^n must be between 1 and 100000, got {2**70}$"):
        kernel().ask(2**70)
    k = kernel()
    with pytest.raises(ValueError, match=f"^seed must be a whole number {u64}, got -1$"):
        k.estimation(seed=-1)
    with pytest.raises(ValueError, match=r"^refine's runs must be a whole number"):
        k.estimation(refine=(2, -100))
    with pytest.raises(ValueError, match=r"^joint_components must be a whole number"):
        k.estimation(refine=(2, 100), joint_components=-2)
    with pytest.raises(ValueError, match=f"^id must be a whole number {u64}, got -1$"):
        k.estimation().tell(-1, True)
    with pytest.raises(ValueError, match=r"^bins must be a whole number from 0 to 4294967295, got -1$"):
        savme.Problem.driving(bins=-1)
    with pytest.raises(ValueError, match=r"^bins must be a whole number"):
        savme.sim.Driving.fidelity_space(bins=2**40)
    p = savme.Protocol(["stopped"], ["cut_in"], preset="quick")
    with pytest.raises(ValueError, match=r"^jobs must be a whole number from 0 to \d+, got -2$"):
        savme.Campaign(p, savme.Problem.driving(), jobs=-2)
    with pytest.raises(ValueError, match=r"^repeat must be a whole number from 0 to 4294967295, got 1099511627776$"):
        savme.Campaign(p, savme.Problem.driving(), repeat=2**40)


def test_protocol_values_that_are_not_finite_or_too_large_are_named():
    for bad in (math.nan, math.inf):
        with pytest.raises(ValueError, match=rf"^budgets = \[{bad}\]: not a finite number \(NaN and infinity are refused\)$"):
            savme.Protocol(["a"], ["b"], budgets=[bad])
    with pytest.raises(ValueError, match=r"^audit_fraction = nan: not a finite number"):
        savme.Protocol(["a"], ["b"], audit_fraction=math.nan)
    with pytest.raises(ValueError, match=rf"^seed = {2**70}: it does not fit in 64 bits$"):
        savme.Protocol(["a"], ["b"], seed=2**70)
    with pytest.raises(ValueError, match=rf"^budgets = \[0.3, {2**70}\]: {2**70} does not fit in 64 bits$"):
        savme.Protocol(["a"], ["b"], budgets=[0.3, 2**70])


def test_a_str_for_a_list_of_scenarios_is_named_not_split():
    with pytest.raises(TypeError, match=r"^train_scenarios must be a list of scenario names, got the str 'ab'; give \['ab'\] for one scenario$"):
        savme.Protocol("ab", ["c"])
    with pytest.raises(TypeError, match=r"^test_scenarios must be a list of scenario names, got the str 'c'"):
        savme.Protocol(["ab"], "c")
    with pytest.raises(TypeError, match=r"^train_scenarios\[1\]: a scenario name must be a str, got 2$"):
        savme.Protocol(["a", 2], ["c"])
    assert savme.Protocol(("a", "b"), iter(["c"])).to_dict()["train_scenarios"] == ["a", "b"]


def test_a_weight_for_a_scenario_the_protocol_does_not_have_is_refused_naming_it():
    with pytest.raises(KeyError, match=r"weights: unknown scenario `zzz` \(the protocol's scenarios: a, b, c\)"):
        savme.Protocol(["a", "b"], ["c"], weights={"a": 2.0, "zzz": 1.0})
    p = savme.Protocol(["a", "b"], ["c"], weights={"a": 2.0, "c": 0.5})
    assert p.to_dict()["weights"] == {"a": 2.0, "c": 0.5}

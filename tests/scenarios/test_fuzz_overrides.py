"""Property-based: any override dict is a ValueError/TypeError naming a field, or an env whose
reset and first step are finite; never NaN, never a hang."""

from __future__ import annotations

import dataclasses
import datetime
import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import marl_social
from marl_social.scenarios import SCENARIOS
from tests.fuzzing import fuzz

VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10**30), max_value=10**30),
    st.just(10**400), st.floats(), st.floats(-300.0, 300.0), st.integers(-5, 40),
    st.text(max_size=5), st.sampled_from(["10", "2.5", "inf", "nan", "", "abc"]),
    st.lists(st.floats(-10, 10), max_size=7), st.dates(), st.just(datetime.time(1, 2)),
)


def _fields(scenario: str) -> list[str]:
    return [f.name for f in dataclasses.fields(SCENARIOS[scenario].params_cls)]


def _overrides(scenario: str):
    names = st.one_of(st.sampled_from(_fields(scenario)), st.sampled_from(["max_cycles"]),
                      st.text(min_size=1, max_size=6))
    return st.dictionaries(names, VALUES, max_size=4)


def _check(scenario: str, overrides: dict) -> None:
    overrides.pop("robot_theta_hat", None)  # file paths: tests/scenarios/test_bad_values.py
    try:
        env = marl_social.parallel_env(scenario, **overrides)
    except (ValueError, TypeError) as err:
        named = [*overrides, *_fields(scenario), "max_cycles"]
        assert any(str(name) in str(err) for name in named), err
        return
    obs, _ = env.reset(seed=0)
    assert all(np.all(np.isfinite(o)) for o in obs.values())
    _, rewards, *_ = env.step({a: np.zeros(2) for a in env.agents})
    assert all(math.isfinite(r) for r in rewards.values())


@fuzz(120, deadline_s=5.0)
@given(overrides=_overrides("occluded_crosswalk"))
def test_occluded_crosswalk_overrides(overrides):
    _check("occluded_crosswalk", overrides)


@fuzz(60, deadline_s=5.0)
@given(overrides=_overrides("long_road"))
def test_long_road_overrides(overrides):
    _check("long_road", overrides)

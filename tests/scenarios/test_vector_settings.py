"""Vector-valued settings follow one rule: a list, tuple or 1-d array of the same numbers is the
same setting; anything else is a one-line error naming the field."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import marl_social
from marl_social.scenarios import make_scenario
from marl_social.scenarios.base import MAX_COST_WEIGHT
from tests.helpers import zero_actions

FIELDS = ("human_theta", "robot_theta_hat")
WEIGHT = st.floats(0.0, MAX_COST_WEIGHT, allow_nan=False)


@settings(max_examples=30, deadline=None)
@given(st.lists(WEIGHT, min_size=6, max_size=6), st.sampled_from(FIELDS),
       st.sampled_from(["occluded_crosswalk", "t_intersection"]))
def test_a_list_a_tuple_and_an_array_of_the_same_weights_are_one_setting(weights, field, scene):
    forms = [list(weights), tuple(weights), np.array(weights), np.array(weights, np.float32)
             .astype(np.float64)]
    params = [getattr(make_scenario(scene, **{field: form}).params, field) for form in forms]
    assert params[0] == params[1] == params[2] == tuple(float(w) for w in weights)


BAD_VECTORS = st.one_of(
    st.text(min_size=1, max_size=4), st.integers(), st.floats(),
    st.lists(WEIGHT, min_size=1, max_size=5), st.lists(WEIGHT, min_size=7, max_size=9),
    st.just(np.ones((2, 3))), st.just([True] * 6), st.just(["1"] * 6),
    st.just([np.nan] * 6), st.just([np.inf] + [0.0] * 5), st.just([10 * MAX_COST_WEIGHT] * 6),
    st.just([10**400] + [0] * 5))


@settings(max_examples=60, deadline=None)
@given(BAD_VECTORS, st.sampled_from(["human_theta"]))
def test_anything_else_is_a_one_line_error_naming_the_field(bad, field):
    with pytest.raises((ValueError, TypeError), match=field) as err:
        make_scenario("occluded_crosswalk", **{field: bad})
    assert "\n" not in str(err.value)


def test_numpy_weights_run_the_episode_of_the_equal_list():
    a = marl_social.parallel_env(human_theta=np.full(6, 0.5)).reset(seed=3)[0]
    b = marl_social.parallel_env(human_theta=[0.5] * 6).reset(seed=3)[0]
    assert all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("name", [["x"], 3, None, b"occluded_crosswalk"])
def test_a_scenario_that_is_not_a_name_is_a_value_error(name):
    with pytest.raises(ValueError, match="unknown scenario"):
        marl_social.parallel_env(scenario=name)


@pytest.mark.parametrize("flag", ["no", "", 0, 1, None, [True]])
def test_render_fov_takes_only_a_bool(flag):
    with pytest.raises(TypeError, match="render_fov must be a bool"):
        marl_social.parallel_env(render_fov=flag)


def test_an_int_beyond_int64_in_an_action_list_is_a_number(paper_env):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["robot_0"] = [2**64, 0]
    paper_env.step(actions)  # saturates at the car's limits, like any large command


def test_a_road_of_very_many_cars_warns_why_it_is_slow():
    with pytest.warns(RuntimeWarning, match=r"n_vehicles=1000: a step costs about the square"):
        make_scenario("long_road", n_vehicles=1000)

"""The page's controls: bound to settings-tree leaves, every bad value one clear line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from marl_social.scenarios import SCENARIOS
from marl_social.scenarios.settings_tree import settings_leaves
from marl_social.teach.controls import (
    THETA_HAT_PRESETS,
    SettingsError,
    scene_controls,
    validate_request,
)


@pytest.mark.parametrize("scenario", ["occluded_crosswalk", "t_intersection",
                                      "signalized_intersection", "long_road"])
def test_every_control_is_a_settings_leaf(scenario):
    leaves = settings_leaves(SCENARIOS[scenario].params_cls)
    for control in scene_controls(scenario):
        assert control.name in leaves or control.name in ("scenario", "seed"), control.name
        json.dumps(control.as_json())  # the page reads them as JSON


def test_the_lecture_controls_are_there():
    names = [c.name for c in scene_controls("occluded_crosswalk")]
    for name in ("scenario", "pedestrian", "robot.planner", "human.beta", "human.blind",
                 "robot.theta_hat", "robot.pos_noise_m", "robot.epsilon", "seed"):
        assert name in names
    t_names = [c.name for c in scene_controls("t_intersection")]
    assert "hidden_vehicle" in t_names and "pedestrian" not in t_names


def test_a_valid_request_becomes_env_settings():
    scenario, settings, seed = validate_request({
        "scenario": "occluded_crosswalk", "human.beta": 2.5, "human.blind": True,
        "robot.theta_hat": "wrong", "robot.planner": "aggressive", "seed": 7})
    assert scenario == "occluded_crosswalk" and seed == 7
    assert settings == {"human.beta": 2.5, "human.blind": True, "robot.planner": "aggressive",
                        "robot.theta_hat": THETA_HAT_PRESETS["wrong"]}


@pytest.mark.parametrize(("request_", "words"), [
    ({"human.betta": 3}, "unknown control 'human.betta' for scene 'occluded_crosswalk'; did you mean 'human.beta'"),
    ({"human.beta": 1e9}, "outside [0, 30]"),
    ({"human.beta": "abc"}, "expected a number"),
    ({"human.beta": float("nan")}, "outside"),
    ({"human.beta": True}, "expected a number"),
    ({"human.blind": "yes"}, "expected true or false"),
    ({"robot.planner": "socia"}, "did you mean 'social'"),
    ({"robot.theta_hat": "../../etc/passwd"}, "is not one of true, learned, wrong"),
    ({"seed": 1.5}, "expected an integer"),
    ({"seed": -1}, "outside"),
    ({"scenario": "nope"}, "unknown scene 'nope'"),
    ({"scenario": 3}, "expected a name"),
    ([1, 2], "expected an object"),
])
def test_bad_requests_fail_with_one_line(request_, words):
    with pytest.raises(SettingsError) as err:
        validate_request(request_)
    message = str(err.value)
    assert words in message and "\n" not in message


def test_the_learned_preset_is_what_the_fit_gives():
    """The "learned" θ̂ preset: fit_theta on 100 near-rational demonstrations (seed 11)."""
    from marl_social.agents.irl.laplace import fit_theta, robot_model_from_fit
    from marl_social.agents.irl.synthetic import near_rational_demonstrations
    from marl_social.sim.costs import CostWeights

    truth = CostWeights().as_array()
    fit = fit_theta(near_rational_demonstrations(10.0 * truth, 100, seed=11))
    theta_hat, _ = robot_model_from_fit(fit.to_json())
    np.testing.assert_allclose(theta_hat.as_array(), THETA_HAT_PRESETS["learned"], rtol=1e-4)

"""Scenario values: finite, in range, bounded sizes; every error names its field."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

import marl_social

INF = math.inf


@pytest.mark.parametrize(("overrides", "field"), [
    ({"road_end_x_m": INF}, "road_end_x_m"),
    ({"road_end_x_m": 1e30}, "road_end_x_m"),
    ({"n_rays": 10**9}, "n_rays"),
    ({"n_slots": 10**9}, "n_slots"),
])
def test_huge_extents_and_sizes_are_rejected_fast(overrides, field):
    start = time.perf_counter()
    with pytest.raises(ValueError, match=f"OccludedCrosswalkParams.{field}"):
        marl_social.parallel_env(**overrides)
    assert time.perf_counter() - start < 1.0


@pytest.mark.parametrize(("overrides", "field"), [
    ({"n_vehicles": 10**7}, "n_vehicles"),
    ({"spacing_m": INF}, "spacing_m"),
    ({"sensor_range_m": INF}, "sensor_range_m"),
])
def test_long_road_sizes_are_bounded(overrides, field):
    with pytest.raises(ValueError, match=f"LongRoadParams.{field}"):
        marl_social.parallel_env("long_road", **overrides)


@pytest.mark.parametrize(("overrides", "field"), [
    ({"collision_penalty": INF}, "collision_penalty"),
    ({"robot_sensor_range_m": INF}, "robot_sensor_range_m"),
    ({"human_sensor_range_m": INF}, "human_sensor_range_m"),
    ({"pedestrian_sensor_range_m": INF}, "pedestrian_sensor_range_m"),
    ({"robot_pos_noise_m": INF}, "robot_pos_noise_m"),
    ({"human_pos_noise_m": INF}, "human_pos_noise_m"),
    ({"human_lead_m": INF}, "human_lead_m"),
    ({"crosswalk_width_m": -5.0}, "crosswalk_width_m"),
    ({"crosswalk_width_m": 0.0}, "crosswalk_width_m"),
    ({"crosswalk_width_m": INF}, "crosswalk_width_m"),
    ({"crosswalk_width_m": -INF}, "crosswalk_width_m"),
    ({"pedestrian_start_delay_s": INF}, "pedestrian_start_delay_s"),
    ({"speed_limit_mps": INF}, "speed_limit_mps"),
])
def test_values_that_would_give_nan_are_rejected(overrides, field):
    with pytest.raises(ValueError, match=f"OccludedCrosswalkParams.{field}"):
        marl_social.parallel_env(**overrides)


def test_largest_accepted_values_give_finite_observations_and_rewards():
    env = marl_social.parallel_env(collision_penalty=1e9, robot_sensor_range_m=1000.0,
                                   human_pos_noise_m=10.0, crosswalk_width_m=20.0,
                                   road_end_x_m=2000.0, max_cycles=3)
    obs, _ = env.reset(seed=0)
    assert all(np.all(np.isfinite(o)) for o in obs.values())
    _, rewards, *_ = env.step({a: np.zeros(2) for a in env.agents})
    assert all(math.isfinite(r) for r in rewards.values())


@pytest.mark.parametrize(("overrides", "field", "error"), [
    ({"n_humans": "abc"}, "n_humans", ValueError),
    ({"n_humans": True}, "n_humans", TypeError),
    ({"human_beta": 10**400}, "human_beta", ValueError),
    ({"crosswalk_x_m": INF}, "crosswalk_x_m", ValueError),
    ({"crosswalk_x_m": "x"}, "crosswalk_x_m", ValueError),
    ({"max_cycles": "ten"}, "max_cycles", ValueError),
    ({"max_cycles": 10**12}, "max_cycles", ValueError),
])
def test_errors_name_the_field(overrides, field, error):
    with pytest.raises(error, match=field):
        marl_social.parallel_env(**overrides)


def test_numeric_strings_still_convert():
    env = marl_social.parallel_env(max_cycles="10", n_humans="2")
    assert env.max_cycles == 10 and env.scenario.params.n_humans == 2


def test_direct_construction_checks_types():
    from marl_social.scenarios.occluded_crosswalk import OccludedCrosswalkParams

    with pytest.raises(TypeError, match="n_humans"):
        OccludedCrosswalkParams(n_humans="2")
    with pytest.raises(ValueError, match="human_beta.*float range"):
        OccludedCrosswalkParams(human_beta=10**400)


def _write(path, content) -> str:
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(json.dumps(content))
    return str(path)


GOOD_FIT = {"format": "marl-social-irl/1", "fitted": ["speed", "accel"],
            "direction": [None, 0.8, 0.6, None, None, None], "scale": 2.0}


@pytest.mark.parametrize(("content", "message"), [
    ([1, 2, 3], "JSON list"),
    ({k: v for k, v in GOOD_FIT.items() if k != "direction"}, "missing field.*direction"),
    ({**GOOD_FIT, "direction": [0.5, 0.5]}, "direction.*6 numbers"),
    ({**GOOD_FIT, "fitted": ["warp"]}, "fitted"),
    ({**GOOD_FIT, "direction": [None, None, 0.6, None, None, None]}, "direction.*speed"),
    ({**GOOD_FIT, "scale": "big"}, "scale"),
    (b"\xff\xfe\x00\x81", "not a UTF-8"),
    (b"", "not a JSON file"),
])
def test_theta_file_errors_name_the_file(tmp_path, content, message):
    path = _write(tmp_path / "theta.json", content)
    with pytest.raises(ValueError, match=f"robot_theta_hat.*theta.json.*{message}"):
        marl_social.parallel_env(robot_theta_hat=path)


def test_theta_file_directory_and_missing(tmp_path):
    with pytest.raises(ValueError, match="robot_theta_hat.*is a directory"):
        marl_social.parallel_env(robot_theta_hat=str(tmp_path))
    with pytest.raises(ValueError, match="robot_theta_hat.*does not exist"):
        marl_social.parallel_env(robot_theta_hat=str(tmp_path / "nope.json"))


def test_empty_theta_path_means_defaults(tmp_path):
    env = marl_social.parallel_env(robot_theta_hat="")
    assert env.scenario.params.robot_theta_hat == ()
    good = _write(tmp_path / "theta.json", GOOD_FIT)
    assert len(marl_social.parallel_env(robot_theta_hat=good).scenario.params.robot_theta_hat) == 6


def test_huge_python_int_for_an_integer_field():
    with pytest.raises(ValueError, match="LongRoadParams.n_vehicles"):
        marl_social.parallel_env("long_road", n_vehicles=10**400)

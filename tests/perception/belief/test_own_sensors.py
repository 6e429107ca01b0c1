"""The robot's own sensors (perception/belief/own_sensors.py): negative information from its
depth rays and positive information from a seen crossing pedestrian."""

from __future__ import annotations

import numpy as np
from marl_social.perception.belief import PedestrianBelief

from tests.perception.belief.episodes import hyp_index, robot_episode, run_beliefs


def test_visible_empty_region_collapses_while_occluded_one_keeps_its_mass():
    """Own sensors only. With the human 60 m ahead and a 200 m sensor the robot sees the right
    curb: "crossing_right" drops below 0.05 within 5 steps. In the paper's scene the right curb
    is out of range, then hidden behind the human car, and keeps its prior mass, while the
    left curb (in view from about x = 20 m) collapses."""
    seen = robot_episode("none", 0, (("human_lead_m", 60.0), ("robot_sensor_range_m", 200.0)),
                          max_steps=8)
    probs, _, belief = run_beliefs(seen, use_social=False)
    right = hyp_index(belief, "crossing_right")
    assert probs[4, right] < 0.05
    assert belief.last_likelihoods["visible_fraction"][right] > 0.9

    hidden = robot_episode("none", 0)
    probs, _, belief = run_beliefs(hidden, use_social=False)
    left = hyp_index(belief, "crossing_left")
    robot_x = hidden[2]
    assert probs[4, right] > 0.24  # prior 0.25, nothing seen
    k = int(np.argmax(robot_x > 30.0))  # 30 m before the crosswalk: right curb in range
    assert probs[k, left] < 0.05
    assert probs[k, right] > 0.25
    fresh = PedestrianBelief(hidden[4].road_map, hidden[4].obs_layout, "robot_0",
                             hidden[4].possible_agents)
    vis = fresh.visible_fraction(hidden[4].obs_layout.decode(hidden[0][k]))
    assert vis[right] == 0.0 and vis[left] == 1.0


def test_seeing_the_pedestrian_is_positive_information():
    """Without social information, once the robot sees the crossing pedestrian the belief in
    "crossing_right" exceeds 0.9 within 3 steps and it is "perceived"."""
    episode = robot_episode("crossing", 0)
    first_seen = int(np.argmax(episode[1]))
    probs, p_ped, belief = run_beliefs(episode, use_social=False)
    right = hyp_index(belief, "crossing_right")
    assert probs[first_seen + 3, right] > 0.9
    assert p_ped[first_seen + 3] == 1.0

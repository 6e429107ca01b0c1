"""fcl contacts and the pymunk ray query used by the fields of view."""

from __future__ import annotations

import numpy as np

import marl_social
from tests.helpers import box, make_world, pedestrian, vehicle, zero_actions


def test_first_hit_matches_pymunk_public_api():
    world = make_world([vehicle("a", 0, 0), vehicle("b", 12.0, 0.5, 0.3), pedestrian("p", 6, 3)],
                       statics=[box(20, -4, 25, 4)])
    rng = np.random.default_rng(1)
    for _ in range(300):
        start = tuple(rng.uniform(-5, 30, 2))
        end = tuple(rng.uniform(-5, 30, 2))
        label, alpha = world.mirror.first_hit(start, end, 0)
        import pymunk

        hit = world.mirror.space.segment_query_first(start, end, 0.0, pymunk.ShapeFilter(group=1))
        if hit is None:
            assert (label, alpha) == (-1, 1.0)
        else:
            assert label == world.mirror.shape_label[hit.shape]
            assert abs(alpha - hit.alpha) < 1e-12


def test_overlapping_vehicles_collide():
    world = make_world([vehicle("a", 0, 0), vehicle("b", 4.0, 0.5)])
    assert world.mirror.contacts() == [(0, 1)]


def test_touching_but_apart_vehicles_do_not_collide():
    # footprints 4.5 m long: centres 4.51 m apart leave a 1 cm gap
    world = make_world([vehicle("a", 0, 0), vehicle("b", 4.51, 0.0)])
    assert world.mirror.contacts() == []
    assert abs(world.mirror.distance(0, 1) - 0.01) < 1e-6
    # side by side in adjacent 3.5 m lanes: 1.7 m apart
    world = make_world([vehicle("a", 0, 0), vehicle("b", 0.0, 3.5)])
    assert world.mirror.contacts() == []
    assert abs(world.mirror.distance(0, 1) - 1.7) < 1e-6


def test_rotated_vehicles_use_their_orientation():
    # b rotated 90 deg: its 4.5 m length now along y, so 2.0 m ahead in x it does not reach a
    world = make_world([vehicle("a", 0, 0), vehicle("b", 3.2, 0.0, np.pi / 2)])
    assert world.mirror.contacts() == []  # a's front at 2.25, b's side at 3.2 - 0.9 = 2.3
    world = make_world([vehicle("a", 0, 0), vehicle("b", 3.0, 0.0, np.pi / 2)])
    assert world.mirror.contacts() == [(0, 1)]


def test_vehicle_into_building_is_a_collision():
    # the car's front is at x = 2.25
    world = make_world([vehicle("a", 0, 0)], statics=[box(2.2, -2, 6, 2)])
    assert world.mirror.contacts() == [(0, 1)]  # label n + 0 = 1 is the building
    world = make_world([vehicle("a", 0, 0)], statics=[box(2.3, -2, 6, 2)])
    assert world.mirror.contacts() == []
    assert abs(world.mirror.distance(0, 1) - 0.05) < 1e-6


def test_pedestrian_hit_by_car_ends_episode_with_collision_in_infos():
    env = marl_social.parallel_env(pedestrian="crossing", human_lead_m=60.0,
                                   pedestrian_start_delay_s=0.0, pedestrian_curb_offset_m=0.0,
                                   crosswalk_x_m=30.0, robot_speed_mps=10.0)
    env.reset(seed=0)
    walk = {"pedestrian_0": np.array([0.0, 1.3], dtype=np.float32)}
    infos = {}
    for _ in range(200):
        if not env.agents:
            break
        actions = zero_actions(env)
        actions.update({k: v for k, v in walk.items() if k in env.agents})
        _, _, terms, _, infos = env.step(actions)
        if any(terms.values()):
            break
    assert infos["robot_0"]["collision"] and infos["pedestrian_0"]["collision"]
    assert infos["robot_0"]["collided_with"] == ["pedestrian_0"]
    assert all(terms.values())
    assert env.agents == []


def test_collision_only_ends_involved_agents_when_configured():
    env = marl_social.parallel_env(scenario="long_road", n_vehicles=4, n_lanes=2,
                                   spacing_m=8.0, terminate_on_collision=False)
    env.reset(seed=0)
    # robot_0 (lane 0, x=0) accelerates into human_1 (lane 0, x=8)
    for _ in range(40):
        acts = zero_actions(env)
        if "robot_0" in acts:
            acts["robot_0"] = np.array([3.0, 0.0], dtype=np.float32)
        _, _, terms, _, _infos = env.step(acts)
        if any(terms.values()):
            break
    assert terms["robot_0"] and terms["human_1"]
    assert not terms["human_0"] and not terms["human_2"]
    assert "robot_0" not in env.agents and "human_0" in env.agents
    assert env.world.mirror.contacts() == []  # the wreck left the mirrors


def test_contact_short_circuit_agrees_with_full_fcl_pass():
    """Random crowded scenes: skipping fcl when no bounds overlap never hides a contact."""
    rng = np.random.default_rng(3)
    n_contacts = 0
    for _ in range(60):
        agents = [vehicle(f"v{i}", *rng.uniform([0, -6], [25, 6]), rng.uniform(-3, 3))
                  for i in range(5)]
        agents.append(pedestrian("p", *rng.uniform([0, -6], [25, 6])))
        x, y = rng.uniform([0, -8], [25, 8])
        world = make_world(agents, statics=[box(x, y, x + 3, y + 2)])
        full = world.mirror.contacts()
        fast = world.mirror.contacts(world.state[:, :2], world.bounding_radius_m, world.active)
        assert fast == full
        n_contacts += len(full)
    assert n_contacts > 0  # the scenes do exercise contacts

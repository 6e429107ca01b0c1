"""Fields of view on real geometry: range, cone, occlusion by agents and static polygons."""

from __future__ import annotations

import numpy as np
import pymunk

import marl_social
from marl_social.perception.fov import depth_ray_angles, target_sample_points
from tests.helpers import box, make_world, pedestrian, vehicle, zero_actions


def _fov(world):
    return world.fov.compute(world.bodies())


def test_paper_scene_robot_cannot_see_pedestrian_but_human_can(paper_env):
    _, infos = paper_env.reset(seed=0)
    assert "pedestrian_0" not in infos["robot_0"]["visible"]
    assert "pedestrian_0" in infos["human_0"]["visible"]
    assert "human_0" in infos["robot_0"]["visible"]


def test_pedestrian_hidden_by_human_car_not_just_by_range():
    """With an unlimited robot range, a human car on the robot's line of sight hides the
    pedestrian (occlusion); moved far ahead, it no longer does."""
    env = marl_social.parallel_env(robot_sensor_range_m=200.0, human_lead_m=25.0)
    _, infos = env.reset(seed=0)
    assert "pedestrian_0" not in infos["robot_0"]["visible"]
    env_no_human_block = marl_social.parallel_env(robot_sensor_range_m=200.0, human_lead_m=60.0)
    _, infos = env_no_human_block.reset(seed=0)
    assert "pedestrian_0" in infos["robot_0"]["visible"]


def test_range_limit():
    near = make_world([vehicle("a", 0, 0, range_m=30.0), pedestrian("p", 29.0, 0.0)])
    far = make_world([vehicle("a", 0, 0, range_m=30.0), pedestrian("p", 31.0, 0.0)])
    assert _fov(near).visible[0, 1]
    assert not _fov(far).visible[0, 1]


def test_view_cone():
    inside = make_world([vehicle("a", 0, 0, half_fov_deg=45.0), pedestrian("p", 10.0, 9.0)])
    outside = make_world([vehicle("a", 0, 0, half_fov_deg=45.0), pedestrian("p", 10.0, 11.0)])
    behind = make_world([vehicle("a", 0, 0, half_fov_deg=45.0), pedestrian("p", -10.0, 0.0)])
    assert _fov(inside).visible[0, 1]
    assert not _fov(outside).visible[0, 1]
    assert not _fov(behind).visible[0, 1]


def test_static_polygon_occludes():
    agents = [vehicle("a", 0, 0), pedestrian("p", 20.0, 0.0)]
    wall = box(10.0, -3.0, 11.0, 3.0)
    assert _fov(make_world(agents)).visible[0, 1]
    world = make_world(agents, statics=[wall])
    fov = _fov(world)
    assert not fov.visible[0, 1]
    # the depth ray straight ahead stops at the wall face (x = 10 minus 0 for the observer centre)
    angles = fov.ray_angles_rad[0]
    ahead = int(np.argmin(np.abs(angles)))
    assert abs(fov.depth_m[0, ahead] - 10.0) < 0.05


def test_partial_occlusion_sees_a_corner():
    """A car half behind a wall is still seen through its visible corner (Nocturne-style)."""
    agents = [vehicle("a", 0, 0), vehicle("b", 20.0, 1.5)]
    wall = box(10.0, -3.0, 11.0, 0.6)
    assert _fov(make_world(agents, statics=[wall])).visible[0, 1]


def test_moving_agents_are_seen_at_their_new_pose():
    """After a step the mirrors hold the new poses: no stale pymunk / fcl state."""
    env = marl_social.parallel_env(robot_sensor_range_m=200.0, human_lead_m=60.0,
                                   pedestrian="waiting")
    _, infos = env.reset(seed=0)
    assert "pedestrian_0" in infos["robot_0"]["visible"]
    # the human car is moved back onto the robot's line of sight to the pedestrian (the line
    # from (0, 1.75) to (60, -5.5) crosses the right lane's car band for x in [21.5, 36.4]):
    # teleport it through the true state and step once; occlusion must follow the car
    world = env.world
    world.state[1, 0] = 29.0
    _, _, _, _, infos = env.step(zero_actions(env))
    assert "pedestrian_0" not in infos["robot_0"]["visible"]
    body = world.mirror._bodies[1]
    assert abs(body.position.x - world.state[1, 0]) < 1e-9


def _brute_force_visible(world) -> np.ndarray:
    """Reference: every sample point in range and cone, public pymunk API, no broad phase."""
    n = world.n
    pts = target_sample_points(world.state[:, :2], world.state[:, 2], world.length_m,
                               world.width_m, world.is_pedestrian)
    vis = np.zeros((n, n), dtype=bool)
    for o in range(n):
        ox, oy, oh = world.state[o, :3]
        for t in range(n):
            if t == o:
                continue
            for p in pts[t]:
                d = np.hypot(p[0] - ox, p[1] - oy)
                b = (np.arctan2(p[1] - oy, p[0] - ox) - oh + np.pi) % (2 * np.pi) - np.pi
                if d > world.sensor_range_m[o] or abs(b) > world.sensor_half_angle_rad[o]:
                    continue
                hit = world.mirror.space.segment_query_first(
                    (ox, oy), tuple(p), 0.0, pymunk.ShapeFilter(group=o + 1))
                if hit is not None and world.mirror.shape_label[hit.shape] == t:
                    vis[o, t] = True
                    break
    return vis


def test_broad_phase_never_changes_the_answer():
    """Random crowded scenes with walls: the numpy broad phase + pymunk narrow phase gives
    exactly the brute-force pymunk answer, and depth rays match direct queries."""
    rng = np.random.default_rng(0)
    for _ in range(15):
        agents = []
        for i in range(12):
            x, y, h = rng.uniform(0, 60), rng.uniform(-15, 15), rng.uniform(-np.pi, np.pi)
            if i % 4 == 3:
                agents.append(pedestrian(f"p{i}", x, y, h))
            else:
                agents.append(vehicle(f"v{i}", x, y, h, range_m=rng.uniform(20, 60),
                                      half_fov_deg=rng.uniform(30, 180)))
        walls = [box(x, y, x + rng.uniform(1, 8), y + rng.uniform(1, 8))
                 for x, y in rng.uniform([0, -20], [60, 20], size=(4, 2))]
        world = make_world(agents, statics=walls, n_rays=24)
        fov = _fov(world)
        np.testing.assert_array_equal(fov.visible, _brute_force_visible(world))
        angles = depth_ray_angles(world.sensor_half_angle_rad, 24)
        for o in range(world.n):
            ox, oy, oh = world.state[o, :3]
            for r in range(24):
                a = oh + angles[o, r]
                end = (ox + world.sensor_range_m[o] * np.cos(a),
                       oy + world.sensor_range_m[o] * np.sin(a))
                hit = world.mirror.space.segment_query_first(
                    (ox, oy), end, 0.0, pymunk.ShapeFilter(group=o + 1))
                expected = world.sensor_range_m[o] * (hit.alpha if hit else 1.0)
                assert abs(fov.depth_m[o, r] - expected) < 1e-9


def test_depth_rays_in_observation(paper_env):
    obs, _ = paper_env.reset(seed=0)
    decoded = paper_env.obs_layout.decode(obs["robot_0"])
    assert decoded.depth_m.shape == (paper_env.obs_layout.n_rays,)
    assert np.all(decoded.depth_m <= 40.0 + 1e-6) and np.all(decoded.depth_m > 0)
    # the human car, 20 m ahead in the next lane, cuts some rays short
    assert decoded.depth_m.min() < 25.0

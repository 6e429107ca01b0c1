"""Signal heads: seen only in range, in the view cone, in front of the head, unoccluded; the
observation's signal slots; maps without signals keep their observation layout."""

from __future__ import annotations

import math

import numpy as np

import marl_social
from marl_social.perception.signal_view import visible_heads
from marl_social.sim.geometry import GeometryMirror
from marl_social.sim.observation import EGO_DIM, SLOT_DIM, ObservationLayout
from marl_social.sim.signals import SignalHead
from tests.helpers import box


def _visible(observer_xy, observer_heading, head, statics=(), range_m=50.0, half_fov_deg=60.0,
             blocker_xy=None):
    """Whether an observer reads `head` (a second car parks at blocker_xy, else far away)."""
    mirror = GeometryMirror(np.zeros(2, bool), np.array([4.5, 4.5]), np.array([1.8, 1.8]),
                            list(statics))
    xy = np.array([observer_xy, blocker_xy if blocker_xy is not None else [1e4, 1e4]], float)
    heading = np.array([observer_heading, 0.0])
    mirror.sync(xy, heading, np.ones(2, bool))
    vis = visible_heads(mirror, (head,), xy, heading, np.full(2, range_m),
                        np.full(2, math.radians(half_fov_deg)), np.ones(2, bool))
    return bool(vis[0, 0])


def test_a_head_is_read_only_when_in_view_in_front_and_unoccluded():
    """Random observer placements in front of a head facing -x: seen iff within range, inside
    the observer's cone, within the head's visor, and no car or building on the line of sight."""
    rng = np.random.default_rng(0)
    head = SignalHead(np.array([0.0, 0.0]), math.pi, "g", 0)  # faces -x
    n_seen = 0
    for _ in range(200):
        xy = rng.uniform([-60.0, -30.0], [30.0, 30.0])
        heading = rng.uniform(-math.pi, math.pi)
        rel = -xy
        dist = float(np.hypot(*rel))
        bearing = math.atan2(rel[1], rel[0])
        in_cone = abs((bearing - heading + math.pi) % (2 * math.pi) - math.pi) <= math.radians(60)
        in_visor = abs((bearing + math.pi - math.pi + math.pi) % (2 * math.pi) - math.pi) \
            <= head.view_half_angle_rad
        expected = dist <= 50.0 and in_cone and in_visor
        got = _visible(xy, heading, head)
        assert got == expected, (xy, heading)
        n_seen += got
        if got:  # a building or a car half way along the line of sight hides it
            mid = 0.5 * xy
            assert not _visible(xy, heading, head, statics=[box(*(mid - 1.0), *(mid + 1.0))])
            if dist > 8.0:
                assert not _visible(xy, heading, head, blocker_xy=mid)
    assert n_seen > 10


def test_layout_signal_slots_round_trip_and_no_signals_keeps_the_layout():
    layout = ObservationLayout(n_slots=3, n_rays=5)
    assert layout.size == EGO_DIM + 3 * SLOT_DIM + 5  # unchanged without signals
    with_signals = ObservationLayout(n_slots=3, n_rays=5, n_signals=3)
    assert with_signals.size == layout.size + 3 * 5
    out = np.zeros((2, with_signals.size), np.float32)
    with_signals._encode_signals(out, np.array([[False, True, True], [False, False, False]]),
                                 np.array([2, 0, 1]))
    assert with_signals.decode(out[0]).signal_states() == {1: 0, 2: 1}
    assert with_signals.decode(out[1]).signal_states() == {}
    assert with_signals.space().contains(out[0])


def test_scenarios_without_signals_have_no_signal_block():
    for name in ("occluded_crosswalk", "t_intersection", "long_road"):
        env = marl_social.parallel_env(scenario=name)
        assert env.obs_layout.n_signals == 0
        p = env.scenario.params
        assert env.observation_space("robot_0").shape == (EGO_DIM + p.n_slots * SLOT_DIM
                                                          + p.n_rays,)


def test_the_robot_reads_only_its_own_head():
    """Along its whole turn the robot never reads the left-turners' or the cross traffic's head
    (their visors face away from it); it reads its own while it approaches."""
    for phase in ("protected_left", "cross_green"):
        env = marl_social.parallel_env(scenario="signalized_intersection", phase=phase,
                                       robot_planner="aggressive", max_cycles=150)
        pols = marl_social.policies(env)
        obs, _ = env.reset(seed=3)
        for policy in pols.values():
            policy.reset(3)
        own = [h.name for h in env.road_map.signal_heads].index("northbound")
        seen = set()
        while "robot_0" in env.agents:
            seen |= set(env.obs_layout.decode(obs["robot_0"]).signal_states())
            obs, *_ = env.step({a: pols[a](obs[a]) for a in env.agents})
        assert seen == {own}

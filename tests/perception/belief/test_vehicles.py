"""Hidden vehicles in the robot's belief (perception/belief/conflicts.py, hypotheses.py, hidden.py)
on a small synthetic crossing (crossing_world.py): the robot drives east on y = 0, a northbound
lane with the right of way crosses at x = 58 and a building hides its upstream part."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from marl_social.models.driver import DriverModel, driver_q_values
from marl_social.perception.belief import (
    BeliefConfig,
    HiddenAgentBelief,
    PedestrianBelief,
    lane_conflicts,
    motion_transition,
    vehicle_hypotheses,
)
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import EGO_DIM, SLOT_DIM, SLOT_INDEX, ObservationLayout
from marl_social.sim.road_map import ConflictZone, Lane, RoadMap, Route
from tests.perception.belief.crossing_world import (
    LANE_POINTS,
    LANE_WIDTH_M,
    NORTH_X_M,
    SPEED_LIMIT_MPS,
    CrossingWorld,
    crossing_map,
    turning_map,
)
from tests.perception.belief.episodes import paper_env

N_DRAWS = 4  # random draws per randomized claim


def _belief(world: CrossingWorld, **kwargs) -> HiddenAgentBelief:
    return HiddenAgentBelief(world.robot_map(), world.layout, "robot_0", ["robot_0"], **kwargs)


def _path_mask(belief, path: str, progress_bin=None) -> np.ndarray:
    return np.array([h.path == path and (progress_bin is None or h.progress_bin == progress_bin)
                     for h in belief.hypotheses])


def test_lanes_with_the_right_of_way_that_cross_the_route_yield_vehicle_hypotheses():
    """The northbound lane (priority in the conflict zone) yields hypotheses; the southbound one
    crosses too but yields to the robot there; the robot's own lane and the parallel westbound
    lane yield none. Without a conflict zone every crossing lane has the right of way."""
    road_map = crossing_map()
    route = road_map.routes["robot_0"]
    conflicts = {c.lane_index: c for c in lane_conflicts(road_map, route)}
    assert sorted(conflicts) == [1, 3]
    north = conflicts[1]
    assert (north.kind, north.zone, north.priority) == ("crossing", "crossing", True)
    assert not conflicts[3].priority
    assert abs(north.route_s_m - (NORTH_X_M + 20.0)) < 0.3  # the route starts at x = -20
    assert abs(north.lane_s_m - (80.0 - 1.75)) < 0.3  # half a lane before the robot's centre line
    cfg = BeliefConfig()
    hyps = vehicle_hypotheses(road_map, route, cfg.vehicle_speed_fractions,
                              cfg.vehicle_progress_step_m, cfg.vehicle_upstream_s)
    assert {h.path for h in hyps} == {"vehicle_north"} and {h.kind for h in hyps} == {"vehicle"}
    no_zone = crossing_map(zones=False)
    hyps = vehicle_hypotheses(no_zone, route, cfg.vehicle_speed_fractions,
                              cfg.vehicle_progress_step_m, cfg.vehicle_upstream_s)
    assert {h.path for h in hyps} == {"vehicle_north", "vehicle_south"}
    # the paper's map: both lanes run parallel to the robot's route, only pedestrians
    env = paper_env()
    robot_map = env.road_map.for_agent("robot_0")
    assert lane_conflicts(robot_map, robot_map.routes["robot_0"]) == []
    belief = PedestrianBelief(robot_map, env.obs_layout, "robot_0", ["robot_0"])
    assert {h.kind for h in belief.hypotheses if h.present} == {"pedestrian"}
    assert belief.p_vehicle == 0.0


def test_vehicle_bins_lie_upstream_of_the_conflict_at_speeds_around_the_limit():
    """Progress bins every vehicle_progress_step_m, the last one starting where the lane meets
    the route and the first vehicle_upstream_s at the fastest speed before it; speed bins at
    the configured fractions of the limit; each bin's region is on the lane, a car's width
    wide, over its bin (the car's length beyond either end)."""
    road_map = crossing_map()
    cfg = BeliefConfig()
    hyps = vehicle_hypotheses(road_map, road_map.routes["robot_0"], cfg.vehicle_speed_fractions,
                              cfg.vehicle_progress_step_m, cfg.vehicle_upstream_s)
    conflict = lane_conflicts(road_map, road_map.routes["robot_0"])[0].lane_s_m
    progress = sorted({h.progress_m for h in hyps})
    np.testing.assert_allclose(np.diff(progress), cfg.vehicle_progress_step_m)
    assert progress[-1] == conflict
    reach = cfg.vehicle_upstream_s * max(cfg.vehicle_speed_fractions) * SPEED_LIMIT_MPS
    assert conflict - reach <= progress[0] < conflict - reach + cfg.vehicle_progress_step_m
    assert sorted({h.walk_speed_mps for h in hyps}) == pytest.approx(
        sorted(f * SPEED_LIMIT_MPS for f in cfg.vehicle_speed_fractions))
    for h in hyps:
        region = h.region()
        assert np.abs(region[:, 0] - NORTH_X_M).max() <= 0.5 * h.width_m + 1e-9
        y = region[:, 1] + 80.0  # arc length along the lane
        assert y.min() == pytest.approx(h.progress_m - 0.5 * h.length_m)
        assert y.max() == pytest.approx(h.progress_m + h.bin_length_m + 0.5 * h.length_m)


def test_hypotheses_on_a_curved_lane_follow_it():
    """A lane coming north that turns right on a quarter circle of random radius (48 points)
    and merges into the robot's route: the conflict is a merge, and its hypotheses' predicted
    positions stay on the arc with headings along it."""
    rng = np.random.default_rng(5)
    robot_route = Route([[-20.0, 0.0], [200.0, 0.0]], "robot_0")
    for _ in range(N_DRAWS):
        radius = float(rng.uniform(8.0, 30.0))
        x_merge = float(rng.uniform(40.0, 100.0))
        centre = np.array([x_merge, -radius])
        theta = np.linspace(np.pi, 0.5 * np.pi, 48)  # clockwise, ends at (x_merge, 0) east
        arc = centre + radius * np.column_stack([np.cos(theta), np.sin(theta)])
        lane = np.vstack([arc[:1] - [0.0, 60.0], arc, [[x_merge + 60.0, 0.0]]])
        road_map = RoadMap(lanes=(Lane(lane, 3.5, "ramp"),), crosswalks=(), static_polygons=(),
                           routes={"robot_0": robot_route}, speed_limit_mps=SPEED_LIMIT_MPS)
        (conflict,) = lane_conflicts(road_map, robot_route)
        assert conflict.kind == "merge" and conflict.priority
        hyps = vehicle_hypotheses(road_map, robot_route, (0.7, 1.0), 4.0, 4.0)
        arc_end = 60.0 + 0.5 * math.pi * radius
        on_arc = [h for h in hyps if 60.0 <= h.progress_m < arc_end]
        assert on_arc and max(h.progress_m for h in hyps) == conflict.lane_s_m
        for h in on_arc:
            times = np.linspace(0.0, (arc_end - h.progress_m) / h.walk_speed_mps, 6)
            xy = h.predict_xy(times)
            dist = np.hypot(*(xy - centre).T)
            assert np.abs(dist - radius).max() < 0.01 * radius
            radial = np.arctan2(xy[:, 1] - centre[1], xy[:, 0] - centre[0])
            error = np.angle(np.exp(1j * (h.predict_heading(times) - (radial - 0.5 * math.pi))))
            assert np.abs(error).max() < 0.05


def test_vehicle_hypotheses_progress_along_their_lane():
    """The motion model: mass on the entry bin at the slower speed moves along the lane at that
    speed on average, leaves for "none" after the conflict; "none" feeds the entry bins of each
    kind at that kind's rate."""
    belief = _belief(CrossingWorld())
    hyps = belief.hypotheses
    mat = motion_transition(hyps, DT_S, {"pedestrian": 0.0, "vehicle": 0.0})
    np.testing.assert_allclose(mat.sum(axis=0), 1.0)
    start = next(i for i, h in enumerate(hyps) if h.present and h.progress_bin == 0
                 and h.speed_bin == 0)
    speed = hyps[start].walk_speed_mps
    progress = np.array([h.progress_m for h in hyps])
    p = np.zeros(len(hyps))
    p[start] = 1.0
    for step in range(1, 31):
        p = mat @ p
        mean = (p[1:] @ progress[1:]) / p[1:].sum()
        assert {hyps[i].speed_bin for i in np.flatnonzero(p[1:] > 1e-12) + 1} == {0}
        if step in (10, 20):
            assert abs(mean - progress[start] - speed * DT_S * step) < 1.5, (step, mean)
    for _ in range(2000):
        p = mat @ p
    assert p[0] > 0.99  # it has passed the conflict
    cfg = belief.config
    born = belief.transition[:, 0]
    assert born[0] == pytest.approx(1.0 - cfg.vehicle_hazard_per_s * DT_S)
    assert all(hyps[i].progress_bin == 0 for i in np.flatnonzero(born[1:]) + 1)
    assert 0.05 < belief.prior[1:].sum() < 0.3


def test_the_robots_rays_seeing_the_lane_empty_lower_its_hypotheses():
    """The robot stands at a random x in [35, 52] m: within 10 steps the hypotheses whose region
    it sees are ruled out (< 0.02 of their prior; < 0.2 if it sees half of the region, which
    keeps receiving mass from the hidden bins upstream); the bins the building hides keep their
    mass. Without the building the lane in its sensor cone is seen empty."""
    rng = np.random.default_rng(11)
    for _ in range(N_DRAWS):
        x = float(rng.uniform(35.0, 52.0))
        for building in (True, False):
            world = CrossingWorld((x, 0.0), building=building)
            belief = _belief(world)
            for _ in range(10):
                belief.update(world.observe()[0])
                world.step()
            visible = belief.last_likelihoods["visible_fraction"]
            seen, hidden = visible >= 0.5, belief._present & (visible == 0.0)
            ratio = belief.probabilities / belief.prior
            assert seen.any() and np.all(ratio[seen] < 0.2) and np.all(ratio[visible > 0.9] < 0.02)
            assert np.all(belief.probabilities[hidden] > 0.8 * belief.prior[hidden])
            if building:
                assert hidden.any() and belief.p_vehicle > 0.5 * belief.prior[1:].sum()
            else:  # everything in the robot's sensor cone (50 m, 70 deg) is in view
                in_cone = [i for i, h in enumerate(belief.hypotheses) if h.present and np.all(
                    (np.hypot(h.region()[:, 0] - x, h.region()[:, 1]) < 49.0)
                    & (np.abs(np.arctan2(h.region()[:, 1], h.region()[:, 0] - x))
                       < math.radians(68.0)))]
                assert in_cone and np.all(visible[in_cone] > 0.9)


def test_a_seen_vehicle_matches_its_hypothesis_and_confirms_it():
    """A car coming north at a random speed emerges from behind the building: from the first
    step the robot sees it, it is perceived (p_vehicle = 1) and within 3 steps the belief is on
    its lane, in the bin and speed bin it is in (> 0.9)."""
    rng = np.random.default_rng(3)
    for _ in range(N_DRAWS):
        speed = float(rng.uniform(8.0, 16.0))
        start = float(rng.uniform(5.0, 30.0))
        world = CrossingWorld((45.0, 0.0), {"human_0": ("north", start, speed)})
        belief = _belief(world)
        first = None
        for k in range(150):
            obs, visible = world.observe()
            belief.update(obs)
            if first is None and visible:
                first = k
                assert belief.perceived_kinds["vehicle"] and belief.p_vehicle == 1.0
            if first is not None and k == first + 3:
                break
            if first is None:
                assert belief.p_vehicle < 0.5
            world.step()
        assert first is not None
        s = float(world.world.state[1, 1]) + 80.0
        matching = [i for i, h in enumerate(belief.hypotheses) if h.present
                    and h.progress_m - 3.25 <= s <= h.progress_m + h.bin_length_m + 3.25
                    and h.speed_range_mps[0] <= speed < h.speed_range_mps[1]]
        assert belief.probabilities[matching].sum() > 0.9, (speed, start)


def test_only_cars_driving_along_the_lane_match():
    """matches: a car on the bin driving along the lane at its speed bin's speed; not one
    standing, driving against the lane, across it, or at the other speed bin's speed."""
    belief = _belief(CrossingWorld())
    h = next(h for h in belief.hypotheses if h.present and h.progress_bin == 2
             and h.speed_bin == 0)
    xy = np.array([[NORTH_X_M + 0.4, h.progress_m + 3.0 - 80.0]])
    v = h.walk_speed_mps
    assert h.matches(xy, np.array([[0.0, v]]), 0.5)
    for velocity in ([0.0, 0.0], [0.0, -v], [v, 0.0], [0.0, SPEED_LIMIT_MPS * 1.2]):
        assert not h.matches(xy, np.array([velocity]), 0.5), velocity
    assert not h.matches(xy + [5.0, 0.0], np.array([[0.0, v]]), 0.5)  # beside the lane
    assert not h.matches(xy + [0.0, 20.0], np.array([[0.0, v]]), 0.5)  # another bin


def test_the_belief_reads_only_the_robots_own_map_and_observations():
    """The same hypotheses and beliefs whether the belief gets the full map (every agent's
    route, one of them on the crossing lane) and the env's agent names, or only the robot's
    map and its own name."""
    world = CrossingWorld((45.0, 0.0), {"human_0": ("north", 20.0, 11.0),
                                        "human_1": ("west", 40.0, 9.0)})
    own = _belief(world)
    full = HiddenAgentBelief(world.road_map, world.layout, "robot_0", world.names)
    renamed = HiddenAgentBelief(world.robot_map(), world.layout, "robot_0",
                                ["robot_0", "car_a", "car_b"])
    assert [h.name for h in own.hypotheses] == [h.name for h in full.hypotheses]
    for _ in range(60):
        obs = world.observe()[0]
        p = own.update(obs)
        np.testing.assert_array_equal(full.update(obs), p)
        np.testing.assert_array_equal(renamed.update(obs), p)
        world.step()


def _human_episode(v: float, accel: float, t_brake: float, x0: float):
    """p_vehicle per step while a human on the westbound lane brakes at `accel` from t_brake."""
    world = CrossingWorld((50.0, 0.0), {"human_0": ("west", LANE_POINTS["west"][0][0] - x0, v)})
    belief = _belief(world)
    p, seen = [], []
    n_steps = round((t_brake + v / max(-accel, 1e-9)) / DT_S) + 10 if accel < 0 else 50
    for k in range(n_steps):
        obs, visible = world.observe()
        belief.update(obs)
        p.append(belief.p_vehicle)
        seen.append(visible == ["human_0"])
        world.step({"human_0": accel if k * DT_S >= t_brake else 0.0})
    return np.array(p), all(seen), float(world.world.state[1, 0]), belief


def test_a_human_waiting_for_a_vehicle_the_robot_cannot_see_is_evidence_for_it():
    """Eq. 9-10 with vehicle hypotheses. A human on the westbound lane sees down the northbound
    lane that the building hides from the robot. Random speed 8-11 m/s, braking 3-4.5 m/s^2
    from 0.7-1.2 s on, to a stop 4-8 m before the crossing: p_vehicle exceeds 0.9; the same
    human driving on leaves it at most its prior (+ 0.01). The robot sees only the human."""
    rng = np.random.default_rng(7)
    for _ in range(N_DRAWS):
        v, a = float(rng.uniform(8.0, 11.0)), float(rng.uniform(-4.5, -3.0))
        t_brake, x_stop = float(rng.uniform(0.7, 1.2)), float(rng.uniform(66.0, 70.0))
        x0 = x_stop + v * t_brake + v * v / (-2.0 * a)
        p_brake, seen, x_end, belief = _human_episode(v, a, t_brake, x0)
        assert seen and 64.0 < x_end < 72.0
        assert p_brake.max() > 0.9, (v, a, t_brake, x_stop)
        p_drive, _, _, _ = _human_episode(v, 0.0, t_brake, x0)
        assert p_drive.max() < belief.prior[1:].sum() + 0.01


def test_a_hypothesised_vehicle_the_human_cannot_see_does_not_change_its_q_values():
    """human_q_values = driver_q_values against hypothesis_scene with the human as viewer; a
    human looking away from the northbound lane (driving east, x = 70) is modelled as
    seeing no hypothesised vehicle, so every hypothesis gives it the Q-values of "none"."""
    belief = _belief(CrossingWorld())
    lane = Route(LANE_POINTS["west"])
    s0 = LANE_POINTS["west"][0][0] - 75.0  # x = 75, looking west at the crossing
    q = belief.human_q_values(lane, s0, 10.0, 0.0)
    xy, heading = lane.point_at(s0)
    scene = belief.hypothesis_scene(viewer=(xy, float(heading)))
    assert scene.mask[:, -1].sum() > 0
    for k, v in enumerate(belief.traffic.grid_mps):
        model = DriverModel(theta=belief.config.theta_hat, beta=belief.config.beta_hat,
                            v_desired_mps=float(v))
        ref = driver_q_values(model, lane, s0, 10.0, 0.0, scene, ())
        np.testing.assert_allclose(q[:, k], ref, rtol=1e-12, atol=1e-9)
    away = Route(LANE_POINTS["east"])
    q_away = belief.human_q_values(away, 90.0, 10.0, 0.0)
    np.testing.assert_array_equal(q_away, np.broadcast_to(q_away[:1], q_away.shape))


def test_negligible_vehicle_hypotheses_are_left_out_of_the_humans_scene():
    """A hypothesis marked negligible gets the Q-values of "none" (the human is modelled as not
    reacting to it); the others keep theirs, computed once per distinct scene."""
    belief = _belief(CrossingWorld())
    lane = Route(LANE_POINTS["west"])
    s0 = LANE_POINTS["west"][0][0] - 75.0  # x = 75, looking west at the crossing
    q = belief.human_q_values(lane, s0, 10.0, 0.0)
    differs = np.any(q != q[:1], axis=(1, 2))
    assert differs.sum() >= 2  # some hypothesised cars make the human wait
    rng = np.random.default_rng(3)
    negligible = differs & (rng.random(len(q)) < 0.5)
    negligible[np.flatnonzero(differs)[0]] = True
    negligible[np.flatnonzero(differs)[-1]] = False
    q_pruned = belief.human_q_values(lane, s0, 10.0, 0.0, negligible=negligible)
    np.testing.assert_array_equal(q_pruned[negligible], np.broadcast_to(
        q[:1], q_pruned[negligible].shape))
    np.testing.assert_allclose(q_pruned[~negligible], q[~negligible], rtol=1e-12)


def test_planner_objects_are_cars_for_vehicle_hypotheses_and_unchanged_for_pedestrians():
    """hypothesis_objects: a hypothesised vehicle is a 4.5 x 1.8 m car heading north along its
    lane, not a pedestrian; on the paper's map the objects are the pedestrians the robot
    planner builds itself (0.6 m, walking direction)."""
    belief = _belief(CrossingWorld())
    times = np.array([0.5, 1.0])
    xy, heading, length, width, is_ped, mask = belief.hypothesis_objects(times)
    assert not mask[0] and mask[1:].all() and not is_ped[1:].any()
    np.testing.assert_allclose(heading[1:], 0.5 * math.pi)
    assert set(length[1:]) == {4.5} and set(width[1:]) == {1.8}
    np.testing.assert_allclose(xy[1:, :, 0], NORTH_X_M)
    env = paper_env()
    peds = PedestrianBelief(env.road_map.for_agent("robot_0"), env.obs_layout, "robot_0",
                            ["robot_0"])
    xy, heading, length, width, is_ped, mask = peds.hypothesis_objects(times)
    for i, h in enumerate(peds.hypotheses):
        if h.present:
            np.testing.assert_array_equal(xy[i], h.predict_xy(times))
            assert (heading[i] == math.atan2(h.walk_dir[1], h.walk_dir[0])).all()
    assert is_ped.all() and set(length) == {0.6} and list(mask) == [h.present
                                                                   for h in peds.hypotheses]


def test_one_observation_moves_the_vehicle_log_odds_by_at_most_the_bound():
    """BeliefConfig.max_log_likelihood_ratio still bounds what one observed action does with
    vehicle hypotheses: the braking human's velocity off by up to +-5 m/s moves the log-odds of
    a hidden vehicle by at most the bound compared with the same step without the human."""
    bound = BeliefConfig().max_log_likelihood_ratio
    world = CrossingWorld((50.0, 0.0), {"human_0": ("west", 150.0 - 95.0, 10.0)})
    belief = _belief(world, use_own_sensors=False)

    def log_odds(b, o):
        b = copy.deepcopy(b)
        b.update(o)
        return math.log(b.p_vehicle / (1.0 - b.p_vehicle))

    checked = 0
    for k in range(30):
        obs = world.observe()[0]
        if k >= 8:
            without = obs.copy()
            without[EGO_DIM:EGO_DIM + SLOT_DIM] = 0.0
            reference = log_odds(belief, without)
            for dv in (-5.0, -0.8, 0.0, 0.8, 5.0):
                o = obs.copy()
                o[EGO_DIM + SLOT_INDEX["vx"]] += dv
                assert abs(log_odds(belief, o) - reference) <= bound + 1e-9, (k, dv)
                checked += 1
        belief.update(obs)
        world.step({"human_0": -3.5 if k >= 8 else 0.0})
    assert checked == 110


def test_bad_vehicle_parameters_are_rejected_by_name():
    with pytest.raises(ValueError, match="vehicle_speed_fractions"):
        BeliefConfig(vehicle_speed_fractions=(0.0, 1.0))
    with pytest.raises(ValueError, match="vehicle_progress_step_m"):
        BeliefConfig(vehicle_progress_step_m=0.0)
    with pytest.raises(ValueError, match="p_hidden"):
        _belief(CrossingWorld()).p_hidden("bicycle")
    zone = ConflictZone(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), "z", priority_lanes=(3,))
    with pytest.raises(ValueError, match="priority lanes"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(), conflict_zones=(zone,))


def test_a_human_is_modelled_along_its_lane_and_the_lane_it_continues_into():
    """paths.LanePaths chains a lane with the one lane starting at its end: a human coming south
    on an approach lane that ends in a left turn across the northbound lane is modelled
    turning, so a hypothesised northbound car it sees coming changes its Q-values (holding its
    speed would hit it); modelled on the approach lane alone (parallel to the northbound lane)
    only its safety margin would. A lane that branches in two ends the path."""
    from marl_social.perception.belief.paths import LanePaths

    road_map = turning_map()  # south -> east, centre (62, -14), radius 8
    lanes, approach = road_map.lanes, road_map.lanes[2].centerline
    paths = LanePaths(road_map)
    assert paths.successors[2] == [3]
    route = paths.route_of(np.array([54.0, -12.0]), -0.5 * math.pi)
    assert route.name == "lane_2+3" and route.points[-1].tolist() == [100.0, -22.0]
    belief = HiddenAgentBelief(road_map, ObservationLayout(4, 8), "robot_0", ["robot_0"])
    assert {h.path for h in belief.hypotheses if h.present} == {"vehicle_north"}
    hold = belief.model.first_actions_mps2.index(0.0)
    # 10 m before the turn crosses the northbound lane, at 4 m/s: within the curve speed the
    # robot assumes for the 8 m turn (sqrt(2.5 m/s^2 * 8 m) = 4.5 m/s), so holding it is allowed
    s0, v0 = 8.0, 4.0
    q_turn = belief.human_q_values(route, s0, v0, 0.0)[:, -1, hold]
    assert np.all(np.isfinite(q_turn))
    assert (q_turn[1:] - q_turn[0]).max() > 100.0
    q_straight = belief.human_q_values(Route(approach), s0, v0, 0.0)[:, -1, hold]
    assert np.abs(q_straight[1:] - q_straight[0]).max() < 10.0  # a safety margin at most
    # a second lane starting at the approach's end: no unique continuation
    branching = RoadMap(lanes=(*lanes, Lane(np.array([[54.0, -14.0], [54.0, -60.0]]),
                                            LANE_WIDTH_M, "straight_on")),
                        crosswalks=(), static_polygons=())
    paths = LanePaths(branching)
    assert sorted(paths.successors[2]) == [3, 4] and paths.routes[2].name == "lane_2"

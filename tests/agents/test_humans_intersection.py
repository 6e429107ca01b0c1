"""Human drivers at the T-intersection: they stop at a stop line, give way to oncoming traffic
they see (gap acceptance from the conflict-zone cost) and keep to the curve speed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import marl_social
from marl_social.agents.human import STOP_REACH_M
from marl_social.models.driver import driver_q_values
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.models.yield_expectation import YieldExpectation
from marl_social.perception.tracking import TrackSet
from marl_social.scenarios import SCENARIOS
from marl_social.scenarios.t_intersection import STOP_LINE_Y_M, TIntersection
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.observation import EGO_INDEX
from marl_social.sim.road_map import Route
from marl_social.sim.route_rules import route_conflicts

ROBOT_BRAKE = np.array([-8.0, 0.0], dtype=np.float32)  # the robot stays where it is


def run_humans(seed: int, max_steps: int = 160, scenario: str = "t_intersection",
               **overrides) -> dict:
    """One episode with every human on its built-in planner and the robot (if any) held at rest.

    Returns the true states (T+1, n, 4), active (T+1, n), accelerations (T, n), agent names,
    the map and the first-step visibility {agent: [names]}.
    """
    env = marl_social.parallel_env(scenario=scenario, max_cycles=max_steps, **overrides)
    pols = marl_social.policies(env)
    for i, p in enumerate(pols.values()):
        p.reset(seed * 100 + i)
    obs, infos = env.reset(seed=seed)
    states, active, accel = [env.world.state.copy()], [env.world.active.copy()], []
    while env.agents:
        actions = {a: ROBOT_BRAKE if env.agent_specs[a].role == "robot" else pols[a](obs[a])
                   for a in env.agents}
        obs, _, _, _, _ = env.step(actions)
        states.append(env.world.state.copy())
        active.append(env.world.active.copy())
        accel.append(env.world.accel_mps2.copy())
    out = {"states": np.array(states), "active": np.array(active), "accel": np.array(accel),
           "names": list(env.possible_agents), "road_map": env.road_map,
           "visible": {a: v["visible"] for a, v in infos.items()}}
    env.close()
    return out


def zone_entry_exit(run: dict, agent: str, zone_name: str) -> tuple[float, float]:
    """First step at which the agent's centre is in the named zone, and the last (nan: never)."""
    zone = next(z for z in run["road_map"].conflict_zones if z.name == zone_name)
    i = run["names"].index(agent)
    inside = np.flatnonzero(zone.contains(run["states"][:, i, :2]) & run["active"][:, i])
    return (float(inside[0]), float(inside[-1])) if len(inside) else (np.nan, np.nan)


def random_overrides(seed: int) -> dict:
    """The left-turners' start, speed and rationality and V3's speed, over a plausible range."""
    rng = np.random.default_rng(20_000 + seed)
    return {"human_start_m": float(rng.uniform(6.0, 20.0)),
            "human_speed_mps": float(rng.uniform(3.0, 8.0)),
            "human_beta": float(rng.uniform(3.0, 20.0)),
            "hidden_speed_mps": float(rng.uniform(9.0, 13.0))}


def left_turner_waits(run: dict, human: str, hidden: str) -> bool:
    """The left-turner entered the crossing only after the eastbound car had left it."""
    h_in, _ = zone_entry_exit(run, human, "left_turn_crossing")
    _, v_out = zone_entry_exit(run, hidden, "left_turn_crossing")
    return bool(np.isnan(h_in) or (not np.isnan(v_out) and h_in > v_out))


@pytest.mark.parametrize("seed", [0, 1])
def test_left_turner_waits_for_an_oncoming_car_it_sees(seed):
    """`near`: the oncoming car would arrive while human_0 turns; human_0 sees it at reset and
    lets it pass first (it crosses after the car has left the crossing), then turns."""
    run = run_humans(seed, hidden_vehicle="near", n_humans=1, **random_overrides(seed))
    assert "human_1" in run["visible"]["human_0"]
    assert left_turner_waits(run, "human_0", "human_1")
    h_in, _ = zone_entry_exit(run, "human_0", "left_turn_crossing")
    assert not np.isnan(h_in), "it never turned after the car had passed"


@pytest.mark.parametrize("seed", [0, 1])
def test_left_turner_turns_without_stopping_when_nothing_comes(seed):
    """`none`: no oncoming car, so human_0 turns at once, never coming to rest."""
    run = run_humans(seed, hidden_vehicle="none", n_humans=1, max_steps=100,
                     **random_overrides(seed))
    h_in, _ = zone_entry_exit(run, "human_0", "left_turn_crossing")
    assert not np.isnan(h_in)
    i = run["names"].index("human_0")
    assert run["states"][: int(h_in) + 1, i, 3].min() > 1.0


@pytest.mark.parametrize("seed", [0, 1])
def test_a_blind_left_turner_does_not_wait(seed):
    """The same `near` scene with the left-turner unable to see the eastbound lane west of the
    junction: it gives way only to what it sees, so it turns in front of the car, which has to
    brake hard for it (or is hit); for the seeing left-turner the car does not brake."""
    seeing = run_humans(seed, hidden_vehicle="near", n_humans=1, **random_overrides(seed))
    blind = run_humans(seed, hidden_vehicle="near", n_humans=1, human_blind=True,
                       **random_overrides(seed))
    assert "human_1" not in blind["visible"]["human_0"]
    hidden = seeing["names"].index("human_1")
    assert seeing["accel"][:, hidden].min() > -1.0
    assert blind["accel"][:, hidden].min() < -3.0


def test_left_turners_take_the_bend_at_the_curve_speed():
    """In the bend they keep to the curve speed sqrt(2.5 m/s^2 * 7.75 m) = 4.4 m/s, so they
    stay in their lane (centre within 1 m of the path: pure pursuit cuts the corner a little)."""
    run = run_humans(0, hidden_vehicle="none", n_humans=2, max_steps=100)
    for name in ("human_0", "human_1"):
        i = run["names"].index(name)
        route: Route = run["road_map"].routes[name]
        states = run["states"][run["active"][:, i], i]
        _, lateral, _ = route.project(states[:, :2])
        in_bend = (states[:, 1] < 1.0) & (states[:, 1] > STOP_LINE_Y_M)
        assert in_bend.any()
        assert states[in_bend, 3].max() <= 4.5
        assert np.abs(lateral).max() < 1.0


class _HumanAtStopSign(TIntersection):
    """The T-intersection with a human driver in the robot's place (approaching the stop line)."""

    name = "t_intersection_human_at_stop"

    def build(self, rng):
        layout = super().build(rng)
        robot = layout.agents[0]
        human = dataclasses.replace(robot, role="human", planner={"beta": 10.0})
        return dataclasses.replace(layout, agents=(human, *layout.agents[1:]))


def test_human_stops_at_the_stop_line_then_goes(monkeypatch):
    """A human approaching the stem's stop line at 8 m/s comes to rest with its front just
    behind the line (within STOP_REACH_M), then goes on and turns right (nothing comes)."""
    monkeypatch.setitem(SCENARIOS, _HumanAtStopSign.name, _HumanAtStopSign)
    run = run_humans(0, scenario=_HumanAtStopSign.name, hidden_vehicle="none", n_humans=0,
                     robot_start_back_m=25.0, robot_speed_mps=8.0, max_steps=150)
    states = run["states"][:, 0]
    front_y = states[:, 1] + 2.25  # it drives north: its front is half a length ahead
    before = front_y <= STOP_LINE_Y_M + 0.05
    assert before[0] and not before[-1], "it never crossed the line"
    k_rest = np.flatnonzero(before & (states[:, 3] <= 0.1))
    assert len(k_rest), "it never came to rest before the line"
    assert STOP_LINE_Y_M - front_y[k_rest[0]] <= STOP_REACH_M
    assert states[-1, 0] > 10.0, "it did not turn right and drive on"
    # it crossed the line only after it had rested
    assert np.flatnonzero(~before)[0] > k_rest[0]


def test_right_of_way_is_read_from_the_map():
    """The left-turners' and the robot's routes yield in their zones; V3's has priority."""
    layout = TIntersection().build(np.random.default_rng(0))
    rm = layout.road_map
    yields = {name: {c.zone.name: c.yields for c in route_conflicts(route, rm)}
              for name, route in rm.routes.items()}
    assert yields["human_0"] == {"left_turn_crossing": True}
    assert yields["robot_0"] == {"right_turn_merge": True}
    assert yields["human_2"] == {"left_turn_crossing": False, "right_turn_merge": False}


@pytest.mark.slow
def test_left_turners_wait_in_near_and_not_in_far():
    """Over 20 randomized seeds: human_0 lets a near car pass first in most episodes, and in a
    `far` episode the car is still far when human_0 has turned (it never waits for it)."""
    near = [left_turner_waits(run_humans(s, hidden_vehicle="near", n_humans=1,
                                         **random_overrides(s)), "human_0", "human_1")
            for s in range(20)]
    far_runs = [run_humans(s, hidden_vehicle="far", n_humans=1, max_steps=100,
                           **random_overrides(s)) for s in range(20)]
    far_first = [not left_turner_waits(r, "human_0", "human_1") for r in far_runs]
    assert np.mean(near) >= 0.9
    assert np.mean(far_first) == 1.0


def _v3_best_accel(robot_front_gap_m: float, robot_speed_mps: float, v3_x_m: float,
                   expects_yield: bool = True) -> float:
    """V3's most likely acceleration [m/s^2] at v3_x_m on the eastbound lane at 11 m/s, tracking
    the robot in the stem heading north at robot_speed_mps with its front robot_front_gap_m
    short of the lane; V3 with the scenario knob human_expects_yield = expects_yield."""
    env = marl_social.parallel_env(scenario="t_intersection", hidden_vehicle="near",
                                   n_humans=0, human_expects_yield=expects_yield)
    v3 = marl_social.policies(env)["human_0"]
    env.close()
    car = VehicleParams()
    xy = np.array([[1.75, -3.5 - robot_front_gap_m - 0.5 * car.length_m]])
    velocity = np.array([[0.0, robot_speed_mps]])
    tracks = TrackSet(np.array([1]), xy, velocity, np.array([0.1]), np.array([car.length_m]),
                      np.array([car.width_m]), np.array([False]), np.array([True]),
                      np.array([0.0]), np.array([0.5 * np.pi]))
    scene = v3.predict(tracks)
    if not expects_yield:  # the default: every other vehicle at constant velocity
        assert v3.yield_expectation is None
        np.testing.assert_array_equal(
            scene.xy, ScenePrediction.from_tracks(tracks, v3.model.plan_times_s).xy)
    s0, _ = v3.route.project_point(v3_x_m, -1.75)
    q = driver_q_values(v3.model, v3.route, s0, 11.0, 0.0, scene, v3.crosswalks,
                        v3.road_rules(s0, 11.0))[0]
    return float(v3.model.first_actions_mps2[int(np.argmin(q))])


@pytest.mark.parametrize("v3_x_m", [-25.0, -18.0])
def test_a_driver_expecting_yield_does_not_brake_for_a_car_creeping_to_its_lane(v3_x_m):
    """human_expects_yield: the robot creeps past its stop line at 1.5-1.9 m/s, its front 1-2 m
    short of the eastbound lane; V3 expects it to give way (it can stop at under 2 m/s^2) and
    keeps its speed. By default V3 predicts it at constant velocity into its lane and brakes
    hard."""
    for gap, speed in [(2.0, 1.9), (1.0, 1.5)]:
        assert _v3_best_accel(gap, speed, v3_x_m) >= 0.0
        assert _v3_best_accel(gap, speed, v3_x_m, expects_yield=False) <= -4.0


def test_a_driver_expecting_yield_brakes_for_a_car_too_fast_to_stop():
    """human_expects_yield: the robot 2 m short of the lane at 5 m/s (6.25 m/s^2 to stop): V3
    takes it to pull out and brakes hard."""
    assert _v3_best_accel(2.0, 5.0, -12.0) <= -4.0


@pytest.mark.parametrize("expects_yield", [True, False])
def test_the_robots_model_of_a_human_predicts_the_robot_as_the_humans_do(expects_yield):
    """The robot's model of a human (perception/belief/human_scene.py) predicts the robot
    itself as the humans do: with human_expects_yield a creeping robot stops at the lane's
    edge, by default it drives on at constant velocity."""
    env = marl_social.parallel_env(scenario="t_intersection", hidden_vehicle="none",
                                   n_humans=1, human_expects_yield=expects_yield)
    obs, _ = env.reset(seed=0)
    robot = marl_social.policies(env)["robot_0"]
    robot.reset(0)
    social = robot.belief.social
    decoded = env.obs_layout.decode(obs["robot_0"])
    env.close()
    car = VehicleParams()
    ego = decoded.ego.copy()  # the robot creeping north 2 m short of the lane at 1.9 m/s
    ego_xy = np.array([1.75, -3.5 - 2.0 - 0.5 * car.length_m])
    ego[[EGO_INDEX["x"], EGO_INDEX["y"]]] = ego_xy
    ego[[EGO_INDEX["cos_psi"], EGO_INDEX["sin_psi"]]] = (0.0, 1.0)
    ego[EGO_INDEX["v"]] = 1.9
    moved = dataclasses.replace(decoded, ego=ego)
    empty, empty_xy = np.zeros(0), np.zeros((0, 2))
    no_tracks = TrackSet(np.zeros(0, dtype=np.int64), empty_xy, empty_xy, empty, empty, empty,
                         np.zeros(0, dtype=bool), np.zeros(0, dtype=bool), empty, empty)
    # a human in the left-turn lane looking west at the junction
    scene = social.prediction.scenes.others_scene(np.array([10.0, 1.75]), np.pi, 2, moved, no_tracks)
    times = social.model.plan_times_s
    expected = YieldExpectation(env.road_map).predict_xy(
        ego_xy[None], np.array([[0.0, 1.9]]), np.array([0.5 * np.pi]),
        np.array([car.length_m]), np.array([car.width_m]), np.array([False]), times)
    if not expects_yield:
        expected = ego_xy + np.array([0.0, 1.9]) * times[:, None]
    np.testing.assert_allclose(scene.xy[0, 0], expected.reshape(-1, 2),
                               atol=1e-5)  # float32 observation
    front_y = scene.xy[0, 0, :, 1].max() + 0.5 * car.length_m
    assert front_y == pytest.approx(-3.5) if expects_yield else front_y > 0.0

"""Human drivers at the T-intersection: they stop at a stop line, give way to oncoming traffic
they see (gap acceptance from the conflict-zone cost) and keep to the curve speed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import marl_social
from marl_social.agents.human import STOP_REACH_M
from marl_social.scenarios import SCENARIOS
from marl_social.scenarios.t_intersection import STOP_LINE_Y_M, TIntersection
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

"""Episodes and synthetic worlds the belief tests share: the robot's own observations only."""

from __future__ import annotations

import functools
import math

import numpy as np

import marl_social
from marl_social.agents.cruise import CruiseVehiclePolicy
from marl_social.perception.belief import PedestrianBelief
from marl_social.sim.observation import EGO_DIM, SLOT_DIM, SLOT_INDEX, ObservationLayout
from marl_social.sim.road_map import Lane, RoadMap, Route

SEEDS = tuple(range(10))
CROSSWALK_X_M = 60.0  # the paper map's crosswalk centre [m]


def paper_env(**overrides):
    return marl_social.parallel_env(scenario="occluded_crosswalk", **overrides)


@functools.cache
def robot_episode(pedestrian: str, seed: int, overrides: tuple = (), max_steps: int = 90):
    """The robot's own observations of one episode with every agent on its built-in planner
    and the robot on the cruise baseline (it brakes only for what it sees). Seeded like
    episode.record_episode. Returns (obs (T, size), robot sees the pedestrian (T,) bool,
    robot x (T,) [m], human speed (T,) [m/s], env) — the last three are the test's ground
    truth, the belief only gets obs."""
    env = paper_env(pedestrian=pedestrian, **dict(overrides))
    pols = marl_social.policies(env)
    pols["robot_0"] = CruiseVehiclePolicy(env.agent_specs["robot_0"], env.obs_layout,
                                          env.road_map)
    for name, policy in pols.items():
        policy.reset(seed + env.possible_agents.index(name))
    obs, infos = env.reset(seed=seed)
    rows = []
    while "robot_0" in env.agents and len(rows) < max_steps:
        state = env.world.state
        rows.append((obs["robot_0"].copy(), "pedestrian_0" in infos["robot_0"]["visible"],
                     float(state[0, 0]), float(state[1, 3])))
        if state[0, 0] > CROSSWALK_X_M + 10.0:
            break
        obs, _, _, _, infos = env.step({a: pols[a](obs[a]) for a in env.agents})
    o, seen, rx, hv = zip(*rows)
    return np.array(o), np.array(seen), np.array(rx), np.array(hv), env


def run_beliefs(episode, **kwargs):
    """Run a fresh PedestrianBelief over an episode's robot observations: (T, L) beliefs,
    (T,) p_pedestrian, the belief object."""
    obs, _, _, _, env = episode
    belief = PedestrianBelief(env.road_map, env.obs_layout, "robot_0", env.possible_agents,
                              **kwargs)
    probs, p_ped = [], []
    for o in obs:
        probs.append(belief.update(o))
        p_ped.append(belief.p_pedestrian)
    return np.array(probs), np.array(p_ped), belief


def hyp_index(belief, name, progress_bin=None):
    """(L,) bool: the hypotheses on path `name` ("crossing_right"), all progress and speed
    bins or only progress bin `progress_bin`; `probs @ mask` is the path's belief."""
    return np.array([h.path == name and (progress_bin is None or h.progress_bin == progress_bin)
                     for h in belief.hypotheses])


def synthetic_world(n_humans: int):
    """A straight road without crosswalks, the robot behind n_humans humans, all driving
    13 m/s; noise-free observation vectors built by hand."""
    names = ["robot_0"] + [f"human_{i}" for i in range(n_humans)]
    routes = {name: Route([[-50.0, y], [1000.0, y]], name)
              for name, y in zip(names, (0.0, -3.5, 3.5))}
    lanes = tuple(Lane(route.points, 3.5) for route in routes.values())  # the humans' paths
    road_map = RoadMap(lanes=lanes, crosswalks=(), static_polygons=(), routes=routes)
    layout = ObservationLayout(n_slots=4, n_rays=8)

    def observe(t_s, visible):
        obs = np.zeros(layout.size, dtype=np.float32)
        obs[:EGO_DIM] = [13.0 * t_s, 0.0, 1.0, 0.0, 13.0, 50.0, math.radians(60.0), 0.0]
        for k, i in enumerate(visible):
            slot = np.zeros(SLOT_DIM)
            fields = ("present", "id", "x", "y", "vx", "cos_psi", "length", "width")
            slot[[SLOT_INDEX[f] for f in fields]] = [1, i + 2, 20.0 + 10.0 * i + 13.0 * t_s,
                                                     (-3.5, 3.5)[i], 13.0, 1.0, 4.5, 1.8]
            obs[EGO_DIM + k * SLOT_DIM:EGO_DIM + (k + 1) * SLOT_DIM] = slot
        obs[EGO_DIM + layout.n_slots * SLOT_DIM:] = 50.0
        return obs

    return road_map, layout, names, observe

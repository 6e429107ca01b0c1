"""Helpers shared by the tests: small hand-made worlds for geometry tests, zero actions, bitwise
equality of arrays, the seeds of the many-seed claims, hand-made observations for trackers."""

from __future__ import annotations

import math
import os

import numpy as np

from marl_social.envs.world import World
from marl_social.scenarios.base import ScenarioLayout, ScenarioParams
from marl_social.sim.agent_spec import AgentSpec, SensorParams
from marl_social.sim.observation import EGO_DIM, SLOT_FIELDS, SLOT_INDEX, ObservationLayout
from marl_social.sim.road_map import RoadMap, Route


def vehicle(name, x, y, heading=0.0, speed=0.0, range_m=50.0, half_fov_deg=70.0):
    return AgentSpec(name, "vehicle", "human", np.array([x, y, heading, speed]),
                     sensor=SensorParams(range_m, math.radians(half_fov_deg), pos_noise_m=0.0,
                                         vel_noise_mps=0.0, heading_noise_rad=0.0))


def pedestrian(name, x, y, heading=0.0):
    return AgentSpec(name, "pedestrian", "pedestrian", np.array([x, y, heading, 0.0]),
                     sensor=SensorParams(50.0, math.radians(100.0)))


def make_world(agents, statics=(), n_rays=16) -> World:
    routes = {a.name: Route([[a.initial_state[0] - 1.0, a.initial_state[1]],
                             [a.initial_state[0] + 500.0, a.initial_state[1]]], a.name)
              for a in agents}
    road_map = RoadMap(lanes=(), crosswalks=(), static_polygons=tuple(statics), routes=routes)
    return World(ScenarioLayout(road_map, tuple(agents), ScenarioParams(n_rays=n_rays)))


def box(x0, y0, x1, y1):
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def zero_actions(env) -> dict:
    """Zero action for every live agent (cars keep their speed, pedestrians stand)."""
    return {a: np.zeros(2, dtype=np.float32) for a in env.agents}


def same_bits(a, b) -> bool:
    """Equal bit for bit: shape, dtype and signed zeros included (NaN equals NaN).

    A NaN's sign bit is not compared: IEEE 754 leaves it unspecified for the result of an
    operation, and numpy's and numba's loops pick different NaN operands to propagate (seed 141
    of test_reachable_progress_matches_numpy_bit_for_bit: inf - inf against a +NaN input).
    """
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind != "f":
        return np.array_equal(a, b)
    number = ~np.isnan(a)
    return (np.array_equal(a, b, equal_nan=True)
            and np.array_equal(np.signbit(a[number]), np.signbit(b[number])))


def read_only(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """C-contiguous copies of the arrays that nobody can write to, as the planners hand their
    tables and frozen scenes to the numba kernels.

    numba compiles a read-only array type apart from a writable one: a test that calls a kernel
    with the planners' kinds of arrays runs the machine code they run, from the cache that
    compile_kernels filled (instead of compiling another signature, ~1-2 s each, in CI).
    """
    copies = tuple(np.array(a, order="C") for a in arrays)
    for copy in copies:
        copy.setflags(write=False)
    return copies


def claim_seeds(default_n: int = 50) -> range:
    """The seeds a many-seed claims test runs on.

    MARL_CLAIM_SEEDS (default `default_n`) seeds from MARL_CLAIM_SEED0 (default 0): the test
    command runs seeds 0-49; claims are judged on seeds the code was not tuned on, e.g.
    `MARL_CLAIM_SEED0=400 python -m pytest tests/evaluation/test_robot_claims.py` runs 400-449.
    """
    values = {}
    for name, default in (("MARL_CLAIM_SEEDS", default_n), ("MARL_CLAIM_SEED0", 0)):
        text = os.environ.get(name, str(default))
        try:
            values[name] = int(text)
        except ValueError:
            raise ValueError(f"{name}={text!r}: expected an integer") from None
    if values["MARL_CLAIM_SEEDS"] < 1 or values["MARL_CLAIM_SEED0"] < 0:
        raise ValueError(f"MARL_CLAIM_SEEDS must be >= 1 and MARL_CLAIM_SEED0 >= 0, got "
                         f"{values['MARL_CLAIM_SEEDS']} and {values['MARL_CLAIM_SEED0']}")
    return range(values["MARL_CLAIM_SEED0"], values["MARL_CLAIM_SEED0"] + values["MARL_CLAIM_SEEDS"])


def slot_observation(layout: ObservationLayout, objects):
    """The decoded observation of `layout` with the given objects in its slots.

    objects: (id, x, y, vx, vy) tuples [m, m/s], each a 4.5 m x 1.8 m car.
    """
    vec = np.zeros(layout.size, dtype=np.float32)
    for k, (oid, x, y, vx, vy) in enumerate(objects):
        base = EGO_DIM + k * len(SLOT_FIELDS)
        vec[base + SLOT_INDEX["present"]] = 1.0
        vec[base + SLOT_INDEX["id"]] = oid
        vec[base + SLOT_INDEX["x"]], vec[base + SLOT_INDEX["y"]] = x, y
        vec[base + SLOT_INDEX["vx"]], vec[base + SLOT_INDEX["vy"]] = vx, vy
        vec[base + SLOT_INDEX["length"]], vec[base + SLOT_INDEX["width"]] = 4.5, 1.8
    return layout.decode(vec)

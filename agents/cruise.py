"""Route-following cruise policies: the simulator's rule-based baseline.

Vehicles: pure-pursuit steering along the agent's own route and the Intelligent Driver Model
(Treiber, Hennecke & Helbing 2000) for speed, treating as a leader every object the agent *sees*
that is, or within `PREDICTION_HORIZON_S` at constant velocity will be, in its lane corridor
ahead. A cruise car therefore brakes for a pedestrian stepping onto the road only once it sees
it: it is an "aggressive" driver in the paper's sense (unseen = absent).

Pedestrians: stand on the curb, then (if their intent is to cross) walk along their route at
their desired speed after their start delay, whatever the traffic — no gap acceptance.

Each policy is built from its agent's observation layout, the static map and the agent's own
parameters; `policy(obs) -> action` reads nothing else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.agents.params import PedestrianPlannerParams, parse_planner_params
from marl_social.models.steering import pure_pursuit, walk_along
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import SLOT_INDEX, ObservationLayout
from marl_social.sim.road_map import RoadMap

PREDICTION_HORIZON_S = 3.0


@dataclass(frozen=True)
class IdmParams:
    """Intelligent Driver Model parameters.

    Attributes:
        min_gap_m: standstill bumper-to-bumper gap s0 [m].
        headway_s: desired time headway T [s].
        accel_mps2: maximum acceleration a [m/s^2].
        comfort_brake_mps2: comfortable deceleration b [m/s^2].
        delta: acceleration exponent.
        corridor_margin_m: lateral margin added to both half-widths for the lane corridor [m].
    """

    min_gap_m: float = 2.0
    headway_s: float = 1.2
    accel_mps2: float = 1.5
    comfort_brake_mps2: float = 3.0
    delta: float = 4.0
    corridor_margin_m: float = 0.5


def idm_acceleration(v_mps, v0_mps, gap_m, closing_mps, p: IdmParams) -> np.ndarray:
    """IDM acceleration [m/s^2]; all array arguments broadcast.

    Args:
        v_mps: speed v [m/s].
        v0_mps: desired speed v0 [m/s].
        gap_m: bumper gap to the leader [m] (inf = no leader).
        closing_mps: closing speed v - v_leader [m/s].
        p: the IDM parameters.
    """
    s_star = p.min_gap_m + np.maximum(
        0.0, v_mps * p.headway_s
        + v_mps * closing_mps / (2.0 * math.sqrt(p.accel_mps2 * p.comfort_brake_mps2))
    )
    free = 1.0 - (v_mps / np.maximum(v0_mps, 0.1)) ** p.delta
    interaction = (s_star / np.maximum(gap_m, 0.1)) ** 2
    return p.accel_mps2 * (free - np.where(np.isfinite(gap_m), interaction, 0.0))


class CruiseVehiclePolicy:
    """Pure pursuit + IDM over the vehicle's own observations (see module docstring).

    Args:
        spec: the vehicle's AgentSpec (reads no planner parameter).
        layout: the shared observation layout.
        road_map: the static map.
        idm: the IDM parameters (default IdmParams()).
    """

    needs_truth = False

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 idm: IdmParams | None = None):
        self.name = spec.name
        self.spec = spec
        self.layout = layout
        self.route = road_map.routes[spec.name]
        self.v0 = min(spec.v_desired_mps, road_map.speed_limit_mps)
        self.idm = idm or IdmParams()
        self._horizon = np.arange(0.0, PREDICTION_HORIZON_S + 1e-9, 0.5)

    def reset(self, seed: int | None = None) -> None:
        """Stateless; present for the policy protocol."""

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The (2,) [acceleration m/s^2, steering rad] for the own observation (obs_dim,)."""
        decoded = self.layout.decode(obs)
        x, y, cos_psi, sin_psi, v = decoded.ego[:5]
        psi = math.atan2(sin_psi, cos_psi)
        s_ego, _, _ = self.route.project(np.array([x, y]))
        gap, closing = self._leader(decoded.objects, float(s_ego), float(v))
        accel = float(idm_acceleration(v, self.v0, gap, closing, self.idm))
        steer = pure_pursuit(self.route, x, y, psi, v, float(s_ego), self.spec.vehicle.wheelbase_m)
        return np.array([accel, steer], dtype=np.float32)

    def _leader(self, objects: np.ndarray, s_ego: float, v: float) -> tuple[float, float]:
        """Bumper gap [m] to the nearest seen object in the corridor ahead, and closing speed."""
        if len(objects) == 0:
            return math.inf, 0.0
        xy = objects[:, [SLOT_INDEX["x"], SLOT_INDEX["y"]]]
        vel = objects[:, [SLOT_INDEX["vx"], SLOT_INDEX["vy"]]]
        # constant-velocity prediction over the horizon: (k, H, 2)
        future = xy[:, None, :] + vel[:, None, :] * self._horizon[None, :, None]
        s_obj, lat_obj, heading = self.route.project(future)
        half_w = 0.5 * self.spec.vehicle.width_m + 0.5 * objects[:, SLOT_INDEX["width"]][:, None]
        in_corridor = (np.abs(lat_obj) < half_w + self.idm.corridor_margin_m) & (s_obj > s_ego)
        hit = in_corridor.any(axis=1)
        if not hit.any():
            return math.inf, 0.0
        first = np.argmax(in_corridor, axis=1)  # earliest predicted entry
        rows = np.flatnonzero(hit)
        s_entry = s_obj[rows, first[rows]]
        along_speed = (vel[rows, 0] * np.cos(heading[rows, 0]) + vel[rows, 1]
                       * np.sin(heading[rows, 0]))
        half_len = 0.5 * self.spec.vehicle.length_m + 0.5 * objects[rows, SLOT_INDEX["length"]]
        gaps = s_entry - s_ego - half_len
        k = int(np.argmin(gaps))
        return float(gaps[k]), v - max(float(along_speed[k]), 0.0)


class CruisePedestrianPolicy:
    """Waits, then walks its route at its desired speed (if its intent is to cross).

    Args:
        spec: the pedestrian's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map.
        params: "crossing" and "start_delay_s" (default: parsed from spec.planner).
    """

    needs_truth = False

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 params: PedestrianPlannerParams | None = None):
        params = params or parse_planner_params(PedestrianPlannerParams, spec)
        self.name = spec.name
        self.layout = layout
        self.route = road_map.routes[spec.name]
        self.speed = spec.v_desired_mps
        self.crossing = params.crossing
        self.start_delay_s = params.start_delay_s
        self._time_s = 0.0

    def reset(self, seed: int | None = None) -> None:
        """Back to the episode start (time 0 s); `seed` is unused (deterministic)."""
        self._time_s = 0.0

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The (2,) walking action for the own observation (obs_dim,)."""
        ego = self.layout.decode(obs).ego
        t = self._time_s
        self._time_s += DT_S
        walking = self.crossing and t >= self.start_delay_s
        return walk_along(self.route, float(ego[0]), float(ego[1]),
                          self.speed if walking else 0.0)


def cruise_policies(env) -> dict:
    """{agent: policy} with the cruise baseline for every agent of a SocialDrivingEnv."""
    env = getattr(env, "unwrapped", env)
    out = {}
    for name, spec in env.agent_specs.items():
        cls = CruisePedestrianPolicy if spec.kind == "pedestrian" else CruiseVehiclePolicy
        out[name] = cls(spec, env.obs_layout, env.road_map)
    return out

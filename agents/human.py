"""Human drivers as noisily-optimal planners (paper section III-B-1, eq. 7-8 and 11).

At every step a human driver computes, from its *own* tracks and the static map,

    Q*(x_hat, u) = min over continuations c of  sum_k theta^T phi(x_k, u_k)      (eq. 11)

for each first action u of a discrete set (held for `first_segment_s`, then continuation c
held to the end of the horizon; all candidates rolled out at once), and samples

    u ~ P(u) = softmax(-beta * Q*(x_hat, u))                                      (eq. 8)

with the episode's seeded generator; beta = inf is the argmin (perfectly rational), beta -> 0
uniform. Others are predicted at constant velocity from the human's tracks. The human chooses
its acceleration along its route (path-velocity decomposition); pure pursuit steers.

`driver_q_values` is the same computation for arbitrary hypotheses about the scene: the robot's
model of a human (issue: social perception) calls it with its own hypotheses and (theta_hat,
beta_hat).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from marl_social.agents.costs import CostWeights, step_cost
from marl_social.agents.steering import pure_pursuit
from marl_social.perception.tracking import Tracker, TrackSet

from marl_social.agent_spec import AgentSpec, VehicleParams
from marl_social.dynamics import DT_S
from marl_social.footprint import covering_circles
from marl_social.observation import ObservationLayout
from marl_social.road_map import Crosswalk, RoadMap, Route


@dataclass(frozen=True)
class DriverModel:
    """What defines a driver's decision (its own, or the robot's estimate of it).

    Attributes:
        theta: cost weights.
        beta: rationality (>= 0; inf = always the best action).
        v_desired_mps: speed it wants [m/s] (its v_ref).
        first_actions_mps2: (A,) candidate first accelerations [m/s^2].
        continuations_mps2: (C,) accelerations held after the first segment [m/s^2].
        first_segment_s: how long the first action is held in the rollout [s].
        horizon_s: planning horizon N [s].
        plan_dt_s: time step of the planner's rollout [s] (coarser than the simulator's;
            per-step costs are scaled by plan_dt / DT_S so Q is in simulator-step units).
        vehicle: its physical parameters.
    """

    theta: CostWeights = field(default_factory=CostWeights)
    beta: float = 5.0
    v_desired_mps: float = 11.5
    first_actions_mps2: tuple = (-8.0, -6.0, -4.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0)
    continuations_mps2: tuple = (-4.0, -2.0, -1.0, 0.0, 1.0)
    first_segment_s: float = 0.5
    horizon_s: float = 3.0
    plan_dt_s: float = 0.25
    vehicle: VehicleParams = field(default_factory=VehicleParams)

    def __post_init__(self):
        if not (self.beta >= 0):  # also rejects NaN
            raise ValueError(f"DriverModel.beta must be >= 0 (inf allowed), got {self.beta}")
        if not self.horizon_s > self.first_segment_s >= self.plan_dt_s > 0:
            raise ValueError("DriverModel: need horizon_s > first_segment_s >= plan_dt_s > 0")

    @property
    def plan_times_s(self) -> np.ndarray:
        """(T,) times of the rollout's states after each planner step [s]."""
        n = round(self.horizon_s / self.plan_dt_s)
        return (np.arange(n) + 1) * self.plan_dt_s


@dataclass(frozen=True)
class ScenePrediction:
    """Predicted others for one or more hypotheses (L of them), M objects, T steps.

    Attributes:
        xy: (L, M, T, 2) positions after each step [m]; heading: (L, M, T) [rad].
        length_m, width_m, radius_m: (L, M) footprint [m]; is_pedestrian: (L, M) bool;
        mask: (L, M) bool, object present in that hypothesis.
    """

    xy: np.ndarray
    heading: np.ndarray
    length_m: np.ndarray
    width_m: np.ndarray
    radius_m: np.ndarray
    is_pedestrian: np.ndarray
    mask: np.ndarray

    @classmethod
    def from_tracks(cls, tracks: TrackSet, times_s: np.ndarray) -> ScenePrediction:
        """One hypothesis: every track at constant velocity."""
        xy = tracks.predict_xy(times_s)[None]  # (1, M, T, 2)
        speed = np.linalg.norm(tracks.velocity, axis=1)
        heading = np.where(speed > 0.05, np.arctan2(tracks.velocity[:, 1], tracks.velocity[:, 0]),
                           0.0)
        heading = np.broadcast_to(heading[None, :, None], xy.shape[:-1])
        radius = 0.5 * np.hypot(tracks.length_m, tracks.width_m)
        m = len(tracks)
        return cls(xy, heading, tracks.length_m[None], tracks.width_m[None], radius[None],
                   tracks.is_pedestrian[None], np.ones((1, m), dtype=bool))


def rollout_speeds(v0: float, accel: np.ndarray, dt_s: float = DT_S) -> tuple[np.ndarray, ...]:
    """Speeds and distances of acceleration profiles with the v >= 0 limit, without a time loop.

    v_{k+1} = max(0, v_k + a_k dt) is a Lindley recursion: with S_k = v0 + sum_{i<k} a_i dt,
    v_k = S_k - min(0, min_{j<=k} S_j).

    Args:
        accel: (..., T) commanded accelerations [m/s^2].
    Returns:
        v (..., T) speed after each step [m/s], ds (..., T) distance travelled up to each step
        [m], a_eff (..., T) effective acceleration (dv / dt) [m/s^2].
    """
    shape = accel.shape
    s = v0 + np.cumsum(accel * dt_s, axis=-1)
    s_full = np.concatenate([np.full(shape[:-1] + (1,), v0), s], axis=-1)
    v_full = s_full - np.minimum(0.0, np.minimum.accumulate(s_full, axis=-1))
    v = v_full[..., 1:]
    ds = np.cumsum(0.5 * (v_full[..., 1:] + v_full[..., :-1]) * dt_s, axis=-1)
    return v, ds, np.diff(v_full, axis=-1) / dt_s


def driver_q_values(model: DriverModel, route: Route, s0: float, v0: float, prev_accel: float,
                    scene: ScenePrediction, crosswalks: tuple[Crosswalk, ...]) -> np.ndarray:
    """Q*(x_hat, u) for each first action u and each scene hypothesis (eq. 11).

    Args:
        route: the driver's route; s0 [m], v0 [m/s]: its arc length and speed;
        prev_accel: its last acceleration [m/s^2] (for the jerk term);
        scene: predicted others, L hypotheses, at model.plan_times_s.
    Returns:
        (L, A) optimal cost-to-go of each first action.
    """
    dt = model.plan_dt_s
    n_steps = round(model.horizon_s / dt)
    n_first = round(model.first_segment_s / dt)
    first = np.asarray(model.first_actions_mps2, dtype=np.float64)
    cont = np.asarray(model.continuations_mps2, dtype=np.float64)
    step = np.arange(n_steps)
    accel = np.where(step < n_first, first[:, None, None], cont[None, :, None])  # (A, C, T)
    v, ds, a_eff = rollout_speeds(v0, accel, dt)
    xy, heading = route.point_at(s0 + ds)  # (A, C, T, 2), (A, C, T)
    veh = model.vehicle
    ego_circles, ego_r = covering_circles(xy, heading, veh.length_m, veh.width_m, False)
    oc, orad = covering_circles(
        scene.xy, scene.heading, scene.length_m[..., None], scene.width_m[..., None],
        scene.is_pedestrian[..., None],
    )  # (L, M, T, C, 2)
    # others to (L, 1, 1, T, M, ...) so they broadcast against the (A, C, T) candidates
    to_cand = lambda a: np.moveaxis(a, 1, 2)[:, None, None]
    prev = np.concatenate([np.full(a_eff.shape[:-1] + (1,), prev_accel), a_eff[..., :-1]], -1)
    cost = step_cost(
        model.theta.as_array(), lateral_m=0.0, speed_mps=v, v_ref_mps=model.v_desired_mps, accel_mps2=a_eff,
        prev_accel_mps2=prev,
        ego_xy=xy, ego_radius=0.5 * math.hypot(veh.length_m, veh.width_m), ego_is_ped=False,
        ego_circles=ego_circles, ego_circle_r=ego_r,
        other_xy=to_cand(scene.xy),
        other_radius=scene.radius_m[:, None, None, None, :],
        other_is_ped=scene.is_pedestrian[:, None, None, None, :],
        other_circles=to_cand(oc), other_circle_r=to_cand(orad),
        other_mask=scene.mask[:, None, None, None, :],
        crosswalks=crosswalks,
    )  # (L, A, C, T)
    return cost.sum(axis=-1).min(axis=-1) * (dt / DT_S)


def boltzmann(q_values: np.ndarray, beta: float) -> np.ndarray:
    """P(u) = softmax(-beta * Q) along the last axis; beta = inf puts all mass on the argmin
    (ties split evenly), beta = 0 is uniform."""
    q = np.asarray(q_values, dtype=np.float64)
    if math.isinf(beta):
        best = q == q.min(axis=-1, keepdims=True)
        return best / best.sum(axis=-1, keepdims=True)
    z = -beta * (q - q.min(axis=-1, keepdims=True))
    p = np.exp(z)
    return p / p.sum(axis=-1, keepdims=True)


class BoltzmannDriver:
    """A human driver policy: tracks what it sees, plans (eq. 11), samples (eq. 8).

    Built from its own AgentSpec (planner parameters: "beta", "theta" override the defaults),
    the shared observation layout and the static map — nothing else.
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap):
        self.name = spec.name
        self.layout = layout
        self.route = road_map.routes[spec.name]
        self.crosswalks = road_map.crosswalks
        self.model = DriverModel(
            theta=spec.cost_weights, beta=float(spec.planner.get("beta", 5.0)),
            v_desired_mps=min(spec.v_desired_mps, road_map.speed_limit_mps),
            vehicle=spec.vehicle,
        )
        self.tracker = Tracker(spec.sensor.pos_noise_m, spec.sensor.vel_noise_mps)
        self._times = self.model.plan_times_s
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        self.tracker.reset()
        self.prev_accel = 0.0
        self.last_probabilities = None
        self.last_q = None

    def action_distribution(self, obs) -> np.ndarray:
        """(A,) probabilities of the first actions for this observation (updates the tracks)."""
        decoded = self.layout.decode(obs)
        x, y = float(decoded.ego[0]), float(decoded.ego[1])
        v = float(decoded.ego[4])
        tracks = self.tracker.update(decoded)
        s0, _ = self.route.project_point(x, y)
        self._last_pose = (x, y, math.atan2(float(decoded.ego[3]), float(decoded.ego[2])), v, s0)
        scene = ScenePrediction.from_tracks(tracks, self._times)
        q = driver_q_values(self.model, self.route, s0, v, self.prev_accel, scene,
                            self.crosswalks)[0]
        self.last_q = q
        self.last_probabilities = boltzmann(q, self.model.beta)
        return self.last_probabilities

    def choose(self, probabilities: np.ndarray) -> int:
        """Sample an action index from the distribution with the policy's seeded generator
        (inverse-CDF sampling: one uniform draw)."""
        cdf = np.cumsum(probabilities)
        k = int(np.searchsorted(cdf, self.rng.random() * cdf[-1], side="right"))
        return min(k, len(probabilities) - 1)

    def __call__(self, obs) -> np.ndarray:
        p = self.action_distribution(obs)
        accel = self.model.first_actions_mps2[self.choose(p)]
        self.prev_accel = accel
        x, y, psi, v, s_arc = self._last_pose
        steer = pure_pursuit(self.route, x, y, psi, v, s_arc, self.model.vehicle.wheelbase_m)
        return np.array([accel, steer], dtype=np.float32)

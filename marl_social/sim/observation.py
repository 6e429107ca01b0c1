"""The one observation layout shared by all agents (a flat float32 vector).

    [ ego (EGO_DIM) | K object slots (K * SLOT_DIM) | depth rays (n_rays)
      | S signal slots (S * SIGNAL_DIM), only in a map with signal heads (S = their number) ]

ego:   x, y [m], cos(psi), sin(psi), v [m/s], sensor range [m], sensor half-angle [rad],
       is_pedestrian (0/1). Ego state is the agent's own odometry: exact.
slot:  present (0/1), object id (agent index + 1; 0 = empty), x, y [m], vx, vy [m/s],
       cos(psi), sin(psi), length [m], width [m], is_pedestrian (0/1) — a noisy measurement of a
       *visible* object; slots are filled nearest first, the rest are zero.
rays:  distance to the first hit along each depth ray [m] (the visibility polygon); ray i points
       at heading + ray_angle(i), angles spread evenly over the agent's cone, edges included
       (`perception.fov.depth_ray_angles`).
signal: present (0/1), head id (head index + 1; 0 = empty), red, yellow, green (one-hot) —
       a signal head the agent reads now (perception/signal_view.py); slots are filled in head
       order with the heads it sees, the rest are zero. A layout with n_signals = 0 (a map
       without signals) has no signal block: its vectors are those of a layout without signals.

Bounds (`ObservationLimits`, `ObservationLayout.space(limits)`): positions lie within the map's
extent grown by how far any agent can travel in an episode (top speed x step x max steps) plus
a noise margin; speeds in [0, top speed]; measured velocities within the top speed plus a noise
margin; cos/sin in [-1, 1]; flags in [0, 1]; object ids in [0, n_agents]; sizes in [0, largest
footprint]; sensor ranges and ray depths in [0, longest sensor range]; half-angles in [0, pi].
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from gymnasium import spaces

from marl_social.sim.bodies import Bodies
from marl_social.sim.kernel_cache import observation_kernels

EGO_FIELDS = ("x", "y", "cos_psi", "sin_psi", "v", "sensor_range", "sensor_half_angle",
              "is_pedestrian")
SLOT_FIELDS = ("present", "id", "x", "y", "vx", "vy", "cos_psi", "sin_psi", "length", "width",
               "is_pedestrian")
SIGNAL_FIELDS = ("present", "id", "red", "yellow", "green")
EGO_DIM = len(EGO_FIELDS)
SIGNAL_DIM = len(SIGNAL_FIELDS)
SIGNAL_INDEX = {name: i for i, name in enumerate(SIGNAL_FIELDS)}  # field -> column of a slot
EGO_INDEX = {name: i for i, name in enumerate(EGO_FIELDS)}  # field name -> column of the ego block
SLOT_INDEX = {name: i for i, name in enumerate(SLOT_FIELDS)}  # field name -> column of a slot
OBS_BOUND = 1.0e5  # [m]; worlds larger than 100 km are out of scope
SLOT_DIM = len(SLOT_FIELDS)
NOISE_SIGMAS = 10.0  # measurement noise margin of the bounds [standard deviations]; P < 1e-20


def position_bounds(extent_m: tuple[float, float, float, float], grow_m: float
                    ) -> tuple[tuple[float, float], tuple[float, float]]:
    """((x low, x high), (y low, y high)) of a position [m] on a map: its extent grown by grow_m.

    Each range also holds 0, the value of an empty slot or a row of an agent that has left
    (a map far from its origin, a real city's, still has it in its bounds); within +-OBS_BOUND.

    Args:
        extent_m: (xmin, xmax, ymin, ymax) of the map [m].
        grow_m: how far beyond it a position may lie [m].
    """
    x0, x1, y0, y1 = extent_m
    return ((max(min(x0 - grow_m, 0.0), -OBS_BOUND), min(max(x1 + grow_m, 0.0), OBS_BOUND)),
            (max(min(y0 - grow_m, 0.0), -OBS_BOUND), min(max(y1 + grow_m, 0.0), OBS_BOUND)))


@dataclass(frozen=True)
class ObservationLimits:
    """The physical limits of every agent in an env, from which the observation bounds follow.

    Attributes:
        extent_m: (xmin, xmax, ymin, ymax) of the map [m].
        reach_m: farthest an agent can travel from the map in an episode [m] (top speed x step
            length x max steps; capped so that coordinates stay within +-OBS_BOUND).
        speed_max_mps: top speed over all agents [m/s].
        sensor_range_max_m: longest sensor range [m].
        half_angle_max_rad: widest sensor half-angle [rad].
        size_max_m: largest footprint length or width [m].
        n_agents: agents in the env (object ids are 1..n_agents).
        pos_noise_max_m: largest position measurement noise std [m].
        vel_noise_max_mps: largest velocity measurement noise std [m/s].
    """

    extent_m: tuple[float, float, float, float]
    reach_m: float
    speed_max_mps: float
    sensor_range_max_m: float
    half_angle_max_rad: float
    size_max_m: float
    n_agents: int
    pos_noise_max_m: float = 0.0
    vel_noise_max_mps: float = 0.0

    def field_bounds(self) -> tuple[dict, dict]:
        """({ego field: (low, high)}, {slot field: (low, high)}) in the fields' units."""
        x, y = position_bounds(self.extent_m,
                               self.reach_m + NOISE_SIGMAS * self.pos_noise_max_m)
        unit, flag = (-1.0, 1.0), (0.0, 1.0)
        v_meas = self.speed_max_mps + NOISE_SIGMAS * self.vel_noise_max_mps
        ego = {"x": x, "y": y, "cos_psi": unit, "sin_psi": unit, "v": (0.0, self.speed_max_mps),
               "sensor_range": (0.0, self.sensor_range_max_m),
               "sensor_half_angle": (0.0, self.half_angle_max_rad), "is_pedestrian": flag}
        slot = {"present": flag, "id": (0.0, float(self.n_agents)), "x": x, "y": y,
                "vx": (-v_meas, v_meas), "vy": (-v_meas, v_meas), "cos_psi": unit,
                "sin_psi": unit, "length": (0.0, self.size_max_m),
                "width": (0.0, self.size_max_m), "is_pedestrian": flag}
        return ego, slot


@dataclass(frozen=True)
class Measurements:
    """Measured objects, one row per visible (observer, target) pair.

    Rows are sorted by observer then true distance.

    Attributes:
        observer: (P,) index of the observing agent.
        target: (P,) index of the observed agent.
        xy: (P, 2) measured position [m].
        velocity: (P, 2) measured velocity [m/s].
        heading: (P,) measured heading [rad].
        distance_m: (P,) true centre distance, for slot ordering [m].
    """

    observer: np.ndarray
    target: np.ndarray
    xy: np.ndarray
    velocity: np.ndarray
    heading: np.ndarray
    distance_m: np.ndarray


@dataclass(frozen=True)
class DecodedObservation:
    """A structured view of one observation vector.

    Attributes:
        ego: (EGO_DIM,) see EGO_FIELDS.
        slots: (K, SLOT_DIM) see SLOT_FIELDS.
        depth_m: (n_rays,) [m].
        signals: (S, SIGNAL_DIM) see SIGNAL_FIELDS ((0, SIGNAL_DIM) without signals).
    """

    ego: np.ndarray
    slots: np.ndarray
    depth_m: np.ndarray
    signals: np.ndarray = field(default_factory=lambda: np.zeros((0, SIGNAL_DIM)))

    def signal_states(self) -> dict[int, int]:
        """{head index: state (0 red, 1 yellow, 2 green)} of the heads seen now.

        On Python floats (exact from float32 or float64): the index is np.rint's round half
        to even (Python's round), the state np.argmax's of the three state fields.
        """
        return {round(row[1]) - 1: _argmax(row[2:5]) for row in self.signals.tolist()
                if row[0] > 0.5}

    @property
    def objects(self) -> np.ndarray:
        """(k, SLOT_DIM) the present slots only."""
        return self.slots[self.slots[:, 0] > 0.5]


_NO_SIGNALS = np.zeros((0, SIGNAL_DIM))  # DecodedObservation.signals without signal slots


def _argmax(values: list) -> int:
    """np.argmax of a few Python floats: the first NaN if there is one, else the first largest."""
    best = 0
    for k, value in enumerate(values):
        if math.isnan(value):
            return k
        if value > values[best]:
            best = k
    return best


@dataclass(frozen=True)
class ObservationLayout:
    """Sizes of the shared layout: K object slots, depth rays and S signal slots.

    Attributes:
        n_slots: object slots K.
        n_rays: depth rays.
        n_signals: signal slots S (the map's signal heads; 0: no signal block).
    """

    n_slots: int
    n_rays: int
    n_signals: int = 0

    @property
    def size(self) -> int:
        return EGO_DIM + self.n_slots * SLOT_DIM + self.n_rays + self.n_signals * SIGNAL_DIM

    @property
    def _rays_end(self) -> int:
        return EGO_DIM + self.n_slots * SLOT_DIM + self.n_rays

    def space(self, limits: ObservationLimits | None = None) -> spaces.Box:
        """The float32 Box of this layout.

        Args:
            limits: the env's physical limits, giving each field its own bounds (see the
                module docstring); None for the loose +-OBS_BOUND (100 km) on every field.
        """
        if limits is None:
            return spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(self.size,), dtype=np.float32)
        ego, slot = limits.field_bounds()
        ego_b = np.array([ego[f] for f in EGO_FIELDS])  # (EGO_DIM, 2) low, high
        slot_b = np.array([slot[f] for f in SLOT_FIELDS])  # (SLOT_DIM, 2)
        ray_b = np.array([[0.0, limits.sensor_range_max_m]])
        signal_b = np.array([[0.0, 1.0], [0.0, float(self.n_signals)], [0.0, 1.0], [0.0, 1.0],
                             [0.0, 1.0]])  # (SIGNAL_DIM, 2)
        bounds = np.concatenate([ego_b, np.tile(slot_b, (self.n_slots, 1)),
                                 np.repeat(ray_b, self.n_rays, axis=0),
                                 np.tile(signal_b, (self.n_signals, 1))])  # (size, 2)
        # float32 rounding is monotonic: a value within a limit stays within it in float32
        return spaces.Box(bounds[:, 0].astype(np.float32), bounds[:, 1].astype(np.float32),
                          dtype=np.float32)

    def slot_index(self, field: str) -> int:
        return SLOT_FIELDS.index(field)

    @functools.cached_property
    def _decode_bounds(self) -> tuple:
        """(size, (n_slots, SLOT_DIM), end of the slots, end of the rays): once per layout."""
        return self.size, (self.n_slots, SLOT_DIM), EGO_DIM + self.n_slots * SLOT_DIM, \
            self._rays_end

    def decode(self, obs) -> DecodedObservation:
        obs = np.asarray(obs)
        size, slots_shape, k1, k2 = self._decode_bounds
        if obs.shape != (size,):
            raise ValueError(f"observation: expected shape ({size},), got {obs.shape}")
        if self.n_signals == 0:  # the shared empty signal block (it holds nothing to change)
            return DecodedObservation(obs[:EGO_DIM], obs[EGO_DIM:k1].reshape(slots_shape),
                                      obs[k1:k2], _NO_SIGNALS)
        return DecodedObservation(obs[:EGO_DIM], obs[EGO_DIM:k1].reshape(slots_shape),
                                  obs[k1:k2], obs[k2:].reshape(self.n_signals, SIGNAL_DIM))

    def encode(self, bodies: Bodies, measurements: Measurements, depth_m,
               signals: tuple | None = None) -> np.ndarray:
        """Observation vectors of all n agents.

        Args:
            bodies: the n agents' true poses, speeds, footprints and sensors (active is not
                read: an inactive agent's row is encoded too).
            measurements: visible pairs, sorted by observer then distance.
            depth_m: (n, n_rays) depth ray distances [m].
            signals: (visible (n, S) bool, states (S,) int) of the map's S signal heads, for a
                layout with n_signals = S; None without signals.

        Returns:
            (n, size) float32.
        """
        b, m = bodies, measurements
        out = np.zeros((len(b.xy), self.size), dtype=np.float32)
        # compiled (sim/observation_kernels.py): the ego block, the object slots (measurement
        # p in slot p - the first row of its observer, while that is < n_slots) and the rays
        observation_kernels().encode_rows(
            out,
            (b.xy, np.cos(b.heading), np.sin(b.heading), b.speed, b.sensor_range_m,
             b.sensor_half_angle_rad, b.is_pedestrian, b.length_m, b.width_m),
            (m.observer, m.target, m.xy, m.velocity, np.cos(m.heading), np.sin(m.heading)),
            depth_m, (self.n_slots, EGO_DIM, SLOT_DIM, EGO_DIM + self.n_slots * SLOT_DIM))
        if self.n_signals:
            if signals is None:
                raise ValueError(f"observation: a layout with {self.n_signals} signal slots "
                                 "needs the heads' visibility and states")
            self._encode_signals(out, *signals)
        return out

    def _encode_signals(self, out: np.ndarray, visible: np.ndarray, states: np.ndarray) -> None:
        """Write the heads each agent sees into its signal slots, in head order."""
        visible = np.asarray(visible, dtype=bool)
        if visible.shape != (len(out), self.n_signals):
            raise ValueError(f"observation: signal visibility must have shape "
                             f"({len(out)}, {self.n_signals}), got {visible.shape}")
        obs_i, head = np.nonzero(visible)
        rank = np.cumsum(visible, axis=1)[obs_i, head] - 1  # slot of each seen head
        slots = out[:, self._rays_end:].reshape(len(out), self.n_signals, SIGNAL_DIM)
        row = np.zeros((len(head), SIGNAL_DIM))
        row[:, 0] = 1.0
        row[:, 1] = head + 1.0
        row[np.arange(len(head)), 2 + np.asarray(states, dtype=np.int64)[head]] = 1.0
        slots[obs_i, rank] = row

"""Pedestrians standing at a crosswalk on the robot's route: "steps off now" or "keeps waiting".

A pedestrian the robot tracks (or, for the oracle, knows) standing at the curb of a crosswalk
that its route crosses may step off at any moment: knowing where it is does not tell when it
will go. The robot plans this as a contingency pair (Alsterda & Gerdes, "Contingency MPC",
ACC 2019): one extra branch in which every such pedestrian steps off now and walks across at
`walk_speed_mps`, with probability `p_step_off`, next to the branches in which they keep
waiting (the belief's hypotheses). With the MPC's soft comfortable-deceleration bound
(mpc_types.MpcConfig.comfort_decel_mps2) the shared trunk slows early enough for the "steps off
now" branch to stop gently, so that a pedestrian who does step off needs no hard braking.

The robot's model of a waiting pedestrian (gap acceptance, as the simulated pedestrians and
real ones behave): it steps off only in front of a car that can still stop before the crosswalk
braking at most `yield_decel_mps2`; for a car closer or faster than that, it keeps waiting (no
branch). A pedestrian that stays on the curb while the robot stands at rest in front of the
crosswalk for `patience_s` is waiting for something else: the robot stops assuming it may step
off (for that track, until it moves or is no longer tracked), and goes. The same gap acceptance
holds a pedestrian still on the sidewalk, walking up to the curb, in front of a car whose
front can no longer stop before the crosswalk braking at most `yield_decel_mps2`
(`hold_at_curb`): it is predicted to wait at the curb, not to walk on into the car's path at its
current velocity (a hesitant pedestrian inching towards the curb would otherwise appear in the
robot's way at the last moment, calling for an emergency stop it does not need); once on the
crosswalk it is predicted from its track again.

Probability 0.2: a pedestrian standing at a crosswalk is there to cross, but most of the
planning steps before it goes it is still waiting (the robot plans every 0.1 s, a pedestrian
waits seconds); it is a weight in the expected cost, the branch's constraints hold regardless.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from marl_social.perception.tracking import TrackSet
from marl_social.sim.road_map import Crosswalk, Route


@dataclass(frozen=True)
class CurbConfig:
    """The robot's model of pedestrians waiting at a crosswalk (module docstring).

    Attributes:
        p_step_off: probability of the "steps off now" branch.
        walk_speed_mps: the speed at which it is assumed to cross [m/s].
        standing_mps: a pedestrian track slower than this is standing [m/s].
        curb_reach_m: a standing pedestrian within this of the crosswalk's ends (along the
            walking direction) or on it is waiting at it [m].
        yield_decel_mps2: it steps off only if the robot can still stop before the crosswalk
            braking at most this [m/s^2].
        patience_s: after the robot stood this long in front of the crosswalk, a pedestrian
            still standing is waiting for something else [s].
        rest_mps: the robot is at rest below this speed [m/s].
        front_m: the robot stands "in front of the crosswalk" within this distance of where
            it stops for it [m].
        prepared_full_s: a pedestrian that steps off after the robot planned its "steps off
            now" branch this long is met with the full comfort weight (`prepared_comfort`) [s].
    """

    p_step_off: float = 0.2
    walk_speed_mps: float = 1.3
    standing_mps: float = 0.3
    curb_reach_m: float = 2.0
    yield_decel_mps2: float = 4.0
    patience_s: float = 2.0
    rest_mps: float = 0.1
    front_m: float = 4.0
    prepared_full_s: float = 1.0

    def __post_init__(self):
        if not 0.0 < self.p_step_off < 1.0:
            raise ValueError(f"CurbConfig.p_step_off: {self.p_step_off} not in (0, 1)")
        if min(self.walk_speed_mps, self.yield_decel_mps2) <= 0.0:
            raise ValueError("CurbConfig: walk_speed_mps and yield_decel_mps2 must be > 0")
        if not self.prepared_full_s > 0.0:
            raise ValueError(f"CurbConfig.prepared_full_s: {self.prepared_full_s} must be > 0 s")


def _crossings(route: Route, crosswalks: tuple[Crosswalk, ...]) -> list[tuple[int, float]]:
    """(index, arc length of the near edge [m]) of each crosswalk the route passes through."""
    out = []
    for i, cw in enumerate(crosswalks):
        s, _, _ = route.project(cw.polygon())
        _, lat_c, _ = route.project(cw.center[None])
        if abs(float(lat_c[0])) <= 0.5 * cw.length_m and s.max() > 0.0:
            out.append((i, float(s.min())))
    return out


class CurbPedestrians:
    """Which standing pedestrians may step off in front of the robot now (module docstring).

    Args:
        route: the robot's route.
        crosswalks: the map's crosswalks.
        config: the model of waiting pedestrians.
        robot_length_m: the robot's length [m].
        gap_m: the longitudinal gap the robot keeps to a pedestrian [m].
        corridor_half_m: half the robot's corridor width (a pedestrian inside it is already
            in its way, predicted from its track) [m].
    """

    def __init__(self, route: Route, crosswalks: tuple[Crosswalk, ...], config: CurbConfig,
                 robot_length_m: float, gap_m: float, corridor_half_m: float):
        self.route, self.crosswalks, self.config = route, crosswalks, config
        self._crossings = _crossings(route, crosswalks)
        self._stop_offset = gap_m + 0.5 * robot_length_m
        self._length = robot_length_m
        self._far = [float(route.project(crosswalks[i].polygon())[0].max())
                     for i, _ in self._crossings]
        self._corridor_half = corridor_half_m
        self.reset()

    @property
    def crosses_crosswalk(self) -> bool:
        """Whether the robot's route passes through a crosswalk (else nothing to do here)."""
        return bool(self._crossings)

    def reset(self) -> None:
        """A new episode: no waiting time, no pedestrian judged to wait for something else."""
        self.wait_s: dict[int, float] = {}  # track id -> time the robot stood in front of it
        self.ignored: set[int] = set()
        self.prepared_s: dict[int, float] = {}  # id -> how long a "steps off" branch was planned

    def _gaps(self, s0: float) -> list[tuple[Crosswalk, float]]:
        """The crossings whose far edge is still ahead of the robot's rear.

        Each as (crosswalk, distance [m] from the robot's front, its centre at s0 [m], to the
        crosswalk's near edge, < 0 once on it): where a pedestrian expects it to stop.
        """
        half = 0.5 * self._length
        return [(self.crosswalks[i], s_near - half - s0)
                for (i, s_near), s_far in zip(self._crossings, self._far) if s_far > s0 - half]

    def hold_at_curb(self, tracks: TrackSet, s0: float, v0: float) -> TrackSet:
        """The tracks, with pedestrians that will wait at the curb for the robot held still.

        A pedestrian on the sidewalk within `curb_reach_m` of a crosswalk on the robot's route,
        walking towards it, waits at the curb (zero velocity) if the robot's front can no
        longer stop before that crosswalk braking at most `yield_decel_mps2`, or is on it
        (the pedestrian's own gap acceptance, agents/pedestrian.py; module docstring).

        Args:
            tracks: the robot's tracks (the truth for the oracle), k of them.
            s0: the robot's arc length (footprint centre) [m].
            v0: its speed [m/s].

        Returns:
            the TrackSet with the held pedestrians' velocity (k, 2) set to zero.
        """
        c = self.config
        if len(tracks) == 0 or not tracks.is_pedestrian.any():
            return tracks
        hold = np.zeros(len(tracks), dtype=bool)
        for cw, gap in self._gaps(s0):
            if v0 * v0 <= 2.0 * c.yield_decel_mps2 * gap:
                continue  # it can still stop: the pedestrian may go (step_off, its own track)
            on_sidewalk = cw.contains(tracks.xy, c.curb_reach_m) & ~cw.contains(tracks.xy)
            approaching = np.einsum("kd,kd->k", cw.center - tracks.xy, tracks.velocity) > 0.0
            hold |= tracks.is_pedestrian & on_sidewalk & approaching
        if not hold.any():
            return tracks
        return replace(tracks, velocity=np.where(hold[:, None], 0.0, tracks.velocity))

    def walk_across(self, tracks: TrackSet) -> TrackSet:
        """The tracks, with pedestrians on a crosswalk of the robot's route walking across it.

        A pedestrian on a crosswalk walks along its walk axis: the component of its tracked
        velocity along the road is tracking noise, not a walk towards the robot (predicted
        over the horizon, 0.05 m/s of it moves a stay-behind bound 0.3 m towards a robot
        stopping in front of the crosswalk, which cannot back up: an emergency stop it does
        not need). Its velocity is projected on the walk axis.

        Args:
            tracks: the robot's tracks (the truth for the oracle), k of them.

        Returns:
            the TrackSet with those pedestrians' velocity (k, 2) projected.
        """
        if len(tracks) == 0 or not tracks.is_pedestrian.any():
            return tracks
        velocity, changed = tracks.velocity, False
        for i, _ in self._crossings:
            cw = self.crosswalks[i]
            on = tracks.is_pedestrian & cw.contains(tracks.xy)
            if not on.any():
                continue
            walk = np.array([np.cos(cw.walk_heading_rad), np.sin(cw.walk_heading_rad)])
            along = velocity @ walk  # (k,) [m/s]
            velocity = np.where(on[:, None], along[:, None] * walk, velocity)
            changed = True
        return replace(tracks, velocity=velocity) if changed else tracks

    def prepared_comfort(self, tracks: TrackSet) -> float:
        """How firmly the robot meets a pedestrian that stepped off as it prepared to, in [0, 1].

        For a pedestrian the robot planned a "steps off now" branch for, now walking on or
        near its crosswalk (within `curb_reach_m`), the contingency came true: the robot
        prepared a comfortable stop for it (mpc_types.MpcConfig.comfort_decel_mps2, a soft
        bound), and meets it with that bound (the comfort weight times this factor) rather than with
        the nominal cost alone, which trades a later, harder stop for speed. The factor is the
        time the branch was planned over `prepared_full_s`, capped at 1: a branch planned
        for an instant has not slowed the robot, and holding it to the comfortable bound then
        means a steeper onset instead. A track no longer tracked or off the crosswalk is
        forgotten.

        Args:
            tracks: the robot's tracks (the truth for the oracle), k of them.

        Returns:
            the largest factor over such pedestrians (0: none).
        """
        if not self.prepared_s:
            return 0.0
        c = self.config
        near = np.zeros(len(tracks), dtype=bool)
        for i, _ in self._crossings:
            near |= self.crosswalks[i].contains(tracks.xy, c.curb_reach_m)
        prepared = np.array([int(t) in self.prepared_s for t in tracks.ids.tolist()], dtype=bool)
        keep = prepared & tracks.is_pedestrian & near  # (np.isin: ~0.1 ms on a few ids)
        self.prepared_s = {int(t): self.prepared_s[int(t)] for t in tracks.ids[keep]}
        walking = np.linalg.norm(tracks.velocity[keep], axis=1) >= c.standing_mps
        if not walking.any():
            return 0.0
        longest = max(self.prepared_s[int(t)] for t in tracks.ids[keep][walking])
        return min(1.0, longest / c.prepared_full_s)

    def step_off(self, tracks: TrackSet, s0: float, v0: float, dt_s: float,
                 times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The "steps off now" predictions of the pedestrians that may step off in front now.

        Called once per planning step (it counts the robot's waiting time).

        Args:
            tracks: the robot's tracks (the truth for the oracle), k of them.
            s0: the robot's arc length (footprint centre) [m].
            v0: its speed [m/s].
            dt_s: time since the last call [s].
            times_s: (T,) prediction times [s].

        Returns:
            xy (K, T, 2) [m] and heading (K,) [rad] of the K pedestrians stepping off now.
        """
        c = self.config
        empty = np.zeros((0, len(times_s), 2)), np.zeros(0)
        standing = tracks.is_pedestrian
        if self._crossings and standing.any():  # most steps: no pedestrian, or none standing
            standing = standing & (np.linalg.norm(tracks.velocity, axis=1) < c.standing_mps)
            if standing.any():  # only standing pedestrians are projected
                _, lateral, _ = self.route.project(tracks.xy[standing])
                standing[standing] = np.abs(lateral) > self._corridor_half
        if not (self._crossings and standing.any()):  # no one to step off: no one waits
            self.wait_s.clear()
            self.ignored.clear()
            return empty
        xy_out, heading_out, seen = [], [], set()
        for i, s_near in self._crossings:
            cw = self.crosswalks[i]
            at_curb = standing & cw.contains(tracks.xy, c.curb_reach_m)
            gap = s_near - self._stop_offset - s0  # to where the robot stops for it [m]
            if not at_curb.any() or gap <= 0.0:
                continue
            walk = np.array([np.cos(cw.walk_heading_rad), np.sin(cw.walk_heading_rad)])
            at_rest = v0 < c.rest_mps and gap <= c.front_m
            for j in np.flatnonzero(at_curb):
                tid = int(tracks.ids[j])
                seen.add(tid)
                self.wait_s[tid] = self.wait_s.get(tid, 0.0) + dt_s if at_rest else 0.0
                if self.wait_s[tid] >= c.patience_s:
                    self.ignored.add(tid)
                if tid in self.ignored or v0 * v0 > 2.0 * c.yield_decel_mps2 * gap:
                    continue
                # it walks across: towards the crosswalk's centre line along the walk axis
                direction = walk if np.dot(cw.center - tracks.xy[j], walk) >= 0.0 else -walk
                xy_out.append(tracks.xy[j] + c.walk_speed_mps * times_s[:, None] * direction)
                self.prepared_s[tid] = self.prepared_s.get(tid, 0.0) + dt_s
                heading_out.append(np.arctan2(direction[1], direction[0]))
        self.wait_s = {k: w for k, w in self.wait_s.items() if k in seen}
        self.ignored &= seen
        if not xy_out:
            return empty
        return np.stack(xy_out), np.array(heading_out)

"""Traffic signals: signal heads, the signal plan (static) and the fixed-time controller (dynamic).

A signalized junction has signal *groups* (movements released together, e.g. "ew" for both
east-west through approaches, "ns_left" for the protected left turns). A `SignalPlan` is the
cycle of `SignalPhase`s: each phase lasts `duration_s` and shows green to some groups, yellow to
others and red to the rest (an all-red clearance phase shows red to every group). A
`SignalHead` is one physical head: a point on the map that shows the state of its group to the
traffic behind one stop line (`StopLine(kind="signal")`), readable only from in front of it
(within `view_half_angle_rad` of the direction it faces, like a head's visor).

The heads and the plan (phases and their durations) are static: part of the map every agent
knows. Where in the cycle the controller is at a given time is not: `SignalController` holds
the phase at time 0 and the time already spent in it, and belongs to the world's true state.
An agent learns a head's state only by seeing it (perception/signal_view.py,
sim/observation.py's signal slots).

States are small integers: RED = 0, YELLOW = 1, GREEN = 2 (`STATE_NAMES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

RED, YELLOW, GREEN = 0, 1, 2
STATE_NAMES = ("red", "yellow", "green")
DEFAULT_VIEW_HALF_ANGLE_RAD = math.radians(30.0)  # a head's visor: readable within this [rad]


@dataclass(frozen=True)
class SignalHead:
    """One signal head.

    Attributes:
        position: (2,) where it stands [m].
        facing_rad: the direction its lamps face (towards the traffic it controls) [rad].
        group: the signal group whose state it shows (one of SignalPlan.groups).
        stop_line: index into RoadMap.stop_lines of the line it controls (kind "signal").
        view_half_angle_rad: it is readable from within this angle of facing_rad [rad].
        name: used in error messages and figures.
    """

    position: np.ndarray
    facing_rad: float
    group: str
    stop_line: int
    view_half_angle_rad: float = DEFAULT_VIEW_HALF_ANGLE_RAD
    name: str = "head"

    def __post_init__(self):
        pos = np.asarray(self.position, dtype=np.float64)
        if pos.shape != (2,) or not np.all(np.isfinite(pos)):
            raise ValueError(f"signal head {self.name!r}: position must be finite (2,), "
                             f"got {pos.shape}")
        if not math.isfinite(self.facing_rad):
            raise ValueError(f"signal head {self.name!r}: facing_rad must be finite")
        if not 0.0 < self.view_half_angle_rad <= math.pi:
            raise ValueError(f"signal head {self.name!r}: view_half_angle_rad must be in "
                             f"(0, pi], got {self.view_half_angle_rad}")
        object.__setattr__(self, "position", pos)


@dataclass(frozen=True)
class SignalPhase:
    """One phase of a signal plan.

    Attributes:
        name: e.g. "protected_left", "cross_green", "all_red_1".
        duration_s: how long it lasts [s], > 0.
        green: the groups shown green.
        yellow: the groups shown yellow (every other group is red).
    """

    name: str
    duration_s: float
    green: tuple[str, ...] = ()
    yellow: tuple[str, ...] = ()

    def __post_init__(self):
        if not (math.isfinite(self.duration_s) and self.duration_s > 0.0):
            raise ValueError(f"signal phase {self.name!r}: duration_s must be finite and > 0, "
                             f"got {self.duration_s}")
        if set(self.green) & set(self.yellow):
            raise ValueError(f"signal phase {self.name!r}: a group is both green and yellow")


@dataclass(frozen=True)
class SignalPlan:
    """The fixed-time cycle of a junction's signals (static: every agent may know it).

    Attributes:
        groups: the signal groups.
        phases: the phases in cycle order.
    """

    groups: tuple[str, ...]
    phases: tuple[SignalPhase, ...]

    def __post_init__(self):
        if not self.phases:
            raise ValueError("signal plan: needs at least one phase")
        names = [p.name for p in self.phases]
        if len(set(names)) != len(names):
            raise ValueError(f"signal plan: phase names must be unique, got {names}")
        for phase in self.phases:
            unknown = sorted(set(phase.green + phase.yellow) - set(self.groups))
            if unknown:
                raise ValueError(f"signal phase {phase.name!r}: unknown groups {unknown} "
                                 f"(plan groups: {list(self.groups)})")
        durations = np.array([p.duration_s for p in self.phases])
        object.__setattr__(self, "_ends", np.cumsum(durations))

    @property
    def cycle_s(self) -> float:
        """Length of one cycle [s]."""
        return float(self._ends[-1])

    @property
    def durations_s(self) -> np.ndarray:
        """(P,) every phase's duration [s]."""
        return np.array([p.duration_s for p in self.phases])

    def phase_index(self, name: str) -> int:
        """Index of the phase called `name` (ValueError naming the valid ones)."""
        for k, phase in enumerate(self.phases):
            if phase.name == name:
                return k
        raise ValueError(f"signal plan: no phase {name!r}; phases: "
                         f"{[p.name for p in self.phases]}")

    def group_states(self) -> np.ndarray:
        """(P, G) int8: the state (RED / YELLOW / GREEN) of every group in every phase."""
        out = np.full((len(self.phases), len(self.groups)), RED, dtype=np.int8)
        for k, phase in enumerate(self.phases):
            for g, group in enumerate(self.groups):
                if group in phase.green:
                    out[k, g] = GREEN
                elif group in phase.yellow:
                    out[k, g] = YELLOW
        return out

    def head_states(self, heads) -> np.ndarray:
        """(P, H) int8: the state every head shows in every phase.

        Args:
            heads: the H SignalHeads (their groups must be plan groups).
        """
        index = {g: i for i, g in enumerate(self.groups)}
        cols = [index[h.group] for h in heads]
        return self.group_states()[:, cols].reshape(len(self.phases), len(cols))

    def phase_at(self, cycle_time_s) -> np.ndarray:
        """(...) int: the phase at times (...) [s] since the start of the first phase."""
        t = np.mod(np.asarray(cycle_time_s, dtype=np.float64), self.cycle_s)
        return np.minimum(np.searchsorted(self._ends, t, side="right"), len(self.phases) - 1)


@dataclass(frozen=True)
class SignalController:
    """The fixed-time controller's clock: which phase runs at time 0 and for how long it has.

    The world's true signal state; no planner reads it (agents see heads through their
    observation only).

    Attributes:
        plan: the junction's SignalPlan (the same object as RoadMap.signal_plan).
        start_phase: index of the phase running at time 0.
        start_elapsed_s: how long that phase has already run at time 0 [s], in
            [0, its duration).
    """

    plan: SignalPlan
    start_phase: int = 0
    start_elapsed_s: float = 0.0

    def __post_init__(self):
        n = len(self.plan.phases)
        if not 0 <= self.start_phase < n:
            raise ValueError(f"signal controller: start_phase {self.start_phase} is not a phase "
                             f"index (the plan has {n} phases)")
        duration = self.plan.phases[self.start_phase].duration_s
        if not 0.0 <= self.start_elapsed_s < duration:
            raise ValueError(f"signal controller: start_elapsed_s must be in [0, {duration:g}) s "
                             f"(phase {self.plan.phases[self.start_phase].name!r}), got "
                             f"{self.start_elapsed_s}")

    def _cycle_time(self, time_s) -> np.ndarray:
        before = 0.0 if self.start_phase == 0 else float(self.plan._ends[self.start_phase - 1])
        return np.asarray(time_s, dtype=np.float64) + before + self.start_elapsed_s

    def phase_at(self, time_s) -> np.ndarray:
        """(...) int: the phase running at world times (...) [s]."""
        return self.plan.phase_at(self._cycle_time(time_s))

    def time_in_phase(self, time_s) -> np.ndarray:
        """(...) how long the running phase has lasted at world times (...) [s]."""
        t = np.mod(self._cycle_time(time_s), self.plan.cycle_s)
        k = self.plan.phase_at(t)
        start = np.where(k > 0, self.plan._ends[np.maximum(k - 1, 0)], 0.0)
        return t - start

    def head_states(self, time_s: float, heads) -> np.ndarray:
        """(H,) int8: the state every head shows at world time time_s [s]."""
        return self.plan.head_states(heads)[int(self.phase_at(time_s))]

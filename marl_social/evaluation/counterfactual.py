"""The counterfactual warning: when a human's behaviour first told of what the robot cannot see.

A human driver *warns* the robot at the first time its speed departs by at least
WARNING_SPEED_MPS from its speed at the same time of the same seed with the hidden agent
removed (the scenario's `hidden_agent().absent` overrides): what it did because of the
hidden agent, not because it settles towards its own cruise speed or meets its curve. The
warning's lead is the time from the earliest warning to the robot's own first sight of the
hidden agent; only warnings before that sight give a lead.

Both runs draw the same random numbers for every human's choices (each policy is seeded with
the episode's seed plus its agent's index, and the hidden agents come last); the env's sensor
noise is one stream for every observer, so once the hidden agent observes or is observed the
two runs' measurement noise differs (small: tests/evaluation/test_counterfactual.py measures
the speeds of humans the hidden agent cannot yet matter to).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marl_social.scenarios.base import HiddenAgent
from marl_social.sim.trace import Trace

WARNING_SPEED_MPS = 1.0  # a human's speed this far from its counterfactual speed warns [m/s]


@dataclass(frozen=True)
class CounterfactualWarning:
    """What the humans told the robot of the hidden agent, against the episode without it.

    Attributes:
        hidden: the scenario's hidden agent (its names, the counterfactual's overrides, the
            belief's trace extra).
        human_warned_s: {human driver: first time its speed departs from its counterfactual
            speed by >= WARNING_SPEED_MPS} [s] (nan: never, while both runs have it active).
        robot_first_sees_s: the robot's first sight of a hidden agent [s] (nan: never, or no
            hidden agent: a hidden signal phase).
        warning_lead_s: robot_first_sees_s minus the earliest human_warned_s at or before it
            [s]; 0.0 if no human warned before that sight; nan without a sight.
    """

    hidden: HiddenAgent
    human_warned_s: dict
    robot_first_sees_s: float
    warning_lead_s: float

    @property
    def first_warned_s(self) -> float:
        """The earliest human_warned_s [s] (nan: no human warned)."""
        times = [t for t in self.human_warned_s.values() if np.isfinite(t)]
        return min(times) if times else float("nan")

    def as_metrics(self) -> dict:
        """The flat numbers for an episode's metrics [s].

        warning_lead_s, first_warned_s, robot_first_sees_hidden_s, human_warned_s_<human>.
        """
        out = {"warning_lead_s": self.warning_lead_s, "first_warned_s": self.first_warned_s,
               "robot_first_sees_hidden_s": self.robot_first_sees_s}
        out.update({f"human_warned_s_{h}": t for h, t in self.human_warned_s.items()})
        return out


def speed_departures(trace: Trace, counterfactual: Trace,
                     threshold_mps: float = WARNING_SPEED_MPS) -> dict[str, float]:
    """{human driver: first time |speed - counterfactual speed| >= threshold_mps} [s].

    Compared at the states both traces have, where the human is active in both; nan where it
    never departs that far. Human drivers are the agents of role "human" present in both (the
    hidden agents, absent from the counterfactual, are left out).

    Args:
        trace: the episode's trace.
        counterfactual: the trace of the same seed with the hidden agent removed.
        threshold_mps: the departure that counts [m/s].
    """
    n = min(len(trace.times_s), len(counterfactual.times_s))
    times = np.asarray(trace.times_s)[:n]
    out = {}
    for i, (name, role) in enumerate(zip(trace.names, trace.roles)):
        if role != "human" or name not in counterfactual.names:
            continue
        j = counterfactual.index(name)
        both = np.asarray(trace.active)[:n, i] & np.asarray(counterfactual.active)[:n, j]
        gap = np.abs(np.asarray(trace.states)[:n, i, 3] - np.asarray(counterfactual.states)[:n, j, 3])
        departed = np.flatnonzero(both & (gap >= threshold_mps))
        out[name] = float(times[departed[0]]) if len(departed) else float("nan")
    return out


def robot_first_sight_s(trace: Trace, names: tuple[str, ...], robot: str = "robot_0") -> float:
    """The first time the robot sees any of `names` [s] (nan: never, or no names)."""
    present = [trace.index(n) for n in names if n in trace.names]
    if not present or robot not in trace.names:
        return float("nan")
    sees = np.asarray(trace.visible)[:, trace.index(robot), present].any(axis=1)
    return float(np.asarray(trace.times_s)[np.argmax(sees)]) if sees.any() else float("nan")


def warning_lead_s(human_warned_s: dict, sight_s: float) -> float:
    """The sight's time minus the earliest warning at or before it [s].

    0.0 if no human warned by then; nan if the robot never saw the hidden agent.
    """
    if not np.isfinite(sight_s):
        return float("nan")
    before = [t for t in human_warned_s.values() if np.isfinite(t) and t <= sight_s]
    # rounded to 1e-9 s: the trace's times are sums of float steps (1.3 - 0.8 = 0.4999...)
    return round(float(sight_s - min(before)), 9) if before else 0.0


def counterfactual_warning(trace: Trace, counterfactual: Trace, hidden: HiddenAgent,
                           robot: str = "robot_0") -> CounterfactualWarning:
    """The humans' warnings of the hidden agent, and their lead over the robot's sight of it.

    Args:
        trace: the episode's trace.
        counterfactual: the trace of the same seed run with `hidden.absent`.
        hidden: the scenario's hidden agent (Scenario.hidden_agent).
        robot: the robot's name.
    """
    warned = speed_departures(trace, counterfactual)
    sight = robot_first_sight_s(trace, hidden.names, robot)
    return CounterfactualWarning(hidden, warned, sight, warning_lead_s(warned, sight))

"""The robot's decision as a pipeline of stages over one planning record.

One decision: observation -> `PlanningRecord` -> stage -> stage -> ... -> the contingency MPC.
A stage (agents/robot/stages.py) takes the record and returns it refined: the belief update
weighs the hypotheses, the branch stage predicts the scene of every branch, the crosswalk,
signal, stop-line, right-of-way and sight-hold stages add branches, claims and stop targets.
Each stage is small and testable alone; a robot runs the stages its route's map elements call
for (`stages.build_stages`), and a new behaviour is a new stage.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from marl_social.agents.robot.corridor import PathObject
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.tracking import TrackSet
from marl_social.sim.observation import DecodedObservation


@dataclass(frozen=True)
class Truth:
    """What a planner with needs_truth (the oracle) is given each step.

    Attributes:
        tracks: the true current state of every other active agent.
        signal_phase: the signal plan's running phase (None: no signals).
    """

    tracks: TrackSet
    signal_phase: int | None = None


@dataclass
class PlanningRecord:
    """What one robot decision plans with, refined stage by stage (module docstring).

    A new record per decision; a stage refines it in place (`refined`) and returns it (a
    frozen record copied at every stage cost ~5 us a copy, a few per cent of a decision).

    B branches: the belief's L hypotheses first, then the branches stages add (a signal
    pattern's copies, a pedestrian stepping off the curb).

    Attributes:
        observation: the robot's raw observation (obs_dim,).
        decoded: its decoded view (ego state, slots, signal heads).
        s_m: the robot's arc length along its route (footprint centre) [m].
        v_mps: its speed [m/s].
        truth: the oracle's true state (None for every other planner).
        tracks: the objects it tracks (the oracle: the truth), k of them.
        v_ref_mps: the speed the MPC tracks [m/s].
        weights: (B,) the branches' weights.
        contingent: (B,) bool or factor in [0, 1] of the comfort weight per branch (the
            contingencies: a branch not seen to be true).
        scene: the B branches' predicted objects at the plan times (None until predicted).
        claims: per branch, the zone claims of cars with the right of way (None: no zone).
        stop_at_m: the arc length the robot's centre must stay behind (inf: none) [m].
        pull_up_to_m: the arc length it drives up to (inf: none) [m].
    """

    observation: np.ndarray
    decoded: DecodedObservation
    s_m: float
    v_mps: float
    truth: Truth | None = None
    tracks: TrackSet | None = None
    v_ref_mps: float = 0.0
    weights: np.ndarray | None = None
    contingent: np.ndarray | None = None
    scene: ScenePrediction | None = None
    claims: list[list[PathObject]] | None = None
    stop_at_m: float = np.inf
    pull_up_to_m: float = np.inf

    def refined(self, **changes) -> PlanningRecord:
        """This record with `changes` (field: value) applied."""
        for name, value in changes.items():
            setattr(self, name, value)
        return self


class Stage(Protocol):
    """One behaviour of the robot: refines the planning record (module docstring)."""

    def reset(self) -> None:
        """Start a new episode (a stage's own state, e.g. time waited at a line)."""

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        """The record refined by this stage."""

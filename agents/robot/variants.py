"""The robot planners as data: what distinguishes one from another (the MPC is the same).

One `RobotVariant` per planner name in `ROBOT_VARIANTS` (agents/robot/planner.py's docstring
tells what each believes). Kept apart from the planner so that the registry
(agents/registry.py) knows the names without importing the MPC and its QP solvers (osqp,
daqp, scipy.sparse: ~0.5 s of `import marl_social`) before a robot planner is built.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class HypothesisWeighting(enum.Enum):
    """How the MPC weighs the hidden-pedestrian hypotheses (`RobotPlanner.hypothesis_weights`)."""

    BELIEF = "belief"  # the belief's probabilities
    PRESENT_LIVE = "present_live"  # every present hypothesis not ruled out, equally
    NONE_ONLY = "none_only"  # only the "no hidden pedestrian" hypothesis


@dataclass(frozen=True)
class RobotVariant:
    """What distinguishes one robot planner from another (the MPC is the same).

    Attributes:
        use_social: the belief also updates from the humans' behaviour (eq. 9-10).
        use_own_sensors: the belief rules hypotheses out with the robot's own sensors.
        infer_beta: the belief also infers each human's rationality (planner.BETA_GRID_HAT).
        weighting: how the MPC weighs the hypotheses.
        needs_truth: the planner is given the true current state (observe_truth).
    """

    use_social: bool
    use_own_sensors: bool
    weighting: HypothesisWeighting
    infer_beta: bool = False
    needs_truth: bool = False


ROBOT_VARIANTS: dict[str, RobotVariant] = {
    "social": RobotVariant(use_social=True, use_own_sensors=True,
                           weighting=HypothesisWeighting.BELIEF),
    "social+beta": RobotVariant(use_social=True, use_own_sensors=True,
                                weighting=HypothesisWeighting.BELIEF, infer_beta=True),
    "aggressive": RobotVariant(use_social=False, use_own_sensors=False,
                               weighting=HypothesisWeighting.NONE_ONLY),
    "conservative": RobotVariant(use_social=False, use_own_sensors=True,
                                 weighting=HypothesisWeighting.PRESENT_LIVE),
    "oracle": RobotVariant(use_social=False, use_own_sensors=False,
                           weighting=HypothesisWeighting.NONE_ONLY, needs_truth=True),
}

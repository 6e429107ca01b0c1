"""The robot's settings as one typed record, and the MPC and belief configurations it implies.

`RobotSettings` groups what a robot planner is built with: its variant (social, aggressive, ...),
its private model of the humans (`RobotModelParams`: theta_hat, beta_hat, epsilon, ...) and the
configuration of each part of its pipeline (the MPC, the belief, the crosswalk, stop-line,
right-of-way and sight-hold stages). A part left None takes the default derived from the
robot's spec and its model of the humans (`robot_configs`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from marl_social.agents.params import RobotModelParams, parse_planner_params
from marl_social.agents.robot.curb import CurbConfig
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.agents.robot.right_of_way import RightOfWayConfig
from marl_social.agents.robot.sight_hold import SightHoldConfig
from marl_social.agents.robot.stop import StopSignConfig
from marl_social.agents.robot.variants import ROBOT_VARIANTS, HypothesisWeighting, RobotVariant
from marl_social.perception.belief import BeliefConfig
from marl_social.sim.agent_spec import AgentSpec

BETA_GRID_HAT = (0.03, 0.1, 0.3, 1.0, 3.0)  # social+beta: rationality grid (log-spaced)
CONSERVATIVE_WALK_SPEED_MPS = 1.3  # conservative: its hypothesised pedestrians' speed [m/s]


@dataclass(frozen=True)
class RobotSettings:
    """What a robot planner is built with (module docstring).

    Attributes:
        planner: a name of ROBOT_VARIANTS ("social", ..., "oracle") or a RobotVariant.
        model: the robot's model of the humans (None: parsed from its spec's planner dict).
        mpc: the MPC's configuration (None: `robot_configs`' from the model).
        belief: the belief's configuration (None: `robot_configs`' from the spec and model).
        curb: the model of pedestrians waiting at a crosswalk (agents/robot/curb.py).
        stop: when it counts as having stopped at a line (agents/robot/stop.py).
        right_of_way: when a car with the right of way claims a zone the robot yields at
            (agents/robot/right_of_way.py).
        sight_hold: where it holds short of a lane it cannot see (agents/robot/sight_hold.py;
            None: SightHoldConfig() with the MPC's comfort_decel_mps2).
    """

    planner: str | RobotVariant = "social"
    model: RobotModelParams | None = None
    mpc: MpcConfig | None = None
    belief: BeliefConfig | None = None
    curb: CurbConfig = field(default_factory=CurbConfig)
    stop: StopSignConfig = field(default_factory=StopSignConfig)
    right_of_way: RightOfWayConfig = field(default_factory=RightOfWayConfig)
    sight_hold: SightHoldConfig | None = None

    @property
    def variant(self) -> RobotVariant:
        """The planner's RobotVariant.

        Raises:
            ValueError: an unknown planner name.
        """
        return robot_variant(self.planner)


def robot_variant(planner: str | RobotVariant) -> RobotVariant:
    """The RobotVariant of a planner name (or the variant itself).

    Raises:
        ValueError: a name that is not one of ROBOT_VARIANTS.
    """
    if isinstance(planner, RobotVariant):
        return planner
    if planner not in ROBOT_VARIANTS:
        raise ValueError(f"robot planner {planner!r}: must be one of {tuple(ROBOT_VARIANTS)}")
    return ROBOT_VARIANTS[planner]


def robot_configs(spec: AgentSpec, planner: str | RobotVariant = "social",
                  params: RobotModelParams | None = None) -> tuple[MpcConfig, BeliefConfig]:
    """The MPC and belief configuration of a robot from its spec.

    The belief's tracker gets the robot's own sensor noise (spec.sensor.pos_noise_m,
    vel_noise_mps); everything else the robot assumes about the humans is the robot's own
    (BeliefConfig's documented defaults unless spec.planner sets theta_hat / beta_hat).

    Args:
        spec: the robot's AgentSpec (its cost weights theta_R and planner parameters).
        planner: a name of ROBOT_VARIANTS or a RobotVariant.
        params: the robot's model of the humans (default: parsed from spec.planner).

    Raises:
        ValueError: an unknown planner, or a planner parameter unknown or out of range.
    """
    variant = robot_variant(planner)
    params = params or parse_planner_params(RobotModelParams, spec)
    belief = BeliefConfig()
    updates = {"epsilon": belief.epsilon if params.epsilon is None else params.epsilon,
               # the tracker filters with the robot's own sensor noise
               "track_pos_noise_m": spec.sensor.pos_noise_m,
               "track_vel_noise_mps": spec.sensor.vel_noise_mps}
    if params.theta_hat is not None:
        updates["theta_hat"] = params.theta_hat
    if params.beta_hat is not None:
        updates["beta_hat"] = params.beta_hat
    if params.human_expects_yield:
        updates["human_expects_yield"] = True
    if variant.infer_beta:
        updates["beta_grid_hat"] = BETA_GRID_HAT
    if variant.weighting is HypothesisWeighting.PRESENT_LIVE:
        # the conservative baseline assumes the worst at every curb it cannot see: a pedestrian
        # stepping off right now (the paper's single pattern per curb), not one that may have
        # walked on; split into progress and speed bins, each bin would fall below epsilon
        updates["progress_step_m"] = None
        updates["walk_speeds_mps"] = (CONSERVATIVE_WALK_SPEED_MPS,)
    return (MpcConfig(epsilon=updates["epsilon"]),
            replace(belief, **updates))

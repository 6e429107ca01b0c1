"""The robot's settings as one typed record, and the MPC and belief configurations it implies.

`RobotSettings` groups what a robot planner is built with: its variant (social, aggressive, ...),
its private model of the humans (`RobotModelParams`: theta_hat, beta_hat, epsilon, ...) and the
configuration of each part of its pipeline (the MPC, the belief, the crosswalk, stop-line,
right-of-way and sight-hold stages). A part left None takes the default derived from the
robot's spec and its model of the humans (`robot_configs`); `resolve_settings` fills them in
and applies the settings tree's `robot.<part>.<field>` leaves (`STAGE_PARTS`), which reach the
robot through its planner parameter `stage_settings`.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass, field, replace
from typing import Any

from marl_social.agents.params import RobotModelParams, parse_planner_params
from marl_social.agents.robot.curb import CurbConfig
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.agents.robot.right_of_way import RightOfWayConfig
from marl_social.agents.robot.sight_hold import SightHoldConfig
from marl_social.agents.robot.stop import StopSignConfig
from marl_social.agents.robot.variants import ROBOT_VARIANTS, HypothesisWeighting, RobotVariant
from marl_social.perception.belief import BeliefConfig
from marl_social.sim.agent_spec import AgentSpec

# the robot's configurable parts: settings-tree name -> (RobotSettings field, its class)
STAGE_PARTS: dict[str, tuple[str, type]] = {
    "mpc": ("mpc", MpcConfig),
    "belief": ("belief", BeliefConfig),
    "curb": ("curb", CurbConfig),
    "stop_line": ("stop", StopSignConfig),
    "right_of_way": ("right_of_way", RightOfWayConfig),
    "hold": ("sight_hold", SightHoldConfig),
}
# fields set from other settings (robot.epsilon, robot.theta_hat, robot.beta_hat, the robot's
# sensor noise, human.expects_yield): not leaves of their own, so each is declared once
DERIVED_FIELDS: dict[str, frozenset[str]] = {
    "mpc": frozenset({"epsilon"}),
    "belief": frozenset({"epsilon", "theta_hat", "beta_hat", "human_expects_yield",
                         "track_pos_noise_m", "track_vel_noise_mps"}),
    "hold": frozenset({"comfort_decel_mps2"}),
}
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


def stage_leaf_fields(part: str) -> list[dataclasses.Field]:
    """The fields of part `part` (of STAGE_PARTS) that are settings leaves of their own."""
    _, cls = STAGE_PARTS[part]
    derived = DERIVED_FIELDS.get(part, frozenset())
    return [f for f in dataclasses.fields(cls) if f.name not in derived
            and isinstance(f.default, (bool, int, float, tuple, type(None)))]


def stage_value(part: str, name: str, value: Any) -> Any:
    """`value` as the type of field `name` of part `part`, validated.

    Raises:
        ValueError: an unknown part or field (with the valid names), or a value of the wrong
            type, naming the leaf robot.<part>.<name>.
    """
    leaf = f"robot.{part}.{name}"
    if part not in STAGE_PARTS:
        close = difflib.get_close_matches(part, list(STAGE_PARTS), n=1, cutoff=0.6)
        hint = f"; did you mean 'robot.{close[0]}.{name}'?" if close else ""
        raise ValueError(f"{leaf}: unknown setting{hint} (parts of robot: "
                         f"{', '.join(STAGE_PARTS)})")
    fields = {f.name: f for f in stage_leaf_fields(part)}
    if name not in fields:
        close = difflib.get_close_matches(name, list(fields), n=1, cutoff=0.6)
        hint = f"; did you mean 'robot.{part}.{close[0]}'?" if close else ""
        raise ValueError(f"{leaf}: unknown setting{hint} (`marl-social params` lists them)")
    default = fields[name].default
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError(f"{leaf}={value!r}: expected a bool")  # noqa: TRY004
        return value
    if isinstance(default, tuple):
        try:
            return tuple(float(v) for v in value)
        except (TypeError, ValueError):
            raise ValueError(f"{leaf}={value!r}: expected a list of numbers") from None
    if isinstance(value, bool):
        raise ValueError(f"{leaf}={value!r}: expected a number")  # noqa: TRY004
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{leaf}={value!r}: expected a number") from None
    if math.isnan(number):
        raise ValueError(f"{leaf}: NaN is not a valid value")
    if isinstance(default, int):
        if not number.is_integer():
            raise ValueError(f"{leaf}={value!r}: expected an integer")
        return int(number)
    return number


def checked_stage_settings(triples) -> tuple[tuple[str, str, Any], ...]:
    """(part, field, value) triples with each value converted, each part checked whole.

    Raises:
        ValueError: an unknown part or field, a value of the wrong type, or a part its own
            checks reject with these values (e.g. MpcConfig's horizon_s > trunk_s).
    """
    if not all(isinstance(v, (tuple, list)) and len(v) == 3 for v in triples):
        raise ValueError(f"robot stage settings {triples!r:.60}: expected (part, field, value) "
                         "triples")
    out = tuple((str(part), str(name), stage_value(str(part), str(name), value))
                for part, name, value in triples)
    for part in dict.fromkeys(p for p, _, _ in out):
        _, cls = STAGE_PARTS[part]
        try:
            replace(cls(), **{name: value for p, name, value in out if p == part})
        except (TypeError, ValueError) as err:
            raise ValueError(f"robot.{part}: {err}") from None
    return out


def resolve_settings(spec: AgentSpec, settings: RobotSettings) -> RobotSettings:
    """The settings with every part filled in and the model's stage settings applied.

    The model is parsed from spec.planner where not given; the MPC and belief take
    `robot_configs`' defaults where None, the sight hold SightHoldConfig() with the MPC's
    comfort_decel_mps2; then each (part, field, value) of model.stage_settings replaces that
    field (a part's own __post_init__ checks the result).

    Raises:
        ValueError: an unknown planner, part or field, or a value out of range.
    """
    model = settings.model or parse_planner_params(RobotModelParams, spec)
    default_mpc, default_belief = robot_configs(spec, settings.variant, model)
    mpc = settings.mpc or default_mpc
    resolved = replace(settings, model=model, mpc=mpc, belief=settings.belief or default_belief,
                       sight_hold=settings.sight_hold or SightHoldConfig(
                           comfort_decel_mps2=mpc.comfort_decel_mps2))
    changes: dict[str, dict[str, Any]] = {}
    for part, name, value in model.stage_settings:
        changes.setdefault(part, {})[name] = stage_value(part, name, value)
    for part, fields in changes.items():
        attr, _ = STAGE_PARTS[part]
        resolved = replace(resolved, **{attr: replace(getattr(resolved, attr), **fields)})
    return resolved

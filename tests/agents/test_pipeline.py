"""The robot's decision as a pipeline of stages: chosen from the map's elements, each alone."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import marl_social
from marl_social.agents.robot.pipeline import PlanningRecord
from marl_social.agents.robot.planner import RobotPlanner
from marl_social.agents.robot.settings import RobotSettings
from marl_social.agents.robot.stages import (
    BeliefUpdate,
    CrosswalkStepOff,
    CurbGapAcceptance,
    HypothesisBranches,
    RightOfWayClaims,
    SightHoldStage,
    SignalBranches,
    StopLines,
)
from marl_social.scenarios import SCENARIOS

REPO = Path(__file__).resolve().parents[2]


def _robot(scenario: str, planner: str = "social", **map_changes) -> RobotPlanner:
    """The robot of `scenario`, built on its map with `map_changes` (RoadMap fields)."""
    env = marl_social.parallel_env(scenario=scenario, robot_planner=planner)
    base = env.unwrapped
    spec = base.agent_specs["robot_0"]
    road_map = replace(base.road_map, **map_changes).for_agent("robot_0")
    model = marl_social.agents.registry.planner_params(planner, spec)
    return RobotPlanner(spec, base.obs_layout, road_map, ["robot_0"],
                        RobotSettings(planner=planner, model=model))


def _kinds(robot: RobotPlanner) -> list[type]:
    return [type(s) for s in robot.stages]


def test_the_stages_follow_the_maps_elements():
    assert _kinds(_robot("occluded_crosswalk")) == [
        BeliefUpdate, CurbGapAcceptance, HypothesisBranches, CrosswalkStepOff]
    assert _kinds(_robot("t_intersection")) == [
        BeliefUpdate, HypothesisBranches, StopLines, RightOfWayClaims, SightHoldStage]
    assert _kinds(_robot("signalized_intersection")) == [
        BeliefUpdate, HypothesisBranches, SignalBranches, StopLines, RightOfWayClaims]


def test_removing_an_element_removes_its_stage():
    """The same scene without its crosswalks, stop lines or conflict zones: no stage for them."""
    assert _kinds(_robot("occluded_crosswalk", crosswalks=())) == [
        BeliefUpdate, HypothesisBranches]
    no_lines = _kinds(_robot("t_intersection", stop_lines=()))
    assert StopLines not in no_lines and SightHoldStage not in no_lines  # holds at a stop sign
    assert RightOfWayClaims in no_lines
    assert RightOfWayClaims not in _kinds(_robot("t_intersection", conflict_zones=()))


def test_no_scene_name_in_the_robot_or_its_perception():
    """The robot's behaviour comes from the map's elements, never from a scene's name."""
    pattern = re.compile(r"\b(" + "|".join(re.escape(name) for name in SCENARIOS) + r")\b")
    offenders = [str(p.relative_to(REPO)) for folder in ("agents", "perception")
                 for p in (REPO / folder).rglob("*.py") if pattern.search(p.read_text())]
    assert offenders == []


def _record(robot: RobotPlanner, scenario: str, s_m: float, v_mps: float) -> PlanningRecord:
    """A planning record of the scene's first observation, the robot put at s_m, v_mps."""
    env = marl_social.parallel_env(scenario=scenario)
    obs, _ = env.reset(seed=0)
    decoded = robot.layout.decode(obs["robot_0"])
    return PlanningRecord(obs["robot_0"], decoded, s_m, v_mps)


def test_the_stop_line_stage_alone_stops_the_robot_at_its_line_then_lets_it_go():
    robot = _robot("t_intersection", "aggressive")
    stage = robot.stage(StopLines)
    line_m = float(stage.stop_signs.lines_m[0])
    half = 0.5 * robot.spec.vehicle.length_m
    stage.reset()
    far = stage(_record(robot, "t_intersection", line_m - 30.0, 8.0))
    assert far.stop_at_m == pytest.approx(line_m - half)  # its front stays behind the line
    assert far.pull_up_to_m == np.inf  # it drives, no pull-up
    cleared = [stage(_record(robot, "t_intersection", line_m - half - 0.5, 0.0)).stop_at_m
               for _ in range(40)]  # 4 s standing at the line
    assert cleared[0] < np.inf and cleared[-1] == np.inf  # stopped long enough: it may go


def test_the_step_off_branch_weighs_the_configured_probability():
    """A pedestrian standing at the curb ahead: one more branch of weight p_step_off."""
    robot = _robot("occluded_crosswalk", "aggressive")
    env = marl_social.parallel_env(scenario="occluded_crosswalk", pedestrian="waiting",
                                   robot_planner="aggressive")
    base = env.unwrapped
    env.reset(seed=0)
    truth = marl_social.envs.policies.truth_tracks(env, "robot_0")
    ped = truth.is_pedestrian
    assert ped.any()
    record = _record(robot, "occluded_crosswalk", 0.0, 3.0)
    record = replace(record, tracks=replace(truth, velocity=np.zeros_like(truth.velocity)))
    n_hyp = len(robot.belief.hypotheses)
    record = robot.stage(HypothesisBranches)(replace(
        record, weights=np.full(n_hyp, 1.0 / n_hyp), contingent=np.zeros(n_hyp, bool)))
    route, crosswalk = base.road_map.routes["robot_0"], base.road_map.crosswalks[0]
    crosswalk_s = float(route.project(crosswalk.center[None])[0][0])
    record = replace(record, s_m=crosswalk_s - 40.0, v_mps=3.0)
    n_branches = len(record.weights)
    out = robot.stage(CrosswalkStepOff)(record)
    p = robot.settings.curb.p_step_off
    assert len(out.weights) == n_branches + 1
    assert out.weights[-1] == pytest.approx(p) and out.weights.sum() == pytest.approx(1.0)
    assert out.contingent[-1]

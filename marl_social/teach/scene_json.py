"""The world as compact JSON for the page: the static map once, then one frame per step.

Positions are metres in the world frame rounded to centimetres (fields of view to decimetres),
angles radians counter-clockwise from +x, speeds m/s, probabilities rounded to 1e-4. Everything
here reads what the env, the world and the robot's policy expose; nothing is changed.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.sim.road_map import RoadMap
from marl_social.viz import style
from marl_social.viz.road import crosswalk_stripes, lane_markings

POSITION_DECIMALS = 2  # [m]
FOV_DECIMALS = 1  # field-of-view outlines [m]
ANGLE_DECIMALS = 3  # [rad]
PROBABILITY_DECIMALS = 4
SPOT_MIN_PROBABILITY = 1e-3  # hypotheses with less belief are not drawn on the map


def _points(array, decimals: int = POSITION_DECIMALS) -> list:
    """A (..., 2) array [m] as nested lists rounded to `decimals`."""
    return np.round(np.asarray(array, dtype=np.float64), decimals).tolist()


def palette() -> dict:
    """The colours of viz/style.py, so the page draws in the frames' and figures' colours."""
    return {
        "background": style.BACKGROUND_COLOR, "road": style.ROAD_COLOR,
        "marking": style.MARKING_COLOR, "house": style.HOUSE_COLOR,
        "house_edge": style.HOUSE_EDGE_COLOR, "roles": dict(style.ROLE_COLORS),
        "role_edges": dict(style.ROLE_EDGE_COLORS), "fan_alpha": dict(style.FAN_ALPHA),
        "signals": list(style.SIGNAL_STATE_COLORS), "beliefs": list(style.BELIEF_COLORS),
    }


def map_json(road_map: RoadMap, robot: str | None) -> dict:
    """The static map: lanes, markings, crosswalk stripes, houses, stop lines, signal heads.

    Args:
        road_map: the episode's map.
        robot: the robot's name (its route is drawn), or None.
    """
    solid, dashed = lane_markings(road_map)
    route = road_map.routes.get(robot) if robot is not None else None
    return {
        "extent": [float(v) for v in road_map.extent],
        "lanes": [_points(lane.polygon()) for lane in road_map.lanes],
        "solid": [_points(line) for line in solid],
        "dashed": [_points(line) for line in dashed],
        "stripes": [_points(s) for cw in road_map.crosswalks for s in crosswalk_stripes(cw)],
        "houses": [_points(p) for p in road_map.static_polygons],
        "stop_lines": [_points(line.segment) for line in road_map.stop_lines],
        "signal_heads": [_points(h.position) for h in road_map.signal_heads],
        "robot_route": _points(route.points) if route is not None else None,
    }


def agents_json(env) -> list[dict]:
    """Every agent's name, role, footprint [m] and whether it is a pedestrian (fixed per env)."""
    world = env.world
    return [{"name": s.name, "role": s.role, "length": round(float(world.length_m[i]), 2),
             "width": round(float(world.width_m[i]), 2),
             "pedestrian": bool(world.is_pedestrian[i])}
            for i, s in enumerate(world.specs)]


def fov_outlines(world, fov) -> list:
    """[[agent index, [[x, y], ...]], ...]: each active agent's visibility polygon [m].

    A cone starts at the agent (its apex); a full circle is the ray ends alone (as
    viz/frames.Renderer draws the fans).
    """
    xy, heading = world.state[:, :2], world.state[:, 2]
    depth = np.asarray(fov.depth_m, dtype=np.float64)
    angles = heading[:, None] + np.asarray(fov.ray_angles_rad, dtype=np.float64)
    ends = xy[:, None, :] + depth[..., None] * np.stack([np.cos(angles), np.sin(angles)], -1)
    full = np.asarray(world.sensor_half_angle_rad) >= math.pi
    out = []
    for i in np.flatnonzero(world.active & (depth > 0.0).any(axis=1)):
        outline = ends[i] if full[i] else np.vstack([xy[i], ends[i]])
        out.append([int(i), _points(outline, FOV_DECIMALS)])
    return out


def headline_belief(belief) -> float:
    """The belief the page reads out: P(a hidden pedestrian), else P(a hidden vehicle)."""
    kinds = {h.kind for h in belief.hypotheses if h.present}
    return float(belief.p_pedestrian if "pedestrian" in kinds or not kinds
                 else belief.p_vehicle)


def belief_json(belief) -> dict:
    """The robot's belief: per hidden path (bars), "none", and each hypothesis on the map.

    Args:
        belief: the robot's HiddenAgentBelief (read only: hypotheses, probabilities,
            path_probabilities(), p_pedestrian, p_vehicle, perceived).

    Returns:
        {"headline": P, "p_pedestrian", "p_vehicle", "perceived": bool, "paths": [[name, P],
        ...] ("none" last), "spots": [[x, y, P, is_pedestrian], ...] where each present
        hypothesis puts its hidden agent now (hypotheses at one spot summed)}.
    """
    paths = belief.path_probabilities()
    none = max(0.0, 1.0 - sum(paths.values()))
    spots: dict = {}
    for h, p in zip(belief.hypotheses, belief.probabilities):
        if h.present and p >= SPOT_MIN_PROBABILITY:
            x, y = h.predict_xy(np.zeros(1))[0]
            key = (round(float(x), 1), round(float(y), 1), h.kind == "pedestrian")
            spots[key] = spots.get(key, 0.0) + float(p)
    digits = PROBABILITY_DECIMALS
    return {
        "headline": round(headline_belief(belief), digits),
        "p_pedestrian": round(float(belief.p_pedestrian), digits),
        "p_vehicle": round(float(belief.p_vehicle), digits),
        "perceived": bool(belief.perceived),
        "paths": [[name, round(p, digits)] for name, p in paths.items()] + [
            ["none", round(none, digits)]],
        "spots": [[x, y, round(p, digits), ped] for (x, y, ped), p in spots.items()],
    }


def plan_json(result, plan_dt_s: float, labels: list[str]) -> dict:
    """The robot's last MPC plan: each live branch's speed profile and weight.

    Args:
        result: the planner's MpcResult (speed_plan (B, N) [m/s], weights (L,), live (L,)).
        plan_dt_s: the plan's step [s] (speeds are at the end of each step).
        labels: the L hypotheses' names (the branches are the live ones, in order).
    """
    live = np.flatnonzero(result.live)
    speeds = np.asarray(result.speed_plan, dtype=np.float64)
    weights = np.asarray(result.weights, dtype=np.float64)[live]
    names = [labels[i] if i < len(labels) else f"branch {k}" for k, i in enumerate(live)]
    return {
        "dt": float(plan_dt_s), "feasible": bool(result.feasible),
        "speeds": np.round(np.nan_to_num(speeds, nan=0.0), 2).tolist(),
        "weights": np.round(weights, PROBABILITY_DECIMALS).tolist(),
        "labels": names[: len(speeds)],
    }

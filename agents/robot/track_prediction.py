"""The robot's prediction of what it tracks: a car in a lane drives on along its lane path.

A tracked car in a lane (perception/belief/paths.LanePaths.route_of: the lane nearest it whose
heading matches its track's, and the lane's unique continuations; never its name) is
predicted along that path at its current speed along it (`path_prediction`: a left-turner
through its turn, not straight across the junction); a pedestrian, or a car in no lane, at
constant velocity (models/scene_prediction.ScenePrediction.from_tracks). The signalled traffic's
phase branches (phase_branches.py) start from this prediction.

Why not constant velocity for every car: the track's heading is noisy while a car is slow, and
constant velocity turns a heading error into a drift across lanes. Measured on the
T-intersection (seed 0 of its claims, no hidden car): a left-turner braking for the robot,
3.1 m/s, read 7 degrees off its lane; constant velocity put it 1.2 m into the eastbound lane
within 3 s, in the corridor of the robot that had just turned into that lane, and the robot
braked from 3.8 m/s at 7.5 m/s^2 and then waited 1.4 s for it.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.belief.paths import LanePaths, route_heading
from marl_social.perception.tracking import TrackSet


def path_prediction(route, s_m: float, v_mps: float, times_s: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Positions (T, 2) [m] and headings (T,) [rad] at constant speed along a lane path.

    Args:
        route: the car's lane path.
        s_m: its arc length along it [m].
        v_mps: its speed along it [m/s] (negative counts as 0).
        times_s: (T,) prediction times [s].
    """
    s = s_m + max(v_mps, 0.0) * np.asarray(times_s, dtype=np.float64)
    xy, heading = route.point_at(s)
    return xy, np.asarray(heading, dtype=np.float64)


def along_lane_paths(scene: ScenePrediction, tracks: TrackSet, lane_paths: LanePaths,
                     times_s: np.ndarray) -> ScenePrediction:
    """The scene with every tracked car in a lane predicted along its lane path.

    On the path's centre line from the car's projection onto it, at the track's velocity
    along the path there (module docstring); every hypothesis alike.

    Args:
        scene: L hypotheses; its first len(tracks) objects are the tracks, in order.
        tracks: the tracks the scene was built from.
        lane_paths: the map's lane paths (the belief's).
        times_s: (T,) the scene's prediction times [s].
    """
    xy, heading = None, None
    for k in np.flatnonzero(~tracks.is_pedestrian).tolist():  # a few tracks
        route = lane_paths.route_of(tracks.xy[k], float(tracks.heading_rad[k]))
        if route is None:
            continue
        if xy is None:
            xy, heading = np.array(scene.xy), np.array(scene.heading)
        s0, _ = route.project_point(float(tracks.xy[k, 0]), float(tracks.xy[k, 1]))
        path_heading = route_heading(route, s0)  # Route.point_at's heading, on floats
        vx, vy = (float(v) for v in tracks.velocity[k])
        speed = vx * math.cos(path_heading) + vy * math.sin(path_heading)
        xy[:, k], heading[:, k] = path_prediction(route, s0, speed, times_s)
    if xy is None:
        return scene
    return ScenePrediction(xy, heading, scene.length_m, scene.width_m, scene.radius_m,
                           scene.is_pedestrian, scene.mask)

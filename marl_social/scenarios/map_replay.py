"""A recorded scene on its map: the recorded vehicles replayed, the robot on a route of the map.

`MapReplay` is `MapScene`'s crosswalk situation (the robot's route through one of the map's
crosswalks, `element`) with the simulated human replaced by the vehicles of an INTERACTION
recording (`tracks`, a ``vehicle_tracks_*.csv`` in the map's frame): every vehicle present at
the replay's first frame (`start_frame`; 0: the recording's first) becomes a human driver
`human_k` whose route is its recorded path and whose policy is agents/log_replay.py. Vehicles
that enter the recording later cannot join a running episode; they are counted
(`late_vehicles`). Pedestrian rows of the file are not replayed (`pedestrian`: the scene's own
hidden pedestrian, "none" by default). The robot's belief so runs on recorded human behaviour.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from marl_social.agents.log_replay import RecordedMotion
from marl_social.maps import load_map
from marl_social.maps.errors import MapError
from marl_social.scenarios.base import MAX_VEHICLE_SPEED_MPS
from marl_social.scenarios.crosswalk_agents import human_spec
from marl_social.scenarios.map_scene import SCENE_MARGIN_M, MapScene, MapSceneParams, scene_road_map
from marl_social.sim.agent_spec import AgentSpec, VehicleParams
from marl_social.sim.road_map import RoadMap, Route

if TYPE_CHECKING:
    from marl_social.data.interaction import Track

PATH_POINT_SPACING_M = 0.2  # recorded positions closer than this to the last kept one are dropped
WHEELBASE_FRACTION = 0.6  # a replayed car's wheelbase: this fraction of its length
REPLAY_ACCEL_MAX_MPS2 = 6.0  # a replayed car's limits: wide enough for recorded driving
REPLAY_LAT_ACCEL_MAX_MPS2 = 8.0


@dataclass(frozen=True)
class MapReplayParams(MapSceneParams):
    """Map replay parameters (MapSceneParams' with these).

    Attributes:
        tracks: the recording's ``vehicle_tracks_*.csv`` (INTERACTION's columns).
        start_frame: the replay's first frame (0: the recording's first).
    """

    tracks: str = ""
    start_frame: int = 0
    pedestrian: str = "none"

    def __post_init__(self):
        super().__post_init__()
        self._check(isinstance(self.tracks, str) and self.tracks != "", "tracks",
                    "must be the path of a vehicle_tracks_*.csv file")
        self._check(self.situation == "crosswalk", "situation",
                    "must be 'crosswalk' (the robot's route through one of the map's crosswalks)")
        self._check(self.start_frame >= 0, "start_frame", "must be >= 0 (0: the first)")


def _recorded_path(xy: np.ndarray, heading_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """The kept points (P, 2) of a recorded path [m] and each sample's arc length (K,) [m].

    A sample's arc length is that of the last kept point at or before it. A car that never moves
    gets a 1 m route along its heading.
    """
    kept, s_of_sample, s = [xy[0]], [0.0], 0.0
    for point in xy[1:]:
        step = float(np.hypot(*(point - kept[-1])))
        if step >= PATH_POINT_SPACING_M:
            kept.append(point)
            s += step
        s_of_sample.append(s)
    if len(kept) < 2:
        kept.append(xy[0] + np.array([np.cos(heading_rad), np.sin(heading_rad)]))
    return np.array(kept), np.array(s_of_sample)


class MapReplay(MapScene):
    """A recording's vehicles replayed on their map, the robot at one of its crosswalks."""

    name = "map_replay"
    params_cls = MapReplayParams
    variants = ({},)

    def __init__(self, **overrides):
        super().__init__(**overrides)
        p: MapReplayParams = self.params
        # the track loader's smoothers (scipy.sparse) come with the first replay, not with
        # `import marl_social`
        from marl_social.data.interaction import read_interaction_csv

        try:
            tracks = read_interaction_csv(p.tracks)
        except (OSError, ValueError) as err:
            raise MapError(str(err).splitlines()[0] if str(err) else repr(err)) from None
        vehicles = {k: t for k, t in tracks.items() if not t.is_pedestrian}
        if not vehicles:
            raise MapError(f"{p.tracks}: the recording has no vehicle track")
        first = min(int(t.frame_id[0]) for t in vehicles.values())
        self.start_frame = p.start_frame or first
        self.late_vehicles = sum(int(t.frame_id[0]) > self.start_frame
                                 for t in vehicles.values())
        present = [t for t in vehicles.values()
                   if t.frame_id[0] <= self.start_frame <= t.frame_id[-1]]
        if not present:
            raise MapError(f"{p.tracks}: no vehicle is recorded at frame {self.start_frame}")
        self.replays = [self._replay(k, track) for k, track in enumerate(present)]
        self.road_map = self._replay_map(load_map(p.map).road_map)

    def _replay(self, k: int, track: Track) -> tuple[AgentSpec, Route, RecordedMotion, str]:
        """human_k driving `track` from the start frame on: spec, route, motion, track id."""
        rows = track.frame_id >= self.start_frame
        xy, t_ms = track.xy[rows], track.timestamp_ms[rows]
        heading = track.heading_rad()[rows]
        speed = np.hypot(*track.vxy[rows].T)
        points, s_m = _recorded_path(xy, float(heading[0]))
        name = f"human_{k}"
        route = Route(points, name)
        state = np.array([xy[0, 0], xy[0, 1], heading[0], speed[0]])
        vehicle = VehicleParams(
            length_m=track.length_m, width_m=track.width_m,
            wheelbase_m=WHEELBASE_FRACTION * track.length_m,
            accel_max_mps2=REPLAY_ACCEL_MAX_MPS2, lat_accel_max_mps2=REPLAY_LAT_ACCEL_MAX_MPS2,
            speed_max_mps=min(MAX_VEHICLE_SPEED_MPS, max(20.0, 1.2 * float(speed.max()))))
        spec = dataclasses.replace(human_spec(self.params, name, state), vehicle=vehicle,
                                   v_desired_mps=float(speed.max()))
        motion = RecordedMotion((t_ms - t_ms[0]) * 1e-3, s_m, speed)
        return spec, route, motion, track.track_id

    def _replay_map(self, full: RoadMap) -> RoadMap:
        """The scene's map over the robot's route, the crosswalk and every replayed path."""
        plan = self.plan
        everything = np.concatenate([plan.robot.points, plan.pedestrian_path,
                                     *(route.points for _, route, _, _ in self.replays)])
        lo, hi = everything.min(axis=0) - SCENE_MARGIN_M, everything.max(axis=0) + SCENE_MARGIN_M
        return scene_road_map(full, (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])),
                              (), self.crosswalk_index)

    def motions(self) -> dict[str, RecordedMotion]:
        """{agent name: its recorded motion} of the replayed vehicles."""
        return {spec.name: motion for spec, _, motion, _ in self.replays}

    def track_ids(self) -> dict[str, str]:
        """{agent name: the recording's track id}."""
        return {spec.name: track_id for spec, _, _, track_id in self.replays}

    def _human(self) -> list[tuple[AgentSpec, Route]]:
        return [(spec, route) for spec, route, _, _ in self.replays]

"""The scenes the robot assumes a human driver reacts to (social.py's model of a human, eq. 11).

`HumanScenes` holds, for the L hidden-agent hypotheses, each one's hidden agent predicted at the
planner's times, and builds a human's L scenes: the hypothesised agent (a hypothesised vehicle
only if inside the view the robot assumes a human has), plus the vehicles the robot tracks and
the robot itself in that view, at constant velocity but for a vehicle that must give way and
can stop before the zone, which the human expects to do so (models/yield_expectation.py, as the
human drivers themselves predict; `others_scene`). What every human of a
step shares is built once per step; a scene without others once per set of hypotheses.
"""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np

from marl_social.models.scene_prediction import ScenePrediction
from marl_social.models.yield_expectation import YieldExpectation
from marl_social.perception.belief import compiled
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.hypotheses import Hypothesis, hypothesis_objects
from marl_social.perception.tracking import TrackSet
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.observation import EGO_INDEX, DecodedObservation

KEPT_SCENES_MAX = 64  # scenes without others remembered per (kept hypotheses, mask)
_EGO_XY = [EGO_INDEX["x"], EGO_INDEX["y"]]
_EGO_COS_SIN = [EGO_INDEX["cos_psi"], EGO_INDEX["sin_psi"]]
_NO_IDS = np.zeros(0, dtype=np.int64)  # view_mask's ids when no row is a tracked object


class HumanScenes:
    """The scenes of the robot's model of a human, for L hypotheses at T planner times.

    Args:
        hypotheses: the L hidden-agent hypotheses ("none" first).
        times_s: (T,) the human's planner times [s].
        config: BeliefConfig (the view the robot assumes a human has).
        vehicle: the footprint of the robot itself (as the humans see it).
        yield_expectation: how the humans predict who gives way (the static map's zones);
            None: every object at constant velocity.
    """

    def __init__(self, hypotheses: list[Hypothesis], times_s: np.ndarray, config: BeliefConfig,
                 vehicle: VehicleParams, yield_expectation: YieldExpectation | None = None):
        """Predict every hypothesis' hidden agent at times_s."""
        self.config = config
        self.vehicle = vehicle
        self.yield_expectation = (yield_expectation if yield_expectation is not None
                                  and yield_expectation.applies else None)
        self._times = times_s
        self._present = np.array([h.present for h in hypotheses])
        self._hyp_scene = hypothesis_objects(hypotheses, self._times)
        self._vehicle = np.array([h.kind == "vehicle" for h in hypotheses])
        self._now_xy = np.array([h.predict_xy(np.zeros(1))[0] if h.present else np.zeros(2)
                                 for h in hypotheses]).reshape(-1, 2)
        self._empty_scene: ScenePrediction | None = None
        self._empty_hyp_scene: ScenePrediction | None = None
        self._kept_scenes: dict[tuple, ScenePrediction] = {}  # (keep, mask) -> scene, no others
        self._kept_fixed: dict[bytes, tuple] = {}  # keep -> the fixed hypothesis arrays kept
        self._step_cache: tuple | None = None  # (decoded, tracks, _step_objects)

    def in_view(self, viewer_xy, viewer_heading_rad: float) -> np.ndarray:
        """(L,) bool: hypothesised agents inside a human's assumed field of view now.

        The view the robot assumes a human has (BeliefConfig.human_range_m,
        human_half_fov_rad) from viewer_xy (2,) [m] looking along viewer_heading_rad [rad];
        False for "none".
        """
        rel = self._now_xy - np.asarray(viewer_xy, dtype=np.float64)
        return compiled.view().view_mask(
            np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 1], rel[:, 0]),
            float(viewer_heading_rad), self._present, _NO_IDS, -1, self.config.human_range_m,
            self.config.human_half_fov_rad)

    def others_scene(self, human_xy, human_heading, human_id, decoded: DecodedObservation,
                     tracks: TrackSet) -> ScenePrediction | None:
        """What the robot assumes the human reacts to besides the hypothesised pedestrian.

        One hypothesis (L = 1): the vehicles the robot tracks (other than the human) and the
        robot itself inside the human's assumed field of view, at constant velocity but for a
        vehicle expected to give way (`_predict_step_objects`); None if
        there is nothing. Seen pedestrians are left to the hypotheses (a crossing one is the
        detected hypothesis).

        Args:
            human_xy: (2,) the human's tracked position [m].
            human_heading: its route heading [rad].
            human_id: its object id (agent index + 1).
            decoded: the robot's decoded observation (its own pose and speed).
            tracks: the robot's current tracks.
        """
        step = self._step_objects(decoded, tracks)
        rel = step["xy"] - human_xy
        # the tracked vehicles but the human, and the robot, inside its view (compiled after
        # np.hypot and np.arctan2: view_kernels.view_mask)
        keep = compiled.view().view_mask(
            np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 1], rel[:, 0]),
            float(human_heading), step["vehicle"], step["ids"], int(human_id),
            self.config.human_range_m, self.config.human_half_fov_rad)
        if not keep.any():
            return None
        if "pred" not in step:
            self._predict_step_objects(step, decoded, tracks)
        m = int(keep.sum())
        heading = np.repeat(step["heading"][keep][:, None], len(self._times), axis=1)
        return ScenePrediction(step["pred"][keep][None], heading[None],
                               step["length"][keep][None], step["width"][keep][None],
                               step["radius"][keep][None], step["is_ped"][keep][None],
                               np.ones((1, m), dtype=bool))

    def _step_objects(self, decoded: DecodedObservation, tracks: TrackSet) -> dict:
        """The tracked objects and the robot as `others_scene` sees them, once per step.

        Remembered for the last (decoded, tracks) pair: every human of a step shares them.
        {"xy": (N + 1, 2) [m], "vehicle": (N + 1,) bool, "ids": (N,) int}: the N tracks, then
        the robot; the
        predictions are added on first use (`_predict_step_objects`).
        """
        cached = self._step_cache
        if cached is not None and cached[0] is decoded and cached[1] is tracks:
            return cached[2]
        step = {"xy": np.vstack([tracks.xy, decoded.ego[None, _EGO_XY]]),
                "vehicle": np.append(~tracks.is_pedestrian, True),
                "ids": np.ascontiguousarray(tracks.ids, dtype=np.int64)}
        self._step_cache = (decoded, tracks, step)
        return step

    def _predict_step_objects(self, step: dict, decoded: DecodedObservation,
                              tracks: TrackSet) -> None:
        """Add to `step` the objects' predictions and their footprints.

        At constant velocity, but for a vehicle expected to stop before a zone it must give way
        in (models/yield_expectation.py), as the human drivers predict their tracks.

        "pred" (N + 1, T, 2) [m], "heading" (N + 1,) [rad], "length", "width", "radius"
        (N + 1,) [m], "is_ped" (N + 1,) bool.
        """
        ego = decoded.ego
        veh = self.vehicle
        ego_velocity = float(ego[EGO_INDEX["v"]]) * ego[None, _EGO_COS_SIN]
        vel = np.vstack([tracks.velocity, ego_velocity])
        length = np.append(tracks.length_m, veh.length_m)
        width = np.append(tracks.width_m, veh.width_m)
        ego_heading = math.atan2(ego[EGO_INDEX["sin_psi"]], ego[EGO_INDEX["cos_psi"]])
        heading = np.append(tracks.heading_rad, ego_heading)
        is_ped = np.append(tracks.is_pedestrian, False)
        if self.yield_expectation is None:
            pred = step["xy"][:, None, :] + vel[:, None, :] * self._times[None, :, None]
        else:
            pred = self.yield_expectation.predict_xy(step["xy"], vel, heading, length, width,
                                                     is_ped, self._times)
        step.update(pred=pred, heading=heading, length=length, width=width,
                    radius=0.5 * np.hypot(length, width), is_ped=is_ped)

    def hypothesis_scene(self, others: ScenePrediction | None = None,
                         viewer: tuple | None = None) -> ScenePrediction:
        """The L scenes the human is modelled against.

        Args:
            others: one-hypothesis scene of the other objects (None: nothing else); each
                hypothesis' hidden agent is added to it (masked out for "none").
            viewer: (xy (2,) [m], heading [rad]) of the human: a hypothesised vehicle outside
                its assumed field of view (`in_view`) is masked out, the human does not react
                to it (None: every hypothesised agent is in the scene). Hypothesised
                pedestrians stay in (the human knows the crosswalk ahead of it).
        """
        objects = self.objects_in_view(viewer)
        if others is None:
            if objects is self._hyp_scene:
                if self._empty_hyp_scene is None:
                    self._empty_hyp_scene = self._no_others().with_extra(*objects)
                return self._empty_hyp_scene
            return self._no_others().with_extra(*objects)
        return others.with_extra(*objects)

    def objects_in_view(self, viewer: tuple | None) -> tuple:
        """The hypotheses' objects (`hypothesis_objects`), vehicles out of the viewer's view masked.

        Args:
            viewer: (xy (2,) [m], heading [rad]) of the human, or None (all in).
        """
        objects = self._hyp_scene
        if viewer is not None and self._vehicle.any():
            hidden = self._vehicle & ~self.in_view(*viewer)
            objects = (*objects[:5], objects[5] & ~hidden)
        return objects

    def _no_others(self) -> ScenePrediction:
        """A one-hypothesis scene without objects (built once)."""
        if self._empty_scene is None:
            n_t = len(self._times)
            self._empty_scene = ScenePrediction(
                np.zeros((1, 0, n_t, 2)), np.zeros((1, 0, n_t)), np.zeros((1, 0)),
                np.zeros((1, 0)), np.zeros((1, 0)), np.zeros((1, 0), dtype=bool),
                np.zeros((1, 0), dtype=bool))
        return self._empty_scene

    def _kept_objects(self, objects: tuple, keep: np.ndarray) -> tuple:
        """tuple(array[keep] for array in objects), the fixed arrays indexed once per `keep`.

        The fixed arrays: all but the mask, when they are this scene's `hypothesis_objects`.
        """
        fixed = self._hyp_scene
        if any(objects[i] is not fixed[i] for i in range(5)):
            return tuple(array[keep] for array in objects)
        key = keep.tobytes()
        kept = self._kept_fixed.get(key)
        if kept is None:
            if len(self._kept_fixed) >= KEPT_SCENES_MAX:
                self._kept_fixed.clear()
            kept = self._kept_fixed[key] = tuple(array[keep] for array in fixed[:5])
            for array in kept:
                array.setflags(write=False)
        return (*kept, objects[5][keep])

    def kept_scene(self, others: ScenePrediction | None, objects: tuple, keep: np.ndarray
                    ) -> ScenePrediction:
        """`hypothesis_scene` restricted to the hypotheses `keep` (K,) (indices).

        The same arrays as indexing the full scene, built from the kept rows only; without
        others, once per (keep, mask) (read-only).

        Args:
            others: one-hypothesis scene of the other objects (None: nothing else).
            objects: the hypotheses' objects (`objects_in_view`).
            keep: (K,) indices of the hypotheses to keep.
        """
        kept = self._kept_objects(objects, keep)
        if others is not None:
            return others.with_extra(*kept)
        key = (keep.tobytes(), kept[5].tobytes())
        scene = self._kept_scenes.get(key)
        if scene is None:
            if len(self._kept_scenes) >= KEPT_SCENES_MAX:
                self._kept_scenes.clear()
            scene = self._no_others().with_extra(*kept)
            for f in fields(scene):
                getattr(scene, f.name).setflags(write=False)
            self._kept_scenes[key] = scene
        return scene

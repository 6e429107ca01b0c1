"""What a planner predicts of the objects around it: L hypotheses of M objects over T steps.

`ScenePrediction` is the scene every candidate evaluation (models/candidates.py) costs its plans
against: the objects' positions, headings and footprints per hypothesis, and which are present.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marl_social.models import kernel_loading


@dataclass(frozen=True)
class ScenePrediction:
    """Predicted others for one or more hypotheses (L of them), M objects, T steps.

    Attributes:
        xy: (L, M, T, 2) positions after each planner step [m].
        heading: (L, M, T) headings after each planner step [rad].
        length_m: (L, M) footprint lengths [m].
        width_m: (L, M) footprint widths [m].
        radius_m: (L, M) footprint bounding radii [m].
        is_pedestrian: (L, M) bool.
        mask: (L, M) bool, object present in that hypothesis.
    """

    xy: np.ndarray
    heading: np.ndarray
    length_m: np.ndarray
    width_m: np.ndarray
    radius_m: np.ndarray
    is_pedestrian: np.ndarray
    mask: np.ndarray

    @classmethod
    def from_tracks(cls, tracks, times_s: np.ndarray, mask: np.ndarray | None = None,
                    predicted_xy: np.ndarray | None = None) -> ScenePrediction:
        """One hypothesis: every track of a TrackSet at constant velocity (or as predicted).

        Footprints are at the tracks' headings (TrackSet.heading_rad, perception/tracking.py).

        Args:
            tracks: the TrackSet, M tracks.
            times_s: (T,) prediction times [s].
            mask: (1, M) bool, the tracks present in the scene (default: all).
            predicted_xy: (M, T, 2) the tracks' positions at times_s [m] (default: constant
                velocity, TrackSet.predict_xy).
        """
        if predicted_xy is None and _float_arrays(tracks.xy, tracks.velocity, tracks.heading_rad,
                                                  times_s):
            # predict_xy's arithmetic and the repeated headings in one compiled call
            xy, heading = kernel_loading.load_all()[2].constant_velocity_scene(  # scene_kernels
                tracks.xy, tracks.velocity, tracks.heading_rad, times_s)
        else:
            if predicted_xy is None:
                predicted_xy = tracks.predict_xy(times_s)
            xy = predicted_xy[None]  # (1, M, T, 2)
            heading = tracks.heading_rad[None, :, None].repeat(xy.shape[2], axis=2)  # (1, M, T)
        radius = 0.5 * np.hypot(tracks.length_m, tracks.width_m)
        if mask is None:  # every track: a copy of a row of Trues (faster than np.ones)
            m = len(tracks)
            mask = (_ALL_PRESENT[:, :m] if m <= _ALL_PRESENT.shape[1]
                    else np.ones((1, m), dtype=bool)).copy()
        return cls(xy, heading, tracks.length_m[None], tracks.width_m[None], radius[None],
                   tracks.is_pedestrian[None], mask)

    def with_extra(self, xy, heading, length_m, width_m, is_pedestrian, mask) -> ScenePrediction:
        """Append one object per hypothesis.

        The L of self must be 1 (broadcast) or L.

        Args:
            xy: (L, T, 2) positions after each planner step [m].
            heading: (L, T) headings after each planner step [rad].
            length_m: (L,) footprint lengths [m].
            width_m: (L,) footprint widths [m].
            is_pedestrian: (L,) bool.
            mask: (L,) bool, object present in that hypothesis.
        """
        n_hyp = len(mask)
        radius = 0.5 * np.hypot(length_m, width_m)

        def append(mine: np.ndarray, extra) -> np.ndarray:
            """(n_hyp, M + 1, ...): mine (1 or n_hyp, M, ...) repeated, then extra (n_hyp, ...)."""
            extra = np.asarray(extra)
            out = np.empty((n_hyp, mine.shape[1] + 1) + mine.shape[2:],
                           dtype=np.result_type(mine.dtype, extra.dtype))  # np.concatenate's
            out[:, :-1] = mine
            out[:, -1] = extra
            return out

        return ScenePrediction(
            append(self.xy, xy), append(self.heading, heading),
            append(self.length_m, length_m), append(self.width_m, width_m),
            append(self.radius_m, radius), append(self.is_pedestrian, is_pedestrian),
            append(self.mask, mask),
        )


_ALL_PRESENT = np.ones((1, 64), dtype=bool)
_ALL_PRESENT.setflags(write=False)


def _float_arrays(xy, velocity, heading, times_s) -> bool:
    """Whether scene_kernels.constant_velocity_scene takes these arrays.

    float64 xy (M, 2), velocity (M, 2), heading (M,) and times_s (T,).
    """
    return (type(xy) is type(velocity) is type(heading) is type(times_s) is np.ndarray
            and xy.dtype == velocity.dtype == heading.dtype == times_s.dtype == np.float64
            and times_s.ndim == 1 and xy.shape == velocity.shape == (len(heading), 2)
            and heading.ndim == 1)

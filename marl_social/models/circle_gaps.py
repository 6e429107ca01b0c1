"""Gaps between an ego's covering circles along its plans and a scene's objects, in one broadcast.

The candidate evaluation (candidates.py: the human drivers' Q*, the robot's model of them and
its MPC) and the pedestrian model share these: `scene_circles` lays out the objects' covering
circles (sim/footprint.py), `circle_pair_gap` the smallest gap of every plan step to every
object (sim/costs.circle_gap's arithmetic, bit for bit; tests/sim/test_fast_paths.py).
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.costs import _cos_sin, crosswalk_occupancy
from marl_social.sim.footprint import circle_layout


def circle_pair_gap(ego_x, ego_y, ego_r: float, other_x, other_y, other_r) -> np.ndarray:
    """(L, ..., T, M) sim/costs.circle_gap(clip=False) of ego plans and scene objects.

    The same arithmetic per circle pair (the smallest squared centre distance, its square root
    minus the two radii); every pair in one broadcast, circle axes first.

    Objects that are the same in every hypothesis (the tracked ones, which a scene built with
    `ScenePrediction.with_extra` repeats in each) are computed once and repeated: the same
    values, for a fraction of the work.

    Args:
        ego_x: (K, ..., T) x of the ego's covering circles along its plans [m] (e.g.
            (K, A, C, T) candidates).
        ego_y: (K, ..., T) their y [m].
        ego_r: their radius [m].
        other_x: (J, L, M, T) x of the objects' covering circles [m].
        other_y: (J, L, M, T) their y [m].
        other_r: (L, M) their radii [m].
    """
    n_hyp, n_obj = other_r.shape
    if n_hyp > 1 and n_obj:
        shared = ((other_x == other_x[:, :1]) & (other_y == other_y[:, :1])).all(axis=(0, 1, 3))
        shared &= (other_r == other_r[:1]).all(axis=0)
        if shared.any():
            out = np.empty((n_hyp,) + ego_x.shape[1:] + (n_obj,))
            same, rest = np.flatnonzero(shared), np.flatnonzero(~shared)
            out[..., same] = _circle_pair_gap(ego_x, ego_y, ego_r, other_x[:, :1, same],
                                              other_y[:, :1, same], other_r[:1, same])
            if len(rest):
                out[..., rest] = _circle_pair_gap(ego_x, ego_y, ego_r, other_x[:, :, rest],
                                                  other_y[:, :, rest], other_r[:, rest])
            return out
    # every object at once: scene_circles gives one circle per object (J = 1) when all are
    # discs, so J > 1 means a vehicle among them and looking for coinciding circles is futile
    return _circle_pair_gap(ego_x, ego_y, ego_r, other_x, other_y, other_r, False)


def _circle_pair_gap(ego_x, ego_y, ego_r: float, other_x, other_y, other_r,
                     look_for_discs: bool = True) -> np.ndarray:
    """`circle_pair_gap` of every object in every hypothesis (the same arguments).

    With look_for_discs, when every object's circles coincide (discs) one stands for all (the
    minimum over repeated circles is the same: either way gives the same values).
    """
    if look_for_discs and len(other_x) > 1 and (other_x[1:] == other_x[:1]).all() and (
            other_y[1:] == other_y[:1]).all():
        other_x, other_y = other_x[:1], other_y[:1]
    plan_axes = (None,) * (ego_x.ndim - 2)  # the ego's plan axes, e.g. (A, C)
    ox = other_x.swapaxes(-2, -1)[(None, slice(None), slice(None)) + plan_axes]
    oy = other_y.swapaxes(-2, -1)[(None, slice(None), slice(None)) + plan_axes]
    dx = ego_x[:, None, None, ..., None] - ox  # (K, J, L, ..., T, M)
    dy = ego_y[:, None, None, ..., None] - oy
    d2 = dx * dx
    d2 += dy * dy
    nearest = np.minimum.reduce(d2.reshape((d2.shape[0] * d2.shape[1],) + d2.shape[2:]), axis=0)
    return np.sqrt(nearest) - ego_r - other_r[(slice(None),) + plan_axes + (None, slice(None))]


_last_read_only: list = [None, None]  # [(scene,), scene_circles(scene)] of a read-only scene


def _remembered(memo: list, key: tuple, compute, inputs: tuple) -> tuple:
    """compute()'s arrays, remembered in memo = [key, out] while every input is read-only.

    A frozen scene of arrays nobody can write to cannot change: the next call with the same
    objects (`key`, compared by identity) returns the remembered, read-only arrays.
    """
    last_key, last_out = memo
    if last_key is not None and len(last_key) == len(key) and all(
            a is b for a, b in zip(last_key, key)):
        return last_out
    out = compute()
    if all(_immutable(array) for array in inputs):
        for array in out:
            array.setflags(write=False)
        memo[:] = [key, out]
    return out


def scene_circles(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The scene objects' covering circles (footprint.covering_circles), circle axis first.

    Args:
        scene: models.scene_prediction.ScenePrediction (L hypotheses, M objects, T steps).

    Returns:
        x (J, L, M, T) and y (J, L, M, T) of the centres [m] (J = 1 when every footprint is a
        disc: its circles coincide), and the radii (L, M) [m].
    """
    # e.g. the scene the robot's model of a human reuses while the human sees nobody
    return _remembered(_last_read_only, (scene,), lambda: _scene_circles(scene),
                       (scene.xy, scene.heading, scene.length_m, scene.width_m,
                        scene.is_pedestrian))


def _immutable(array: np.ndarray) -> bool:
    """Whether neither the array nor any array it views can be written to."""
    while isinstance(array, np.ndarray):
        if array.flags.writeable:
            return False
        array = array.base
    return True


# circle_layout of the scene objects' dimensions and its kernel forms (_layout_entry), by their
# bytes (a scene's objects keep their sizes from step to step); read-only arrays; emptied when
# it reaches this many entries
_MAX_LAYOUTS = 256
_LAYOUTS: dict[tuple, tuple[np.ndarray, ...]] = {}


def _layout_entry(length_m: np.ndarray, width_m: np.ndarray, is_pedestrian: np.ndarray
                  ) -> tuple[np.ndarray, ...]:
    """circle_layout's along and radius (L, M, C) [m] and their kernel forms, once per input.

    The kernel forms: along and radius[..., 0] (L, M) as C-contiguous float64 (the same bits).
    Every array read-only.
    """
    length_m, width_m = np.asarray(length_m), np.asarray(width_m)
    is_pedestrian = np.asarray(is_pedestrian)
    key = (length_m.dtype, width_m.dtype, is_pedestrian.dtype, length_m.shape, width_m.shape,
           is_pedestrian.shape, length_m.tobytes(), width_m.tobytes(), is_pedestrian.tobytes())
    hit = _LAYOUTS.get(key)
    if hit is None:
        along, radius = circle_layout(length_m, width_m, is_pedestrian)
        hit = (along, radius, np.ascontiguousarray(along, dtype=np.float64),
               np.ascontiguousarray(radius[..., 0], dtype=np.float64))
        for array in hit:
            array.setflags(write=False)
        if len(_LAYOUTS) >= _MAX_LAYOUTS:
            _LAYOUTS.clear()
        _LAYOUTS[key] = hit
    return hit


def _scene_layout(length_m: np.ndarray, width_m: np.ndarray, is_pedestrian: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """footprint.circle_layout(length_m, width_m, is_pedestrian) (L, M), once per distinct input.

    Returns:
        along (L, M, C) [m] and radius (L, M, C) [m], read-only.
    """
    return _layout_entry(length_m, width_m, is_pedestrian)[:2]


def _kernel_layout(length_m, width_m, is_pedestrian) -> tuple[np.ndarray, np.ndarray]:
    """_scene_layout's along (L, M, C) [m] and radius[..., 0] (L, M) [m] as the kernels take them.

    C-contiguous float64, read-only, remembered with the layout (np.ascontiguousarray of the
    same values: the same bits).
    """
    return _layout_entry(length_m, width_m, is_pedestrian)[2:]


def _scene_circles(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`scene_circles` computed."""
    along, radius = _scene_layout(scene.length_m, scene.width_m, scene.is_pedestrian)
    if not along.any():  # only discs: their circles coincide, one stands for all
        along = along[..., :1]
    along = along.transpose(2, 0, 1)[..., None]  # (L, M, J) -> (J, L, M, 1)
    return (scene.xy[..., 0] + along * np.cos(scene.heading),
            scene.xy[..., 1] + along * np.sin(scene.heading), radius[..., 0])


_last_kernel_inputs: list = [None, None]  # [(scene,), scene_circle_inputs(scene)], read-only


def scene_circle_inputs(scene) -> tuple[np.ndarray, ...]:
    """What the compiled kernels build `scene_circles` from (models/gap_kernels.scene_circles).

    Remembered for a scene of arrays nobody can write to, as scene_circles is.

    Args:
        scene: models.scene_prediction.ScenePrediction (L hypotheses, M objects, T steps).

    Returns:
        C-contiguous float arrays: xy (L, M, T, 2) [m], np.cos and np.sin of the headings
        (L, M, T), footprint.circle_layout's offsets along them (L, M, C) [m] and the circles'
        radii (L, M) [m].
    """
    def compute():
        along, radius = _kernel_layout(scene.length_m, scene.width_m, scene.is_pedestrian)
        heading = scene.heading
        return (np.ascontiguousarray(scene.xy, dtype=np.float64),
                np.ascontiguousarray(np.cos(heading), dtype=np.float64),
                np.ascontiguousarray(np.sin(heading), dtype=np.float64), along, radius)

    if scene.xy.flags.writeable:  # a scene of this step (e.g. from the tracks): nothing to recall
        return compute()
    return _remembered(_last_kernel_inputs, (scene,), compute,
                       (scene.xy, scene.heading, scene.length_m, scene.width_m,
                        scene.is_pedestrian))


# [(scene, crosswalks), scene_crosswalk_occupancy(scene, crosswalks)] of a read-only scene
_last_occupancy: list = [None, None]


def scene_crosswalk_occupancy(scene, crosswalks: tuple) -> tuple[np.ndarray, ...]:
    """The scene objects' crosswalk occupancy, per crosswalk, as the candidates see them.

    crosswalk_occupancy(xy, radius, cw) of the objects' predictions brought to the candidates'
    axes (models/candidates.evaluate_candidates): remembered for a scene of arrays nobody can
    write to (the hypothesised pedestrians the robot's model of a human reuses step after step).

    Args:
        scene: models.scene_prediction.ScenePrediction (L hypotheses, M objects, T steps).
        crosswalks: the map's crosswalks.

    Returns:
        per crosswalk, (L, 1, 1, T, M) occupancy in 0..1.
    """
    def compute():
        xy = scene.xy.swapaxes(1, 2)[:, None, None]  # (L, 1, 1, T, M, 2)
        radius = scene.radius_m[:, None, None, None, :]
        return tuple(crosswalk_occupancy(xy, radius, cw) for cw in crosswalks)

    return _remembered(_last_occupancy, (scene, crosswalks), compute,
                       (scene.xy, scene.radius_m))


# id(crosswalks) -> (crosswalks, their read-only `crosswalk_rows`); emptied at 64 entries
_CROSSWALK_ROWS: dict[int, tuple] = {}
_NO_CROSSWALKS = np.zeros((0, 6))
_NO_CROSSWALKS.setflags(write=False)


def crosswalk_rows(crosswalks: tuple) -> np.ndarray:
    """(W, 6) read-only `crosswalk_row` of each crosswalk, remembered for the same tuple.

    The map's crosswalks (frozen, their centres never written) keep their rows.
    """
    if not crosswalks:
        return _NO_CROSSWALKS
    hit = _CROSSWALK_ROWS.get(id(crosswalks))
    if hit is not None and hit[0] is crosswalks:
        return hit[1]
    rows = np.array([crosswalk_row(cw) for cw in crosswalks]).reshape(-1, 6)
    rows.setflags(write=False)
    if len(_CROSSWALK_ROWS) >= 64:
        _CROSSWALK_ROWS.clear()
    _CROSSWALK_ROWS[id(crosswalks)] = (crosswalks, rows)
    return rows


def crosswalk_row(crosswalk) -> tuple:
    """(centre x, y [m], cos and sin of the walk heading, half length, half width [m]).

    What the compiled kernels (models/gap_kernels.occupancy_arguments) take of a crosswalk:
    the values sim/costs.crosswalk_occupancy computes with (its cached cos and sin).
    """
    c, s = _cos_sin(crosswalk.walk_heading_rad)
    return (crosswalk.center[0], crosswalk.center[1], c, s, 0.5 * crosswalk.length_m,
            0.5 * crosswalk.width_m)

"""Which signal heads each agent sees: range, view cone, the head's visor and occlusion.

An observer reads a head (sim/signals.SignalHead) when

* the head lies within its sensor range and view cone (the same as for objects, perception/
  fov.py),
* the observer stands in front of the head: within the head's view_half_angle_rad of the
  direction it faces (its visor: the cross street's heads cannot be read), and
* the segment from the observer to the head hits no other agent and no static polygon (one
  chipmunk ray query per remaining pair, `GeometryMirror.first_hits`, the observer's own shape
  filtered out).

The first three tests are numpy over every (observer, head) pair; only pairs passing them cost
a ray query.
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.geometry import GeometryMirror


def _wrap(angle):
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def visible_heads(mirror: GeometryMirror, heads, xy, heading, range_m, half_angle_rad,
                  active) -> np.ndarray:
    """(n, H) bool: visible[o, h] if observer o reads head h now (module docstring).

    Args:
        mirror: the world's geometry mirror, synced to the current poses.
        heads: the H SignalHeads of the map.
        xy: (n, 2) observer positions [m].
        heading: (n,) observer headings [rad].
        range_m: (n,) sensor ranges [m].
        half_angle_rad: (n,) half-angles of the view cones [rad].
        active: (n,) bool, inactive observers see nothing.
    """
    n = len(xy)
    if not heads or n == 0:
        return np.zeros((n, len(heads)), dtype=bool)
    pos = np.array([h.position for h in heads])  # (H, 2)
    facing = np.array([h.facing_rad for h in heads])
    visor = np.array([h.view_half_angle_rad for h in heads])
    rel = pos[None, :, :] - np.asarray(xy)[:, None, :]  # (n, H, 2) observer -> head
    dist = np.hypot(rel[..., 0], rel[..., 1])
    bearing = np.arctan2(rel[..., 1], rel[..., 0])
    in_cone = np.abs(_wrap(bearing - np.asarray(heading)[:, None])) <= np.asarray(
        half_angle_rad)[:, None]
    # seen from the head, the observer lies in the opposite direction of `bearing`
    in_front = np.abs(_wrap(bearing + np.pi - facing[None, :])) <= visor[None, :]
    candidate = (np.asarray(active)[:, None] & (dist <= np.asarray(range_m)[:, None])
                 & in_cone & in_front)
    obs, head = np.nonzero(candidate)
    if len(obs):
        labels, _ = mirror.first_hits(np.asarray(xy)[obs], pos[head], obs)
        candidate[obs, head] = labels < 0
    return candidate

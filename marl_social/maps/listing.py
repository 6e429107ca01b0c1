"""Where each paper situation can be built on a map, and why not: `marl-social scenes`.

`scene_listing(loaded)` tries every crosswalk (maps/scenes.py) and junction
(maps/junction_scenes.py) of a map with the default needs.
"""

from __future__ import annotations

from typing import NamedTuple

from marl_social.maps.junction_scenes import junction_plan
from marl_social.maps.scenes import SceneError, crosswalk_plan


class SceneEntry(NamedTuple):
    """One line of a map's scene listing: an element, a situation, and why not (or "")."""

    element: int
    situation: str
    reason: str


def scene_listing(loaded) -> list[SceneEntry]:
    """Every crosswalk, junction and signal of a map with whether its situation can be built.

    The reason is "" where it can (with the default needs), else why not.
    """
    _, elements = loaded
    entries = []
    for crosswalk_id in sorted(elements.crosswalks):
        try:
            crosswalk_plan(loaded, crosswalk_id)
            entries.append(SceneEntry(crosswalk_id, "crosswalk", ""))
        except SceneError as err:
            entries.append(SceneEntry(crosswalk_id, "crosswalk", str(err)))
    for junction_id in sorted(elements.junctions):
        try:
            junction_plan(loaded, junction_id)
            entries.append(SceneEntry(junction_id, "junction", ""))
        except SceneError as err:
            entries.append(SceneEntry(junction_id, "junction", str(err)))
    entries += [SceneEntry(s, "signal", "signal scenes are not built yet")
                for s in sorted(elements.signals)]
    return entries

"""Where each paper situation can be built on a map, and why not: `marl-social scenes`.

`scene_listing(loaded)` tries every crosswalk (maps/scenes.py), junction
(maps/junction_scenes.py) and traffic light (maps/signal_scenes.py) of a map with the default
needs.
"""

from __future__ import annotations

from typing import NamedTuple

from marl_social.maps.junction_scenes import junction_plan
from marl_social.maps.scenes import SceneError, crosswalk_plan
from marl_social.maps.signal_scenes import signal_plan_of


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
    for situation, ids, plan in (("crosswalk", elements.crosswalks, crosswalk_plan),
                                 ("junction", elements.junctions, junction_plan),
                                 ("signal", elements.signals, signal_plan_of)):
        for element_id in sorted(ids):
            try:
                plan(loaded, element_id)
                entries.append(SceneEntry(element_id, situation, ""))
            except SceneError as err:
                entries.append(SceneEntry(element_id, situation, str(err)))
    return entries

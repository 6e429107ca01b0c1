"""What a converted map keeps besides its RoadMap: the Lanelet2 ids of every element.

A scene is built around one element of a map (a crosswalk, a stop line, a signal, a
junction); these records name each element by its Lanelet2 id and point at the RoadMap entries
made from it, with the routing graph's neighbours needed to find a route through it. A lane is
keyed by `LaneKey` (the lanelet's id, and whether it is driven against the lanelet's own
direction: a two-way lanelet gives a lane each way).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np


class LaneKey(NamedTuple):
    """A lane's lanelet: its id and whether the lane runs against the lanelet's direction."""

    lanelet_id: int
    inverted: bool = False


@dataclass(frozen=True)
class MapSource:
    """Where a map came from and how it was projected.

    Attributes:
        path: the .osm file.
        origin: (lat, lon) [deg] of the UTM projection's origin (unused for local x/y maps).
        convention: "utm" (lat/lon projected about origin) or "local_xy" (the INTERACTION
            convention: every node carries local `x` / `y` tags [m], used as they are).
    """

    path: str
    origin: tuple[float, float]
    convention: str


@dataclass(frozen=True)
class LaneElement:
    """One lane and its place in the routing graph.

    Attributes:
        index: into RoadMap.lanes.
        key: its lanelet (LaneKey).
        subtype: the lanelet's subtype ("road", "highway").
        speed_limit_mps: the traffic rules' speed limit on it [m/s].
        successors, predecessors: the lanes a car may drive on next / came from (LaneKeys).
        left, right: the lanes beside it a car may change to (LaneKeys).
        adjacent_left, adjacent_right: the lanes beside it in the same direction a car may
            not change to (a solid or virtual line between; LaneKeys).
    """

    index: int
    key: LaneKey
    subtype: str
    speed_limit_mps: float
    successors: tuple[LaneKey, ...]
    predecessors: tuple[LaneKey, ...]
    left: tuple[LaneKey, ...] = ()
    right: tuple[LaneKey, ...] = ()
    adjacent_left: tuple[LaneKey, ...] = ()
    adjacent_right: tuple[LaneKey, ...] = ()

    def beside(self, side: int) -> tuple[LaneKey, ...]:
        """The lanes beside it in the same direction on one side (+1 left, -1 right)."""
        return self.left + self.adjacent_left if side > 0 else self.right + self.adjacent_right


@dataclass(frozen=True)
class CrosswalkElement:
    """A crosswalk lanelet.

    Attributes:
        lanelet_id: the crosswalk lanelet's id.
        index: into RoadMap.crosswalks.
        crossed_lanes: the lanes whose centre line crosses its walking path (LaneKeys).
    """

    lanelet_id: int
    index: int
    crossed_lanes: tuple[LaneKey, ...]


@dataclass(frozen=True)
class StopLineElement:
    """A stop line of the map (a `stop_line` line string).

    Attributes:
        line_id: the line string's id.
        rule: "signal", "stop_sign", "yield" (a give-way line: the conflict zones' priority
            holds the rule, no RoadMap stop line) or "" (no regulatory element uses it).
        indices: into RoadMap.stop_lines (one per signal or stop rule using the line).
        lanes: the lanes it stops (LaneKeys).
        regulatory_elements: ids of the regulatory elements that use it.
    """

    line_id: int
    rule: str
    indices: tuple[int, ...]
    lanes: tuple[LaneKey, ...]
    regulatory_elements: tuple[int, ...] = ()


@dataclass(frozen=True)
class SignalElement:
    """A traffic light regulatory element: one signal group.

    Attributes:
        regulatory_element_id: its id.
        group: the group's name in RoadMap.signal_plan.
        heads: indices into RoadMap.signal_heads (one per light the element refers to).
        stop_line: index into RoadMap.stop_lines of the line its heads control.
        lanes: the lanes it controls (LaneKeys).
    """

    regulatory_element_id: int
    group: str
    heads: tuple[int, ...]
    stop_line: int
    lanes: tuple[LaneKey, ...]


@dataclass(frozen=True)
class ConflictElement:
    """Two lanes that overlap (cross or merge), and who has the right of way.

    Attributes:
        lanes: the two lanes (LaneKeys).
        zone: index into RoadMap.conflict_zones.
        priority: the lanes with the right of way (LaneKeys; empty: neither).
        rule: what decides it: "right_of_way:ID", "right_of_way:ID (fallback)",
            "all_way_stop:ID", "signals", "left_turn_yields (default)",
            "right_before_left (default)" or "" (nothing in the map decides it).
    """

    lanes: tuple[LaneKey, LaneKey]
    zone: int
    priority: tuple[LaneKey, ...]
    rule: str


@dataclass(frozen=True)
class JunctionElement:
    """Lanes that overlap one another, transitively: one junction.

    Attributes:
        junction_id: the smallest lanelet id among its lanes.
        lanes: its lanes (LaneKeys).
        conflicts: its conflicts (keys of MapElements.conflicts).
        signals: ids of the traffic light elements whose rule reaches its lanes.
        stop_lines: ids of the stop lines whose lanes lead into it (or lie in it).
    """

    junction_id: int
    lanes: tuple[LaneKey, ...]
    conflicts: tuple[tuple[LaneKey, LaneKey], ...]
    signals: tuple[int, ...]
    stop_lines: tuple[int, ...]


@dataclass(frozen=True)
class MapElements:
    """Every element a converted map keeps, by Lanelet2 id (module docstring).

    Attributes:
        source: the file and its projection.
        lanes: per LaneKey, its LaneElement (RoadMap.lanes[element.index]).
        crosswalks: per crosswalk lanelet id.
        stop_lines: per stop line id.
        signals: per traffic light element id.
        conflicts: per pair of LaneKeys (sorted).
        junctions: per junction id.
        parking_areas: per parking area id, its outline (V, 2) [m] (kept for parked cars; not
            an obstacle itself).
        occluder_sources: per RoadMap.static_polygons entry, (kind, id) of the map element it
            comes from ("wall", "fence", "guard_rail", "building").
        not_mapped: one line per kind of thing the converter could not map.
    """

    source: MapSource
    lanes: dict[LaneKey, LaneElement]
    crosswalks: dict[int, CrosswalkElement]
    stop_lines: dict[int, StopLineElement]
    signals: dict[int, SignalElement]
    conflicts: dict[tuple[LaneKey, LaneKey], ConflictElement]
    junctions: dict[int, JunctionElement]
    parking_areas: dict[int, np.ndarray] = field(default_factory=dict)
    occluder_sources: tuple[tuple[str, int], ...] = ()
    not_mapped: tuple[str, ...] = ()

    def lane_index(self, key: LaneKey) -> int:
        """Index into RoadMap.lanes of a lane (KeyError if the map has no such lane)."""
        return self.lanes[key].index

"""Occluders from a Lanelet2 map: walls, fences, guard rails and buildings as convex obstacles.

The simulator's static polygons block sight and motion and must be strictly convex. A thin
line (wall, fence, guard rail) becomes one rectangle per segment, OCCLUDER_THICKNESS_M thick;
a building's outline is cut into few convex pieces (geometry.convex_pieces). Fences count as
opaque (a hedge-like garden fence; a see-through fence would be mapped as nothing at all).
Parking areas are not obstacles: they are kept as outlines for placing parked cars. Other
areas (vegetation of unknown height, walkways, traffic islands, ...) are listed as not mapped.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from marl_social.maps.geometry import convex_pieces, thin_polyline_pieces

OCCLUDER_THICKNESS_M = {"wall": 0.3, "fence": 0.1, "guard_rail": 0.2}  # per line type [m]
BUILDING_SUBTYPES = ("building",)
PARKING_SUBTYPES = ("parking",)


def _attr(element, key: str, default: str) -> str:
    """A lanelet2 element's attribute, or default (lanelet2's AttributeMap has no .get)."""
    return element.attributes[key] if key in element.attributes else default  # noqa: SIM401


def _xy(points) -> np.ndarray:
    return np.array([[p.x, p.y] for p in points], dtype=np.float64).reshape(-1, 2)


def map_occluders(lanelet_map):
    """The map's occluders and parking areas.

    Args:
        lanelet_map: lanelet2's LaneletMap.

    Returns:
        (polygons, sources, parking_areas, not_mapped): convex polygons (V, 2) [m]; per
        polygon (kind, element id); parking area id -> outline (V, 2) [m]; Counter of the
        area subtypes not mapped.
    """
    polygons, sources = [], []
    for line in sorted(lanelet_map.lineStringLayer, key=lambda ls: ls.id):
        kind = _attr(line, "type", "")
        if kind in OCCLUDER_THICKNESS_M:
            for piece in thin_polyline_pieces(_xy(line), OCCLUDER_THICKNESS_M[kind]):
                polygons.append(piece)
                sources.append((kind, int(line.id)))
    parking, skipped = {}, Counter()
    for area in sorted(lanelet_map.areaLayer, key=lambda a: a.id):
        subtype = _attr(area, "subtype", "(none)")
        outline = _xy(area.outerBoundPolygon())
        if subtype in BUILDING_SUBTYPES:
            for piece in convex_pieces(outline):
                polygons.append(piece)
                sources.append((subtype, int(area.id)))
        elif subtype in PARKING_SUBTYPES:
            parking[int(area.id)] = outline
        else:
            skipped[subtype] += 1
    return polygons, sources, parking, skipped

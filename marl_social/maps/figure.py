"""A figure of a converted map as the simulator sees it: the whole map and one junction.

Lanes (grey), conflict zones (orange outlines), crosswalks (zebra stripes), stop lines
(white), signal heads (dark squares), occluders (brown) and parking areas (hatched).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from marl_social.maps.elements import MapElements
from marl_social.sim.road_map import RoadMap
from marl_social.viz.road import crosswalk_stripes, signal_head_squares
from marl_social.viz.style import (
    BACKGROUND_COLOR,
    HOUSE_COLOR,
    HOUSE_EDGE_COLOR,
    MARKING_COLOR,
    ROAD_COLOR,
    SIGNAL_HEAD_EDGE_COLOR,
    SIGNAL_HEAD_OFF_COLOR,
)

ZONE_COLOR = "#e07b00"
PARKING_COLOR = "#9aa3ad"
DETAIL_HALF_SIZE_M = 45.0  # half the side of the detail panel's square [m]
FIGURE_DPI = 150


def _draw(ax, road_map: RoadMap, elements: MapElements, detail: bool) -> None:
    """Everything static of the map on one Axes (metres); finer lines in the detail panel."""
    from matplotlib.collections import LineCollection, PolyCollection

    scale = 1.0 if detail else 0.3
    ax.set_facecolor(BACKGROUND_COLOR)
    ax.add_collection(PolyCollection([lane.polygon() for lane in road_map.lanes],
                                      facecolors=ROAD_COLOR, edgecolors=ROAD_COLOR,
                                      linewidths=0.3 * scale, zorder=1))
    ax.add_collection(PolyCollection(list(elements.parking_areas.values()), facecolors="none",
                                     edgecolors=PARKING_COLOR, hatch="///",
                                     linewidths=0.6 * scale, zorder=1.5))
    if detail:
        ax.add_collection(PolyCollection([z.polygon for z in road_map.conflict_zones],
                                         facecolors="none", edgecolors=ZONE_COLOR,
                                         linewidths=0.6, zorder=2))
    stripes = [s for cw in road_map.crosswalks for s in crosswalk_stripes(cw)]
    ax.add_collection(PolyCollection(stripes, facecolors=MARKING_COLOR, edgecolors="none",
                                     zorder=3))
    if not detail:  # a crosswalk is a few pixels at full extent: ring it
        centers = np.array([cw.center for cw in road_map.crosswalks]).reshape(-1, 2)
        ax.scatter(centers[:, 0], centers[:, 1], s=40, facecolors="none",
                   edgecolors=MARKING_COLOR, linewidths=1.0, zorder=3.5)
    ax.add_collection(LineCollection([line.segment for line in road_map.stop_lines],
                                     colors=MARKING_COLOR, linewidths=2.0 * scale, zorder=3))
    if road_map.signal_heads:
        ax.add_collection(PolyCollection(signal_head_squares(road_map),
                                         facecolors=SIGNAL_HEAD_OFF_COLOR,
                                         edgecolors=SIGNAL_HEAD_EDGE_COLOR, zorder=4))
    ax.add_collection(PolyCollection(list(road_map.static_polygons), facecolors=HOUSE_COLOR,
                                     edgecolors=HOUSE_EDGE_COLOR, linewidths=0.5 * scale,
                                     zorder=4))
    ax.set_aspect("equal")


def _detail_center(road_map: RoadMap, elements: MapElements) -> np.ndarray:
    """(2,) [m]: the junction with the most signals (then lanes), else the map's centre."""
    if not elements.junctions:
        x0, x1, y0, y1 = road_map.extent
        return np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)])
    junction = max(elements.junctions.values(), key=lambda j: (len(j.signals), len(j.lanes)))
    zones = [road_map.conflict_zones[elements.conflicts[p].zone].polygon
             for p in junction.conflicts]
    return np.concatenate(zones).mean(axis=0)


def plot_map(road_map: RoadMap, elements: MapElements, path, title: str = "") -> Path:
    """Save the figure (module docstring) to `path` (PNG, or any format matplotlib writes).

    Args:
        road_map: the converted map.
        elements: its elements (parking areas, junctions).
        path: the output file.
        title: the figure's title.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x0, x1, y0, y1 = road_map.extent
    fig, (full, zoom) = plt.subplots(1, 2, figsize=(15, 5.2),
                                     gridspec_kw={"width_ratios": [2.4, 1]})
    _draw(full, road_map, elements, detail=False)
    full.set_xlim(x0, x1)
    full.set_ylim(y0, y1)
    center = _detail_center(road_map, elements)
    _draw(zoom, road_map, elements, detail=True)
    zoom.set_xlim(center[0] - DETAIL_HALF_SIZE_M, center[0] + DETAIL_HALF_SIZE_M)
    zoom.set_ylim(center[1] - DETAIL_HALF_SIZE_M, center[1] + DETAIL_HALF_SIZE_M)
    full.add_patch(plt.Rectangle(center - DETAIL_HALF_SIZE_M, 2 * DETAIL_HALF_SIZE_M,
                                 2 * DETAIL_HALF_SIZE_M, fill=False, edgecolor="black",
                                 linewidth=0.8, zorder=5))
    full.set_title("the whole map [m]", fontsize=10)
    zoom.set_title("the junction in the box: conflict zones, signals, stop lines [m]",
                   fontsize=10)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=FIGURE_DPI)
    plt.close(fig)
    return path

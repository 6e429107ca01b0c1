"""A small Lanelet2 map in INTERACTION's convention (local x/y tags), written by the tests."""

from __future__ import annotations

import numpy as np

M_PER_DEG = 111_000.0  # lat/lon beside the local x/y, as INTERACTION's files carry both


def _node(node_id: int, x: float, y: float, local_xy: bool) -> str:
    tags = f'<tag k="x" v="{x}"/><tag k="y" v="{y}"/>' if local_xy else ""
    return (f'<node id="{node_id}" visible="true" version="1" lat="{y / M_PER_DEG:.10f}" '
            f'lon="{x / M_PER_DEG:.10f}">{tags}</node>')


def _way(way_id: int, nodes, kind: str) -> str:
    refs = "".join(f'<nd ref="{n}"/>' for n in nodes)
    return f'<way id="{way_id}" visible="true" version="1">{refs}<tag k="type" v="{kind}"/></way>'


def _lanelet(rel_id: int, left: int, right: int, subtype: str, extra: str = "",
             one_way: str = "yes") -> str:
    return (f'<relation id="{rel_id}" visible="true" version="1">'
            f'<member type="way" role="left" ref="{left}"/>'
            f'<member type="way" role="right" ref="{right}"/>{extra}'
            '<tag k="type" v="lanelet"/><tag k="subtype" v="' + subtype + '"/>'
            f'<tag k="location" v="urban"/><tag k="one_way" v="{one_way}"/></relation>')


def synthetic_osm(local_xy: bool = True) -> str:
    """Lane 100 east along y = 0 (x 0..50), lane 101 north along x = 25 (y -25..25), both
    3.5 m wide; crosswalk 102 across lane 100 at x = 10; an unknown regulatory element 200
    ("mystery_rule") on lane 100; a wall along y = 5 from x 30 to 40."""
    points = {
        1: (0, 1.75), 2: (50, 1.75), 3: (0, -1.75), 4: (50, -1.75),  # lane 100: left, right
        5: (23.25, -25), 6: (23.25, 25), 7: (26.75, -25), 8: (26.75, 25),  # lane 101
        9: (9, -4), 10: (9, 4), 11: (11, -4), 12: (11, 4),  # crosswalk 102 (walks north)
        13: (30, 5), 14: (40, 5),  # wall
        15: (5, -3), 16: (5, -3.5),  # a traffic sign the unknown rule refers to
    }
    nodes = "".join(_node(i, x, y, local_xy) for i, (x, y) in points.items())
    ways = "".join([
        _way(21, (1, 2), "line_thin"), _way(22, (3, 4), "road_border"),
        _way(23, (5, 6), "line_thin"), _way(24, (7, 8), "road_border"),
        _way(25, (9, 10), "pedestrian_marking"), _way(26, (11, 12), "pedestrian_marking"),
        _way(27, (13, 14), "wall"), _way(28, (15, 16), "traffic_sign"),
    ])
    rule = ('<relation id="200" visible="true" version="1">'
            '<member type="way" role="refers" ref="28"/>'
            '<tag k="type" v="regulatory_element"/><tag k="subtype" v="mystery_rule"/>'
            '</relation>')
    relations = "".join([
        _lanelet(100, 21, 22, "road",
                 '<member type="relation" role="regulatory_element" ref="200"/>'),
        _lanelet(101, 23, 24, "road"), _lanelet(102, 25, 26, "crosswalk"), rule,
    ])
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<osm version="0.6" generator="tests">'
            f"{nodes}{ways}{relations}</osm>\n")


TURN_CENTRE = (8.25, 5.0)  # the left turn's centre line: a quarter circle about it [m]
TURN_RADIUS_M = 10.0


def junction_osm() -> str:
    """Two-way street 300 east along y = 0 (x 0..50, 6 m wide, no lane marking) and, apart
    from it, a junction: lane 310 north along x = 101.75 (y -20..20, 3.5 m wide, after lane
    309 from y = -45) and lane 311,
    3.5 m wide, a left turn across it (south along x = 98.25 from y = 5, a quarter circle of
    10 m radius to east along y = -5)."""
    points = {1: (0, 3), 2: (50, 3), 3: (0, -3), 4: (50, -3),  # street 300: left, right
              5: (100, -20), 6: (100, 20), 7: (103.5, -20), 8: (103.5, 20),  # lane 310
              9: (100, -45), 10: (103.5, -45)}  # lane 309, leading into 310
    ways = [_way(21, (1, 2), "road_border"), _way(22, (3, 4), "road_border"),
            _way(23, (5, 6), "line_thin"), _way(24, (7, 8), "road_border"),
            _way(27, (9, 5), "line_thin"), _way(28, (10, 7), "road_border")]
    for way_id, radius, first in ((25, TURN_RADIUS_M - 1.75, 30), (26, TURN_RADIUS_M + 1.75, 50)):
        ids = []
        for k, angle in enumerate(np.linspace(np.pi, 1.5 * np.pi, 10)):
            points[first + k] = (100 + TURN_CENTRE[0] + radius * np.cos(angle),
                                 TURN_CENTRE[1] + radius * np.sin(angle))
            ids.append(first + k)
        ways.append(_way(way_id, ids, "line_thin"))
    nodes = "".join(_node(i, round(float(x), 6), round(float(y), 6), True)
                    for i, (x, y) in points.items())
    relations = "".join([_lanelet(300, 21, 22, "road", one_way="no"),
                         _lanelet(309, 27, 28, "road"), _lanelet(310, 23, 24, "road"),
                         _lanelet(311, 25, 26, "road")])
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<osm version="0.6" generator="tests">'
            f"{nodes}{''.join(ways)}{relations}</osm>\n")

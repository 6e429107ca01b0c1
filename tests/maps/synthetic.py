"""A small Lanelet2 map in INTERACTION's convention (local x/y tags), written by the tests."""

from __future__ import annotations

M_PER_DEG = 111_000.0  # lat/lon beside the local x/y, as INTERACTION's files carry both


def _node(node_id: int, x: float, y: float, local_xy: bool) -> str:
    tags = f'<tag k="x" v="{x}"/><tag k="y" v="{y}"/>' if local_xy else ""
    return (f'<node id="{node_id}" visible="true" version="1" lat="{y / M_PER_DEG:.10f}" '
            f'lon="{x / M_PER_DEG:.10f}">{tags}</node>')


def _way(way_id: int, nodes, kind: str) -> str:
    refs = "".join(f'<nd ref="{n}"/>' for n in nodes)
    return f'<way id="{way_id}" visible="true" version="1">{refs}<tag k="type" v="{kind}"/></way>'


def _lanelet(rel_id: int, left: int, right: int, subtype: str, extra: str = "") -> str:
    return (f'<relation id="{rel_id}" visible="true" version="1">'
            f'<member type="way" role="left" ref="{left}"/>'
            f'<member type="way" role="right" ref="{right}"/>{extra}'
            '<tag k="type" v="lanelet"/><tag k="subtype" v="' + subtype + '"/>'
            '<tag k="location" v="urban"/><tag k="one_way" v="yes"/></relation>')


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

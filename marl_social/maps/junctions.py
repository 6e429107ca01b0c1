"""A map's junctions: the connected components of its conflict graph (maps/convert.py)."""

from __future__ import annotations

from collections import defaultdict

from marl_social.maps.elements import JunctionElement


def junction_elements(conflicts, signal_reach: dict, line_reach: dict) -> dict:
    """{junction id: JunctionElement}, one per connected component of the conflicts.

    A junction's id is its lowest lanelet id; its signals and stop lines are those whose
    rules reach one of its lanes.

    Args:
        conflicts: the conflicting lane pairs (a, b) (LaneKeys), in the map's order.
        signal_reach: {signal element id: the lanes its rule holds on}.
        line_reach: {stop line element id: the lanes its rule holds on}.
    """
    parent: dict = {}

    def find(k):
        while parent.setdefault(k, k) != k:
            k = parent[k]
        return k

    for a, b in conflicts:
        parent[find(a)] = find(b)
    members = defaultdict(list)
    for k in list(parent):
        members[find(k)].append(k)
    out = {}
    for lanes in members.values():
        lanes = sorted(lanes)
        inside = set(lanes)
        junction_id = min(k.lanelet_id for k in lanes)
        out[junction_id] = JunctionElement(
            junction_id, tuple(lanes), tuple(p for p in conflicts if p[0] in inside),
            tuple(sorted(i for i, r in signal_reach.items() if r & inside)),
            tuple(sorted(i for i, r in line_reach.items() if r & inside)))
    return out

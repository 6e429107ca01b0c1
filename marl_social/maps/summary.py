"""A converted map in a few lines of text: what it holds and what could not be mapped."""

from __future__ import annotations

from collections import Counter

from marl_social.maps.registry import LoadedMap


def describe(name: str, loaded: LoadedMap) -> str:
    """The summary `marl-social maps show` prints.

    Args:
        name: the map's name or file.
        loaded: the converted map.
    """
    road_map, el = loaded
    rules = Counter(c.rule.split(":")[0] if c.rule else "none" for c in el.conflicts.values())
    occluders = Counter(kind for kind, _ in el.occluder_sources)
    line_rules = Counter(s.rule or "none" for s in el.stop_lines.values())
    x0, x1, y0, y1 = road_map.extent
    src = el.source
    projection = ("local x/y tags (INTERACTION)" if src.convention == "local_xy"
                  else f"UTM about lat {src.origin[0]:g}, lon {src.origin[1]:g}")
    lines = [
        f"map {name}: {src.path}",
        (f"  projection:      {projection}; extent x {x0:.0f}..{x1:.0f} m, "
         f"y {y0:.0f}..{y1:.0f} m"),
        (f"  lanes:           {len(road_map.lanes)} (from "
         f"{len({k.lanelet_id for k in el.lanes})} lanelets; speed limits "
         f"{sorted({round(e.speed_limit_mps * 3.6) for e in el.lanes.values()})} km/h)"),
        f"  crosswalks:      {len(road_map.crosswalks)}",
        f"  stop lines:      {len(road_map.stop_lines)} in the road map; map's stop lines by "
        "rule: " + ", ".join(f"{k} {v}" for k, v in sorted(line_rules.items())),
        f"  signals:         {len(el.signals)} groups, {len(road_map.signal_heads)} heads, "
        f"cycle {road_map.signal_plan.cycle_s:g} s" if road_map.signal_plan else
        "  signals:         none",
        f"  conflict zones:  {len(road_map.conflict_zones)} in {len(el.junctions)} junctions; "
        "decided by: " + ", ".join(f"{k} {v}" for k, v in sorted(rules.items())),
        f"  occluders:       {len(road_map.static_polygons)} convex polygons ("
        + ", ".join(f"{k} {v}" for k, v in sorted(occluders.items())) + ")",
        f"  parking areas:   {len(el.parking_areas)}",
        f"  not mapped:      {len(el.not_mapped)} kinds",
    ]
    lines += [f"    - {line}" for line in el.not_mapped]
    return "\n".join(lines)

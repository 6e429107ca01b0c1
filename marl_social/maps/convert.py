"""A Lanelet2 map as the simulator's RoadMap, with the MapElements that name its pieces.

What becomes what (lanelet2's German traffic rules for a vehicle decide who may drive where):

- a lanelet a car may use: a Lane (its centre line, the mean distance between its bounds as
  width); a two-way lanelet (one without lane markings, driven both ways) gives one lane each
  way, the right half in its direction (keep right: the middle between the centre line and
  the right bound, half the width); its speed limit from the traffic rules;
- a crosswalk lanelet: a Crosswalk, the rectangle along its centre line that holds it;
- a traffic light element: a signal group, a "signal" StopLine at its stop line (the part of
  the line across the lanes it controls; the lanelet's end where it names none) and one
  SignalHead per light, facing the traffic it controls; the cycle is signal_plan's default;
- a right of way element: the priority of the conflict zones between its right-of-way and
  its yield lanes (and the lanes that start within RULE_REACH_M after them: the junction's
  lanes after short approach lanelets); its
  stop line a "stop_sign" StopLine when it refers to a stop sign (STOP_SIGN_SUBTYPES), else a
  give-way line that only the zones carry;
- two lanes that overlap (the routing graph's conflicting lanelets; lanes leaving the same
  lane, and the two halves of a two-way lanelet, are not in conflict): a ConflictZone, the
  convex hull of their overlap; its priority lanes are the lanes with the right of way (only
  those: the lanes leading to them are not added, see docs/maps.md);
- walls, fences, guard rails, buildings: static polygons (occluders.py); parking areas kept.

Anything else, and anything that fails on the way, is listed in MapElements.not_mapped and in
one warning (MapConversionWarning): the converter never guesses silently.
"""

from __future__ import annotations

import math
import warnings
from collections import Counter, defaultdict

import numpy as np

from marl_social.maps.default_rules import (
    LEFT_TURN_YIELDS,
    RIGHT_BEFORE_LEFT,
    from_the_right_priority,
    left_turn_priority,
)
from marl_social.maps.elements import (
    ConflictElement,
    CrosswalkElement,
    JunctionElement,
    LaneElement,
    LaneKey,
    MapElements,
    MapSource,
    SignalElement,
    StopLineElement,
)
from marl_social.maps.geometry import (
    aligned_rectangle,
    clean_polyline,
    extended_polyline,
    heading_near,
    mean_width,
    overlap_hull,
    polyline_crossings,
    polylines_cross,
    right_half_line,
)
from marl_social.maps.junctions import junction_elements
from marl_social.maps.occluders import map_occluders
from marl_social.maps.signal_plan import conflicting_groups, default_signal_plan
from marl_social.sim.road_map import ConflictZone, Crosswalk, Lane, RoadMap, Route, StopLine
from marl_social.sim.signals import SignalHead

RULE_REACH_M = 30.0  # a rule on a lane also holds on the lanes starting this close after it [m]
STOP_SIGN_SUBTYPES = ("de206", "usR1-1", "stop_sign", "stop")  # traffic sign subtypes: stop
EXTENT_MARGIN_M = 5.0  # the drawn extent around everything mapped [m]
STOP_LINE_REACH_M = 0.5  # a lane's centre line is tested against a stop line this far past its ends [m]
MIN_LANE_WIDTH_M = 1.0  # a lane narrower than this (a degenerate lanelet) is not mapped [m]
LISTED_IDS = 6  # ids listed per line of the summary before "..."


class MapConversionWarning(UserWarning):
    """The one-warning summary of what a map conversion could not map."""

def _xy(points) -> np.ndarray:
    """(P, 2) x, y [m] of lanelet2 points (a line string, a polygon)."""
    return np.array([[p.x, p.y] for p in points], dtype=np.float64).reshape(-1, 2)


def _attr(element, key: str, default: str = "") -> str:
    """A lanelet2 element's attribute, or default (lanelet2's AttributeMap has no .get)."""
    return element.attributes[key] if key in element.attributes else default  # noqa: SIM401


def _key(lanelet) -> LaneKey:
    return LaneKey(int(lanelet.id), bool(lanelet.inverted()))


def _ids(items) -> str:
    items = sorted(items)
    head = ", ".join(str(i) for i in items[:LISTED_IDS])
    return head + (", ..." if len(items) > LISTED_IDS else "")


class _Converter:
    """One conversion's state: the lanelet2 map, its rules and graph, what is built so far."""

    def __init__(self, lanelet_map, source: MapSource, problems):
        import lanelet2

        rules_mod = lanelet2.traffic_rules
        self.map = lanelet_map
        self.source = source
        self.rules = rules_mod.create(rules_mod.Locations.Germany,
                                      rules_mod.Participants.Vehicle)
        self.graph = lanelet2.routing.RoutingGraph(lanelet_map, self.rules)
        self.not_mapped = []
        problems = [p.strip() for p in problems if not p.strip().lower().startswith("errors")]
        if problems:  # e.g. a regulatory element of a type lanelet2 knows no rule for
            listed = "; ".join(p.lstrip("- ") for p in problems[:LISTED_IDS])
            self.not_mapped.append(f"lanelet2 could not read {len(problems)} elements: {listed}"
                                   + ("; ..." if len(problems) > LISTED_IDS else ""))
        self.lanes: list[Lane] = []
        self.lane_views: dict[LaneKey, object] = {}
        self.lane_polygons: dict[LaneKey, np.ndarray] = {}
        self.lane_bounds: dict[LaneKey, tuple[np.ndarray, np.ndarray]] = {}  # (left, right)
        self.lane_elements: dict[LaneKey, LaneElement] = {}
        self.lane_lengths_m: dict[LaneKey, float] = {}
        self.stop_lines: list[StopLine] = []
        self.heads: list[SignalHead] = []
        self.signals: dict[int, SignalElement] = {}
        self.stop_line_elements: dict[int, StopLineElement] = {}
        self.roles: list[tuple[object, dict[LaneKey, str]]] = []  # right of way elements
        self.signal_groups: dict[LaneKey, set[str]] = defaultdict(set)
        self.used_lines: set[int] = set()
        self.crosswalk_elements: dict[int, CrosswalkElement] = {}
        self.walk_paths: dict[int, np.ndarray] = {}  # crosswalk lanelet id -> centre line

    # lanes and crosswalks -----------------------------------------------------------------

    def map_lanelets(self) -> list[Crosswalk]:
        """Lanes (self.lanes) and crosswalks (returned, with their elements in self)."""
        crosswalks = []
        skipped = Counter()
        for lanelet in sorted(self.map.laneletLayer, key=lambda ll: ll.id):
            subtype = _attr(lanelet, "subtype", "(none)")
            if subtype == "crosswalk":
                crosswalks.append(self._crosswalk(lanelet, len(crosswalks)))
            elif self.rules.canPass(lanelet):
                if self.rules.isOneWay(lanelet):
                    self._add_lane(lanelet, subtype, two_way=False)
                else:
                    for view in (lanelet, lanelet.invert()):
                        self._add_lane(view, subtype, two_way=True)
            else:
                skipped[subtype] += 1
        if skipped:
            self.not_mapped.append(f"{sum(skipped.values())} lanelets no car may use: "
                                   + ", ".join(f"{k} {v}" for k, v in sorted(skipped.items())))
        self._link_lanes()
        for element in list(self.crosswalk_elements.values()):
            walk = self.walk_paths[element.lanelet_id]
            crossed = tuple(k for k in self.lane_views
                            if polylines_cross(self.lanes[self.lane_elements[k].index]
                                               .centerline, walk))
            self.crosswalk_elements[element.lanelet_id] = CrosswalkElement(
                element.lanelet_id, element.index, crossed)
        return crosswalks

    def _crosswalk(self, lanelet, index: int) -> Crosswalk:
        walk = clean_polyline(_xy(lanelet.centerline))
        outline = np.concatenate([_xy(lanelet.leftBound), _xy(lanelet.rightBound)])
        heading = math.atan2(*(walk[-1] - walk[0])[::-1])
        center, length, width = aligned_rectangle(outline, heading)
        self.walk_paths[int(lanelet.id)] = walk
        self.crosswalk_elements[int(lanelet.id)] = CrosswalkElement(int(lanelet.id), index, ())
        return Crosswalk(center, heading, length, width)

    def _add_lane(self, view, subtype: str, two_way: bool) -> None:
        """The lane of a lanelet view; of a two-way lanelet, the view's right half."""
        key = _key(view)
        centerline = clean_polyline(_xy(view.centerline))
        left, right = _xy(view.leftBound), _xy(view.rightBound)
        width = mean_width(left, right) if len(left) and len(right) else 0.0
        if len(centerline) < 2 or width < MIN_LANE_WIDTH_M:
            self.not_mapped.append(f"lanelet {key.lanelet_id}: degenerate (centre line of "
                                   f"{len(centerline)} points, width {width:.2f} m)")
            return
        if two_way:  # keep right: the half between the centre line and the right bound
            left, centerline, width = centerline, right_half_line(centerline, right), 0.5 * width
        name = f"lanelet_{key.lanelet_id}" + ("_inverted" if key.inverted else "")
        self.lane_views[key] = view
        self.lane_bounds[key] = (left, right)
        self.lane_polygons[key] = np.concatenate([left, right[::-1]])
        limit = float(self.rules.speedLimit(view).speedLimitMPS)
        self.lane_elements[key] = LaneElement(len(self.lanes), key, subtype, limit, (), ())
        self.lanes.append(Lane(centerline, width, name))
        self.lane_lengths_m[key] = float(np.linalg.norm(np.diff(centerline, axis=0),
                                                        axis=1).sum())

    def _link_lanes(self) -> None:
        """The routing graph's successors, predecessors and neighbours (lane change or not) of each lane."""
        dead_ends = []
        for key, view in self.lane_views.items():
            def known(lanelets):
                return tuple(k for k in (_key(ll) for ll in lanelets) if k in self.lane_views)

            def one(lanelet):
                return known([lanelet] if lanelet else [])

            element = self.lane_elements[key]
            successors = known(self.graph.following(view))
            self.lane_elements[key] = LaneElement(
                element.index, key, element.subtype, element.speed_limit_mps, successors,
                known(self.graph.previous(view)), one(self.graph.left(view)),
                one(self.graph.right(view)), one(self.graph.adjacentLeft(view)),
                one(self.graph.adjacentRight(view)))
            if not successors:
                dead_ends.append(key.lanelet_id)
        if dead_ends:
            self.not_mapped.append(f"{len(dead_ends)} lanes without a routable successor (the "
                                   f"map's edge, or a gap in it): lanelets {_ids(dead_ends)}")

    def reach(self, key: LaneKey, reach_m: float = RULE_REACH_M) -> set[LaneKey]:
        """The lane and the lanes that start less than reach_m [m] after its end."""
        found, frontier = {key}, [(key, 0.0)]
        while frontier:
            lane, start_m = frontier.pop()
            for succ in self.lane_elements[lane].successors:
                if succ not in found:
                    found.add(succ)
                    end_m = start_m + self.lane_lengths_m[succ]
                    if end_m < reach_m:
                        frontier.append((succ, end_m))
        return found

    # regulatory elements -------------------------------------------------------------------

    def map_regulatory_elements(self) -> None:
        """Signals, right of way and stop lines from the regulatory elements."""
        users = defaultdict(list)  # element id -> the lanes referencing it
        for key, view in self.lane_views.items():
            if not key.inverted:
                for element in view.regulatoryElements:
                    users[int(element.id)].append(key)
        unused, unknown = [], []
        for element in sorted(self.map.regulatoryElementLayer, key=lambda r: r.id):
            subtype = _attr(element, "subtype", "(none)")
            self.used_lines |= {int(p.id) for params in element.parameters.values()
                                for p in params if hasattr(p, "id")}
            lanes = users.get(int(element.id), [])
            if subtype == "traffic_light" and lanes:
                self._traffic_light(element, lanes)
            elif subtype == "right_of_way" and (element.rightOfWayLanelets()
                                                or element.yieldLanelets()):
                self._right_of_way(element)
            elif subtype in ("speed_limit", "traffic_sign") and lanes:
                pass  # the traffic rules read them (each lane's speed limit)
            elif subtype in ("traffic_light", "speed_limit", "traffic_sign", "right_of_way"):
                unused.append(f"{element.id} ({subtype})")
            else:
                unknown.append(f"{element.id} ({subtype})")
        if unused:
            self.not_mapped.append(f"{len(unused)} regulatory elements no lane uses: "
                                   + ", ".join(unused))
        if unknown:
            self.not_mapped.append(f"{len(unknown)} regulatory elements of a kind the "
                                   f"simulator has no rule for: {', '.join(unknown)}")

    def _stop_segment(self, line: np.ndarray | None, lanes: list[LaneKey]) -> np.ndarray:
        """(2, 2) the part [m] of a stop line across `lanes` (their ends where line is None)."""
        if line is None:  # Lanelet2: no stop line, stop at the lanelet's end
            ends = [bound[-1] for k in lanes for bound in self.lane_bounds[k]]
            line = np.array([ends[0], ends[-1]])
        chord = np.array([line[0], line[-1]])
        direction = chord[1] - chord[0]
        length = float(np.hypot(*direction))
        direction = direction / length
        spans = []
        for key in lanes:
            centerline = self.lanes[self.lane_elements[key].index].centerline
            # a lane ending exactly on its stop line crosses it (its successor would)
            s = polyline_crossings(line, extended_polyline(centerline, STOP_LINE_REACH_M))
            if len(s):
                hit = Route(line).point_at(s[0])[0]
                u = float((hit - chord[0]) @ direction)
                half = 0.5 * self.lanes[self.lane_elements[key].index].width_m
                spans += [u - half, u + half]
        if not spans:
            return chord
        lo, hi = max(min(spans), 0.0), min(max(spans), length)
        return np.array([chord[0] + lo * direction, chord[0] + hi * direction])

    def _traffic_light(self, element, lanes: list[LaneKey]) -> None:
        line = element.stopLine
        line_xy = _xy(line) if line is not None else None
        segment = self._stop_segment(line_xy, lanes)
        lane_index = self.lane_elements[lanes[0]].index
        stop_index = len(self.stop_lines)
        self.stop_lines.append(StopLine(segment, "signal", lane_index))
        group = f"light_{element.id}"
        heading = heading_near(self.lanes[lane_index].centerline, segment.mean(axis=0))
        head_indices = []
        for light in element.trafficLights:
            head_indices.append(len(self.heads))
            self.heads.append(SignalHead(_xy(light).mean(axis=0), float(heading) + math.pi,
                                         group, stop_index, name=f"light_{light.id}"))
        self.signals[int(element.id)] = SignalElement(int(element.id), group, tuple(head_indices),
                                                      stop_index, tuple(lanes))
        for key in lanes:
            for reached in self.reach(key):
                self.signal_groups[reached].add(group)
        if line is not None:
            self._note_stop_line(int(line.id), "signal", stop_index, lanes, int(element.id))

    def _right_of_way(self, element) -> None:
        roles: dict[LaneKey, str] = {}
        for lanelets, role in ((element.rightOfWayLanelets(), "priority"),
                               (element.yieldLanelets(), "yield")):
            for lanelet in lanelets:
                key = _key(lanelet)
                if key in self.lane_views:
                    for reached in self.reach(key):
                        roles.setdefault(reached, role)
        self.roles.append((element, roles))
        line = element.stopLine
        if line is None:
            return
        yielding = [_key(ll) for ll in element.yieldLanelets() if _key(ll) in self.lane_views]
        signs = {_attr(s, "subtype") for s in element.parameters["refers"]} \
            if "refers" in element.parameters else set()
        if yielding and signs & set(STOP_SIGN_SUBTYPES) and _attr(element, "fallback") != "yes":
            index = len(self.stop_lines)
            segment = self._stop_segment(_xy(line), yielding)
            self.stop_lines.append(StopLine(segment, "stop_sign",
                                            self.lane_elements[yielding[0]].index))
            self._note_stop_line(int(line.id), "stop_sign", index, yielding, int(element.id))
        else:
            self._note_stop_line(int(line.id), "yield", None, yielding, int(element.id))

    def _note_stop_line(self, line_id: int, rule: str, index, lanes, element_id: int) -> None:
        old = self.stop_line_elements.get(line_id)
        indices = (old.indices if old else ()) + ((index,) if index is not None else ())
        merged_lanes = tuple(dict.fromkeys((old.lanes if old else ()) + tuple(lanes)))
        elements = (old.regulatory_elements if old else ()) + (element_id,)
        if old and old.rule in ("signal", "stop_sign") and rule == "yield":
            rule = old.rule  # a line both a light's and a fallback give-way: the light's
        self.stop_line_elements[line_id] = StopLineElement(line_id, rule, indices, merged_lanes,
                                                           elements)

    def unused_stop_lines(self) -> None:
        """Stop lines no regulatory element uses: kept with rule "", listed as not mapped."""
        across = 0
        unused = []
        for line in sorted(self.map.lineStringLayer, key=lambda ls: ls.id):
            if _attr(line, "type") != "stop_line" or int(line.id) in self.stop_line_elements:
                continue
            xy = _xy(line)
            lanes = tuple(k for k in self.lane_views
                          if polylines_cross(self.lanes[self.lane_elements[k].index].centerline,
                                             xy))
            across += bool(lanes)
            unused.append(int(line.id))
            self.stop_line_elements[int(line.id)] = StopLineElement(int(line.id), "", (), lanes)
        if unused:
            self.not_mapped.append(f"{len(unused)} stop lines no regulatory element uses ("
                                   f"{across} across lanes, the others off every lane): no "
                                   f"rule to stop by, kept in elements.stop_lines with rule ''")
        signs = [int(ls.id) for ls in self.map.lineStringLayer
                 if _attr(ls, "type") == "traffic_sign" and int(ls.id) not in self.used_lines]
        if signs:
            self.not_mapped.append(f"{len(signs)} traffic signs no regulatory element uses: "
                                   f"{_ids(signs)}")

    # conflicts, junctions, signal plan -------------------------------------------------------

    def map_conflicts(self) -> tuple[list[ConflictZone], dict]:
        """Conflict zones of overlapping lanes, with their priority (module docstring)."""
        pairs = set()
        for key, view in self.lane_views.items():
            for other in self.graph.conflicting(view):
                other_key = _key(other)
                if other_key in self.lane_views and other_key.lanelet_id != key.lanelet_id:
                    pairs.add(tuple(sorted((key, other_key))))
        zones, conflicts = [], {}
        thin, undecided = [], 0
        for a, b in sorted(pairs):
            if set(self.lane_elements[a].predecessors) & set(self.lane_elements[b].predecessors):
                continue  # two lanes leaving the same lane: one follows the other, no conflict
            hull = overlap_hull(self.lane_polygons[a], self.lane_polygons[b])
            if hull is None:
                thin.append(a.lanelet_id)
                continue
            priority, rule = self._priority(a, b)
            if rule == "":
                priority, rule = self._left_turn_yields(a, b)
            if rule == "":
                priority, rule = self._from_the_right(a, b, hull.mean(axis=0))
            undecided += rule == ""
            indices = tuple(self.lane_elements[k].index for k in priority)
            zone_name = f"conflict_{a.lanelet_id}_{b.lanelet_id}"
            conflicts[(a, b)] = ConflictElement((a, b), len(zones), priority, rule)
            zones.append(ConflictZone(hull, zone_name, indices))
        if thin:
            self.not_mapped.append(f"{len(thin)} conflicting lanelets whose lanes overlap too "
                                   "little for a conflict zone (e.g. a two-way lanelet's other "
                                   "half)")
        left_turns = sum(c.rule == LEFT_TURN_YIELDS for c in conflicts.values())
        if left_turns:
            self.not_mapped.append(f"{left_turns} conflicts no regulatory element or signal "
                                   "decides between a left turn and oncoming traffic: given to "
                                   f"the oncoming lane ({LEFT_TURN_YIELDS})")
        by_default = sum(c.rule == RIGHT_BEFORE_LEFT for c in conflicts.values())
        if by_default:
            self.not_mapped.append(f"{by_default} conflicts no regulatory element or signal "
                                   f"decides: given to the lane from the right ({RIGHT_BEFORE_LEFT})")
        if undecided:
            self.not_mapped.append(f"{undecided} conflicts no regulatory element, signal or "
                                   "default decides (merging or oncoming lanes): their zones "
                                   "give no lane priority (rule '')")
        return zones, conflicts

    def _priority(self, a: LaneKey, b: LaneKey) -> tuple[tuple[LaneKey, ...], str]:
        ordered = sorted(self.roles, key=lambda er: _attr(er[0], "fallback") == "yes")
        for element, roles in ordered:
            ra, rb = roles.get(a), roles.get(b)
            if {ra, rb} == {"priority", "yield"}:
                fallback = " (fallback)" if _attr(element, "fallback") == "yes" else ""
                return ((a,) if ra == "priority" else (b,)), f"right_of_way:{element.id}{fallback}"
        ga, gb = self.signal_groups.get(a, set()), self.signal_groups.get(b, set())
        if ga and gb and not ga & gb:
            return (), "signals"
        return (), ""

    def _left_turn_yields(self, a: LaneKey, b: LaneKey) -> tuple[tuple[LaneKey, ...], str]:
        """The left turn gives way to oncoming traffic (default_rules.left_turn_priority)."""
        first = left_turn_priority(self._centerline(a), self._centerline(b))
        return ((), "") if first is None else (((a, b)[first],), LEFT_TURN_YIELDS)

    def _from_the_right(self, a: LaneKey, b: LaneKey, point: np.ndarray
                        ) -> tuple[tuple[LaneKey, ...], str]:
        """The lane from the right has priority (default_rules.from_the_right_priority)."""
        first = from_the_right_priority(self._centerline(a), self._centerline(b), point)
        return ((), "") if first is None else (((a, b)[first],), RIGHT_BEFORE_LEFT)

    def _centerline(self, key: LaneKey) -> np.ndarray:
        """(P, 2) the centre line of a mapped lane [m]."""
        return self.lanes[self.lane_elements[key].index].centerline

    def junctions(self, conflicts: dict) -> dict[int, JunctionElement]:
        """Connected components of the conflict graph, with their signals and stop lines."""
        return junction_elements(
            conflicts, {i: self._reached(s.lanes) for i, s in self.signals.items()},
            {i: self._reached(s.lanes) for i, s in self.stop_line_elements.items()})

    def signal_plan(self, conflicts: dict):
        """The default cycle of the map's signal groups (signal_plan.py), None without any."""
        if not self.signals:
            return None
        reached = {s.group: self._reached(s.lanes) for s in self.signals.values()}
        return default_signal_plan(list(reached), conflicting_groups(reached, conflicts))

    def _reached(self, lanes) -> set[LaneKey]:
        """The lanes a rule on `lanes` holds on (`reach` of each)."""
        return set().union(*(self.reach(k) for k in lanes))


def _extent(road_map_parts) -> tuple[float, float, float, float]:
    pts = np.concatenate([np.asarray(p).reshape(-1, 2) for p in road_map_parts])
    lo, hi = pts.min(axis=0) - EXTENT_MARGIN_M, pts.max(axis=0) + EXTENT_MARGIN_M
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def convert_lanelet_map(lanelet_map, source: MapSource, problems=(), name: str = ""):
    """The RoadMap and MapElements of a loaded Lanelet2 map (module docstring).

    Args:
        lanelet_map: lanelet2's LaneletMap (projected).
        source: where it came from (MapSource).
        problems: what lanelet2 reported while loading it (strings).
        name: the map's name in the warning (default: its file).

    Returns:
        (road_map, elements): the RoadMap (no routes: a scene adds them) and MapElements.
    """
    conv = _Converter(lanelet_map, source, list(problems))
    crosswalks = conv.map_lanelets()
    if not conv.lanes:
        from marl_social.maps.errors import MapError

        raise MapError(f"{source.path}: the map has no lanelet a car may drive on")
    conv.map_regulatory_elements()
    conv.unused_stop_lines()
    zones, conflicts = conv.map_conflicts()
    plan = conv.signal_plan(conflicts)
    polygons, sources, parking, skipped_areas = map_occluders(lanelet_map)
    if skipped_areas:
        conv.not_mapped.append("areas that are no obstacle or of unknown height: " + ", ".join(
            f"{k} {v}" for k, v in sorted(skipped_areas.items())))
    limits = Counter(e.speed_limit_mps for e in conv.lane_elements.values())
    road_map = RoadMap(
        lanes=tuple(conv.lanes), crosswalks=tuple(crosswalks), static_polygons=tuple(polygons),
        speed_limit_mps=limits.most_common(1)[0][0],
        extent=_extent([lane.centerline for lane in conv.lanes] + list(polygons)),
        stop_lines=tuple(conv.stop_lines), conflict_zones=tuple(zones),
        signal_heads=tuple(conv.heads), signal_plan=plan)
    elements = MapElements(
        source=source, lanes=conv.lane_elements, crosswalks=conv.crosswalk_elements,
        stop_lines=conv.stop_line_elements, signals=conv.signals, conflicts=conflicts,
        junctions=conv.junctions(conflicts), parking_areas=parking,
        occluder_sources=tuple(sources), not_mapped=tuple(conv.not_mapped))
    if conv.not_mapped:
        warnings.warn(MapConversionWarning(
            f"map {name or source.path}: not mapped: " + "; ".join(conv.not_mapped)),
            stacklevel=3)
    return road_map, elements

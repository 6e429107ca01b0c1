import subprocess
import sys
import textwrap
import time
import warnings

import numpy as np
import pytest

from marl_social.maps import MapConversionWarning, MapError, load_map
from marl_social.maps.default_rules import LEFT_TURN_YIELDS, RIGHT_BEFORE_LEFT
from marl_social.maps.geometry import convex_pieces, polygon_area
from marl_social.maps.registry import _CACHE, BUILTIN_DIR, BUILTIN_MAPS
from tests.maps.synthetic import junction_osm, synthetic_osm

KARLSRUHE_OSM = BUILTIN_DIR / BUILTIN_MAPS["karlsruhe"].file


@pytest.fixture(scope="module")
def karlsruhe():
    pytest.importorskip("lanelet2")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MapConversionWarning)
        return load_map("karlsruhe")


def test_builtin_map_ships_with_its_license():
    folder = KARLSRUHE_OSM.parent
    assert "FZI Forschungszentrum Informatik" in (folder / "LICENSE").read_text()
    assert "BSD 3-clause" in (folder / "README.md").read_text()


def test_karlsruhe_counts(karlsruhe):
    road_map, el = karlsruhe
    # 371 lanelets: 328 a car may use (60 of them two-way: a lane each way), 8 crosswalks,
    # 35 no car may use (listed as not mapped)
    assert len({k.lanelet_id for k in el.lanes}) == 328
    assert len(road_map.lanes) == 328 + 60
    assert len(road_map.crosswalks) == len(el.crosswalks) == 8
    assert any(line.startswith("35 lanelets no car may use") for line in el.not_mapped)
    assert 328 + 8 + 35 == 371
    # the 6 traffic light elements: a signal stop line each, one head per light (10)
    assert len(el.signals) == 6
    assert len(road_map.stop_lines) == 6
    assert all(line.kind == "signal" for line in road_map.stop_lines)
    assert len(road_map.signal_heads) == 10
    # all 28 stop line strings are kept by id; 4 used by the lights, 24 by nothing
    assert len(el.stop_lines) == 28
    assert sum(s.rule == "signal" for s in el.stop_lines.values()) == 4
    assert len(road_map.static_polygons) > 100
    assert {kind for kind, _ in el.occluder_sources} == {"wall", "fence", "guard_rail",
                                                         "building"}
    assert len(el.parking_areas) == 19
    assert len(road_map.conflict_zones) == len(el.conflicts) > 100


def test_karlsruhe_elements_point_at_the_road_map(karlsruhe):
    road_map, el = karlsruhe
    for key, lane in el.lanes.items():
        assert road_map.lanes[lane.index].name.startswith(f"lanelet_{key.lanelet_id}")
        assert all(s in el.lanes for s in lane.successors)
    for cw in el.crosswalks.values():
        assert 0 <= cw.index < len(road_map.crosswalks)
    assert any(cw.crossed_lanes for cw in el.crosswalks.values())
    for signal in el.signals.values():
        assert all(road_map.signal_heads[h].group == signal.group for h in signal.heads)
        assert road_map.stop_lines[signal.stop_line].kind == "signal"
    for conflict in el.conflicts.values():
        zone = road_map.conflict_zones[conflict.zone]
        assert zone.priority_lanes == tuple(el.lanes[k].index for k in conflict.priority)
    rules = {c.rule.split(":")[0] for c in el.conflicts.values()}
    assert {"right_of_way", "signals", ""} <= rules
    signalled = max(el.junctions.values(), key=lambda j: len(j.signals))
    assert len(signalled.signals) == 6  # the map's one signalized junction


def test_karlsruhe_default_signal_cycle_never_greens_conflicting_groups(karlsruhe):
    road_map, el = karlsruhe
    plan = road_map.signal_plan
    states = plan.group_states()  # (P, G)
    assert (states == 2).any(axis=0).all()  # every group gets a green
    by_group = {s.group: s for s in el.signals.values()}
    for phase in states:
        green = [plan.groups[g] for g in np.flatnonzero(phase == 2)]
        for a in green:
            for b in green:
                lanes_a = set(by_group[a].lanes)
                assert a == b or not lanes_a & set(by_group[b].lanes)
    assert len(plan.phases) < 3 * len(plan.groups)  # groups that do not conflict share


def test_karlsruhe_loads_fast_and_is_cached(karlsruhe):
    _CACHE.clear()
    start = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MapConversionWarning)
        first = load_map("karlsruhe")
    assert time.process_time() - start <= 2.0
    start = time.process_time()
    assert load_map("karlsruhe") is first
    assert time.process_time() - start < 0.01


def test_interaction_convention_local_xy(tmp_path):
    pytest.importorskip("lanelet2")
    path = tmp_path / "local.osm"
    path.write_text(synthetic_osm(local_xy=True))
    with pytest.warns(MapConversionWarning) as record:
        road_map, el = load_map(path)
    assert el.source.convention == "local_xy"
    lane = road_map.lanes[el.lanes[(100, False)].index]
    np.testing.assert_allclose(lane.centerline[[0, -1]], [[0, 0], [50, 0]], atol=1e-6)
    assert lane.width_m == pytest.approx(3.5)
    assert len(road_map.lanes) == 2 and len(road_map.crosswalks) == 1
    cw = road_map.crosswalks[0]
    np.testing.assert_allclose(cw.center, [10, 0], atol=1e-6)
    assert cw.walk_heading_rad == pytest.approx(np.pi / 2)
    assert (cw.length_m, cw.width_m) == (pytest.approx(8.0), pytest.approx(2.0))
    assert el.crosswalks[102].crossed_lanes == ((100, False),)
    assert len(road_map.conflict_zones) == 1  # the two lanes cross at (25, 0)
    zone = road_map.conflict_zones[0]
    assert zone.contains(np.array([25.0, 0.0]))
    # nothing in the map decides it: right before left, lane 101 (northbound) comes from the
    # right of lane 100 (eastbound)
    conflict = el.conflicts[((100, False), (101, False))]
    assert conflict.rule == RIGHT_BEFORE_LEFT and conflict.priority == ((101, False),)
    assert zone.priority_lanes == (el.lanes[(101, False)].index,)
    assert [kind for kind, _ in el.occluder_sources] == ["wall"]
    message = str(record[0].message)
    assert "mystery_rule" in message  # the unknown regulatory element, listed
    assert "without a routable successor" in message
    assert "no regulatory element or signal decides" in message


def test_latlon_map_near_zero_projects_about_zero(tmp_path):
    pytest.importorskip("lanelet2")
    path = tmp_path / "latlon.osm"
    path.write_text(synthetic_osm(local_xy=False))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MapConversionWarning)
        road_map, el = load_map(path)
    assert el.source.convention == "utm" and el.source.origin == (0.0, 0.0)
    lane = road_map.lanes[el.lanes[(100, False)].index]
    np.testing.assert_allclose(lane.centerline[-1] - lane.centerline[0], [50, 0], atol=0.5)


@pytest.mark.parametrize("content, says", [
    (None, "not a well-formed OSM file"),  # truncated: the first 20 kB of karlsruhe
    ("<osm><node id='1' lat='0' lon='0'></osm>", "not a well-formed OSM file"),
    ("<map></map>", "not an OSM map"),
    ("<osm></osm>", "has no nodes"),
    ("<osm><node id='1' lat='x' lon='0'/></osm>", "lat/lon is not a number"),
])
def test_malformed_files_give_one_line_errors(tmp_path, content, says):
    path = tmp_path / "bad.osm"
    if content is None:
        path.write_bytes(KARLSRUHE_OSM.read_bytes()[:20_000])
    else:
        path.write_text(content)
    with pytest.raises(MapError, match=says) as err:
        load_map(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_missing_file_and_unknown_name(tmp_path):
    with pytest.raises(MapError, match="no such map file"):
        load_map(tmp_path / "nowhere.osm")
    with pytest.raises(MapError, match="unknown map 'karlsruh'.*did you mean 'karlsruhe'"):
        load_map("karlsruh")


def test_cli_maps_show_and_errors(tmp_path, capsys):
    pytest.importorskip("lanelet2")
    from marl_social.cli import main

    figure = tmp_path / "map.png"
    assert main(["maps", "show", "karlsruhe", "--figure", str(figure)]) == 0
    out = capsys.readouterr().out
    assert "crosswalks:      8" in out and "not mapped:" in out
    assert figure.stat().st_size > 10_000
    assert main(["maps", "show", "nowhere"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown map 'nowhere'" in err
    assert main(["maps", "list"]) == 0
    assert "karlsruhe" in capsys.readouterr().out


def test_package_works_without_lanelet2():
    code = textwrap.dedent("""
        import sys
        sys.modules["lanelet2"] = None  # import lanelet2 raises ImportError
        import marl_social, marl_social.maps
        from marl_social.maps import MapError, load_map
        try:
            load_map("karlsruhe")
        except MapError as err:
            print(err)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert 'pip install -e ".[maps]"' in out and out.count("\n") == 1


def test_convex_pieces_cover_a_concave_outline():
    ell = np.array([[0, 0], [4, 0], [4, 1], [1, 1], [1, 3], [0, 3]], dtype=float)
    pieces = convex_pieces(ell)
    assert len(pieces) == 2
    assert sum(polygon_area(p) for p in pieces) == pytest.approx(polygon_area(ell))
    from marl_social.sim.road_map import RoadMap

    RoadMap(lanes=(), crosswalks=(), static_polygons=tuple(pieces))  # strictly convex, CCW


def test_two_way_lanelet_and_left_turn(tmp_path):
    """A two-way lanelet gives each direction its right half (keep right), side by side, not
    in conflict; a left turn across oncoming traffic gives way to it (StVO section 9 (3))."""
    pytest.importorskip("lanelet2")
    path = tmp_path / "junction.osm"
    path.write_text(junction_osm())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MapConversionWarning)
        road_map, el = load_map(path)
    east, west = (road_map.lanes[el.lanes[(300, inverted)].index] for inverted in (False, True))
    np.testing.assert_allclose(east.centerline[[0, -1]], [[0, -1.5], [50, -1.5]], atol=1e-6)
    np.testing.assert_allclose(west.centerline[[0, -1]], [[50, 1.5], [0, 1.5]], atol=1e-6)
    np.testing.assert_allclose(east.centerline[:, 1], -1.5, atol=1e-6)
    np.testing.assert_allclose(west.centerline[:, 1], 1.5, atol=1e-6)
    assert east.width_m == pytest.approx(3.0) and west.width_m == pytest.approx(3.0)
    assert not any(300 in (a.lanelet_id, b.lanelet_id) for a, b in el.conflicts)
    conflict = el.conflicts[((310, False), (311, False))]
    assert conflict.rule == LEFT_TURN_YIELDS and conflict.priority == ((310, False),)
    zone = road_map.conflict_zones[conflict.zone]
    assert zone.priority_lanes == (el.lanes[(310, False)].index,)

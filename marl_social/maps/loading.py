"""Read a Lanelet2 .osm file robustly: checks first, then lanelet2 with the right projection.

Projection: a lat/lon map goes through a UTM projection about an origin (lat, lon) [deg]: the
`origin` argument, else a built-in map's own, else the centre of the nodes' lat/lon box. The
INTERACTION convention is detected: nodes that carry local `x` / `y` tags [m] keep those
coordinates; a map whose lat/lon all lie within LOCAL_LATLON_DEG of (0, 0) is projected about
(0, 0), as INTERACTION's maps are, so it lines up with their track files.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple
from xml.etree import ElementTree

from marl_social.data.file_limits import MB, check_file_size
from marl_social.maps.elements import MapSource
from marl_social.maps.errors import MapError, require_lanelet2

MAX_OSM_BYTES = 200 * MB  # a Lanelet2 map larger than this is refused (a city is ~10 MB)
LOCAL_LATLON_DEG = 1.0  # lat/lon within this of (0, 0): INTERACTION's local maps [deg]


class OsmSummary(NamedTuple):
    """What a first pass over the XML learns: whether nodes carry local x/y, the lat/lon box."""

    n_nodes: int
    local_xy: bool
    lat_range: tuple[float, float]
    lon_range: tuple[float, float]


def scan_osm(path: Path) -> OsmSummary:
    """Check that `path` is a well-formed OSM XML file with nodes (MapError naming the problem).

    Args:
        path: the .osm file.
    """
    n_nodes = n_local = 0
    lats: list[float] = []
    lons: list[float] = []
    root_tag = None
    try:
        for event, elem in ElementTree.iterparse(path, events=("start", "end")):
            if event == "start":
                if root_tag is None:
                    root_tag = elem.tag
                continue
            if elem.tag != "node":
                continue
            n_nodes += 1
            tags = {t.get("k") for t in elem.iter("tag")}
            n_local += {"x", "y"} <= tags
            if elem.get("lat") is not None and elem.get("lon") is not None:
                lats.append(float(elem.get("lat")))
                lons.append(float(elem.get("lon")))
            elem.clear()
    except ElementTree.ParseError as err:
        raise MapError(f"{path}: not a well-formed OSM file ({err}); truncated or corrupted?") \
            from None
    except ValueError as err:
        raise MapError(f"{path}: a node's lat/lon is not a number ({err})") from None
    if root_tag != "osm":
        raise MapError(f"{path}: not an OSM map (its root element is <{root_tag}>, not <osm>)")
    if n_nodes == 0:
        raise MapError(f"{path}: the map has no nodes")
    if 0 < n_local < n_nodes:
        raise MapError(f"{path}: {n_local} of {n_nodes} nodes carry local x/y tags; either all "
                       "or none must (the INTERACTION convention)")
    if n_local == 0 and len(lats) < n_nodes:
        raise MapError(f"{path}: {n_nodes - len(lats)} nodes have neither lat/lon nor local x/y")
    lat_range = (min(lats), max(lats)) if lats else (0.0, 0.0)
    lon_range = (min(lons), max(lons)) if lons else (0.0, 0.0)
    return OsmSummary(n_nodes, n_local == n_nodes, lat_range, lon_range)


def choose_origin(scan: OsmSummary, origin) -> tuple[tuple[float, float], str]:
    """The projection's origin (lat, lon) [deg] and the convention (module docstring).

    Args:
        scan: the file's first pass.
        origin: (lat, lon) [deg] given by the caller, or None.
    """
    if scan.local_xy:
        return (0.0, 0.0), "local_xy"
    if origin is not None:
        lat, lon = (float(v) for v in origin)
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise MapError(f"origin ({lat}, {lon}): latitude must be in [-90, 90] and "
                           "longitude in [-180, 180] degrees")
        return (lat, lon), "utm"
    near_zero = max(abs(v) for v in (*scan.lat_range, *scan.lon_range)) <= LOCAL_LATLON_DEG
    if near_zero:
        return (0.0, 0.0), "utm"
    return (0.5 * sum(scan.lat_range), 0.5 * sum(scan.lon_range)), "utm"


def read_lanelet_map(path, origin=None):
    """Load a Lanelet2 map with lanelet2, projected (module docstring).

    Args:
        path: the .osm file.
        origin: (lat, lon) [deg] of the UTM origin, or None (module docstring).

    Returns:
        (lanelet_map, source, problems): lanelet2's LaneletMap, the MapSource, and the
        problems lanelet2 reported while loading (a list of strings).
    """
    path = Path(path)
    if not path.is_file():
        raise MapError(f"{path}: no such map file")
    try:
        check_file_size(path, MAX_OSM_BYTES, "a Lanelet2 map")
    except ValueError as err:
        raise MapError(str(err)) from None
    scan = scan_osm(path)
    chosen, convention = choose_origin(scan, origin)
    lanelet2 = require_lanelet2()
    from lanelet2.projection import UtmProjector

    projector = UtmProjector(lanelet2.io.Origin(*chosen))
    try:
        lanelet_map, problems = lanelet2.io.loadRobust(str(path), projector)
    except RuntimeError as err:
        raise MapError(f"{path}: lanelet2 cannot read it ({str(err).strip()})") from None
    if convention == "local_xy":
        lanelet_map = _with_local_xy(lanelet2, lanelet_map)
    return lanelet_map, MapSource(str(path), chosen, convention), list(problems)


def _with_local_xy(lanelet2, lanelet_map):
    """The map with every point moved to its local x/y tags [m], re-indexed.

    The layers' spatial indices are built when elements are added, so the moved elements go
    into a fresh map (the routing graph's overlap search reads those indices).
    """
    for point in lanelet_map.pointLayer:
        point.x = float(point.attributes["x"])
        point.y = float(point.attributes["y"])
    fresh = lanelet2.core.LaneletMap()
    for layer in (lanelet_map.laneletLayer, lanelet_map.areaLayer,
                  lanelet_map.regulatoryElementLayer, lanelet_map.lineStringLayer,
                  lanelet_map.polygonLayer, lanelet_map.pointLayer):
        for element in layer:
            fresh.add(element)
    return fresh

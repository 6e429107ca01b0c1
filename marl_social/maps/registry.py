"""The built-in maps, and `load_map`: a name or a file to a RoadMap and its MapElements.

A conversion is cached in-process (per file, its size and modification time, and origin):
the returned RoadMap and MapElements are shared, not to be modified.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from marl_social.maps.convert import convert_lanelet_map
from marl_social.maps.elements import MapElements
from marl_social.maps.errors import MapError
from marl_social.maps.loading import read_lanelet_map
from marl_social.sim.road_map import RoadMap

BUILTIN_DIR = Path(__file__).resolve().parent / "builtin-maps"  # no package name: data only
MAX_CACHED_MAPS = 8


@dataclass(frozen=True)
class BuiltinMap:
    """A map shipped with the package: its file (under maps/builtin-maps/) and UTM origin [deg]."""

    file: str
    origin: tuple[float, float]
    description: str


BUILTIN_MAPS = {
    "karlsruhe": BuiltinMap("karlsruhe/mapping_example.osm", (49.0, 8.42),
                            "Lanelet2's example map: a district of Karlsruhe (BSD 3-clause, "
                            "FZI Forschungszentrum Informatik)"),
}


class LoadedMap(NamedTuple):
    """A converted map: the simulator's RoadMap (no routes) and the elements' ids."""

    road_map: RoadMap
    elements: MapElements


_CACHE: dict[tuple, LoadedMap] = {}


def resolve_map(map_ref, origin=None) -> tuple[Path, tuple[float, float] | None, str]:
    """(file, origin, name) of a built-in map's name or an .osm path (MapError if neither).

    Args:
        map_ref: a built-in name (BUILTIN_MAPS) or a path to an .osm file.
        origin: (lat, lon) [deg], or None (a built-in's own, else loading.choose_origin's).
    """
    text = str(map_ref)
    if text in BUILTIN_MAPS:
        builtin = BUILTIN_MAPS[text]
        return BUILTIN_DIR / builtin.file, origin or builtin.origin, text
    path = Path(text)
    if path.suffix.lower() == ".osm" or path.exists() or "/" in text:
        return path, origin, text
    close = difflib.get_close_matches(text, list(BUILTIN_MAPS), n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise MapError(f"unknown map {text!r}: neither a built-in map ({', '.join(BUILTIN_MAPS)}) "
                   f"nor an .osm file{hint}")


def load_map(map_ref, origin=None) -> LoadedMap:
    """A Lanelet2 map as a RoadMap and its MapElements (convert.py), cached in-process.

    Args:
        map_ref: a built-in name ("karlsruhe") or a path to a Lanelet2 .osm file.
        origin: (lat, lon) [deg] of the UTM projection's origin; None: a built-in map's own,
            else the file's (loading.py; the INTERACTION convention is detected).

    Raises:
        MapError: a missing, malformed or truncated file, an unknown name, or no lanelet2
            (the message says `pip install -e ".[maps]"`).
    """
    path, chosen, name = resolve_map(map_ref, origin)
    try:
        stat = path.stat()
    except OSError:
        raise MapError(f"{path}: no such map file") from None
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns,
           None if chosen is None else tuple(float(v) for v in chosen))
    hit = _CACHE.get(key)
    if hit is None:
        lanelet_map, source, problems = read_lanelet_map(path, chosen)
        hit = LoadedMap(*convert_lanelet_map(lanelet_map, source, problems, name))
        if len(_CACHE) >= MAX_CACHED_MAPS:
            _CACHE.clear()
        _CACHE[key] = hit
    return hit

"""Real maps: Lanelet2 .osm files as the simulator's RoadMap, and the built-in maps.

`load_map("karlsruhe")` or `load_map(PATH, origin=(lat, lon))` gives a LoadedMap: the RoadMap
and the MapElements that name its lanes, crosswalks, stop lines, signals and junctions by their
Lanelet2 ids. Reading a map needs the optional `lanelet2` package (`pip install -e ".[maps]"`);
importing this package does not.
"""

from marl_social.maps.convert import MapConversionWarning
from marl_social.maps.elements import LaneKey, MapElements, MapSource
from marl_social.maps.errors import INSTALL_HINT, MapError
from marl_social.maps.registry import BUILTIN_MAPS, LoadedMap, load_map

__all__ = ["BUILTIN_MAPS", "INSTALL_HINT", "LaneKey", "LoadedMap", "MapConversionWarning",
           "MapElements", "MapError", "MapSource", "load_map"]

"""A small INTERACTION recording (map and vehicle track file) written by the tests."""

from __future__ import annotations

from tests.maps.synthetic import _lanelet, _node, _way

HEADER = "track_id,frame_id,timestamp_ms,agent_type,x,y,vx,vy,psi_rad,length,width"


def replay_osm() -> str:
    """INTERACTION's convention (local x/y): lane 100 east along y = 0 (x 0..200), lane 101
    north along x = 150 (y -60..60), both 3.5 m wide; crosswalk 102 across lane 100 at
    x = 100."""
    points = {
        1: (0, 1.75), 2: (200, 1.75), 3: (0, -1.75), 4: (200, -1.75),
        5: (148.25, -60), 6: (148.25, 60), 7: (151.75, -60), 8: (151.75, 60),
        9: (99, -4), 10: (99, 4), 11: (101, -4), 12: (101, 4),
    }
    nodes = "".join(_node(i, x, y, True) for i, (x, y) in points.items())
    ways = "".join([
        _way(21, (1, 2), "line_thin"), _way(22, (3, 4), "road_border"),
        _way(23, (5, 6), "line_thin"), _way(24, (7, 8), "road_border"),
        _way(25, (9, 10), "pedestrian_marking"), _way(26, (11, 12), "pedestrian_marking"),
    ])
    relations = "".join([_lanelet(100, 21, 22, "road"), _lanelet(101, 23, 24, "road"),
                         _lanelet(102, 25, 26, "crosswalk")])
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<osm version="0.6" generator="tests">'
            f"{nodes}{ways}{relations}</osm>\n")


def synthetic_tracks(n_frames: int = 60) -> str:
    """Car 1 east on lane 100 from x = 70 at 8 m/s, braking at 1 m/s^2 from frame 20 (ahead of
    the robot, which starts 60 m before the crosswalk); car 2 north on lane 101 from y = -40 at
    6 m/s; car 3 enters at frame 10 (a late vehicle). 10 Hz, frames from 1."""
    rows = [HEADER]
    x, v = 70.0, 8.0
    for k in range(n_frames):
        frame, t_ms = k + 1, 100 * (k + 1)
        rows.append(f"1,{frame},{t_ms},car,{x:.4f},0.0,{v:.4f},0.0,0.0,4.5,1.8")
        rows.append(f"2,{frame},{t_ms},car,150.0,{-40.0 + 0.6 * k:.4f},0.0,6.0,1.5707963,4.2,1.7")
        if k >= 9:
            rows.append(f"3,{frame},{t_ms},car,{0.4 * (k - 9):.4f},0.0,4.0,0.0,0.0,4.5,1.8")
        if k >= 20:
            v = max(v - 0.1, 0.0)
        x += 0.1 * v
    return "\n".join(rows) + "\n"

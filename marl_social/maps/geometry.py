"""Plane geometry the converter needs: convex hulls, convex pieces, rectangles, overlaps.

The simulator's static obstacles and conflict zones must be strictly convex (sim/road_map.py);
a map's walls, buildings and lane overlaps are not. Points are (N, 2) arrays [m].
"""

from __future__ import annotations

import itertools
import math

import numpy as np

MIN_AREA_M2 = 1e-3  # a hull or piece smaller than this is degenerate (a line or a point) [m^2]
COLLINEAR_TOL = 1e-9  # |cross product| below this: collinear [m^2]


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """The cross product (a - o) x (b - o) of points (2,) [m^2]."""
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def polygon_area(poly: np.ndarray) -> float:
    """Signed area [m^2] of a polygon (V, 2) [m]: positive when counter-clockwise."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def convex_hull(points) -> np.ndarray | None:
    """Strictly convex hull (V, 2) [m], counter-clockwise, of points (N, 2) [m].

    Collinear points are dropped (monotone chain); None when the hull is degenerate (fewer than
    3 corners or an area under MIN_AREA_M2).
    """
    pts = np.unique(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)
    if len(pts) < 3:
        return None
    lower: list[np.ndarray] = []
    upper: list[np.ndarray] = []
    for chain, ordered in ((lower, pts), (upper, pts[::-1])):
        for p in ordered:
            while len(chain) >= 2 and _cross(chain[-2], chain[-1], p) <= COLLINEAR_TOL:
                chain.pop()
            chain.append(p)
    hull = np.array(lower[:-1] + upper[:-1])
    if len(hull) < 3 or polygon_area(hull) < MIN_AREA_M2:
        return None
    return hull


def thin_polyline_pieces(polyline: np.ndarray, thickness_m: float) -> list[np.ndarray]:
    """A thin wall along a polyline (P, 2) [m]: one rectangle (4, 2) [m] per segment.

    Each rectangle is the segment widened by thickness_m [m] (centred on it); consecutive
    rectangles overlap at the joints, so the wall has no gap at a bend.
    """
    pieces = []
    for a, b in itertools.pairwise(polyline):
        d = b - a
        length = float(np.hypot(*d))
        if length < 1e-6:
            continue
        n = np.array([-d[1], d[0]]) / length * 0.5 * thickness_m
        piece = convex_hull(np.array([a - n, b - n, b + n, a + n]))
        if piece is not None:
            pieces.append(piece)
    return pieces


def _point_in_triangle(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> bool:
    return _cross(a, b, p) >= 0 and _cross(b, c, p) >= 0 and _cross(c, a, p) >= 0


def _ear_clip(poly: np.ndarray) -> list[list[int]]:
    """Triangles (index triples) of a simple counter-clockwise polygon (V, 2), ear clipping."""
    idx = list(range(len(poly)))
    triangles = []
    guard = 0
    while len(idx) > 3 and guard < 10 * len(poly) ** 2:
        guard += 1
        for k in range(len(idx)):
            i, j, m = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            if _cross(poly[i], poly[j], poly[m]) <= COLLINEAR_TOL:
                continue  # reflex or flat corner: not an ear
            if any(_point_in_triangle(poly[q], poly[i], poly[j], poly[m])
                   for q in idx if q not in (i, j, m)):
                continue
            triangles.append([i, j, m])
            idx.pop(k)
            break
        else:
            break  # no ear left (a self-intersecting outline): keep what was clipped
    if len(idx) == 3:
        triangles.append(idx)
    return triangles


def _merged(a: list[int], b: list[int]) -> list[int] | None:
    """The union of two index rings sharing exactly one edge (None if they do not)."""
    for k in range(len(a)):
        u, v = a[k], a[(k + 1) % len(a)]
        if u in b and v in b:
            j = b.index(v)
            if b[(j + 1) % len(b)] != u:
                continue
            rest = [b[(j + 2 + t) % len(b)] for t in range(len(b) - 2)]
            return a[:k + 1] + rest + a[k + 1:]
    return None


def _is_strictly_convex(poly: np.ndarray) -> bool:
    n = len(poly)
    return all(_cross(poly[k], poly[(k + 1) % n], poly[(k + 2) % n]) > COLLINEAR_TOL
               for k in range(n))


def convex_pieces(polygon) -> list[np.ndarray]:
    """Strictly convex pieces (V_k, 2) [m] that together cover a simple polygon (V, 2) [m].

    A convex polygon is its own single piece; a concave one is cut into triangles (ear
    clipping), then neighbouring pieces are merged while their union stays convex
    (Hertel-Mehlhorn), which leaves few pieces.
    """
    poly = np.asarray(polygon, dtype=np.float64)
    if len(poly) > 1 and np.allclose(poly[0], poly[-1]):
        poly = poly[:-1]
    keep = np.ones(len(poly), dtype=bool)  # drop repeated vertices
    keep[1:] = np.linalg.norm(np.diff(poly, axis=0), axis=1) > 1e-6
    poly = poly[keep]
    if len(poly) < 3 or abs(polygon_area(poly)) < MIN_AREA_M2:
        return []
    if polygon_area(poly) < 0:
        poly = poly[::-1].copy()
    hull = convex_hull(poly)
    if hull is not None and abs(polygon_area(hull) - polygon_area(poly)) <= 1e-6 * polygon_area(
            hull):
        return [hull]
    rings = _ear_clip(poly)
    merged = True
    while merged:
        merged = False
        for i in range(len(rings)):
            for j in range(i + 1, len(rings)):
                union = _merged(rings[i], rings[j])
                if union is not None and _is_strictly_convex(poly[union]):
                    rings[i] = union
                    rings.pop(j)
                    merged = True
                    break
            if merged:
                break
    pieces = [convex_hull(poly[ring]) for ring in rings]
    return [p for p in pieces if p is not None]


def points_in_polygon(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """(N,) bool: which points (N, 2) [m] lie inside a simple polygon (V, 2) [m] (even-odd)."""
    x, y = points[:, 0][:, None], points[:, 1][:, None]
    x0, y0 = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    straddles = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return (np.count_nonzero(straddles & (x < x_at), axis=1) % 2) == 1


def _edge_intersections(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(K, 2) points [m] where the closed outlines a (V, 2) and b (W, 2) cross."""
    p, r = a, np.roll(a, -1, axis=0) - a  # (V, 2)
    q, s = b, np.roll(b, -1, axis=0) - b  # (W, 2)
    denom = r[:, None, 0] * s[None, :, 1] - r[:, None, 1] * s[None, :, 0]
    qp = q[None, :, :] - p[:, None, :]  # (V, W, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * s[None, :, 1] - qp[..., 1] * s[None, :, 0]) / denom
        u = (qp[..., 0] * r[:, None, 1] - qp[..., 1] * r[:, None, 0]) / denom
    hit = (np.abs(denom) > 1e-12) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    vi, _ = np.nonzero(hit)
    return p[vi] + t[hit][:, None] * r[vi]


def overlap_hull(a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """Convex hull (V, 2) [m] of the overlap of two simple polygons a and b [m] (None: none).

    The overlap's corners are a's corners inside b, b's corners inside a and the points where
    the outlines cross; their hull is the hull of the overlap.
    """
    corners = [a[points_in_polygon(a, b)], b[points_in_polygon(b, a)], _edge_intersections(a, b)]
    return convex_hull(np.concatenate(corners))


def aligned_rectangle(points: np.ndarray, heading_rad: float) -> tuple[np.ndarray, float, float]:
    """The smallest rectangle aligned with heading_rad [rad] around points (N, 2) [m].

    Returns:
        center (2,) [m], extent along the heading [m], extent across it [m].
    """
    along = np.array([np.cos(heading_rad), np.sin(heading_rad)])
    across = np.array([-along[1], along[0]])
    u, w = points @ along, points @ across
    center = 0.5 * (u.min() + u.max()) * along + 0.5 * (w.min() + w.max()) * across
    return center, float(u.max() - u.min()), float(w.max() - w.min())


def clean_polyline(points) -> np.ndarray:
    """A polyline (P, 2) [m] without repeated consecutive points (zero-length segments)."""
    pts = np.asarray(points, dtype=np.float64)
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-6
    return pts[keep]


def polylines_cross(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the open polylines a (P, 2) and b (Q, 2) [m] cross or touch."""
    return len(polyline_crossings(a, b)) > 0


def polyline_crossings(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(K,) arc lengths along a [m] at which the open polylines a (P, 2) and b (Q, 2) [m] meet."""
    p, r = a[:-1], np.diff(a, axis=0)  # (P-1, 2)
    q, s = b[:-1], np.diff(b, axis=0)  # (Q-1, 2)
    denom = r[:, None, 0] * s[None, :, 1] - r[:, None, 1] * s[None, :, 0]
    qp = q[None, :, :] - p[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * s[None, :, 1] - qp[..., 1] * s[None, :, 0]) / denom
        u = (qp[..., 0] * r[:, None, 1] - qp[..., 1] * r[:, None, 0]) / denom
    hit = (np.abs(denom) > 1e-12) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    vertex_s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(r, axis=1))])
    vi, _ = np.nonzero(hit)
    return np.sort(vertex_s[vi] + t[hit] * np.linalg.norm(r[vi], axis=1))


def extended_polyline(points: np.ndarray, by_m: float) -> np.ndarray:
    """(P, 2) a polyline [m] whose first and last segments go on straight by_m [m] past its ends."""
    out = np.array(points, dtype=np.float64)
    for end, inner in ((0, 1), (-1, -2)):
        step = out[end] - out[inner]
        out[end] = out[end] + by_m * step / max(float(np.hypot(*step)), 1e-12)
    return out


def nearest_points_on(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """(N, 2) the point of a polyline (P, 2) [m] nearest to each of points (N, 2) [m]."""
    start, d = polyline[:-1], np.diff(polyline, axis=0)  # (P-1, 2)
    length2 = np.maximum((d * d).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - start[None]) * d[None]).sum(axis=2) / length2, 0.0, 1.0)
    foot = start[None] + t[..., None] * d[None]  # (N, P-1, 2)
    k = np.argmin(np.linalg.norm(foot - points[:, None, :], axis=2), axis=1)
    return foot[np.arange(len(points)), k]


def right_half_line(centerline: np.ndarray, right_bound: np.ndarray) -> np.ndarray:
    """(P, 2) the middle [m] of a lane's right half, a quarter of the width right of the centre.

    Each centre line point (P, 2) [m] moved half way to its nearest point on the right bound
    (Q, 2) [m]; the ends half way to the bound's ends, so that the halves of two lanelets
    that share an end edge join there.
    """
    half = 0.5 * (centerline + nearest_points_on(centerline, right_bound))
    half[0] = 0.5 * (centerline[0] + right_bound[0])
    half[-1] = 0.5 * (centerline[-1] + right_bound[-1])
    return clean_polyline(half)


def heading_near(polyline: np.ndarray, point: np.ndarray) -> float:
    """Heading [rad] of the segment of a polyline (P, 2) [m] closest to a point (2,) [m]."""
    start, d = polyline[:-1], np.diff(polyline, axis=0)
    t = np.clip(((point - start) * d).sum(axis=1) / (d * d).sum(axis=1), 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(start + t[:, None] * d - point, axis=1)))
    return math.atan2(d[k, 1], d[k, 0])


def mean_width(left: np.ndarray, right: np.ndarray) -> float:
    """Mean distance [m] between two bounds (P, 2), (Q, 2), resampled at equal arc fractions."""
    def resample(line: np.ndarray, n: int) -> np.ndarray:
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
        if s[-1] <= 0.0:
            return np.repeat(line[:1], n, axis=0)
        f = np.linspace(0.0, s[-1], n)
        return np.column_stack([np.interp(f, s, line[:, 0]), np.interp(f, s, line[:, 1])])

    n = max(len(left), len(right), 2) * 2
    return float(np.mean(np.linalg.norm(resample(left, n) - resample(right, n), axis=1)))

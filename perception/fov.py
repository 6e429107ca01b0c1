"""Fields of view: range, view cone and occlusion by every vehicle, pedestrian and static polygon.

The model is Nocturne's: an observer sees a target if a ray from the observer to one of the
target's sample points (its centre, then points just inside its corners) first hits the target.
Depth rays at fixed angles across the cone give each observer's visibility polygon.

Rays are answered in two phases, for all observers at once:

1. broad phase (compiled: `fov_kernels.maybe_blocked`), for the observers with no static
   polygon's bounding box within their range: each ray segment against every other agent's
   bounding circle. A ray that crosses no other agent's circle cannot be occluded (a target
   ray) or hits nothing (a depth ray): it needs no query. The rays of an observer with a static
   polygon in range all go to the narrow phase: where buildings line the road most of them end
   on one, and the test would cost more than the queries it saves.
2. chipmunk narrow phase (the pymunk Space, `GeometryMirror.first_hits` / `hits_targets`):
   the exact first hit of every remaining ray, the observer's own shape filtered out by its
   group.

The array arithmetic around the queries (sample points, range and cone, the rays' ends, the
second round's corner points) runs in numba kernels (perception/fov_kernels.py, loaded at the
first field of view), each bit for bit the numpy formulation kept in its test; the
trigonometry stays numpy's.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from marl_social.sim.bodies import Bodies
from marl_social.sim.footprint import place_local
from marl_social.sim.geometry import GeometryMirror
from marl_social.sim.kernel_cache import cached_kernels

_INNER_FRACTION = 0.85  # sample points sit this fraction of the way from centre to corner
fov_kernels = cached_kernels("marl_social.perception", "fov_kernels",
                             "the field of view's numba kernels", 3)


@dataclass(frozen=True)
class FovResult:
    """What every observer sees this step.

    Attributes:
        visible: (n, n) bool, visible[o, t] is True if observer o sees agent t.
        depth_m: (n, n_rays) distance to the first hit along each depth ray, capped at the
            observer's range [m]; inactive observers get 0.
        ray_angles_rad: (n, n_rays) ray directions relative to the observer's heading [rad].
        n_queries: number of pymunk ray queries this step (profiling aid).
    """

    visible: np.ndarray
    depth_m: np.ndarray
    ray_angles_rad: np.ndarray
    n_queries: int


def depth_ray_angles(half_angle_rad: np.ndarray, n_rays: int) -> np.ndarray:
    """Relative ray directions (n, n_rays) [rad], evenly across each cone, edges included.

    A full circle (half-angle >= pi) is split evenly without repeating -pi/+pi.

    Args:
        half_angle_rad: (n,) half-angles of the observers' view cones [rad].
        n_rays: depth rays per observer.
    """
    half = np.asarray(half_angle_rad, dtype=np.float64)
    frac = np.linspace(-1.0, 1.0, n_rays) if n_rays > 1 else np.zeros(1)
    full = np.linspace(-np.pi, np.pi, n_rays, endpoint=False)
    return np.where((half >= np.pi)[:, None], full[None, :], half[:, None] * frac[None, :])


def sample_point_layout(length, width, is_pedestrian) -> np.ndarray:
    """Body-frame points whose sight proves a target visible (n, 5, 2) [m].

    The centre, then 4 points just inside the outline (the corners of a car; 4 points around a
    pedestrian).

    Args:
        length: (n,) target lengths [m].
        width: (n,) target widths [m].
        is_pedestrian: (n,) bool.
    """
    half = 0.5 * _INNER_FRACTION * np.column_stack([length, width])  # (n, 2)
    local = np.zeros((len(half), 5, 2))
    local[:, 1:] = half[:, None, :] * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1.0]])
    ped_local = half[:, None, :1] * np.array([[1, 0], [0, 1], [-1, 0], [0, -1.0]])
    local[:, 1:] = np.where(np.asarray(is_pedestrian)[:, None, None], ped_local, local[:, 1:])
    return local


def target_sample_points(xy, heading, length, width, is_pedestrian) -> np.ndarray:
    """World positions (n, 5, 2) [m] of sample_point_layout for poses xy (n, 2), heading (n,)."""
    return place_local(xy, heading, sample_point_layout(length, width, is_pedestrian))


def _inside_convex(points, polygon) -> np.ndarray:
    """Whether points (n, 2) lie inside a convex polygon (V, 2) given in either orientation."""
    edge = np.roll(polygon, -1, axis=0) - polygon
    rel = points[:, None, :] - polygon[None]
    cross = edge[None, :, 0] * rel[..., 1] - edge[None, :, 1] * rel[..., 0]
    return np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)


class FieldOfView:
    """Computes every agent's field of view against a GeometryMirror.

    Args:
        mirror: the synced geometry (its pymunk Space answers the narrow phase).
        static_polygons: the same convex polygons the mirror holds, (V, 2) each [m].
        n_rays: depth rays per observer.
        blind_regions: (observer index, convex polygon (V, 2) [m]) pairs: the observer sees no
            object whose centre is inside the polygon.
    """

    def __init__(self, mirror: GeometryMirror, static_polygons, n_rays: int,
                 blind_regions=()):
        """Cache the static polygons' bounding boxes for the broad phase."""
        self.mirror = mirror
        # (observer, polygon) pairs: the observer sees no object whose centre is inside
        self._blind = [(int(o), np.asarray(poly, dtype=np.float64)) for o, poly in blind_regions]
        self.n_rays = int(n_rays)
        polys = list(static_polygons)
        self._box_min = np.array([p.min(axis=0) for p in polys]).reshape(-1, 2)
        self._box_max = np.array([p.max(axis=0) for p in polys]).reshape(-1, 2)
        self._angles_key = None
        self._angles = None
        self._local = None  # body-frame sample points, built on first use (sizes are fixed)
        self._layout_key = None
        self._layout = None

    def ray_angles(self, half_angle_rad: np.ndarray) -> np.ndarray:
        """depth_ray_angles for these half-angles, cached (sensors do not change in an episode)."""
        key = half_angle_rad.tobytes()
        if key != self._angles_key:
            self._angles_key, self._angles = key, depth_ray_angles(half_angle_rad, self.n_rays)
        return self._angles

    def compute(self, bodies: Bodies) -> FovResult:
        """Fields of view of all active agents.

        `bodies` gives their poses, footprints, bounding radii (the broad phase), activity and
        sensors; inactive agents neither see nor occlude. Speeds are not read.
        """
        xy, heading, length, width = bodies.xy, bodies.heading, bodies.length_m, bodies.width_m
        is_pedestrian, bounding_radius, active = (bodies.is_pedestrian, bodies.bounding_radius_m,
                                                  bodies.active)
        range_m, half_angle_rad = bodies.sensor_range_m, bodies.sensor_half_angle_rad
        n = len(xy)
        self._queries = 0
        kernels = fov_kernels()
        lay = self._active_layout(active, half_angle_rad, range_m)
        d_obs = lay.d_obs
        # -- target sample points within range and cone: (observer, target, point)
        if self._local is None or len(self._local) != n:
            self._local = sample_point_layout(length, width, is_pedestrian)
        points, rel = kernels.sample_points(xy, np.cos(heading), np.sin(heading), self._local)
        d_dir = heading[d_obs] + lay.d_angle
        sensed, centre_pairs, static_near, d_end = kernels.sensed_rays(
            rel, np.arctan2(rel[..., 1], rel[..., 0]),
            (xy, heading, lay.range2, half_angle_rad, lay.pair_ok),
            (self._box_min, self._box_max), (np.cos(d_dir), np.sin(d_dir), d_obs, lay.d_range))
        # -- round 1: centre rays and depth rays. The rays of observers with a static polygon
        # in range (static_near) go straight to the narrow phase (where buildings line the
        # road most of them end on one); the others' through the compiled broad phase.
        visible = np.zeros((n, n), dtype=bool)
        o1, t1 = centre_pairs
        if static_near.all():  # every ray goes to the narrow phase: no broad phase to run
            self._query_targets(xy[o1], points[t1, 0], o1, t1, visible)
            alpha = self.mirror.fan_alphas(xy[lay.observers], lay.observers, d_end)
            self._queries += len(d_obs)
        else:
            n_t = len(o1)
            radii = np.where(active, bounding_radius, -1.0)  # inactive agents never occlude
            ray_obs = np.concatenate([o1, d_obs])
            start = xy[ray_obs]
            end = np.concatenate([points[t1, 0], d_end])
            maybe = self._maybe_blocked(start, end, ray_obs, t1, xy, radii, static_near)
            self._resolve_targets(start[:n_t], end[:n_t], o1, t1, maybe[:n_t], visible)
            todo = np.flatnonzero(maybe[n_t:])
            alpha = np.ones(len(d_obs))
            alpha[todo] = self.mirror.first_hits(start[n_t + todo], d_end[todo], d_obs[todo])[1]
            self._queries += len(todo)
        depth = np.zeros((n, self.n_rays))
        depth[active] = (alpha * lay.d_range).reshape(-1, self.n_rays)
        # -- round 2: corner rays of targets in view whose centre was hidden
        o2, t2, k2 = kernels.hidden_centre_points(sensed, visible)
        if len(o2):
            start2, end2 = xy[o2], points[t2, k2]
            if static_near[o2].all():
                self._query_targets(start2, end2, o2, t2, visible)
            else:
                radii = np.where(active, bounding_radius, -1.0)
                maybe2 = self._maybe_blocked(start2, end2, o2, t2, xy, radii, static_near)
                self._resolve_targets(start2, end2, o2, t2, maybe2, visible)
        for o, poly in self._blind:
            visible[o] &= ~_inside_convex(xy, poly)
        return FovResult(visible, depth, lay.angles, self._queries)

    def _active_layout(self, active, half_angle_rad, range_m) -> SimpleNamespace:
        """Constants of a set of active observers, rebuilt only when it changes.

        Returns:
            a namespace: angles, the ray angles (n, R) [rad]; observers, the A active
            observers (A,) int; d_obs, the observer (A * R,) int, d_angle, the relative angle
            (A * R,) [rad] and d_range, the length (A * R,) [m] of every active observer's
            depth ray; pair_ok, the (observer, target) pairs that can
            see each other (n, n) bool; range2, the squared ranges (n,) [m^2].
        """
        key = active.tobytes() + half_angle_rad.tobytes() + range_m.tobytes()
        if key != self._layout_key:
            angles = self.ray_angles(half_angle_rad)
            observers = np.flatnonzero(active)
            d_obs = np.repeat(observers, self.n_rays)
            pair_ok = active[:, None] & active[None, :]
            np.fill_diagonal(pair_ok, False)
            self._layout_key = key
            self._layout = SimpleNamespace(
                angles=angles, observers=observers, d_obs=d_obs,
                d_angle=angles[active].ravel(), d_range=range_m[d_obs],
                pair_ok=pair_ok, range2=range_m ** 2)
        return self._layout

    def _maybe_blocked(self, start, end, ray_obs, tgt, centres, radii, static_near
                       ) -> np.ndarray:
        """Broad phase: could anything be in the way of each ray? (R,) bool.

        Anything but the ray's observer and, for the first len(tgt) rays, their target. The
        rays of observers with `static_near` are not tested (True); the others' observers have
        no static polygon within their range, so only the agents' bounding circles count.
        """
        # compiled (perception/fov_kernels.py), the numpy formulation's decisions
        return fov_kernels().maybe_blocked(start, end, ray_obs, tgt, centres, radii, static_near)

    def _resolve_targets(self, start, end, obs, tgt, maybe, visible) -> None:
        """Mark visible[o, t] for target rays that cannot be blocked; ask pymunk for the others.

        The narrow phase skips targets an earlier sample point already proved visible.
        """
        clear = ~maybe
        visible[obs[clear], tgt[clear]] = True
        todo = np.flatnonzero(maybe & ~visible[obs, tgt])
        self._query_targets(start[todo], end[todo], obs[todo], tgt[todo], visible)

    def _query_targets(self, start, end, obs, tgt, visible) -> None:
        """Narrow phase of target rays (R, 2)->(R, 2): mark visible[o, t] where a ray hits it."""
        seen, n_queries = self.mirror.hits_targets(start, end, obs, tgt)
        visible[obs[seen], tgt[seen]] = True
        self._queries += n_queries

"""Geometry mirrors of the world, synced once per step.

* a pymunk Space of kinematic bodies (plus static polygons) answers first-hit ray queries for the
  fields of view;
* python-fcl objects (tall boxes / cylinders / convex prisms, so that overlaps never resolve along
  z) in a dynamic AABB-tree broad-phase manager answer contacts and distances.

fcl objects cannot be pickled: a mirror is built by the world at reset and never pickled.
Labels: agents are 0..n-1, static polygon k is n + k.
"""

from __future__ import annotations

import fcl
import numpy as np
import pymunk
from pymunk._chipmunk import ffi, lib

from marl_social.sim.kernel_cache import geometry_kernels

_TALL_M = 100.0  # z-extent of the fcl solids [m]


def _prism(polygon: np.ndarray) -> fcl.Convex:
    """A convex polygon (V, 2), CCW, extruded to a tall fcl.Convex prism."""
    v = len(polygon)
    bottom = np.column_stack([polygon, np.full(v, -0.5 * _TALL_M)])
    top = np.column_stack([polygon, np.full(v, 0.5 * _TALL_M)])
    verts = np.vstack([bottom, top])
    faces = [v, *range(v - 1, -1, -1)]  # bottom, outward normal -z
    faces += [v, *range(v, 2 * v)]  # top, +z
    for i in range(v):
        j = (i + 1) % v
        faces += [4, i, j, v + j, v + i]
    return fcl.Convex(verts, v + 2, np.asarray(faces, dtype=np.int64))


def _cp_vects(points: np.ndarray):
    """(R, 2) points [m] as a chipmunk cpVect[R] array, copied in one memmove.

    cpVect is two doubles, the layout of a C-contiguous (R, 2) float64 array; passing its
    items to chipmunk skips the conversion of a Python sequence per call (~25 % of a ray).
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    vects = ffi.new("cpVect[]", max(len(points), 1))
    ffi.memmove(vects, points, points.nbytes)
    return vects


class GeometryMirror:
    """pymunk + fcl mirror of every agent footprint and static polygon.

    Args:
        kinds_is_pedestrian: (n,) bool.
        lengths_m, widths_m: (n,) footprint sizes [m] (pedestrian: diameter for both).
        static_polygons: convex polygons (V, 2), CCW [m].
    """

    def __init__(self, kinds_is_pedestrian, lengths_m, widths_m, static_polygons):
        self.n_agents = len(kinds_is_pedestrian)
        self.space = pymunk.Space()
        self._bodies: list[pymunk.Body] = []
        self._shapes: list[pymunk.Shape] = []
        self.shape_label: dict[pymunk.Shape, int] = {}
        self._cp_label: dict = {}  # chipmunk cpShape* -> label
        self._query_info = ffi.new("cpSegmentQueryInfo *")
        self._fcl_objects: list[fcl.CollisionObject] = []
        self._geom_label: dict[int, int] = {}
        self._geoms = []  # keep geometries alive: labels are keyed by id()
        self._in_space = np.zeros(self.n_agents, dtype=bool)
        self._off_diagonal = ~np.eye(self.n_agents, dtype=bool)
        self._fcl_pose = None  # (xy, heading) the fcl objects have yet to move to
        self._touch_key = None  # _bounds_may_touch's constants, per active set
        self._touch = None
        self._ray_filters: list[pymunk.ShapeFilter] = []
        self._cp_filter_owners = []  # chipmunk cpShapeFilter structs, built once per agent

        for i, is_ped in enumerate(kinds_is_pedestrian):
            body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            length, width = float(lengths_m[i]), float(widths_m[i])
            if is_ped:
                shape = pymunk.Circle(body, 0.5 * width)
                geom = fcl.Cylinder(0.5 * width, _TALL_M)
            else:
                shape = pymunk.Poly.create_box(body, (length, width))
                geom = fcl.Box(length, width, _TALL_M)
            shape.filter = pymunk.ShapeFilter(group=i + 1)
            self._ray_filters.append(pymunk.ShapeFilter(group=i + 1))
            self._cp_filter_owners.append(ffi.new("cpShapeFilter *", tuple(shape.filter)))
            self._bodies.append(body)
            self._shapes.append(shape)
            self.shape_label[shape] = i
            self._cp_label[shape._shape] = i
            self._add_fcl(geom, i)

        for k, poly in enumerate(static_polygons):
            shape = pymunk.Poly(self.space.static_body, [tuple(p) for p in poly])
            self.space.add(shape)
            self.shape_label[shape] = self.n_agents + k
            self._cp_label[shape._shape] = self.n_agents + k
            self._add_fcl(_prism(np.asarray(poly)), self.n_agents + k)

        # two broad-phase managers: agents (refitted every step) and statics (built once)
        self.manager = fcl.DynamicAABBTreeCollisionManager()
        self.manager.registerObjects(self._fcl_objects[: self.n_agents])
        self.manager.setup()
        self.static_manager = fcl.DynamicAABBTreeCollisionManager()
        self.static_manager.registerObjects(self._fcl_objects[self.n_agents:])
        self.static_manager.setup()
        self._registered = np.ones(self.n_agents, dtype=bool)
        polys = [np.asarray(p) for p in static_polygons]
        self._signature = (np.asarray(kinds_is_pedestrian, dtype=bool).copy(),
                           np.asarray(lengths_m, dtype=np.float64).copy(),
                           np.asarray(widths_m, dtype=np.float64).copy(),
                           [p.copy() for p in polys])
        self._static_min = np.array([p.min(axis=0) for p in polys], np.float64).reshape(-1, 2)
        self._static_max = np.array([p.max(axis=0) for p in polys], np.float64).reshape(-1, 2)
        # passed by value to chipmunk: a ready struct converts faster than a ShapeFilter tuple
        self._cp_filters = [owner[0] for owner in self._cp_filter_owners]

    def matches(self, kinds_is_pedestrian, lengths_m, widths_m, static_polygons) -> bool:
        """True if this mirror was built from exactly these agents and static polygons.

        Then `restore()` makes it as good as a new one: the world reuses it across resets
        instead of rebuilding the fcl solids and pymunk shapes (whose native memory is not all
        given back).

        Args:
            kinds_is_pedestrian: (n,) bool.
            lengths_m: (n,) footprint lengths [m].
            widths_m: (n,) footprint widths [m].
            static_polygons: convex polygons (V, 2) [m].
        """
        kinds, lengths, widths, polys = self._signature
        statics = [np.asarray(p) for p in static_polygons]
        return (np.array_equal(kinds, np.asarray(kinds_is_pedestrian, dtype=bool))
                and np.array_equal(lengths, np.asarray(lengths_m, dtype=np.float64))
                and np.array_equal(widths, np.asarray(widths_m, dtype=np.float64))
                and len(polys) == len(statics)
                and all(np.array_equal(a, b) for a, b in zip(polys, statics)))

    def restore(self) -> None:
        """Every agent back in the fcl broad phase (the next `sync` re-adds the pymunk bodies)."""
        for i in np.flatnonzero(~self._registered).tolist():
            self.manager.registerObject(self._fcl_objects[i])
        self._registered[:] = True
        self.manager.update()

    def _add_fcl(self, geom, label: int) -> None:
        self._geoms.append(geom)
        self._geom_label[id(geom)] = label
        self._fcl_objects.append(fcl.CollisionObject(geom, fcl.Transform()))

    def sync(self, xy: np.ndarray, heading: np.ndarray, active: np.ndarray) -> None:
        """Move every active agent's pymunk body and fcl object to its pose; remove inactive ones.

        The pymunk bodies move now (every step's rays need them); the fcl objects when fcl is
        next asked (`contacts` past its bounding-circle check, `distance`): most steps nothing
        can touch and fcl is never asked.

        Args:
            xy: (n, 2) agent centres [m].
            heading: (n,) agent headings [rad].
            active: (n,) bool, False for agents to remove.
        """
        space_ptr = self.space._space
        self._fcl_pose = (np.array(xy, dtype=np.float64), np.array(heading, dtype=np.float64))
        for i, (x, y), a, active_i in zip(range(self.n_agents), xy.tolist(),
                                          np.asarray(heading).tolist(), active.tolist()):
            if not active_i:
                self._deactivate(i)
                continue
            if not self._in_space[i]:
                self.space.add(self._bodies[i], self._shapes[i])
                self._in_space[i] = True
            # chipmunk's setters (what pymunk's Body.position / Body.angle call), then reindex
            # so that ray queries see the new pose
            body_ptr = self._bodies[i]._body
            lib.cpBodySetPosition(body_ptr, (x, y))
            lib.cpBodySetAngle(body_ptr, a)
            lib.cpSpaceReindexShapesForBody(space_ptr, body_ptr)

    def _sync_fcl(self) -> None:
        """Move the fcl objects of the agents in the broad phase to the last synced poses."""
        if self._fcl_pose is None:
            return
        xy, heading = self._fcl_pose
        half = 0.5 * heading
        qw, qz = np.cos(half).tolist(), np.sin(half).tolist()
        for i, (x, y), registered in zip(range(self.n_agents), xy.tolist(),
                                         self._registered.tolist()):
            if registered:
                self._fcl_objects[i].setTransform(
                    fcl.Transform([qw[i], 0.0, 0.0, qz[i]], [x, y, 0.0]))
        self.manager.update()
        self._fcl_pose = None

    def _deactivate(self, i: int) -> None:
        if self._in_space[i]:
            self.space.remove(self._bodies[i], self._shapes[i])
            self._in_space[i] = False
        if self._registered[i]:
            self.manager.unregisterObject(self._fcl_objects[i])
            self._registered[i] = False

    def first_hit(self, start, end, observer: int) -> tuple[int, float]:
        """First shape hit by the segment start->end, ignoring the observer's own shape.

        This is chipmunk's cpSpaceSegmentQueryFirst, the call behind pymunk's
        `Space.segment_query_first`, made directly through pymunk's cffi binding with a reused
        result buffer: the wrapper's per-call allocations cost more than the query itself
        (see docs/benchmarks.md). tests/sim/test_geometry.py checks that both agree.

        Args:
            start: (x, y) tuple, start of the segment [m].
            end: (x, y) tuple, end of the segment [m].
            observer: label of the agent whose shape is ignored.

        Returns:
            (label, alpha): label of the shape hit (-1 if none), alpha in [0, 1] along the
            segment (1.0 if none).
        """
        hit = lib.cpSpaceSegmentQueryFirst(
            self.space._space, start, end, 0.0, self._ray_filters[observer], self._query_info
        )
        if hit == ffi.NULL:
            return -1, 1.0
        return self._cp_label[hit], self._query_info.alpha

    def first_hits(self, start: np.ndarray, end: np.ndarray, observer: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
        """`first_hit` of many segments, one chipmunk query each, no per-ray Python call.

        Args:
            start: (R, 2) segment starts [m].
            end: (R, 2) segment ends [m].
            observer: (R,) int, label of the agent whose shape each segment ignores.

        Returns:
            labels (R,) int (-1 where nothing is hit) and alpha (R,) in [0, 1] (1.0 where
            nothing is hit).
        """
        query, space, info = lib.cpSpaceSegmentQueryFirst, self.space._space, self._query_info
        filters, label_of = self._cp_filters, self._cp_label
        starts, ends = _cp_vects(start), _cp_vects(end)
        labels = [-1] * len(observer)
        alpha = [1.0] * len(observer)
        for r, o in enumerate(np.asarray(observer).tolist()):
            hit = query(space, starts[r], ends[r], 0.0, filters[o], info)
            if hit:
                labels[r] = label_of[hit]
                alpha[r] = info.alpha
        return np.array(labels, dtype=np.int64), np.array(alpha, dtype=np.float64)

    def fan_alphas(self, origin: np.ndarray, observer: np.ndarray, end: np.ndarray
                   ) -> np.ndarray:
        """`first_hits` alphas of fans of rays: R rays from each observer's centre.

        The same chipmunk queries in the same order as `first_hits` on the repeated starts,
        with the per-observer start and filter looked up once per fan.

        Args:
            origin: (A, 2) the observers' centres [m].
            observer: (A,) int, their labels (each fan ignores its observer's shape).
            end: (A * R, 2) ray ends [m], observer by observer.

        Returns:
            (A * R,) alpha in [0, 1] along each ray (1.0 where nothing is hit).
        """
        query, space, info = lib.cpSpaceSegmentQueryFirst, self.space._space, self._query_info
        filters = self._cp_filters
        origins, ends = _cp_vects(origin), _cp_vects(end)
        n_obs = len(observer)
        per = len(end) // n_obs if n_obs else 0
        alpha = [1.0] * len(end)
        for k, o in enumerate(np.asarray(observer).tolist()):
            start, ray_filter = origins[k], filters[o]
            for r in range(k * per, (k + 1) * per):
                if query(space, start, ends[r], 0.0, ray_filter, info):
                    alpha[r] = info.alpha
        return np.array(alpha, dtype=np.float64)

    def hits_targets(self, start: np.ndarray, end: np.ndarray, observer: np.ndarray,
                     target: np.ndarray) -> tuple[np.ndarray, int]:
        """Whether each segment's first hit is its target: rays from observers to targets.

        The rays of one (observer, target) pair must be consecutive; once one of them hits its
        target, the pair's remaining rays are not queried (False).

        Args:
            start: (R, 2) segment starts [m].
            end: (R, 2) segment ends [m] (sample points on the targets).
            observer: (R,) int, label of the agent whose shape each segment ignores.
            target: (R,) int, label of the agent each segment aims at.

        Returns:
            (R,) bool and the number of chipmunk queries made.
        """
        query, space, info = lib.cpSpaceSegmentQueryFirst, self.space._space, self._query_info
        filters, label_of = self._cp_filters, self._cp_label
        seen = [False] * len(observer)
        found, n_queries = None, 0
        starts, ends = _cp_vects(start), _cp_vects(end)
        for r, o, t in zip(range(len(observer)), np.asarray(observer).tolist(),
                           np.asarray(target).tolist()):
            if found == (o, t):
                continue
            n_queries += 1
            hit = query(space, starts[r], ends[r], 0.0, filters[o], info)
            if hit and label_of[hit] == t:
                seen[r] = True
                found = (o, t)
        return np.array(seen, dtype=bool), n_queries

    def contacts(self, xy=None, bounding_radius=None, active=None) -> list[tuple[int, int]]:
        """All touching pairs (label_a < label_b), agent-agent and agent-static.

        The pairs come from the fcl broad-phase managers. If the agents' centres xy (n, 2) [m], bounding radii (n,) [m] and active mask (n,) are
        given, fcl is skipped when no two bounding circles (or circle and static box) overlap:
        then nothing can touch.
        """
        if xy is not None and not self._bounds_may_touch(xy, bounding_radius, active):
            return []
        self._sync_fcl()
        request = fcl.CollisionRequest(num_max_contacts=10_000, enable_contact=False)
        data = fcl.CollisionData(request=request)
        self.manager.collide(data, fcl.defaultCollisionCallback)
        if len(self._static_min):
            self.manager.collide(self.static_manager, data, fcl.defaultCollisionCallback)
        pairs = set()
        for contact in data.result.contacts:
            a = self._geom_label[id(contact.o1)]
            b = self._geom_label[id(contact.o2)]
            if a != b and min(a, b) < self.n_agents:  # static-static pairs are not contacts
                pairs.add((min(a, b), max(a, b)))
        return sorted(pairs)

    def _bounds_may_touch(self, xy, radius, active) -> bool:
        """Whether two active agents' bounding circles, or one and a static box, overlap.

        Args:
            xy: (n, 2) agent centres [m].
            radius: (n,) bounding radii [m].
            active: (n,) bool; inactive agents touch nothing.
        """
        key = active.tobytes() + radius.tobytes()
        if key != self._touch_key:  # squared reaches, per pair and per agent, of this active set
            pairs = self._off_diagonal & active[:, None] & active[None, :]
            reach = radius[:, None] + radius
            self._touch_key = key
            self._touch = (reach * reach, pairs, np.where(active, radius * radius, -1.0))
        reach2, pairs, radius2 = self._touch
        # compiled (sim/geometry_kernels.py): the pairs' squared distances against reach2,
        # then each centre's gap to each static box against radius2
        return geometry_kernels().bounds_may_touch(xy, reach2, pairs, self._static_min,
                                                   self._static_max, radius2)

    def distance(self, label_a: int, label_b: int) -> float:
        """Exact fcl distance between two labelled solids [m] (0 when they overlap)."""
        self._sync_fcl()
        result = fcl.DistanceResult()
        d = fcl.distance(
            self._fcl_objects[label_a], self._fcl_objects[label_b], fcl.DistanceRequest(), result
        )
        return max(float(d), 0.0)

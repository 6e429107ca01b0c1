"""Right of way at conflict zones: the robot keeps out of a zone it yields at while a car comes.

The robot's route passes conflict zones of the map (sim/route_rules.route_conflicts); where it
yields (its route enters the zone on none of the zone's priority lanes), a car with the right of
way there (a predicted object travelling along one of the zone's priority lanes now,
route_rules.priority_mask) claims the whole stretch [s_enter_m, s_exit_m] of the robot's route
through the zone for the plan steps in which it is predicted in the zone (its centre within
half its length of the zone's outline).

Each claim is one corridor object (agents/robot/corridor.PathObject) of the branch whose scene
predicts that car: a tracked car in every branch, a hypothesised hidden car
(perception/belief, `hypothesis_objects`) only in its own hypothesis' branch. The MPC then,
per branch, either keeps the robot's front `min_gap_m` short of the zone while it is claimed
("behind": it waits until the car has passed), or has the robot's rear out of the zone
`pass_margin_s` (2.5 s) before the claim starts ("past": the margin covers the 2 s within
which a car reaching the zone means the robot did not give way, metrics/physical.yielded).
So the contingency MPC gives way to every car it believes may come, weighed by its belief, and
pulls out only where it can clear the zone well before the car arrives.

A *merge* (the robot's route leaves the zone along one of its priority lanes: a right turn into
the lane of the traffic it yields to) is car following, not a crossing: the car with the right
of way ends up behind or ahead of the robot in the same lane. Its claim is the car itself, its
predicted position along the lane mapped onto the robot's route (from the step its front reaches
the zone on): "behind", the robot follows it (front `min_gap_m` short of its rear, and of the
zone while its rear is short of the zone: mapped onto the robot's route before the join, the
rear would lie on the robot's approach, not on the car's lane); "past", the robot's rear stays
`min_gap_m` ahead of where the car's front would be if it kept its speed until the robot's front
can first be in its lane (`RightOfWay.lane_entry_s`: from the robot's speed at its acceleration
limit, round the bend at its curve speed) plus `follower_reaction_s`, and then slowed for the
robot at `follower_decel_mps2` (a gap a follower keeps by braking at most that hard: once it has
slowed to the robot's speed it only follows). The robot merges in front of a car only where that
car need not brake harder than a comfortable follower does. The simulated followers react to the
robot as it straightens into their lane, not as it pulls out: at the signalled junction of paper
Fig. 1 c, their braking began within 0.4 s of the robot's heading coming within 15 degrees of the
lane's, 3.7-6.6 s after it pulled out (a follower modelled as braking 2 s after each plan's
start let the robot merge where the follower then braked at 3-6 m/s^2, in 14 of 300 fresh
seeds).

A zone the robot's front has entered by more than `committed_m` is not claimed against it any
more: it is committed and clears the zone (stopping inside would block the car with the right
of way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.agents.robot.corridor import (
    PathObject,
    curvature_speed_bound,
    occupied_spans,
    route_curvature,
)
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.route_rules import RouteConflict, on_lanes, priority_mask, route_conflicts


@dataclass(frozen=True)
class RightOfWayConfig:
    """When a zone is no longer claimed against the robot, and what a merge asks of a follower.

    Attributes:
        committed_m: the robot's front this far into the zone (past s_enter_m) is committed:
            the zone is no longer claimed against it [m], >= 0.
        follower_decel_mps2: at a merge, the braking the robot may ask of a car it merges in
            front of [m/s^2], > 0.
        follower_reaction_s: ... which starts braking this long after the robot's front can
            first be in its lane [s], >= 0 (`RightOfWay.lane_entry_s`: the followers react as
            the robot straightens into their lane, not as it pulls out; measured in the signal
            claims' forced seeds: braking onset within 0.4 s of the robot's heading coming
            within 15 degrees of the lane's).
    """

    committed_m: float = 0.0
    follower_decel_mps2: float = 2.0
    follower_reaction_s: float = 0.0

    def __post_init__(self):
        if not self.committed_m >= 0.0:
            raise ValueError(f"RightOfWayConfig.committed_m must be >= 0, got {self.committed_m}")
        if not self.follower_decel_mps2 > 0.0:
            raise ValueError("RightOfWayConfig.follower_decel_mps2 must be > 0, got "
                             f"{self.follower_decel_mps2}")
        if not self.follower_reaction_s >= 0.0:
            raise ValueError("RightOfWayConfig.follower_reaction_s must be >= 0, got "
                             f"{self.follower_reaction_s}")


class RightOfWay:
    """The zones on the robot's route where it yields, and the claims on them (module docstring).

    Args:
        route: the robot's route.
        road_map: the static map the robot may know (its conflict zones and lanes).
        robot_length_m: the robot's length [m] (the claims bound its front and rear).
        config: when a car claims a zone (default RightOfWayConfig()).
        accel_max_mps2: the robot's largest acceleration [m/s^2] (`lane_entry_s`; default
            VehicleParams().accel_max_mps2).
        lat_accel_max_mps2: the lateral acceleration its MPC allows in bends [m/s^2]
            (`lane_entry_s`; default MpcConfig().lat_accel_max_mps2).
    """

    def __init__(self, route: Route, road_map: RoadMap, robot_length_m: float,
                 config: RightOfWayConfig | None = None, accel_max_mps2: float | None = None,
                 lat_accel_max_mps2: float | None = None):
        self.config = config or RightOfWayConfig()
        self.road_map = road_map
        self.conflicts: tuple[RouteConflict, ...] = tuple(
            c for c in route_conflicts(route, road_map) if c.yields)
        # per conflict: (the priority lane's path, the lane's arc length where the robot's route
        # joins it) for a merge, None for a crossing
        self.merges = tuple(_merge_lane(route, road_map, c) for c in self.conflicts)
        self._half = 0.5 * robot_length_m
        self.accel_max_mps2 = float(VehicleParams().accel_max_mps2 if accel_max_mps2 is None
                                    else accel_max_mps2)
        self.lat_accel_max_mps2 = float(MpcConfig().lat_accel_max_mps2
                                        if lat_accel_max_mps2 is None else lat_accel_max_mps2)
        self._vertex_s, self._vertex_kappa = route_curvature(route)

    def lane_entry_s(self, conflict: RouteConflict, s0: float, v0: float) -> float:
        """The earliest time the robot's front can reach the end of a merge zone [s].

        Where the robot's route joins the lane: from speed v0, accelerating at accel_max_mps2
        up to the curve speed sqrt(lat_accel_max_mps2 / kappa) of the route's sharpest bend
        between its front and the zone's end (at most the speed limit), then at that speed.
        A robot at or above that speed covers the rest at it; 0 once its front is there.

        Args:
            conflict: the merge zone on the robot's route.
            s0: the robot's arc length along its route (footprint centre) [m].
            v0: its speed [m/s].
        """
        front = s0 + self._half
        distance = conflict.s_exit_m - front
        if distance <= 0.0:
            return 0.0
        # the MPC's curve speed bound over [front, s_exit_m] (no footprint window), capped
        bound, _ = curvature_speed_bound(self._vertex_s, self._vertex_kappa, np.array([front]),
                                         np.array([conflict.s_exit_m]), 0.0,
                                         self.lat_accel_max_mps2, self.road_map.speed_limit_mps)
        v_curve = float(bound[0])
        v0 = max(float(v0), 0.0)
        if v0 >= v_curve:
            return distance / v_curve
        a = self.accel_max_mps2
        t_ramp = (v_curve - v0) / a
        d_ramp = 0.5 * (v0 + v_curve) * t_ramp
        if d_ramp >= distance:
            return (math.sqrt(v0 * v0 + 2.0 * a * distance) - v0) / a
        return t_ramp + (distance - d_ramp) / v_curve

    def claims(self, scene: ScenePrediction, s0: float, v0: float, times_s: np.ndarray
               ) -> list[list[PathObject]]:
        """Per hypothesis of `scene`, the zone claims of the cars with the right of way.

        Args:
            scene: the predicted objects (L hypotheses, M objects, N plan steps).
            s0: the robot's arc length along its route (footprint centre) [m].
            v0: its speed [m/s] (when a follower at a merge starts braking, `lane_entry_s`).
            times_s: (N,) the plan steps' times [s].

        Returns:
            L lists of PathObject (one per claiming car and zone). A crossing: s_rear_m = the
            zone's s_enter_m, s_front_m = its s_exit_m along the robot's route. A merge: the
            car along the robot's route (s_rear_m its rear, at least the zone's s_enter_m;
            s_front_m where its front is if it slows for the robot; module docstring),
            pass_margin False.
        """
        n_hyp, n_obj = scene.mask.shape
        out: list[list[PathObject]] = [[] for _ in range(n_hyp)]
        if n_obj == 0 or not self.conflicts:
            return out
        n_t = scene.xy.shape[2]
        vehicle = scene.mask & ~scene.is_pedestrian  # (L, M)
        if not vehicle.any():
            return out
        front = s0 + self._half
        active = [(conflict, merge) for conflict, merge in zip(self.conflicts, self.merges)
                  if front <= conflict.s_enter_m + self.config.committed_m]  # else committed
        if not active:
            return out
        src_l, src_m = np.nonzero(vehicle)  # (P,) the (hypothesis, car) pairs, in order
        source = np.arange(len(src_l))  # (P,) each pair's index into the unique pairs
        u_l, u_m = src_l, src_m  # (U,) the unique pairs
        if n_hyp > 1 and (vehicle.sum(axis=0) > 1).any():
            # a car predicted alike in several hypotheses (a tracked one) is computed once:
            # from the first hypothesis with that car, where predicted alike
            first = np.argmax(vehicle, axis=0)[src_m]  # (P,)
            alike = (np.all(scene.xy[src_l, src_m] == scene.xy[first, src_m], axis=(1, 2))
                     & np.all(scene.heading[src_l, src_m] == scene.heading[first, src_m],
                              axis=1)
                     & (scene.length_m[src_l, src_m] == scene.length_m[first, src_m]))
            unique = ~alike | (src_l == first)
            index = np.full((n_hyp, n_obj), -1)
            index[src_l[unique], src_m[unique]] = np.arange(int(unique.sum()))
            source = index[np.where(alike, first, src_l), src_m]
            u_l, u_m = src_l[unique], src_m[unique]
        for conflict, merge in active:
            zone = conflict.zone
            xy0 = scene.xy[u_l, u_m, 0]  # (U, 2) the first predicted pose
            has_way = priority_mask(zone, self.road_map, xy0, scene.heading[u_l, u_m, 0])
            if not has_way.any():
                continue
            way = np.flatnonzero(has_way)  # the unique pairs with the right of way
            # in the zone: its footprint's centre within half its length of the outline
            margin = 0.5 * scene.length_m[u_l[way], u_m[way]]  # (W,)
            xy = scene.xy[u_l[way], u_m[way]]  # (W, N, 2)
            if merge is not None:
                reaction = (self.lane_entry_s(conflict, s0, v0)
                            + self.config.follower_reaction_s)
                made = self._merge_claims(conflict, merge, xy, margin, times_s, reaction)
            else:
                claimed = _inside(zone, xy, margin)  # (W, N)
                s_rear = np.full(n_t, conflict.s_enter_m)
                s_front = np.full(n_t, conflict.s_exit_m)
                made = [None] * len(way)
                for w, first, last in occupied_spans(claimed):
                    made[w] = PathObject(claimed[w], s_rear, s_front, first, last)
            if all(obj is None for obj in made):
                continue
            claim = [None] * len(u_l)
            for w, obj in zip(way.tolist(), made):
                claim[w] = obj
            for l, u in zip(src_l.tolist(), source.tolist()):
                if claim[u] is not None:
                    out[l].append(claim[u])
        return out

    def _merge_claims(self, conflict: RouteConflict, merge: tuple, xy: np.ndarray,
                      half_length_m: np.ndarray, times_s: np.ndarray, reaction_s: float
                      ) -> list:
        """The claims of W cars at a merge (module docstring): W PathObjects or None.

        Args:
            conflict: the merge zone on the robot's route.
            merge: (the priority lane's path, its arc length where the robot's route joins it).
            xy: (W, N, 2) their predicted positions [m].
            half_length_m: (W,) half their lengths [m].
            times_s: (N,) the plan steps' times [s].
            reaction_s: when a follower starts braking for the robot, from now [s].
        """
        lane, s_join = merge
        c = self.config
        s_lane, _ = lane.project_xy(xy[..., 0], xy[..., 1])  # (W, N) along the lane [m]
        centre = conflict.s_exit_m + (s_lane - s_join)  # ... along the robot's route [m]
        rear = centre - half_length_m[:, None]
        front = centre + half_length_m[:, None]
        # where its front would be if it slowed for the robot (speeds between plan steps)
        t = np.asarray(times_s, dtype=np.float64)
        dt = t[1:] - t[:-1]  # (N-1,) between plan steps [s]
        speed = (s_lane[:, 1:] - s_lane[:, :-1]) / dt  # (W, N-1) [m/s]
        slowed = np.maximum(speed - c.follower_decel_mps2
                            * np.maximum(t[1:] - reaction_s, 0.0), 0.0)
        advance = np.zeros(s_lane.shape)  # (W, N) from the first step [m]
        np.cumsum(slowed * dt, axis=1, out=advance[:, 1:])
        yielding_front = front[:, :1] + advance
        # it has reached the zone; a car already past the join is a car ahead (the corridor's)
        claimed = (front >= conflict.s_enter_m) & (rear[:, :1] <= conflict.s_exit_m)  # (W, N)
        # following it, the robot's front stays short of its rear, and of the zone until its rear
        # is in there: before the join, the car's rear mapped onto the robot's route lies on
        # the robot's approach, not on the car's lane (measured: a robot rolling past its sight
        # hold point, 2.3 m short of the zone, could not stay a car length short of it once a
        # hidden-car branch became live and braked at 8 m/s^2)
        follow = np.maximum(rear, conflict.s_enter_m)
        made = [None] * len(claimed)
        for p, first, last in occupied_spans(claimed):
            made[p] = PathObject(claimed[p], follow[p], yielding_front[p], first, last,
                                 pass_margin=False)
        return made


def _merge_lane(route: Route, road_map: RoadMap, conflict: RouteConflict
                ) -> tuple[Route, float] | None:
    """(the priority lane's path, its arc length at the join) at a merge, else None.

    A merge: `route` leaves `conflict`'s zone along one of the zone's priority lanes.
    """
    xy, heading = route.point_at(np.array([conflict.s_exit_m]))
    for i in conflict.zone.priority_lanes:
        lane = road_map.lanes[i]
        if on_lanes([lane], xy, heading)[0]:
            path = Route(lane.centerline, lane.name or f"lane {i}")
            return path, float(path.project(xy)[0][0])
    return None


def _inside(zone, xy: np.ndarray, margin_m: np.ndarray) -> np.ndarray:
    """(P, N) bool: points xy (P, N, 2) [m] inside `zone` grown by margin_m (P,) [m]."""
    a = zone.polygon
    edge = np.roll(a, -1, axis=0) - a  # (V, 2)
    length = np.linalg.norm(edge, axis=1)
    rel = xy[..., None, :] - a  # (P, N, V, 2)
    cross = (edge[:, 0] * rel[..., 1] - edge[:, 1] * rel[..., 0]) / length
    return np.all(cross >= -margin_m[:, None, None], axis=-1)

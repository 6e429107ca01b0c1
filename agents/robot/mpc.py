"""Probabilistic contingency MPC (paper section IV-A) as a quadratic program.

The structure is that of Zhan et al. 2016 ("non-conservatively defensive" planning) and of
Alsterda & Gerdes, "Contingency MPC for automated vehicles" (ACC 2019): along its route
(path-velocity decomposition) the robot plans one acceleration profile per live hypothesis l
(b_l >= epsilon, renormalized) over a horizon that holds a comfortable stop; the first
`trunk_s` is shared by every branch (non-anticipativity: it is what is executed before the next
observation). The expected cost

    J = sum_l b_l dt sum_k [w_v (v - v_ref)^2 + w_a a^2 + w_j jerk^2 + w_c c^2]

is minimized subject to every branch's constraints (agents/robot/qp.py): speed in [0, v_max]
with v_max from the speed limit and the route's curvature (v^2 kappa <= a_lat), the vehicle's
acceleration and jerk bounds, and per predicted object of that branch's scene that occupies the
robot's corridor (agents/robot/corridor.py) either "stay behind it" (with a time headway: car
following) or "be past it before it arrives" (with a time margin). Each branch picks the
cheapest feasible combination of these modes (one small QP per combination, only when more than
one is plausible), then the joint QP is solved once. Every live hypothesis must be safe
(defensive); each one's cost counts with its belief (not overly conservative). If no plan meets
the jerk bound (a constraint that appeared suddenly), the jerk bound gives way first
(MpcResult.jerk_relaxed). If no plan is feasible even then because of a hidden agent it has not
seen (a contingency branch's own object, not a pedestrian, not in every branch), that object's
bound gives way to where a comfortable stop gets the robot, or if that still conflicts with the
branch's other objects (a car it passes in front of, with the hidden one behind it in its lane),
the object is left out (MpcResult.contingency_given_way): a hypothesised car it can no longer
stop for, even at its limit, is not met with an emergency stop (a car that comes into view is
then a tracked object like any other). Only if no plan is feasible even then does the robot brake as hard as it can,
flagged in MpcResult.feasible.

Comfort (Alsterda & Gerdes): a contingency branch (a hypothesis not seen to be true) may brake
harder than `comfort_decel_mps2` only at the price w_c c^2, c the deceleration beyond it (a
soft bound, so that feasibility is that of the vehicle's limits); what the robot sees is met
by the nominal cost (w_a, w_j: a smooth onset) alone, except a pedestrian that steps off the
curb as a branch prepared for (agents/robot/curb.py, `prepared_comfort`: the comfort weight,
by how long it was prepared for). A likely contingency that would need hard braking
therefore slows the shared trunk early: the branch "the pedestrian on the curb steps off now" (agents/robot/curb.py), or a
hidden pedestrian the belief gives weight to, is met with a comfortable stop if it comes true.
The robot also stays behind the stop line of a stop sign it has not yet stopped at
(agents/robot/stop.py, `stop_at_m`); at rest it may always stay where it stands (noise that
moves a bound behind it does not make it infeasible).

Weights (SI, per second of plan), tuned on the paper's scenario over its wide randomization:
w_v = 1 / (m/s)^2 (1 m/s too slow for a second costs 1), w_a = 10 / (m/s^2)^2 (braking at
2 m/s^2 costs 40 per second: a stop spreads its deceleration over the distance available,
about v^2 / 2d, not the limit), w_j = 2 / (m/s^3)^2 (onsets over about a second). The hard
jerk bound 15 m/s^3 is the brake actuator's; the time headway 1 s is ramped in over 3 s (a gap
already short stays feasible) and grows to 1.5 s on the last step (room to stop beyond the
horizon). Pedestrians have the right of way: one walking towards the robot's path is in its
way from the next lane on, and the robot passes in front of one only if it cannot stop.
Comfort: 2.5 m/s^2 (margin for replanning: the oracle then brakes <= 3 m/s^2 in 150 of 150 seeds)
with w_c = 100 / (m/s^2)^2: 1 m/s^2 beyond it for a second, in a branch of weight 0.2, costs 20,
as much as driving 2 m/s slower for 5 s.
"""

from __future__ import annotations

import itertools

import numpy as np

from marl_social.agents.robot.corridor import (
    BEHIND,
    PAST,
    Clearances,
    PathObject,
    StaticObstacles,
    corridor_kernels,
    curvature_speed_bound,
    full_acceleration_progress,
    mode_bounds,
    objects_on_path,
    past_reachable,
    provably_infeasible,
    reachable_progress,
    route_curvature,
)
from marl_social.agents.robot.give_way import comfortable_stop_meets, contingencies_given_way
from marl_social.agents.robot.mpc_types import BrakingStart, MpcConfig, MpcResult, PlanRequest
from marl_social.agents.robot.qp import ContingencyQp
from marl_social.agents.robot.qp_types import QpInstance, QpSolution, QpWeights
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import Route

MAX_MODE_OBJECTS = 3  # per branch, objects beyond this many with two plausible modes stay behind
INFEASIBLE_MARGIN_M = 0.5  # bounds violated by more than this even at best skip the QP [m]
ROOM_M = 0.1  # a stay-behind bound gives way to where braking gets the robot plus this [m]
STANDSTILL_MARGIN_M = 0.05  # at rest, plans going no further than the room + this stay [m]


class ContingencyMpc:
    """The robot's MPC: holds one warm-started QP per number of branches.

    Args:
        config: the MPC configuration.
        vehicle: the robot's physical parameters (acceleration limits, footprint).
    """

    def __init__(self, config: MpcConfig, vehicle: VehicleParams):
        self.config, self.vehicle = config, vehicle
        self._qps: dict[int, ContingencyQp] = {}
        self._mode_qp: ContingencyQp | None = None
        self._curvature: tuple[Route, tuple[np.ndarray, np.ndarray]] | None = None
        # the static boxes projected on the route, per (route, boxes array): they do not move
        self._static: tuple[Route, np.ndarray | None, StaticObstacles] | None = None
        self._headway = config.headway_s()
        self._plan_times = config.plan_times_s
        # (N,) the speed braking at half the limit loses by the end of each step [m/s]
        self._brake_decel = 0.5 * vehicle.brake_max_mps2 * self._plan_times
        self._n_steps = config.n_steps  # N (a property computed at each access)
        self._reach = np.zeros(self._n_steps)  # _braking_reach(v0), set by plan
        # reachable_progress of this plan's state per (speed bound array, jerk bound): every
        # mode and joint QP of one curvature iteration shares them (reset by plan)
        self._reachable: list[tuple[np.ndarray, float, np.ndarray]] = []
        self._full: tuple[np.ndarray, np.ndarray] | None = None  # set by _full_progress
        self._comfort = np.ones(0)  # (L,) comfort weight factor per hypothesis, set by plan
        self._goal = (0.0, 0.0)  # the pull-up term (weight, progress to the line), set by plan
        # the previous plan's (s0, v0, prev_accel), one simulator step before the next
        # (MpcResult.surprise_infeasible); None: no plan yet this episode
        self._previous: tuple[float, float, float] | None = None

    def reset(self) -> None:
        """Forget the QPs (their warm starts and step sizes): a new episode, bit-identical."""
        self._qps.clear()
        self._mode_qp = None
        self._previous = None

    def _new_qp(self, n_branches: int) -> ContingencyQp:
        """A fresh QP of n_branches branches (its layout's structure built once per process)."""
        c = self.config
        return ContingencyQp(n_branches, c.n_steps, c.n_trunk, c.plan_dt_s, DT_S,
                             QpWeights(c.w_speed, c.w_accel, c.w_jerk, c.w_comfort),
                             c.headway_s())

    def build_layouts(self, max_branches: int) -> None:
        """Build the QP layouts of 1..max_branches branches now, not at their first plan.

        A layout's structure (qp.py: index maps, A, the condensed or tree form; 5-140 ms,
        and the tree solver's kernels loaded with the first 3+-branch one) depends only on
        the number of branches and this configuration; it is kept process-wide, so that a
        plan that meets a new number of live branches does not build it within its decision.
        The QPs themselves (warm starts) stay per episode (`reset`).

        Args:
            max_branches: the largest number of branches built ahead (more are built when met).
        """
        for n_branches in range(1, max_branches + 1):
            self._new_qp(n_branches)

    def _qp(self, n_branches: int, for_modes: bool = False) -> ContingencyQp:
        if for_modes:
            if self._mode_qp is None:
                self._mode_qp = self._new_qp(n_branches)
            return self._mode_qp
        if n_branches not in self._qps:
            self._qps[n_branches] = self._new_qp(n_branches)
        return self._qps[n_branches]

    def _speed_bound(self, route: Route, s_lo: np.ndarray, s_hi: np.ndarray,
                     v_cap: float) -> tuple[np.ndarray, bool]:
        """(N,) speed bounds [m/s] for positions in [s_lo, s_hi] (N,) [m]; whether any curve."""
        c = self.config
        if self._curvature is None or self._curvature[0] is not route:
            self._curvature = (route, route_curvature(route))
        vertex_s, kappa = self._curvature[1]
        return curvature_speed_bound(vertex_s, kappa, s_lo, s_hi, c.curvature_window_m,
                                     c.lat_accel_max_mps2, v_cap)

    def plan(self, route: Route, request: PlanRequest) -> MpcResult:
        """One MPC solve.

        Args:
            route: the robot's route.
            request: where the robot is, the branches and their weights, the stop targets
                (mpc_types.PlanRequest).
        """
        r = request
        s0, v0, prev_accel, scene = r.s0, r.v0, r.prev_accel, r.scene
        v_ref_mps, speed_limit_mps, beliefs = r.v_ref_mps, r.speed_limit_mps, r.beliefs
        static_outlines, stop_at_m, contingent = r.static_outlines, r.stop_at_m, r.contingent
        extra_objects, pull_up_to_m = r.extra_objects, r.pull_up_to_m
        c, veh = self.config, self.vehicle
        self._goal = ((c.w_pull_up, pull_up_to_m - s0) if np.isfinite(pull_up_to_m)
                      else (0.0, 0.0))
        beliefs = np.asarray(beliefs, dtype=np.float64)
        self._comfort = (np.ones(len(beliefs)) if contingent is None
                         else np.asarray(contingent, dtype=np.float64))
        live = beliefs >= c.epsilon
        if not live.any():
            live = beliefs == beliefs.max()
        weights = np.where(live, beliefs, 0.0)
        weights = weights / weights.sum()
        n = self._n_steps
        v_cap = min(speed_limit_mps, veh.speed_max_mps)
        v_ref = min(v_ref_mps, v_cap)
        # a braking command larger than the speed left is realized only in part (v >= 0)
        prev_accel = max(prev_accel, -v0 / DT_S)
        if (self._static is None or self._static[0] is not route
                or self._static[1] is not static_outlines):
            self._static = (route, static_outlines, StaticObstacles.project(
                route, static_outlines, veh.width_m, c.lateral_margin_m))
        wall = (self._static[2].limit(s0, veh.length_m) - c.min_gap_m - 0.5 * veh.length_m
                - s0)
        wall = min(wall, stop_at_m - s0)
        # only the live branches' objects are planned for: the others are not projected
        per_hyp = objects_on_path(route, scene, s0, veh.length_m, veh.width_m,
                                  Clearances(c.lateral_margin_m, c.pedestrian_margin_m,
                                             c.pedestrian_clearance_m),
                                  scene.mask & live[:, None])
        if extra_objects is not None:
            per_hyp = [objs + list(more) for objs, more in zip(per_hyp, extra_objects)]
        live_idx = np.flatnonzero(live)
        margin = round(c.pass_margin_s / c.plan_dt_s)
        self._reach = self._braking_reach(v0)  # _branch_bounds' room, for this v0
        self._reachable = []
        self._full = None  # _full_progress' (speed bound array, progress) of this plan
        # the curvature bound needs the positions, which the plan decides: guess them (constant
        # speed), solve, and widen the guess to the solution's positions until it holds them
        # or the wider guess bounds the speed as before (the same QP again)
        guess_lo = guess_hi = s0 + v0 * self._plan_times
        v_max, curved = self._speed_bound(route, guess_lo, guess_hi, v_cap)
        for _ in range(4):
            bounds = (v0, prev_accel, v_ref, v_max, wall, margin, s0)
            chosen, solution, relaxed, given_way = self._solve_all(per_hyp, live_idx, weights,
                                                                   bounds, v_cap)
            if not (curved and solution.solved):
                break
            lo = s0 + solution.progress_m.min(axis=0)
            hi = s0 + solution.progress_m.max(axis=0)
            if np.all(lo >= guess_lo - 0.5) and np.all(hi <= guess_hi + 0.5):
                break
            guess_lo, guess_hi = np.minimum(guess_lo, lo), np.maximum(guess_hi, hi)
            wider, curved = self._speed_bound(route, guess_lo, guess_hi, v_cap)
            if np.array_equal(wider, v_max):
                break
            v_max = wider
        modes = [()] * len(beliefs)
        for l, m in zip(live_idx, chosen):
            modes[l] = m
        previous, self._previous = self._previous, (s0, v0, prev_accel)
        if not solution.solved:
            nan = np.full((len(live_idx), n), np.nan)
            surprise = previous is not None and self._stop_meets_bounds(
                BrakingStart(*previous, DT_S), per_hyp, live_idx, bounds)
            return MpcResult(-veh.brake_max_mps2, False, live, weights, tuple(modes), nan,
                             nan.copy(), nan.copy(), np.inf, relaxed, surprise_infeasible=surprise)
        accel = float(solution.accel_mps2[0, 0])
        if v0 <= c.rest_mps and solution.progress_m.max() <= ROOM_M + STANDSTILL_MARGIN_M:
            # standstill: a robot at rest whose plans only use the room a bound gives way by
            # (_branch_bounds) stays where it is, slowing to rest over standstill_s, rather
            # than creeping on by that room at every step
            accel = min(accel, -v0 / c.standstill_s)
        return MpcResult(accel, True, live, weights, tuple(modes),
                         solution.accel_mps2, solution.speed_mps, solution.progress_m,
                         solution.cost, relaxed, contingency_given_way=given_way)

    def _solve_all(self, per_hyp, live_idx, weights, bounds, v_cap):
        """Modes per branch, then the joint QP, relaxing in order until a plan is feasible.

        1. Vehicles: the cheapest feasible mode; pedestrians: behind (they have the right of
           way). 2. Every object behind. 3. The same with the jerk bound relaxed (an emergency
        stop). 4. Pedestrians may be passed in front too, if the robot cannot stay behind, with
        the jerk bound, then without it. 5. The contingencies' own vehicles given way to a
        comfortable stop (`_contingencies_given_way`), the modes chosen as in 1, then every
        object behind, each with the jerk bound, then without it; the same with those objects
        left out.
        Returns (modes per live branch, the solution, whether the jerk bound was relaxed,
        whether contingencies were given way).
        """
        jerk_free = self.vehicle.brake_max_mps2 / DT_S
        chosen = [self._choose_modes(per_hyp[l], bounds, v_cap, False, l) for l in live_idx]
        solution = self._solve_joint(per_hyp, live_idx, weights, chosen, bounds)
        if not solution.solved and any(PAST in m for m in chosen):
            chosen = [tuple(BEHIND for _ in m) for m in chosen]
            solution = self._solve_joint(per_hyp, live_idx, weights, chosen, bounds)
        if solution.solved:
            return chosen, solution, False, False
        solution = self._solve_joint(per_hyp, live_idx, weights, chosen, bounds, jerk_free)
        if solution.solved:
            return chosen, solution, True, False
        crossing = [self._choose_modes(per_hyp[l], bounds, v_cap, True, l) for l in live_idx]
        if crossing != chosen:
            for jerk_max, relaxed in ((None, False), (jerk_free, True)):
                solution = self._solve_joint(per_hyp, live_idx, weights, crossing, bounds,
                                             jerk_max)
                if solution.solved:
                    return crossing, solution, relaxed, False
        eased, moved = self._contingencies_given_way(per_hyp, live_idx, bounds)
        if moved:
            # the modes chosen afresh with the moved objects (so that it still, say,
            # passes a car it passes in front of), then every object behind; then without the
            # moved objects (a hidden car it can neither stop for nor pass before the car it
            # passes in front of: in one lane, the two are one car)
            left_out = [[o for j, o in enumerate(objects) if (l, j) not in moved]
                        for l, objects in enumerate(per_hyp)]
            for objects in (eased, left_out):
                rechosen = [self._choose_modes(objects[l], bounds, v_cap, False, l)
                            for l in live_idx]
                behind = [tuple(BEHIND for _ in objects[l]) for l in live_idx]
                for modes in ([rechosen, behind] if rechosen != behind else [behind]):
                    for jerk_max, relaxed in ((None, False), (jerk_free, True)):
                        given_way = self._solve_joint(objects, live_idx, weights, modes, bounds,
                                                      jerk_max)
                        if given_way.solved:
                            return modes, given_way, relaxed, True
        return chosen, solution, True, False

    def _contingencies_given_way(self, per_hyp, live_idx, bounds) -> tuple[list, set]:
        """The contingencies' own vehicles given way to a comfortable stop from bounds' state.

        (give_way.contingencies_given_way; the rear floor: where braking at
        comfort_decel_mps2 gets the robot, plus the gap.)
        """
        c, veh = self.config, self.vehicle
        v0, s0 = bounds[0], bounds[6]
        reach = np.empty(self._n_steps)
        corridor_kernels().braking_reach(float(v0), c.comfort_decel_mps2 * self._plan_times,
                                         c.plan_dt_s, self._headway, ROOM_M, reach)
        rear_floor = s0 + reach + c.min_gap_m + 0.5 * veh.length_m
        return contingencies_given_way(per_hyp, live_idx, self._comfort, rear_floor)

    def _stop_meets_bounds(self, start: BrakingStart, per_hyp, live_idx, bounds) -> bool:
        """Whether braking comfortably from `start` meets this plan's stop bounds.

        The bounds a stop must meet: every live branch's with each object behind (the
        fallback modes of an infeasible plan), the tightest per step, and the speed bounds
        (comfortable_stop_meets).
        """
        tightest = np.full(self._n_steps, np.inf)
        for l in live_idx:
            _, s_up = self._branch_bounds(per_hyp[l], (BEHIND,) * len(per_hyp[l]), bounds)
            np.minimum(tightest, s_up, out=tightest)
        c, s0, v_max = self.config, bounds[6], bounds[3]
        return comfortable_stop_meets(start, s0 + tightest, v_max, self._plan_times,
                                      self._headway, c.comfort_decel_mps2, c.jerk_max_mps3)

    def _braking_reach(self, v0: float) -> np.ndarray:
        """(N,) how far braking at half the limit gets the robot, plus headway and room [m].

        Braking at half the limit in the plan's steps (constant per step, v >= 0), not at the
        limit, and ROOM_M beyond: the feasible set a bound gives way to has room around it (at
        the limit it is a single point, slow for OSQP). Depends on v0 only: once per plan.

        Args:
            v0: the robot's speed [m/s].
        """
        # v = max(v0 - decel, 0), the progress the sum of 0.5 (v_{k-1} + v_k) dt, plus headway
        # times v and ROOM_M: one compiled pass (corridor_kernels.braking_reach; its numpy
        # reference: tests/agents/test_corridor_kernels.py)
        out = np.empty(len(self._brake_decel))
        corridor_kernels().braking_reach(float(v0), self._brake_decel, self.config.plan_dt_s,
                                         self._headway, ROOM_M, out)
        return out

    def _branch_bounds(self, objects: list[PathObject], modes: tuple, bounds: tuple):
        c, veh = self.config, self.vehicle
        wall, margin, s0 = bounds[4:]
        s_low, s_up = mode_bounds(objects, modes, self._n_steps, s0, veh.length_m, c.min_gap_m,
                                  margin, c.pedestrian_gap_m)
        # noise on a tracked object's position moves a bound the robot stopped at by a few cm:
        # up to position_tolerance_m, a bound is never tighter than firm braking now gets (nor
        # than staying where it is, at rest), so noise alone does not make it infeasible; at
        # rest the robot can always stay where it stands (it cannot back up): noise that moves
        # a bound it waits at behind it, by any amount, does not make it infeasible, and a plan
        # that only uses the room does not move it (plan: standstill). Within the wall, >= 0:
        # one compiled pass in place (corridor_kernels.give_way_bound; its numpy reference:
        # tests/agents/test_corridor_kernels.py)
        corridor_kernels().give_way_bound(s_up, float(wall), self._reach,
                                          c.position_tolerance_m, bool(bounds[0] > c.rest_mps),
                                          s_up)
        return s_low, s_up

    def _solve(self, qp: ContingencyQp, weights: np.ndarray, s_low: np.ndarray,
               s_up: np.ndarray, bounds: tuple, comfort: np.ndarray,
               jerk_max: float | None = None) -> QpSolution:
        veh = self.vehicle
        v0, prev, v_ref, v_max = bounds[:4]
        jerk_max = jerk_max or self.config.jerk_max_mps3
        # a QP that reachability shows infeasible is not solved: OSQP may need thousands of
        # iterations to find that out
        reachable = next((r for bound, jerk, r in self._reachable
                          if bound is v_max and jerk == jerk_max), None)
        if reachable is None:
            reachable = reachable_progress(v0, prev, veh.accel_max_mps2, jerk_max, DT_S,
                                           self.config.plan_dt_s, v_max)
            self._reachable.append((v_max, jerk_max, reachable))
        if provably_infeasible(s_low, s_up, reachable, INFEASIBLE_MARGIN_M):
            return qp.failed()
        v_max_b = v_max[None].repeat(len(s_low), 0)  # (L, N), a copy: cheaper than a view
        return qp.solve(QpInstance(weights, v0, prev, v_ref, v_max_b, s_low, s_up,
                                   -veh.brake_max_mps2, veh.accel_max_mps2, jerk_max,
                                   self.config.comfort_decel_mps2, comfort, *self._goal))

    def _full_progress(self, v0: float, v_cap: float, v_max: np.ndarray) -> np.ndarray:
        """(N,) corridor.full_acceleration_progress of this plan's v0 and v_cap [m].

        Computed once per speed bound array v_max (N,) [m/s]: every branch's objects share it
        (reset by plan).
        """
        if self._full is None or self._full[0] is not v_max:
            self._full = (v_max, full_acceleration_progress(
                v0, v_cap, self.vehicle.accel_max_mps2, self.config.plan_dt_s, self._n_steps,
                v_max))
        return self._full[1]

    def _choose_modes(self, objects: list[PathObject], bounds: tuple, v_cap: float,
                      pass_pedestrians: bool, hyp: int) -> tuple:
        """The cheapest feasible mode per object of branch `hyp` (alone, one QP each).

        Pedestrians are passed in front only with `pass_pedestrians`.
        """
        c, veh = self.config, self.vehicle
        v0, v_max, margin, s0 = bounds[0], bounds[3], bounds[5], bounds[6]
        options = []
        for obj in objects:
            two = (len([o for o in options if len(o) == 2]) < MAX_MODE_OBJECTS
                   and (pass_pedestrians or not obj.is_pedestrian)
                   and past_reachable(obj, v0, v_cap, veh.accel_max_mps2, c.plan_dt_s,
                                      c.min_gap_m + 0.5 * veh.length_m - s0, margin,
                                      None if obj.pass_margin
                                      else self._full_progress(v0, v_cap, v_max)))
            options.append((BEHIND, PAST) if two else (BEHIND,))
        combos = list(itertools.product(*options))
        if len(combos) == 1:
            return combos[0]
        qp = self._qp(1, for_modes=True)
        best, best_cost = combos[0], np.inf
        for combo in combos:
            s_low, s_up = self._branch_bounds(objects, combo, bounds)
            sol = self._solve(qp, np.ones(1), s_low[None], s_up[None], bounds,
                              self._comfort[hyp:hyp + 1])
            if sol.solved and sol.cost < best_cost:
                best, best_cost = combo, sol.cost
        return best

    def _solve_joint(self, per_hyp, live_idx, weights, chosen, bounds,
                     jerk_max: float | None = None) -> QpSolution:
        s_low = np.empty((len(live_idx), self._n_steps))  # (L, N), a row per branch
        s_up = np.empty_like(s_low)
        for row, (l, m) in enumerate(zip(live_idx, chosen)):
            s_low[row], s_up[row] = self._branch_bounds(per_hyp[l], m, bounds)
        comfort = self._comfort[live_idx]
        # branches alike in all but their weight -- the same bounds and comfort factor, e.g.
        # hidden pedestrians whose walks stay out of the corridor over the horizon -- have the
        # same plan: for a given trunk the QP separates into its branches, and alike ones
        # minimize the same strictly convex cost over the same set; so they are solved as one
        # branch of their summed weight (a smaller QP, the same optimum) and copied back
        first, inverse = distinct_branches(s_low, s_up, comfort)
        if len(first) == len(live_idx):
            return self._solve(self._qp(len(live_idx)), weights[live_idx], s_low, s_up, bounds,
                               comfort, jerk_max)
        merged = np.zeros(len(first))
        np.add.at(merged, inverse, weights[live_idx])
        solution = self._solve(self._qp(len(first)), merged, s_low[first], s_up[first], bounds,
                               comfort[first], jerk_max)
        return QpSolution(solution.solved, solution.cost, solution.accel_mps2[inverse],
                          solution.speed_mps[inverse], solution.progress_m[inverse])


def distinct_branches(s_low: np.ndarray, s_up: np.ndarray, comfort: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The first of each group of alike branches and each branch's group.

    Alike: equal progress bounds and comfort factor (exactly; NaN never equals).

    Args:
        s_low: (L, N) lower progress bounds [m].
        s_up: (L, N) upper progress bounds [m].
        comfort: (L,) comfort weight factors.

    Returns:
        first: (G,) the row of each group's first branch, increasing; inverse: (L,) the group
        of each branch (first[inverse[l]] is alike branch l).
    """
    first: list[int] = []
    inverse = np.empty(len(comfort), dtype=np.intp)
    for l in range(len(comfort)):
        for g, k in enumerate(first):
            if (comfort[k] == comfort[l] and np.array_equal(s_low[k], s_low[l])
                    and np.array_equal(s_up[k], s_up[l])):
                inverse[l] = g
                break
        else:
            inverse[l] = len(first)
            first.append(l)
    return np.array(first, dtype=np.intp), inverse


def plan(config: MpcConfig, vehicle: VehicleParams, route: Route,
         request: PlanRequest) -> MpcResult:
    """One MPC solve with a fresh ContingencyMpc (ContingencyMpc.plan).

    Args:
        config: the MPC configuration.
        vehicle: the robot's physical parameters.
        route: the robot's route.
        request: what to plan for (mpc_types.PlanRequest).
    """
    return ContingencyMpc(config, vehicle).plan(route, request)

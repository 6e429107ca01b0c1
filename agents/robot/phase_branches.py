"""The signalled traffic's futures per signal phase: branches of the contingency MPC.

Every tracked car with a signal line ahead on its lane path (perception/belief/phase.py,
`signalled_cars`), and every hypothesised hidden car with one (in its hypothesis' branches),
either stops at its line or drives on, depending on the phase: in phase p it
stops if its head's state in p demands it (`stops_per_phase`: red, or a yellow it can stop for
comfortably) and it can stop before the line at all (at most its braking limit). Phases that
agree on what every such car does are one *pattern*; a pattern's weight is the belief in its
phases.

`PhaseBranches.expand` turns the robot's L hypotheses into P' x L (P' patterns): in each
pattern's copy the stopping cars are predicted decelerating uniformly to rest with their front
at the line (`stopping_prediction`); the others, and every other tracked car in a lane, drive on
along their lane path at their current speed, as the planner predicts them
(track_prediction.py). Branch weights are the products of the pattern and hypothesis weights;
the right-of-way claims (agents/robot/right_of_way.py) then follow each branch's predictions:
a car predicted to stop at its line claims no conflict zone beyond it. A pattern other than the
most likely one is a contingency (the MPC's comfort rule). A hypothesised car within
TRACK_MATCH_M of a tracked car is the tracked car (the hidden-agent belief holds the bin where
it sees one): it is left out.
"""

from __future__ import annotations

import numpy as np

from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.belief.paths import LanePaths
from marl_social.perception.belief.phase import SignalledCar, signalled_cars, stops_per_phase
from marl_social.perception.tracking import TrackSet
from marl_social.sim.road_map import RoadMap
from marl_social.sim.signal_rules import route_signal_lines

# a hypothesised car whose position now is this close to a tracked car's is that car (the belief
# holds the bin where it sees a car; the track predicts it better than the bin's speed) [m]
TRACK_MATCH_M = 6.0


def stopping_prediction(car: SignalledCar, times_s: np.ndarray, brake_max_mps2: float
                        ) -> tuple[np.ndarray, np.ndarray] | None:
    """Positions (T, 2) [m] and headings (T,) [rad] of a car braking uniformly to its line.

    None if it cannot stop with its front at the line braking at most brake_max_mps2.

    Args:
        car: the car (its path, position, speed and line).
        times_s: (T,) prediction times [s].
        brake_max_mps2: the hardest braking assumed possible [m/s^2].
    """
    v0 = max(car.v_mps, 0.0)
    room = car.to_line_m
    if room <= 0.0:
        if v0 > 0.5:
            return None
        room = 0.0
    decel = v0 * v0 / (2.0 * room) if room > 0.0 else (np.inf if v0 > 0.0 else 0.0)
    if decel > brake_max_mps2:
        return None
    t = np.asarray(times_s, dtype=np.float64)
    if decel > 0.0:
        t_stop = v0 / decel
        tt = np.minimum(t, t_stop)
        s = car.s_m + v0 * tt - 0.5 * decel * tt * tt
    else:
        s = np.full(len(t), car.s_m)
    xy, heading = car.route.point_at(s)
    return xy, np.broadcast_to(heading, (len(t),)).copy()


def unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """np.unique(rows, axis=0, return_inverse=True) of a (P, C) bool array, a quarter the time.

    Rows of at most 62 columns are packed into integers, the first column the most significant
    bit: their order is np.unique's (lexicographic, False before True); wider ones go to
    np.unique itself.

    Returns:
        (K, C) the distinct rows in that order, and (P,) each row's index among them.
    """
    n_cols = rows.shape[1]
    if n_cols > 62:
        unique, inverse = np.unique(rows, axis=0, return_inverse=True)
        return unique, inverse.reshape(-1)
    bits = np.left_shift(1, np.arange(n_cols - 1, -1, -1, dtype=np.int64))
    keys = (rows * bits).sum(axis=1)
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    return rows[first], inverse.reshape(-1)


class PhaseBranches:
    """Expands the MPC's hypotheses by the signalled traffic's patterns (module docstring).

    Args:
        road_map: the static map the robot may know.
        lane_paths: the map's lane paths (the belief's).
        head_states: (P, H) what every head shows in every phase (SignalPhaseBelief).
        brake_max_mps2: the hardest braking a human is assumed capable of [m/s^2].
        epsilon: hypothesised cars of hypotheses weighted below this (not planned for by the
            MPC) do not split the patterns.
    """

    def __init__(self, road_map: RoadMap, lane_paths: LanePaths, head_states: np.ndarray,
                 brake_max_mps2: float, epsilon: float = 0.0):
        self.road_map = road_map
        self.lane_paths = lane_paths
        self.head_states = head_states
        self.brake_max_mps2 = brake_max_mps2
        self.epsilon = epsilon
        # route_signal_lines per lane path (static: the map's), computed once each
        self._lines: dict[int, tuple] = {}

    def _signal_lines(self, route) -> tuple[np.ndarray, np.ndarray]:
        """route_signal_lines(route, road_map), computed once per lane path (read only)."""
        hit = self._lines.get(id(route))
        if hit is None or hit[0] is not route:
            hit = (route, route_signal_lines(route, self.road_map))
            self._lines[id(route)] = hit
        return hit[1]

    @staticmethod
    def _without_tracked_duplicates(scene: ScenePrediction, tracks: TrackSet) -> ScenePrediction:
        """The scene without hypothesised cars that are a tracked car (module docstring)."""
        n = len(tracks)
        cars = ~tracks.is_pedestrian
        if scene.mask.shape[1] <= n or not cars.any():
            return scene
        first = scene.xy[:, n:, 0]  # (L, E, 2) the hypothesised objects now
        gap = np.linalg.norm(first[:, :, None, :] - tracks.xy[cars][None, None], axis=-1)
        same = (gap.min(axis=-1) < TRACK_MATCH_M) & ~scene.is_pedestrian[:, n:]
        if not same.any():
            return scene
        mask = scene.mask.copy()
        mask[:, n:] &= ~same
        return ScenePrediction(scene.xy, scene.heading, scene.length_m, scene.width_m,
                               scene.radius_m, scene.is_pedestrian, mask)

    def _hidden_cars(self, scene: ScenePrediction, n_tracks: int, weights: np.ndarray,
                     times_s: np.ndarray) -> list[tuple[int, SignalledCar]]:
        """(hypothesis, car) of every hypothesised car with a signal line ahead on its lane path.

        The columns after the tracks, in hypotheses weighted at least epsilon; each car's path, speed
        and line from its first two predicted poses.
        """
        out = []
        if scene.mask.shape[1] <= n_tracks or len(times_s) < 2:
            return out
        dt = float(times_s[1] - times_s[0])
        cars = scene.mask[:, n_tracks:] & ~scene.is_pedestrian[:, n_tracks:]
        live = np.asarray(weights) >= max(self.epsilon, 1e-12)
        for hyp, col in zip(*np.nonzero(cars & live[:, None])):
            m = n_tracks + int(col)
            xy0 = scene.xy[hyp, m, 0]
            route = self.lane_paths.route_of(xy0, float(scene.heading[hyp, m, 0]))
            if route is None:
                continue
            lines, heads = self._signal_lines(route)
            s0, _ = route.project_point(float(xy0[0]), float(xy0[1]))
            half = 0.5 * float(scene.length_m[hyp, m])
            ahead = np.flatnonzero(lines > s0 + half)
            if not len(ahead):
                continue
            v = float(np.linalg.norm(scene.xy[hyp, m, 1] - xy0)) / dt
            j = int(ahead[0])
            out.append((int(hyp), SignalledCar(m, route, s0, v, float(lines[j]), int(heads[j]),
                                               2.0 * half)))
        return out

    def patterns(self, cars: list[SignalledCar], phase_weights: np.ndarray | None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(K, C) bool stop patterns and their (K,) weights.

        Args:
            cars: the C signalled cars.
            phase_weights: (P,) the belief in each phase; None: every car stops (the
                favourable assumption).
        """
        if phase_weights is None:
            return np.ones((1, len(cars)), dtype=bool), np.ones(1)
        stops = np.array([stops_per_phase(self.head_states, c) for c in cars]).T  # (P, C)
        patterns, inverse = unique_rows(stops)
        weights = np.bincount(inverse.ravel(), weights=phase_weights, minlength=len(patterns))
        keep = weights > 0.0
        return patterns[keep], weights[keep]

    def expand(self, scene: ScenePrediction, weights: np.ndarray, contingent: np.ndarray,
               tracks: TrackSet, phase_weights: np.ndarray | None, times_s: np.ndarray
               ) -> tuple[ScenePrediction, np.ndarray, np.ndarray]:
        """The (K * L)-hypothesis scene, weights and contingent flags (module docstring).

        Args:
            scene: L hypotheses; its first len(tracks) objects are the tracks, in order (a
                tracked car in a lane along its lane path, track_prediction.along_lane_paths).
            weights: (L,) the hypotheses' weights.
            contingent: (L,) bool, the contingency branches.
            tracks: the tracks the scene was built from.
            phase_weights: (P,) belief over the phases (all 0: no car stops); None: every car
                stops.
            times_s: (T,) the scene's prediction times [s].
        """
        scene = self._without_tracked_duplicates(scene, tracks)
        if phase_weights is not None and not np.any(np.asarray(phase_weights) > 0.0):
            return scene, weights, contingent  # no phase in which a car stops
        entries = [(None, c) for c in signalled_cars(self.lane_paths, self.road_map, tracks)]
        entries += self._hidden_cars(scene, len(tracks), weights, times_s)
        stopping = [stopping_prediction(c, times_s, self.brake_max_mps2) for _, c in entries]
        entries = [e for e, st in zip(entries, stopping) if st is not None]
        stopping = [st for st in stopping if st is not None]
        if not entries:
            return scene, weights, contingent
        patterns, w_pattern = self.patterns([c for _, c in entries], phase_weights)
        if len(patterns) == 1 and not patterns[0].any():
            return scene, weights, contingent  # every car drives on: the tracks' prediction
        parts, best = [], int(np.argmax(w_pattern))
        for pattern in patterns:
            xy, heading = np.array(scene.xy), np.array(scene.heading)
            for (hyp, car), (stop_xy, stop_heading), stops in zip(entries, stopping, pattern):
                if stops:
                    rows = slice(None) if hyp is None else hyp
                    xy[rows, car.row] = stop_xy
                    heading[rows, car.row] = stop_heading
            parts.append((xy, heading))
        k, n = len(patterns), len(weights)
        tile = lambda a: np.concatenate([a] * k)
        expanded = ScenePrediction(
            np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
            tile(scene.length_m), tile(scene.width_m), tile(scene.radius_m),
            tile(scene.is_pedestrian), tile(scene.mask))
        not_best = np.repeat(np.arange(k) != best, n)
        return (expanded, np.outer(w_pattern, weights).ravel(),
                tile(np.asarray(contingent, dtype=bool)) | not_best)

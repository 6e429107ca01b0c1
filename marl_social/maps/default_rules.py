"""Who keeps the right of way where nothing in a map decides (German rules, StVO).

A left turn gives way to oncoming traffic (section 9 (3)); at a crossing without signs or
signals the lane from the right has priority (section 8). The converter (maps/convert.py)
applies them, in that order, to conflicts no regulatory element or signal decides, and lists
how many it decided so in its warning summary.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.maps.geometry import heading_near

RIGHT_BEFORE_LEFT = "right_before_left (default)"  # the rule of a crossing nothing else decides
LEFT_TURN_YIELDS = "left_turn_yields (default)"  # ... of a left turn across oncoming traffic
ONCOMING_RAD = math.radians(135.0)  # two lanes entering this far apart in heading: oncoming
LEFT_TURN_RAD = math.radians(45.0)  # a lane whose heading turns this far left: a left turn
END_HEADING_M = 3.0  # a lane's heading at its start (end): over its first (last) metres [m]


def entry_and_turn(centerline: np.ndarray) -> tuple[float, float]:
    """A lane's heading at its start [rad] and how far it turns left to its end [rad].

    The headings are the chords over the first and last END_HEADING_M [m] of the centre line
    (P, 2) [m] (at most a third of it each), which a digitized kink does not sway.
    """
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(centerline, axis=0), axis=1))])
    reach = min(END_HEADING_M, s[-1] / 3.0)

    def at(u: float) -> np.ndarray:
        return np.array([np.interp(u, s, centerline[:, 0]), np.interp(u, s, centerline[:, 1])])

    start, end = at(reach) - centerline[0], centerline[-1] - at(s[-1] - reach)
    entry, exit_ = math.atan2(start[1], start[0]), math.atan2(end[1], end[0])
    return entry, math.remainder(exit_ - entry, 2.0 * math.pi)


def left_turn_priority(centerline_a: np.ndarray, centerline_b: np.ndarray) -> int | None:
    """Which of two lanes keeps the right of way against a left turn: 0 (a), 1 (b) or None.

    Who turns left lets oncoming vehicles pass (StVO section 9 (3)). Two lanes (centre lines
    (P, 2) [m]) entering ONCOMING_RAD or more apart in heading, exactly one of them turning
    left by LEFT_TURN_RAD or more (its end's heading against its start's): the other keeps the
    right of way, also where the two end in the same lane (the oncoming car turns right into
    the street the left turn goes to). Else None (undecided).
    """
    (start_a, turn_a), (start_b, turn_b) = entry_and_turn(centerline_a), entry_and_turn(
        centerline_b)
    if abs(math.remainder(start_b - start_a, 2.0 * math.pi)) < ONCOMING_RAD:
        return None
    left_a, left_b = turn_a >= LEFT_TURN_RAD, turn_b >= LEFT_TURN_RAD
    if left_a == left_b:
        return None
    return 1 if left_a else 0


def from_the_right_priority(centerline_a: np.ndarray, centerline_b: np.ndarray,
                            point: np.ndarray) -> int | None:
    """Which of two crossing lanes comes from the other's right: 0 (a), 1 (b) or None.

    Right before left, the default at a junction without signs or signals (StVO section 8),
    which Lanelet2's example maps follow. Two lanes (centre lines (P, 2) [m]) crossing at
    45-135 degrees at the zone (their headings at its centre point (2,) [m]); merging or
    oncoming lanes are None (undecided).
    """
    heading_a, heading_b = heading_near(centerline_a, point), heading_near(centerline_b, point)
    turn = math.remainder(heading_b - heading_a, 2.0 * math.pi)  # b relative to a [rad]
    if math.radians(45.0) < abs(turn) < math.radians(135.0):
        return 1 if turn > 0.0 else 0  # b heading to a's left (turn > 0) comes from a's right
    return None

"""A default fixed-time cycle for a map's traffic lights (Lanelet2 maps carry no timing).

Each traffic light element is one signal group. Groups whose lanes conflict (their lanes, or
the lanes up to two lanelets after them, overlap: the routing graph's conflicts) never show
green together: the groups are coloured greedily (in id order) so that no two conflicting
groups share a colour, and the cycle gives each colour in turn DEFAULT_GREEN_S of green,
DEFAULT_YELLOW_S of yellow and DEFAULT_ALL_RED_S of all-red clearance.
"""

from __future__ import annotations

from marl_social.sim.signals import SignalPhase, SignalPlan

DEFAULT_GREEN_S = 20.0  # [s]
DEFAULT_YELLOW_S = 3.0  # [s]
DEFAULT_ALL_RED_S = 2.0  # [s]


def colour_groups(groups: list[str], conflicting: set[frozenset]) -> list[list[str]]:
    """Groups partitioned so that no two conflicting groups share a part (greedy colouring).

    Args:
        groups: the group names, in the order they are coloured.
        conflicting: pairs of group names (frozensets) that must not be green together.
    """
    colours: list[list[str]] = []
    for group in groups:
        for members in colours:
            if all(frozenset((group, other)) not in conflicting for other in members):
                members.append(group)
                break
        else:
            colours.append([group])
    return colours


def default_signal_plan(groups: list[str], conflicting: set[frozenset]) -> SignalPlan:
    """The default cycle (module docstring) of the given groups.

    Args:
        groups: the group names, in the order they are coloured.
        conflicting: pairs of group names (frozensets) that must not be green together.
    """
    phases = []
    for k, members in enumerate(colour_groups(groups, conflicting)):
        members = tuple(members)
        phases += [SignalPhase(f"green_{k}", DEFAULT_GREEN_S, green=members),
                   SignalPhase(f"yellow_{k}", DEFAULT_YELLOW_S, yellow=members),
                   SignalPhase(f"all_red_{k}", DEFAULT_ALL_RED_S)]
    return SignalPlan(tuple(groups), tuple(phases))


def conflicting_groups(reached: dict, conflicts) -> set[frozenset]:
    """Pairs of signal groups whose lanes conflict (or share a lane).

    Args:
        reached: {group name: the set of lanes its rule holds on}.
        conflicts: the map's conflicting lane pairs (a, b).
    """
    groups = list(reached)
    out = set()
    for ga in groups:
        for gb in groups:
            if ga < gb and any((a, b) in conflicts or (b, a) in conflicts or a == b
                               for a in reached[ga] for b in reached[gb]):
                out.add(frozenset((ga, gb)))
    return out

"""Registry of named episode metrics.

A metric is a function of (trace, road_map, robot) registered under one name, or a small family
of metrics that share one computation registered under several names (the function then
returns one value per name, in the order of the names). Each metric belongs to a group
("episode": the robot's motion and the crosswalk, "belief": the robot's belief in a crossing
pedestrian). `compute_metrics` evaluates the requested names, calling each function once.

    @register_metric("mean_speed_mps", "min_speed_mps", group="episode")
    def robot_speeds(trace, road_map, robot):
        ...
        return mean, minimum
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

from marl_social.sim.road_map import RoadMap
from marl_social.sim.trace import Trace

MetricValue = float | bool
MetricFunction = Callable[[Trace, RoadMap, str], "MetricValue | tuple[MetricValue, ...]"]


@dataclass(frozen=True)
class Metric:
    """One registered metric function.

    Attributes:
        names: the metric names it computes, in the order of its returned values.
        group: "episode" or "belief".
        function: (trace, road_map, robot) -> one value (one name) or a tuple of len(names).
    """

    names: tuple[str, ...]
    group: str
    function: MetricFunction

    def values(self, trace: Trace, road_map: RoadMap, robot: str) -> dict[str, MetricValue]:
        """{name: value} of every name of this metric for one episode.

        Args:
            trace: the episode's finalized trace.
            road_map: the episode's static map.
            robot: name of the agent the metrics describe.
        """
        out = self.function(trace, road_map, robot)
        if len(self.names) == 1:
            return {self.names[0]: out}
        if len(out) != len(self.names):
            raise ValueError(f"metric function {self.function.__name__} returned {len(out)} "
                             f"values for the names {self.names}")
        return dict(zip(self.names, out, strict=True))


_METRICS: dict[str, Metric] = {}  # name -> its Metric, in registration order


def register_metric(*names: str, group: str) -> Callable[[MetricFunction], MetricFunction]:
    """Decorator: register a metric function under one or more names.

    Args:
        *names: the names of the values the function returns (one, or one per tuple entry).
        group: the metric group, e.g. "episode" or "belief".

    Returns:
        The decorator; it returns the function unchanged.
    """
    if not names:
        raise ValueError("register_metric: give at least one name")

    def decorator(function: MetricFunction) -> MetricFunction:
        taken = [n for n in names if n in _METRICS]
        if taken:
            raise ValueError(f"metric name(s) {taken} already registered")
        metric = Metric(tuple(names), group, function)
        for name in names:
            _METRICS[name] = metric
        return function

    return decorator


def metric_names(group: str | None = None) -> tuple[str, ...]:
    """Registered metric names in registration order.

    Args:
        group: only the names of this group; None: all names.
    """
    return tuple(n for n, m in _METRICS.items() if group is None or m.group == group)


def compute_metrics(trace: Trace, road_map: RoadMap, robot: str = "robot_0",
                    names: Iterable[str] | None = None) -> dict[str, MetricValue]:
    """Evaluate registered metrics on one episode.

    Args:
        trace: the episode's finalized trace.
        road_map: the episode's static map.
        robot: name of the agent the metrics describe.
        names: the metric names to compute, in the order of the result; None: all registered.

    Returns:
        {name: float or bool}; each metric function is called once, even for several names.

    Raises:
        ValueError: for a name that is not registered (the message lists the valid ones).
    """
    names = metric_names() if names is None else tuple(names)
    unknown = [n for n in names if n not in _METRICS]
    if unknown:
        raise ValueError(f"unknown metric(s) {unknown}; registered: {list(metric_names())}")
    values: dict[str, MetricValue] = {}
    for name in names:
        if name not in values:
            values.update(_METRICS[name].values(trace, road_map, robot))
    return {name: values[name] for name in names}

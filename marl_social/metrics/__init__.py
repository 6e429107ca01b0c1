"""Episode metrics computed from a trace and the static map, by name from a registry.

`metric_names()` lists every registered metric, in the order `run_episode` returns them
(`episode_metrics` then `belief_metrics`); `compute_metrics` evaluates any of them;
`register_metric` adds one. The metrics themselves live in `physical` (group "episode") and
`belief` (group "belief"; it imports `physical`, so the "episode" names always come first).
"""

from marl_social.metrics.episode import belief_metrics, episode_metrics
from marl_social.metrics.registry import compute_metrics, metric_names, register_metric

__all__ = ["belief_metrics", "compute_metrics", "episode_metrics", "metric_names",
           "register_metric"]

"""Episode metrics computed from a trace and the static map."""

from marl_social.metrics.episode import belief_metrics, episode_metrics

__all__ = ["belief_metrics", "episode_metrics"]

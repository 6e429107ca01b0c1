"""The RLlib callback that logs each episode's robot metrics (collision, hard brake, ...)."""

from __future__ import annotations

import math

from ray.rllib.callbacks.callbacks import RLlibCallback

from marl_social.training.scene import METRIC_KEYS


class EpisodeMetrics(RLlibCallback):
    """Logs the "episode_metrics" the env puts in the learners' last infos (training/env.py).

    Each key of METRIC_KEYS is averaged over the iteration's episodes (RLlib's results
    `env_runners/<key>`); a NaN (e.g. a time to pass the robot never reached) is left out.
    """

    def on_episode_end(self, *, episode, metrics_logger=None, **kwargs) -> None:
        if metrics_logger is None:
            return
        metrics = None
        for agent_episode in episode.agent_episodes.values():
            if len(agent_episode) == 0:
                continue
            info = agent_episode.get_infos(-1)
            if isinstance(info, dict) and "episode_metrics" in info:
                metrics = info["episode_metrics"]
                break
        if metrics is None:
            return
        for key in METRIC_KEYS:
            value = float(metrics[key])
            if not math.isnan(value):
                metrics_logger.log_value(key, value, reduce="mean", window=20)

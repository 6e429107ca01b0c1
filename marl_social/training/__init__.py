"""Multi-agent reinforcement learning on Ray RLlib (the `[rllib]` extra).

    from marl_social.training import SceneSettings, TrainSettings, train, evaluate_checkpoint

* env.py: `SceneEnv`, RLlib's MultiAgentEnv of a scene's learners (the others on their
  planners), and `SceneSettings`;
* trainer.py: `train` (multi-agent PPO, checkpoints, resume, CSV/TensorBoard log);
* learned.py: `LearnedPlanner` (a trained RLModule as a planner that sees only its agent's
  observation) and `evaluate_checkpoint` (the reproduce table of a checkpoint).

RLlib and torch are imported when a run starts, so `import marl_social.training` works without
them (`TrainingError` then names the extra to install).
"""

from marl_social.training.scene import SceneSettings
from marl_social.training.trainer import (
    PPOSettings,
    TrainingError,
    TrainResult,
    TrainSettings,
    train,
)


def __getattr__(name):
    if name in ("evaluate_checkpoint", "LearnedPlanner"):
        from marl_social.training import learned

        return getattr(learned, name)
    raise AttributeError(f"module 'marl_social.training' has no attribute {name!r}")


__all__ = ["LearnedPlanner", "PPOSettings", "SceneSettings", "TrainResult", "TrainSettings",
           "TrainingError", "evaluate_checkpoint", "train"]

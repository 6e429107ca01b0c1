"""marl-social: a PettingZoo multi-agent driving simulator.

Humans are explicit planners with their own fields of view (Sun, Zhan, Chan, Tomizuka, "Behavior
Planning of Autonomous Cars with Social Perception", IEEE IV 2019).
"""

from marl_social.envs.autopilot import autopilot
from marl_social.envs.homogeneous import homogeneous_spaces
from marl_social.envs.parallel import SocialDrivingEnv, env, parallel_env, raw_env
from marl_social.envs.policies import policies
from marl_social.envs.vector import vector_env
from marl_social.evaluation.run import run_episode

__version__ = "0.1.0"
__all__ = ["SocialDrivingEnv", "__version__", "autopilot", "env", "homogeneous_spaces",
           "parallel_env", "policies", "raw_env", "run_episode", "vector_env"]

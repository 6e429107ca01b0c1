"""The robot's social perception (Sun et al. 2019, eq. 9-12, Algorithm 1), one job per module.

* hypotheses.py: `Hypothesis`, `crosswalk_hypotheses`, `motion_transition` (hidden agents as
  (kind, path, progress bin, speed bin), their motion model and regions);
* paths.py: `LanePaths` (a tracked car's lane, from its track);
* bayes.py: `bayes_step`, `markov_transition`, `TrafficSpeedBelief` (discrete Bayes, eq. 12);
* own_sensors.py: `OwnSensors` (detections and negative information from depth rays);
* social.py: `action_log_likelihood`, `SocialLikelihood` (the robot's model of a human, eq. 9-11);
* config.py: `BeliefConfig`;
* pedestrian.py: `PedestrianBelief`, which combines them (the joint b(l, v) update).
"""

from marl_social.perception.belief.bayes import (
    TrafficSpeedBelief,
    bayes_step,
    markov_transition,
    sanitize_log_likelihood,
)
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.hypotheses import (
    PEDESTRIAN_DIAMETER_M,
    Hypothesis,
    crosswalk_hypotheses,
    motion_transition,
    stationary_distribution,
)
from marl_social.perception.belief.own_sensors import OwnSensors
from marl_social.perception.belief.pedestrian import PedestrianBelief
from marl_social.perception.belief.social import SocialLikelihood, action_log_likelihood

__all__ = [
    "PEDESTRIAN_DIAMETER_M",
    "BeliefConfig",
    "Hypothesis",
    "OwnSensors",
    "PedestrianBelief",
    "SocialLikelihood",
    "TrafficSpeedBelief",
    "action_log_likelihood",
    "bayes_step",
    "crosswalk_hypotheses",
    "markov_transition",
    "motion_transition",
    "sanitize_log_likelihood",
    "stationary_distribution",
]

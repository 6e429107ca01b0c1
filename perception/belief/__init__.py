"""The robot's social perception (Sun et al. 2019, eq. 9-12, Algorithm 1), one job per module.

* hypotheses.py: `Hypothesis`, `crosswalk_hypotheses`, `motion_transition`,
  `hypothesis_objects` (hidden agents as (kind, path, progress bin, speed bin), their motion
  model, regions and predictions);
* conflicts.py: `lane_conflicts`, `vehicle_hypotheses` (the lanes that cross or merge into the
  robot's route with the right of way, and the hidden vehicles on them);
* paths.py: `LanePaths` (a tracked car's lane and the lane it continues into, from its track);
* bayes.py: `bayes_step`, `markov_transition`, `TrafficSpeedBelief` (discrete Bayes, eq. 12);
* own_sensors.py: `OwnSensors` (detections and negative information from depth rays);
* action_model.py: `action_log_likelihood`, `bounded_log_likelihood` (a human's observed action
  as evidence, eq. 9-10);
* human_prediction.py: `HumanPrediction` (a human's Q-values under every hypothesis and
  traffic speed, eq. 11);
* action_scoring.py: `ActionScoring` (the likelihood of its observed action, eq. 9-10);
* rationality.py: `RationalityBelief` (the belief over its rationality beta);
* social.py: `SocialLikelihood` (follows each tracked human and puts the three together, eq. 12);
* human_scene.py: `HumanScenes` (the scenes the robot assumes a human reacts to);
* config.py: `BeliefConfig`;
* hidden.py: `HiddenAgentBelief` (alias `PedestrianBelief`), which combines them (the joint
  b(l, v) update).
"""

from marl_social.perception.belief.action_model import action_log_likelihood
from marl_social.perception.belief.action_scoring import ActionScoring
from marl_social.perception.belief.bayes import (
    TrafficSpeedBelief,
    bayes_step,
    markov_transition,
    sanitize_log_likelihood,
)
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.conflicts import (
    LaneConflict,
    lane_conflicts,
    vehicle_hypotheses,
)
from marl_social.perception.belief.hidden import HiddenAgentBelief, PedestrianBelief
from marl_social.perception.belief.human_prediction import HumanPrediction
from marl_social.perception.belief.hypotheses import (
    PEDESTRIAN_DIAMETER_M,
    Hypothesis,
    crosswalk_hypotheses,
    hypothesis_objects,
    motion_transition,
    stationary_distribution,
)
from marl_social.perception.belief.own_sensors import OwnSensors
from marl_social.perception.belief.rationality import RationalityBelief
from marl_social.perception.belief.social import SocialLikelihood

__all__ = [
    "PEDESTRIAN_DIAMETER_M",
    "ActionScoring",
    "BeliefConfig",
    "HiddenAgentBelief",
    "HumanPrediction",
    "Hypothesis",
    "LaneConflict",
    "OwnSensors",
    "PedestrianBelief",
    "RationalityBelief",
    "SocialLikelihood",
    "TrafficSpeedBelief",
    "action_log_likelihood",
    "bayes_step",
    "crosswalk_hypotheses",
    "hypothesis_objects",
    "lane_conflicts",
    "markov_transition",
    "motion_transition",
    "sanitize_log_likelihood",
    "stationary_distribution",
    "vehicle_hypotheses",
]

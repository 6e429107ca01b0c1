"""Near-rational synthetic demonstrations with a known theta.

Scenes like the paper's road, and controls drawn from the Laplace (Gaussian) form of
P(u) ∝ exp(-C(u; theta)) around the continuous optimum (agents/irl/laplace.sample_demonstration).
The ground truth for checking inverse optimal control (`marl-social record --synthetic`,
tests/agents/test_irl.py).

Scene kinds (each demonstration T steps of dt on a 3.5 m lane with a 4 m crosswalk at x = 30 m):

* "follow": a slower car 5.5-12 m ahead (centre to centre) in the lane: speed against safety;
* "crosswalk": a pedestrian walking in the crosswalk 6.5-11 m ahead of a car at 3-8 m/s that
  must stop for it: speed against the crosswalk conflict;
* "free": an empty road, speed against comfort (acceleration, jerk).
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.agents.irl.laplace import sample_demonstration
from marl_social.data.demonstrations import Demonstration
from marl_social.sim.road_map import Crosswalk

SCENE_KINDS = ("follow", "crosswalk", "free")
CROSSWALK_X_M = 30.0
_PATH = np.array([[-50.0, 0.0], [200.0, 0.0]])
_CROSSWALK = Crosswalk(np.array([CROSSWALK_X_M, 0.0]), math.pi / 2, 7.0, 4.0)


def random_scene(rng: np.random.Generator, n_steps: int = 30, dt_s: float = 0.1,
                 kind_probabilities=(0.4, 0.4, 0.2)) -> Demonstration:
    """One scene (a Demonstration with zero controls: the start of the optimization)."""
    kind = SCENE_KINDS[rng.choice(len(SCENE_KINDS), p=kind_probabilities)]
    t = (np.arange(n_steps) + 1) * dt_s
    others = {"others_xy": np.zeros((0, n_steps, 2)), "others_heading": np.zeros((0, n_steps)),
                  "others_length_m": [], "others_width_m": [], "others_is_pedestrian": []}
    v0 = rng.uniform(4.0, 12.0)
    if kind == "follow":
        x0 = rng.uniform(-40.0, -10.0)
        lead_x = x0 + rng.uniform(5.5, 12.0) + rng.uniform(0.3, 0.9) * v0 * t
        others = {"others_xy": np.stack([lead_x, np.zeros(n_steps)], -1)[None],
                      "others_heading": np.zeros((1, n_steps)), "others_length_m": [4.5],
                      "others_width_m": [1.9], "others_is_pedestrian": [False]}
    elif kind == "crosswalk":
        v0 = rng.uniform(3.0, 8.0)
        x0 = CROSSWALK_X_M - rng.uniform(6.5, 11.0)
        ped_y = rng.uniform(-3.0, 0.0) + rng.uniform(0.3, 0.8) * t
        others = {"others_xy": np.stack([np.full(n_steps, CROSSWALK_X_M), ped_y], -1)[None],
                      "others_heading": np.full((1, n_steps), math.pi / 2),
                      "others_length_m": [0.6], "others_width_m": [0.6], "others_is_pedestrian": [True]}
    else:
        x0 = rng.uniform(-40.0, 60.0)
    return Demonstration(np.zeros(n_steps), dt_s, x0 - _PATH[0, 0], v0, rng.uniform(-1.0, 1.0),
                         rng.uniform(9.0, 13.0), _PATH, crosswalks=(_CROSSWALK,),
                         agent=kind, source="synthetic", **others)


def near_rational_demonstrations(theta, n: int, seed: int = 0, n_steps: int = 30
                                 ) -> list[Demonstration]:
    """N demonstrations of a demonstrator with unnormalized weights theta in random scenes.

    theta is (6,), its scale the demonstrator's rationality; the scenes are seeded.
    """
    theta = np.asarray(theta, dtype=np.float64)
    if theta.shape != (6,) or not np.all(np.isfinite(theta)) or np.any(theta < 0):
        raise ValueError(f"synthetic demonstrations: theta must be 6 finite weights >= 0, "
                         f"got {theta}")
    rng = np.random.default_rng(seed)
    return [sample_demonstration(random_scene(rng, n_steps), theta, rng) for _ in range(n)]

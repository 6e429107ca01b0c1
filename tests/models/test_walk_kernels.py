"""The pedestrian's compiled Q values (models/gap_kernels.py, cost_kernels.py) equal its numpy ones, bit for bit.

Up to 20 objects (from MAX_KERNEL_OBJECTS on numpy), several hypotheses, absent objects, vehicles
on the crosswalk, weights with zeros, straight and bent crossing routes; and a non-finite
arc length takes the numpy path.
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models import pedestrian
from marl_social.models.candidates import ScenePrediction
from marl_social.models.circle_gaps import MAX_KERNEL_OBJECTS
from marl_social.models.pedestrian import PedestrianModel
from marl_social.sim.costs import CostWeights
from marl_social.sim.road_map import Crosswalk, Route
from tests.helpers import same_bits
from tests.models.test_pedestrian_costs import random_walk_case

CROSSWALK = Crosswalk(center=np.array([0.0, 0.0]), walk_heading_rad=0.5 * np.pi,
                      length_m=10.0, width_m=4.0)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 4), n_obj=st.integers(0, 20),
       crosswalks=st.integers(0, 2), p_ped=st.sampled_from([0.0, 0.5, 1.0]),
       p_absent=st.sampled_from([0.0, 0.3]), zero_weights=st.booleans())
def test_compiled_q_values_equal_numpy(seed, n_hyp, n_obj, crosswalks, p_ped, p_absent,
                                       zero_weights):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.1, 3.0, 6) * np.array([1, 1, 1, 1, 1, 300.0])
    if zero_weights:
        theta[rng.random(6) < 0.4] = 0.0
    model = PedestrianModel(theta=CostWeights(*theta.tolist()), v_walk_mps=1.3)
    route, scene = random_walk_case(rng, model, n_hyp, n_obj, p_ped, p_absent)
    shifted = Crosswalk(center=np.array([1.0, 2.0]), walk_heading_rad=1.3, length_m=8.0,
                        width_m=3.0)
    args = (model, route, rng.uniform(-1.0, 12.0), rng.choice([0.0, 1.3]),
            rng.uniform(0.0, 2.0), scene, (CROSSWALK, shifted)[:crosswalks])
    want = pedestrian._numpy_q_values(*args)
    assert same_bits(pedestrian.pedestrian_q_values(*args), np.asarray(want))
    if n_obj < MAX_KERNEL_OBJECTS:  # what the kernels take
        assert same_bits(pedestrian._compiled_q_values(*args), np.asarray(want))


def test_a_non_finite_arc_length_takes_numpy():
    model = PedestrianModel()
    route = Route([[0.0, -5.0], [0.0, 5.0]])
    scene = ScenePrediction(np.zeros((1, 0, 16, 2)), np.zeros((1, 0, 16)), np.zeros((1, 0)),
                            np.zeros((1, 0)), np.zeros((1, 0)), np.zeros((1, 0), bool),
                            np.zeros((1, 0), bool))
    with np.errstate(invalid="ignore"):
        got = pedestrian.pedestrian_q_values(model, route, np.nan, 1.3, 0.0, scene, ())
        want = pedestrian._numpy_q_values(model, route, np.nan, 1.3, 0.0, scene, ())
    assert same_bits(got, want)

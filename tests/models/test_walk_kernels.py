"""The pedestrian's compiled Q values (models/gap_kernels.py, cost_kernels.py) equal its numpy ones, bit for bit.

The numpy reference: tests/reference/pedestrian_q.py. Up to 40 objects and a crowd of 100-200
(more than 8: sim/costs.object_sum then adds pairwise whatever the reference's layout),
several hypotheses, absent objects, vehicles on the crosswalk, weights with zeros, straight
and bent crossing routes, and non-finite arc lengths.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models import pedestrian
from marl_social.models.pedestrian import PedestrianModel
from marl_social.sim.costs import CostWeights
from marl_social.sim.road_map import Crosswalk
from tests.helpers import same_bits
from tests.models.test_pedestrian_costs import random_walk_case
from tests.reference.pedestrian_q import pedestrian_q_values as numpy_q_values

CROSSWALK = Crosswalk(center=np.array([0.0, 0.0]), walk_heading_rad=0.5 * np.pi,
                      length_m=10.0, width_m=4.0)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 4),
       n_obj=st.one_of(st.integers(0, 40), st.integers(100, 200)),
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
    want = numpy_q_values(*args)
    assert same_bits(pedestrian.pedestrian_q_values(*args), np.asarray(want))


@pytest.mark.parametrize("s0", [np.nan, np.inf, -np.inf, 1e300])
@pytest.mark.parametrize("n_obj", [0, 3, 12])
def test_a_non_finite_arc_length_gives_numpys_costs(s0, n_obj):
    rng = np.random.default_rng(n_obj)
    model = PedestrianModel()
    route, scene = random_walk_case(rng, model, 2, n_obj, 0.5, 0.3)
    with np.errstate(invalid="ignore", over="ignore"):
        got = pedestrian.pedestrian_q_values(model, route, s0, 1.3, 0.0, scene, (CROSSWALK,))
        want = numpy_q_values(model, route, s0, 1.3, 0.0, scene, (CROSSWALK,))
    assert same_bits(got, np.asarray(want))

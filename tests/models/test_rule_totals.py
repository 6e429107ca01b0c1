"""The compiled rule_abiding_totals (models/cost_kernels.py) equals its numpy reference, bit for bit.

Random step costs (with NaN, inf and signed zeros), vehicle gaps that collide in some, every or
no plan, clearances with NaN, stop lines passed by some, every or no plan, curve excesses with
NaN and inf, several hypotheses and horizons; and evaluations the kernel does not take (not
C-contiguous step costs) go to numpy.
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models import driver
from marl_social.models.candidates import CandidateEvaluation
from marl_social.models.driver import DriverModel, RoadRules
from tests.helpers import same_bits


def _sprinkle(rng, values, p, specials):
    """values with a fraction p replaced by random picks of `specials`."""
    where = rng.random(values.shape) < p
    values[where] = rng.choice(specials, size=int(where.sum()))
    return values


def _random_evaluation(rng, n_hyp, n_first, n_cont, n_t, p_special, curve):
    shape = (n_hyp, n_first, n_cont)
    cost = _sprinkle(rng, rng.exponential(1.0, shape + (n_t,)) * (rng.random(shape + (n_t,))
                                                                   < 0.9),
                     p_special, [np.nan, np.inf, -0.0, 0.0])
    clearance = _sprinkle(rng, rng.normal(0.5, 1.0, shape), p_special, [np.nan, 0.0, -0.0])
    gap = np.maximum(clearance, 0.0)
    if rng.random() < 0.3:  # every plan of a hypothesis collides
        gap[rng.integers(n_hyp)] = 0.0
    travel = np.cumsum(rng.uniform(0.0, 3.0, (n_first, n_cont, n_t)), axis=-1)
    travel = _sprinkle(rng, travel, p_special / 4, [np.nan, np.inf])
    excess = None
    if curve:
        excess = _sprinkle(rng, rng.normal(-0.5, 1.0, (n_first, n_cont)), p_special,
                           [np.nan, np.inf, -np.inf, -0.0])
    return CandidateEvaluation(cost, np.zeros(shape[1:] + (n_t,)), np.zeros(shape[1:] + (n_t,)),
                               None, None, None, gap, None, travel, clearance, excess)


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 4), n_first=st.integers(1, 9),
       n_cont=st.integers(1, 6), n_t=st.integers(1, 20), p_special=st.sampled_from([0.0, 0.05, 0.3]),
       curve=st.booleans(), stop=st.sampled_from(["none", "ahead", "passed", "nan"]),
       no_rules=st.booleans())
def test_compiled_rule_totals_equal_numpy(seed, n_hyp, n_first, n_cont, n_t, p_special, curve,
                                          stop, no_rules):
    rng = np.random.default_rng(seed)
    ev = _random_evaluation(rng, n_hyp, n_first, n_cont, n_t, p_special, curve)
    model = DriverModel()
    s0 = float(rng.uniform(-5.0, 50.0))
    stop_s_m = {"none": None, "ahead": s0 + rng.uniform(0.0, 40.0),
                "passed": s0 - rng.uniform(0.0, 5.0), "nan": np.nan}[stop]
    rules = None if no_rules else RoadRules(stop_s_m)
    assert driver._compiled_evaluation(ev)
    with np.errstate(invalid="ignore"):
        want = driver._numpy_rule_abiding_totals(ev, model, s0, rules)
        got = driver.rule_abiding_totals(ev, model, s0, rules)
    assert same_bits(got, np.asarray(want, dtype=np.float64))


def test_a_strided_evaluation_takes_numpy():
    rng = np.random.default_rng(3)
    ev = _random_evaluation(rng, 2, 9, 5, 12, 0.0, True)
    strided = CandidateEvaluation(np.asfortranarray(ev.step_cost), *[
        getattr(ev, name) for name in list(ev.__dataclass_fields__)[1:]])
    assert not driver._compiled_evaluation(strided)
    rules = RoadRules(10.0)
    want = driver._numpy_rule_abiding_totals(strided, DriverModel(), 2.0, rules)
    assert same_bits(driver.rule_abiding_totals(strided, DriverModel(), 2.0, rules), want)

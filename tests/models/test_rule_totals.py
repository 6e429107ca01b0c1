"""The compiled rule_abiding_totals (models/cost_kernels.py) equals its numpy reference, bit for bit.

Random step costs (with NaN, inf and signed zeros), vehicle gaps that collide in some, every or
no plan, clearances with NaN, stop lines passed by some, every or no plan, curve excesses with
NaN and inf, several hypotheses and horizons (more steps than numpy's pairwise block too); step
costs in other layouts (numpy sums those in their own order) and broadcast gaps. The numpy
reference: tests/reference/rule_totals.py.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models import driver
from marl_social.models.candidates import CandidateEvaluation
from marl_social.models.driver import DriverModel, RoadRules
from tests.helpers import same_bits
from tests.reference.rule_totals import rule_abiding_totals as numpy_rule_totals


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
       n_cont=st.integers(1, 6), n_t=st.one_of(st.integers(1, 20), st.integers(120, 300)), p_special=st.sampled_from([0.0, 0.05, 0.3]),
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
    with np.errstate(invalid="ignore"):
        want = numpy_rule_totals(ev, model, s0, rules)
        got = driver.rule_abiding_totals(ev, model, s0, rules)
    assert same_bits(got, np.asarray(want, dtype=np.float64))


@pytest.mark.parametrize("n_t", [5, 12, 40, 200])
@pytest.mark.parametrize("layout", ["fortran", "broadcast", "reversed"])
def test_other_layouts_sum_as_numpy_does(n_t, layout):
    """A step cost numpy sums in its own order (e.g. one by one along a strided axis)."""
    rng = np.random.default_rng(n_t)
    ev = _random_evaluation(rng, 3, 9, 5, n_t, 0.05, True)
    cost = {"fortran": np.asfortranarray(ev.step_cost),
            "broadcast": np.broadcast_to(ev.step_cost[:1], ev.step_cost.shape),
            "reversed": ev.step_cost[..., ::-1]}[layout]
    other = CandidateEvaluation(cost, *[getattr(ev, name)
                                        for name in list(ev.__dataclass_fields__)[1:]])
    for rules in (None, RoadRules(10.0), RoadRules(None)):
        with np.errstate(invalid="ignore"):
            want = numpy_rule_totals(other, DriverModel(), 2.0, rules)
            got = driver.rule_abiding_totals(other, DriverModel(), 2.0, rules)
        assert same_bits(got, np.asarray(want, dtype=np.float64))


def test_gaps_of_one_hypothesis_broadcast_as_in_numpy():
    rng = np.random.default_rng(5)
    ev = _random_evaluation(rng, 3, 9, 5, 12, 0.05, True)
    fields = {name: getattr(ev, name) for name in ev.__dataclass_fields__}
    fields["min_vehicle_gap_m"] = fields["min_vehicle_gap_m"][0]
    fields["vehicle_clearance_m"] = fields["vehicle_clearance_m"][0]
    other = CandidateEvaluation(**fields)
    with np.errstate(invalid="ignore"):
        want = numpy_rule_totals(other, DriverModel(), 2.0, RoadRules(30.0))
        got = driver.rule_abiding_totals(other, DriverModel(), 2.0, RoadRules(30.0))
    assert same_bits(got, np.asarray(want, dtype=np.float64))

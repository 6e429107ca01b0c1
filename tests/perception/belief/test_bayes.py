"""Discrete Bayes (perception/belief/bayes.py; Algorithm 1, eq. 12): exact filter steps on
hand-computed cases, garbage sources, and the traffic-speed belief as a product."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.perception.belief import TrafficSpeedBelief, bayes_step, markov_transition
from marl_social.perception.belief.bayes import bayes_update, normalize


def test_markov_transition_moves_the_hazard_mass_evenly():
    t = markov_transition(3, 0.1)
    np.testing.assert_allclose(t, [[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]])
    np.testing.assert_allclose(t.sum(axis=0), 1.0)
    np.testing.assert_allclose(markov_transition(1, 0.5), [[1.0]])


def test_bayes_step_is_exact_on_a_hand_computed_case():
    """predicted = T prior = [0.475, 0.305, 0.22]; times likelihood [0.9, 0.1, 0.5] gives
    [0.4275, 0.0305, 0.11], sum 0.568."""
    post = bayes_step([0.5, 0.3, 0.2], np.log([0.9, 0.1, 0.5]), markov_transition(3, 0.1),
                      floor=1e-12)
    np.testing.assert_allclose(post, np.array([0.4275, 0.0305, 0.11]) / 0.568, rtol=1e-9)


def test_bayes_step_predicts_with_the_transition_matrix():
    """Column-stochastic T: predicted = T @ prior. With T moving all mass of hypothesis 0 to
    hypothesis 1 and a flat likelihood: [0.5, 0.3, 0.2] -> [0, 0.8, 0.2]."""
    t = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    post = bayes_step([0.5, 0.3, 0.2], np.zeros(3), t, floor=1e-12)
    np.testing.assert_allclose(post, [0.0, 0.8, 0.2], atol=1e-11)


def test_bayes_step_multiplies_independent_sources():
    """Two sources [0.9, 0.1, 0.5] and [0.5, 0.5, 1.0] on a prior [0.5, 0.3, 0.2], no
    transition: [0.225, 0.015, 0.1] / 0.34 (eq. 12: a product of likelihoods)."""
    ll = np.log([[0.9, 0.1, 0.5], [0.5, 0.5, 1.0]])
    post = bayes_step([0.5, 0.3, 0.2], ll, None, floor=1e-12)
    np.testing.assert_allclose(post, np.array([0.225, 0.015, 0.1]) / 0.34, rtol=1e-9)


def test_bayes_step_floor_and_garbage_sources():
    """A zero likelihood is floored (never all-zero); a source that is NaN, +inf or zero
    everywhere carries no information; the result is always a finite distribution."""
    floor = 1e-6
    with np.errstate(divide="ignore"):
        ll = np.log([1.0, 0.0, 0.0])
    post = bayes_step([0.5, 0.5, 0.0], ll, None, floor=floor)
    np.testing.assert_allclose(post, np.array([1.0, floor, floor]) / (1.0 + 2 * floor))
    prior = np.array([0.2, 0.3, 0.5])
    for garbage in ([np.nan, 0.0, 0.0], [np.inf, 0.0, 0.0], [-np.inf] * 3):
        post = bayes_step(prior, np.array(garbage), None, floor=1e-12)
        np.testing.assert_allclose(post, prior, rtol=1e-9)
    post = bayes_step([np.nan, 0.0, 0.0], np.zeros(3), None)
    assert np.all(np.isfinite(post)) and post.min() > 0 and abs(post.sum() - 1) < 1e-12


def test_traffic_speed_belief_update_is_a_product():
    ll = np.log([0.2, 0.3, 0.5])
    one = TrafficSpeedBelief([8.0, 11.5, 13.0], hazard_per_step=0.0)
    one.update(ll[None])
    two = TrafficSpeedBelief([8.0, 11.5, 13.0], hazard_per_step=0.0)
    two.update(np.stack([ll, ll]))
    np.testing.assert_allclose(one.probabilities, [0.2, 0.3, 0.5], rtol=1e-9)
    np.testing.assert_allclose(two.probabilities, np.array([0.04, 0.09, 0.25]) / 0.38,
                               rtol=1e-9)
    assert two.expected_mps > one.expected_mps


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 300))
def test_inlined_normalize_and_update_are_filterpy_bit_for_bit(seed, n):
    """normalize and bayes_update run filterpy.discrete_bayes' operations inline: the same bits
    (sums of many entries over a wide range of magnitudes, where the order of the sum shows)."""
    from filterpy.discrete_bayes import normalize as filterpy_normalize
    from filterpy.discrete_bayes import update as filterpy_update

    rng = np.random.default_rng(seed)
    pdf = np.exp(rng.uniform(-30.0, 5.0, n))
    likelihood = np.exp(rng.uniform(-30.0, 0.0, n))
    assert np.array_equal(normalize(pdf.copy()), filterpy_normalize(pdf.copy()))
    assert np.array_equal(bayes_update(likelihood, pdf), filterpy_update(likelihood, pdf))
    pdf_in = pdf.copy()
    assert normalize(pdf_in) is pdf_in  # in place, as filterpy

"""The belief's compiled kernels (perception/belief/belief_kernels.py) against numpy, bit for bit.

Each compiled path is compared with the numpy arithmetic it replaces, written out here as it
stood before the kernels: the Boltzmann-Gaussian action likelihood (action_model), the
bounded log-likelihood, the joint b(l, v) update with its marginals and debugging summaries
(bayes.joint_bayes_update against bayes_step), and the own sensors' free-space fractions
(OwnSensors.visible_fraction). Random inputs with a wide range of magnitudes, -inf and +-0.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.perception.belief import compiled
from marl_social.perception.belief.action_model import (
    action_log_likelihood,
    bounded_log_likelihood,
    logsumexp,
    speed_averaged_log_likelihood,
)
from marl_social.perception.belief.bayes import (
    bayes_step,
    joint_bayes_update,
    markov_transition,
    normalize,
    sanitize_log_likelihood,
)
from tests.helpers import same_bits

SEEDS = st.integers(0, 2**32 - 1)


def _same(a, b) -> bool:
    """Equal bit for bit as float64 (tests/helpers.same_bits)."""
    return same_bits(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))


def _reference_action_log_likelihood(q, beta, a_obs, actions, sigma_mps2, tail_dof):
    """action_model.action_log_likelihood in plain numpy (finite beta)."""
    q = np.asarray(q, dtype=np.float64)
    if not math.isfinite(a_obs) or not np.all(np.isfinite(q)):
        return np.zeros(q.shape[:-1])
    sigma = max(float(sigma_mps2), 1e-3)
    z = -beta * (q - q.min(axis=-1, keepdims=True))
    log_p = z - np.log(np.exp(z).sum(axis=-1, keepdims=True))
    with np.errstate(over="ignore"):
        d2 = ((a_obs - actions) / sigma) ** 2
    if math.isinf(tail_dof):
        log_kernel = -0.5 * d2 - math.log(sigma * math.sqrt(2 * math.pi))
    else:
        nu = tail_dof
        log_kernel = (math.lgamma(0.5 * (nu + 1)) - math.lgamma(0.5 * nu)
                      - math.log(math.sqrt(nu * math.pi) * sigma)
                      - 0.5 * (nu + 1) * np.log1p(d2 / nu))
    return logsumexp(log_p + log_kernel, axis=-1)


@settings(max_examples=300, deadline=None)
@given(seed=SEEDS, n_rows=st.integers(0, 9),
       n_actions=st.one_of(st.integers(1, 40), st.integers(120, 300)),
       beta=st.sampled_from([0.0, 1e-3, 0.3, 5.0, 1e4]), dof=st.sampled_from([math.inf, 8.0, 1.0]))
def test_action_log_likelihood_is_numpys(seed, n_rows, n_actions, beta, dof):
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-3, 6)
    q = rng.normal(size=(n_rows, 2, n_actions)) * scale
    actions = np.sort(rng.uniform(-8, 3, n_actions))
    a_obs = float(rng.choice([rng.normal() * 3, 1e160, -2.0]))
    sigma = float(10.0 ** rng.uniform(-4, 1))
    got = action_log_likelihood(q, beta, a_obs, actions, sigma, dof)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        want = _reference_action_log_likelihood(q, beta, a_obs, actions, sigma, dof)
    assert _same(got, want)


def test_action_log_likelihood_non_finite_inputs_give_zeros():
    q = np.zeros((3, 4, 5))
    q[1, 2, 3] = np.inf
    assert _same(action_log_likelihood(q, 0.3, 0.5, np.arange(5.0), 0.5, 8.0), np.zeros((3, 4)))
    assert _same(action_log_likelihood(np.zeros((3, 5)), 0.3, np.nan, np.arange(5.0), 0.5),
                 np.zeros(3))
    # rows longer than numpy's pairwise block (128) too
    q = np.random.default_rng(1).normal(size=(3, 200))
    actions = np.linspace(-8, 3, 200)
    assert _same(action_log_likelihood(q, 0.3, 0.1, actions, 0.5, 8.0),
                 _reference_action_log_likelihood(q, 0.3, 0.1, actions, 0.5, 8.0))
    assert _same(action_log_likelihood(q, 0.3, 0.1, actions, 0.5, math.inf),
                 _reference_action_log_likelihood(q, 0.3, 0.1, actions, 0.5, math.inf))


@settings(max_examples=200, deadline=None)
@given(seed=SEEDS, n=st.integers(1, 60), ratio=st.sampled_from([1e-3, 2.5, 50.0]))
def test_bounded_log_likelihood_is_numpys(seed, n, ratio):
    rng = np.random.default_rng(seed)
    ll = rng.normal(size=(n, 2)) * 10.0 ** rng.uniform(-3, 3)
    if rng.random() < 0.2:
        ll[rng.integers(n), 0] = rng.choice([np.inf, -np.inf, np.nan])
    want = ll if not np.all(np.isfinite(ll)) else np.maximum(ll, ll.max() - ratio)
    assert _same(bounded_log_likelihood(ll, ratio), want)


def _reference_joint(prior_l, prior_v, own, social, transition, floor):
    """HiddenAgentBelief.update's fusion as it stood: bayes_step on the stacked sources, then
    the floored marginals and the debugging exponentials."""
    n, n_v = len(prior_l), len(prior_v)
    sources = np.vstack([np.broadcast_to(own[:, None], (n, n_v))[None], social])
    prior = np.outer(prior_l, prior_v).ravel()
    joint = bayes_step(prior, sources.reshape(len(sources), -1), transition,
                       floor).reshape(n, n_v)
    by_l = normalize(np.maximum(joint.sum(axis=1), floor))
    by_v = normalize(np.maximum(joint.sum(axis=0), floor))
    social_evidence = np.exp(sanitize_log_likelihood(social.sum(axis=0).ravel())).reshape(n, n_v)
    return joint, by_l, by_v, social_evidence, np.exp(sanitize_log_likelihood(own))


@settings(max_examples=300, deadline=None)
@given(seed=SEEDS, n=st.integers(1, 30), n_v=st.integers(1, 10), n_humans=st.integers(0, 4),
       floor=st.sampled_from([1e-6, 1e-300, 0.01]))
def test_joint_bayes_update_is_bayes_step(seed, n, n_v, n_humans, floor):
    rng = np.random.default_rng(seed)
    prior_l = normalize(np.maximum(rng.dirichlet(np.full(n, 0.3)), floor))
    prior_v = normalize(np.maximum(rng.dirichlet(np.full(n_v, 0.3)), floor))
    transition = np.kron(markov_transition(n, rng.uniform(0, 0.5)),
                         markov_transition(n_v, rng.uniform(0, 0.1)))
    own = np.log(rng.uniform(1e-12, 1, n)) * rng.choice([1.0, 1e3])
    social = rng.normal(size=(n_humans, n, n_v)) * 10.0 ** rng.uniform(-2, 3)
    if n_humans and rng.random() < 0.3:  # a garbage source, -inf entries, signed zeros
        social[rng.integers(n_humans), rng.integers(n), rng.integers(n_v)] = rng.choice(
            [np.inf, -np.inf, np.nan, -0.0])
    if rng.random() < 0.2:
        own[rng.integers(n)] = -np.inf
    with np.errstate(all="ignore"):
        want = _reference_joint(prior_l, prior_v, own, social, transition, floor)
        got = joint_bayes_update(prior_l, prior_v, own, social, transition, floor)
    for g, w in zip(got, want):
        assert _same(g, w)


def test_joint_bayes_update_falls_back_to_the_prediction():
    """A transition that loses all mass (0 / 0): bayes_step's fallback, the same bits."""
    n, n_v = 4, 3
    prior_l, prior_v = np.full(n, 0.25), np.full(n_v, 1 / 3)
    own = np.array([0.0, -800.0, -800.0, -800.0])
    social = np.zeros((1, n, n_v))
    transition = np.zeros((n * n_v, n * n_v))
    with np.errstate(all="ignore"):
        got = joint_bayes_update(prior_l, prior_v, own, social, transition, 1e-6)
        want = _reference_joint(prior_l, prior_v, own, social, transition, 1e-6)
    for g, w in zip(got, want):
        assert _same(g, w)


def _reference_visible_counts(dist, bearing, heading, angles, depth, rng, half):
    """OwnSensors.visible_fraction's count as it stood in numpy."""
    bearing = bearing - heading
    bearing = (bearing + np.pi) % (2.0 * np.pi) - np.pi
    n_rays = len(angles)
    if half >= np.pi:
        i1 = np.searchsorted(angles, bearing) % n_rays
        i0 = (i1 - 1) % n_rays
        in_cone = np.ones(bearing.shape, dtype=bool)
    else:
        i1 = np.minimum(np.searchsorted(angles, bearing), n_rays - 1)
        i0 = np.maximum(i1 - 1, 0)
        in_cone = np.abs(bearing) <= half + 1e-9
    reach = np.minimum(depth[i0], depth[i1])
    seen = in_cone & (dist <= rng) & (reach >= dist - 0.25)
    return seen.sum(axis=1)


@settings(max_examples=300, deadline=None)
@given(seed=SEEDS, n_p=st.integers(0, 12), n_k=st.integers(1, 20), n_rays=st.integers(1, 40),
       half=st.sampled_from([0.3, 1.2, math.pi - 1e-12, math.pi, 4.0]))
def test_visible_counts_are_numpys(seed, n_p, n_k, n_rays, half):
    from marl_social.perception.fov import depth_ray_angles

    rng = np.random.default_rng(seed)
    rel = rng.normal(size=(2, n_p, n_k)) * 30.0
    rel[:, rng.random((n_p, n_k)) < 0.1] = 0.0  # points on the robot: bearing +-0
    dist, bearing = np.hypot(rel[0], rel[1]), np.arctan2(rel[1], rel[0])
    heading = float(rng.uniform(-4, 4))
    angles = np.ascontiguousarray(depth_ray_angles(np.array([half]), n_rays)[0])
    depth = rng.uniform(0, 60, n_rays)
    counts = compiled.view().visible_counts(dist, bearing, heading, angles, depth,
                                               (40.0, half, 1e-9, 0.25))
    assert np.array_equal(counts, _reference_visible_counts(dist, bearing, heading, angles,
                                                            depth, 40.0, half))


@settings(max_examples=200, deadline=None)
@given(seed=SEEDS, n_lanes=st.integers(1, 5))
def test_lane_projections_are_project_point(seed, n_lanes):
    """Short lanes (Route.project_point's Python loop) and long ones (Route.project)."""
    from marl_social.sim.road_map import PROJECT_POINT_LOOP_MAX, Route

    rng = np.random.default_rng(seed)
    lanes = []
    for _ in range(n_lanes):
        n_points = int(rng.choice([2, 3, PROJECT_POINT_LOOP_MAX + 1, PROJECT_POINT_LOOP_MAX + 2,
                                   40]))
        steps = rng.normal(size=(n_points - 1, 2)) * rng.uniform(0.1, 20)
        points = np.vstack([rng.normal(size=(1, 2)) * 50, steps]).cumsum(axis=0)
        lanes.append(Route(points, "lane"))
    segments = np.vstack([np.column_stack([r.segment_start_m, r.segment_direction,
                                           r.segment_length_m, r.vertex_s_m[:-1]])
                          for r in lanes])
    first = np.cumsum([0] + [r.n_segments for r in lanes])
    for x, y in rng.normal(size=(20, 2)) * 80:
        s, lateral = compiled.view().lane_projections(float(x), float(y), segments, first)
        want = np.array([r.project_point(float(x), float(y)) for r in lanes])
        assert _same(s, want[:, 0]) and _same(lateral, want[:, 1])


@settings(max_examples=200, deadline=None)
@given(seed=SEEDS, n_kept=st.integers(1, 6),
       n_t=st.one_of(st.integers(1, 30), st.integers(120, 300)), n_cont=st.integers(1, 6))
def test_speed_q_values_are_numpys(seed, n_kept, n_t, n_cont):
    """HumanPrediction.q_values' speed feature and minimum, with +inf (excluded plans)."""
    rng = np.random.default_rng(seed)
    n_act, n_v, n_hyp = 5, 4, 9
    base = rng.uniform(0, 1e4, (n_kept, n_act, n_cont))
    base[rng.random(base.shape) < 0.2] = np.inf
    speeds = rng.uniform(0, 20, (n_act, n_cont, n_t))
    v_ref = rng.uniform(5, 15, n_v)
    rows = rng.integers(0, n_kept, n_hyp)
    weight = float(rng.uniform(0.1, 3))
    speed = weight * np.square(speeds - v_ref[:, None, None, None]).sum(axis=-1)
    want = (base[:, None] + speed[None]).min(axis=-1)[rows]
    got = compiled.kernels().speed_q_values(base, speeds, v_ref, weight, rows)
    assert _same(got, want)


@settings(max_examples=100, deadline=None)
@given(seed=SEEDS, n_kept=st.integers(1, 6), n_t=st.integers(1, 30), n_cont=st.integers(1, 6))
def test_node_speed_q_values_are_each_nodes(seed, n_kept, n_t, n_cont):
    """node_speed_q_values of three evaluations is speed_q_values of each (the speed nodes),
    also with two nodes sharing one evaluation (a human at rest)."""
    rng = np.random.default_rng(seed)
    n_act, n_v, n_hyp = 5, 4, 9
    bases = [rng.uniform(0, 1e4, (n_kept, n_act, n_cont)) for _ in range(3)]
    for base in bases:
        base[rng.random(base.shape) < 0.2] = np.inf
    speeds = [rng.uniform(0, 20, (n_act, n_cont, n_t)) for _ in range(3)]
    bases[0], speeds[0] = bases[1], speeds[1]
    v_ref = rng.uniform(5, 15, n_v)
    rows = rng.integers(0, n_kept, n_hyp)
    weight = float(rng.uniform(0.1, 3))
    kernels = compiled.kernels()
    got = kernels.node_speed_q_values(tuple(bases), tuple(speeds), v_ref, weight, rows)
    want = [kernels.speed_q_values(b, v, v_ref, weight, rows) for b, v in zip(bases, speeds)]
    assert got.shape == (3, n_hyp, n_v, n_act) and _same(got, np.stack(want))


def _reference_speed_average(ll):
    """action_model.speed_averaged_log_likelihood's average of (3, ...) log-likelihoods in
    plain numpy (zeros if one is not finite)."""
    if not np.all(np.isfinite(ll)):
        return np.zeros(ll.shape[1:])
    weights = np.log(np.array([1.0, 4.0, 1.0]) / 6.0).reshape((-1,) + (1,) * (ll.ndim - 1))
    return logsumexp(ll + weights, axis=0)


@settings(max_examples=300, deadline=None)
@given(seed=SEEDS, shape=st.sampled_from([(), (1,), (7,), (13, 4), (2, 3, 5)]),
       beta=st.sampled_from([0.0, 0.3, 5.0, 1e4]), dof=st.sampled_from([math.inf, 8.0]))
def test_speed_averaged_log_likelihood_is_numpys(seed, shape, beta, dof):
    """The average over the speed nodes (belief_kernels.node_average_terms, column_sums) is
    the numpy logsumexp it replaced, of action_log_likelihood's (3, ...) values; with a
    non-finite Q-value or observation, zeros."""
    rng = np.random.default_rng(seed)
    n_actions = 9
    q = rng.normal(size=(3,) + shape + (n_actions,)) * 10.0 ** rng.uniform(-3, 5)
    if rng.random() < 0.1:
        q.flat[int(rng.integers(q.size))] = np.inf
    actions = np.sort(rng.uniform(-8, 3, n_actions))
    a_obs = float(rng.choice([rng.normal() * 3, 1e160, -2.0, np.nan]))
    sigma = float(rng.uniform(0.5, 2.0))
    got = speed_averaged_log_likelihood(q, beta, a_obs, actions, sigma, dof)
    want = _reference_speed_average(action_log_likelihood(q, beta, a_obs, actions, sigma, dof))
    assert got.shape == want.shape and _same(got, want)


@settings(max_examples=200, deadline=None)
@given(seed=SEEDS, n=st.integers(0, 15))
def test_view_mask_is_numpys(seed, n):
    """HumanScenes' view test (others_scene, in_view), points on the viewer and on the edges."""
    rng = np.random.default_rng(seed)
    rel = rng.normal(size=(n, 2)) * 40.0
    rel[rng.random(n) < 0.1] = 0.0
    dist, bearing = np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 1], rel[:, 0])
    heading = float(rng.choice([rng.uniform(-7, 7), np.pi, -np.pi, 0.0]))
    candidates = rng.random(n) < 0.7
    ids = rng.integers(1, 5, max(n - 1, 0))
    exclude = int(rng.integers(1, 5))
    range_m, half_fov = 50.0, math.radians(70.0)
    wrapped = np.abs((bearing - heading + np.pi) % (2.0 * np.pi) - np.pi)
    want = candidates & (dist <= range_m) & (wrapped <= half_fov)
    want[:len(ids)] &= ids != exclude
    got = compiled.view().view_mask(dist, bearing, heading, candidates, ids, exclude, range_m,
                                       half_fov)
    assert np.array_equal(got, want)


def _reference_bayes_step(prior, log_likelihoods, transition, floor):
    """bayes.bayes_step as it stood in numpy."""
    prior = np.asarray(prior, dtype=np.float64)
    total_prior = prior.sum()
    if not (math.isfinite(total_prior) and total_prior > 0.0 and prior.min() >= 0.0):
        prior, total_prior = np.ones_like(prior), float(len(prior))
    predicted = prior / total_prior
    if transition is not None:
        predicted = np.asarray(transition) @ predicted
    predicted = np.maximum(predicted, 0.0)
    ll = np.atleast_2d(np.asarray(log_likelihoods, dtype=np.float64))
    total = sanitize_log_likelihood(sanitize_log_likelihood(ll).sum(axis=0))
    posterior = normalize(predicted * np.exp(total))
    if not np.all(np.isfinite(posterior)):
        posterior = predicted / predicted.sum() if predicted.sum() > 0 else np.ones(len(prior))
    return normalize(np.maximum(posterior, floor))


@settings(max_examples=300, deadline=None)
@given(seed=SEEDS, n=st.integers(1, 12), n_sources=st.integers(0, 4),
       with_transition=st.booleans())
def test_bayes_step_is_numpys(seed, n, n_sources, with_transition):
    rng = np.random.default_rng(seed)
    prior = rng.dirichlet(np.full(n, 0.5)) * rng.choice([1.0, 3.0])
    if rng.random() < 0.1:
        prior[0] = rng.choice([np.nan, -1.0, 0.0])
    ll = rng.normal(size=(n_sources, n)) * 10.0 ** rng.uniform(-2, 3)
    ll[rng.random(ll.shape) < 0.15] = -np.inf
    if n_sources and rng.random() < 0.2:
        ll[rng.integers(n_sources), rng.integers(n)] = rng.choice([np.inf, np.nan])
    transition = markov_transition(n, rng.uniform(0, 0.5)) if with_transition else None
    floor = float(rng.choice([1e-6, 1e-300]))
    with np.errstate(all="ignore"):
        assert _same(bayes_step(prior, ll, transition, floor),
                     _reference_bayes_step(prior, ll, transition, floor))
        assert _same(bayes_step(prior, ll[0] if n_sources else np.zeros(n), transition, floor),
                     _reference_bayes_step(prior, ll[0] if n_sources else np.zeros(n),
                                           transition, floor))


@settings(max_examples=200, deadline=None)
@given(seed=SEEDS, n=st.integers(1, 20), p_detect=st.sampled_from([0.0, 0.95, 1.0]))
def test_own_likelihoods_are_numpys(seed, n, p_detect):
    rng = np.random.default_rng(seed)
    visible = rng.choice([0.0, 1.0, 0.5, 1 / 3], n) * (rng.random(n) < 0.8)
    present = rng.random(n) < 0.8
    detected = (rng.random(n) < 0.2) & present
    p_fa = 0.01
    miss = np.where(present, np.minimum(np.maximum(1.0 - p_detect * visible, 1e-12), 1.0), 1.0)
    want = (np.where(detected, p_detect, p_fa * miss) if detected.any()
            else (1.0 - p_fa) * miss)
    got = compiled.view().own_likelihoods(visible, present, detected, p_detect, p_fa,
                                             1.0 - p_fa, 1e-12)
    assert _same(got, want)


@settings(max_examples=200, deadline=None)
@given(seed=SEEDS, n_points=st.integers(2, 30), n=st.integers(0, 12))
def test_route_projections_are_route_project(seed, n_points, n):
    from marl_social.sim.road_map import Route

    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(n_points - 1, 2)) * rng.uniform(0.1, 20)
    route = Route(np.vstack([rng.normal(size=(1, 2)) * 50, steps]).cumsum(axis=0), "path")
    segments = np.column_stack([route.segment_start_m, route.segment_direction,
                                route.segment_length_m, route.vertex_s_m[:-1]])
    xy = rng.normal(size=(n, 2)) * 80
    s, lateral, k = compiled.view().route_projections(xy, segments)
    want_s, want_lateral, want_heading = route.project(xy)
    assert _same(s, want_s) and _same(lateral, want_lateral)
    assert _same(route.segment_heading_rad[k], want_heading)


def _reference_path_matches(along, lateral, v_along, v_floor, bounds, v_min, vehicle):
    """own_sensors._PathGroup.matches' comparisons as they stood in numpy (bounds (5, H, 1))."""
    half, lo, hi, b3, b4 = bounds
    inside = (np.abs(lateral) <= half) & (along >= lo) & (along <= hi)
    if vehicle:
        return np.any(inside & (v_along >= v_floor) & (v_along >= b3) & (v_along < b4), axis=1)
    on_road = (along >= b3) & (along <= b4)
    crossing = (on_road & (v_along > -v_min)) | (v_along >= v_min)
    return np.any(inside & crossing, axis=1)


_SPECIAL = np.array([np.nan, np.inf, -np.inf, 0.0, -0.0, 1.0, -1.0, 0.3, -0.3])


@settings(max_examples=400, deadline=None)
@given(seed=SEEDS, n=st.integers(0, 6), n_h=st.integers(0, 8), vehicle=st.booleans())
def test_path_matches_are_numpys(seed, n, n_h, vehicle):
    """The bins' comparisons, with NaN, +-inf and +-0 among the coordinates and the bounds."""
    rng = np.random.default_rng(seed)

    def values(shape, scale):
        out = rng.normal(size=shape) * scale
        special = rng.random(shape) < 0.25
        out[special] = rng.choice(_SPECIAL, int(special.sum()))
        return out

    along, lateral, v_along, v_floor = (values(n, s) for s in (5.0, 2.0, 2.0, 1.0))
    lo = values(n_h, 3.0)
    with np.errstate(invalid="ignore"):  # -inf + inf
        bounds = np.stack([np.abs(values(n_h, 2.0)), lo, lo + np.abs(values(n_h, 4.0)),
                           values(n_h, 2.0), values(n_h, 4.0)])  # (5, H)
    v_min = float(rng.choice([0.3, 0.0, -0.0]))
    got = compiled.view().path_matches(along, lateral, v_along, v_floor, bounds, v_min,
                                          vehicle)
    want = _reference_path_matches(along, lateral, v_along, v_floor, bounds[..., None], v_min,
                                   vehicle)
    assert got.dtype == np.bool_ and np.array_equal(got, want)


def test_no_candidate_actions_is_a_value_error():
    import pytest

    with pytest.raises(ValueError, match="no candidate actions"):
        action_log_likelihood(np.zeros((2, 0)), 0.3, 0.1, np.zeros(0), 0.5)

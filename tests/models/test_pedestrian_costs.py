"""The pedestrian's Q values and sampler equal the plain formulas they replace, bit for bit.

pedestrian_q_values against sim/costs.step_cost of every step (the formula it replaced);
the pedestrian's sampler against Generator.choice; vehicles_expected_to_yield against the
array formula.
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.agents.pedestrian import vehicles_expected_to_yield
from marl_social.models.circle_gaps import circle_pair_gap, scene_circles
from marl_social.models.pedestrian import PedestrianModel, pedestrian_q_values
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.tracking import TrackSet
from marl_social.sim.costs import CostWeights, step_cost
from marl_social.sim.dynamics import DT_S
from marl_social.sim.footprint import circle_layout
from marl_social.sim.road_map import Crosswalk, Route

CROSSWALK = Crosswalk(center=np.array([0.0, 0.0]), walk_heading_rad=0.5 * np.pi,
                      length_m=10.0, width_m=4.0)


def _reference_q(model, route, s0, v_ref, prev_speed, scene, crosswalks):
    """pedestrian_q_values as first written: step_cost of every step, summed."""
    dt = model.plan_dt_s
    t = model.plan_times_s
    speeds = np.array(model.speeds_mps, dtype=np.float64)
    diam = 2.0 * model.radius_m
    ego_along, ego_radius = circle_layout(diam, diam, True)
    s = np.minimum(s0 + speeds[:, None] * t[None, :], route.length_m)
    xy, heading = route.point_at(s)
    v = np.broadcast_to(speeds[:, None], s.shape)
    accel = np.zeros_like(v)
    accel[:, 0] = (speeds - prev_speed) / dt
    ego_x = (xy[..., 0] + ego_along[0] * np.cos(heading))[None]
    ego_y = (xy[..., 1] + ego_along[0] * np.sin(heading))[None]
    ox, oy, other_r = scene_circles(scene)
    gap = np.maximum(circle_pair_gap(ego_x, ego_y, float(ego_radius[0]), ox, oy, other_r), 0.0)
    to_cand = lambda a: a.swapaxes(1, 2)[:, None]
    cost = step_cost(
        model.theta.as_array(), lateral_m=0.0, speed_mps=v, v_ref_mps=v_ref, accel_mps2=accel,
        prev_accel_mps2=0.0, ego_xy=xy, ego_radius=model.radius_m, ego_is_ped=True,
        ego_circles=None, ego_circle_r=None, other_xy=to_cand(scene.xy),
        other_radius=scene.radius_m[:, None, None, :],
        other_is_ped=scene.is_pedestrian[:, None, None, :], other_circles=None,
        other_circle_r=None, other_mask=scene.mask[:, None, None, :], crosswalks=crosswalks,
        gap=gap)
    return cost.sum(axis=-1) * (dt / DT_S)


def random_walk_case(rng, model, n_hyp: int, n_obj: int, p_ped: float, p_absent: float):
    """(route, scene): a straight or bent walk and L x M random cars and pedestrians over the
    model's plan steps, a share p_absent of them absent."""
    route = Route([[0.0, -5.0], [0.0, 5.0]]) if rng.random() < 0.5 else Route(
        [[0.0, -5.0], [0.0, 0.0], [3.0, 4.0]])
    return route, random_scene(rng, n_hyp, n_obj, len(model.plan_times_s), p_ped, p_absent,
                               (-15.0, 15.0))


def random_scene(rng, n_hyp: int, n_obj: int, n_t: int, p_ped: float, p_absent: float,
                 xy_range_m: tuple) -> ScenePrediction:
    """L x M random cars and pedestrians (a share p_ped) over n_t steps, starting uniformly in
    xy_range_m [m] on both axes and drifting randomly, a share p_absent of them absent."""
    is_ped = rng.random((n_hyp, n_obj)) < p_ped
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, (n_hyp, n_obj)))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.2, (n_hyp, n_obj)))
    xy = rng.uniform(*xy_range_m, (n_hyp, n_obj, 1, 2)) + rng.normal(
        size=(n_hyp, n_obj, 1, 2)) * np.arange(1, n_t + 1)[:, None]
    heading = np.repeat(rng.uniform(-4, 4, (n_hyp, n_obj, 1)), n_t, axis=2)
    return ScenePrediction(xy, heading, length, width, 0.5 * np.hypot(length, width), is_ped,
                           rng.random((n_hyp, n_obj)) >= p_absent)


@settings(max_examples=120, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 3), n_obj=st.integers(0, 4),
       crosswalk=st.booleans(), p_ped=st.sampled_from([0.0, 0.5, 1.0]),
       p_absent=st.sampled_from([0.0, 0.3]), zero_weights=st.booleans())
def test_pedestrian_q_values_equal_step_cost(seed, n_hyp, n_obj, crosswalk, p_ped, p_absent,
                                             zero_weights):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.1, 3.0, 6) * np.array([1, 1, 1, 1, 1, 300.0])
    if zero_weights:
        theta[rng.random(6) < 0.4] = 0.0
        theta[4] = theta[4] or 1.0  # keep a term that depends on the scene
    model = PedestrianModel(theta=CostWeights(*theta.tolist()), v_walk_mps=1.3)
    route, scene = random_walk_case(rng, model, n_hyp, n_obj, p_ped, p_absent)
    args = (model, route, rng.uniform(0.0, 9.0), rng.choice([0.0, 1.3]), rng.uniform(0.0, 2.0),
            scene, (CROSSWALK,) if crosswalk else ())
    want = _reference_q(*args)
    got = pedestrian_q_values(*args)
    assert got.shape == want.shape == (n_hyp, len(model.speeds_mps))
    assert np.array_equal(got, want)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 5))
def test_vehicles_expected_to_yield_equal_the_array_formula(seed, n):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-40.0, 40.0, (n, 2))
    velocity = rng.normal(size=(n, 2)) * rng.choice([0.0, 0.5, 8.0], (n, 1))
    length = rng.uniform(0.5, 5.0, n)
    tracks = TrackSet(np.arange(n) + 1, xy, velocity, np.zeros(n), length, length * 0.4,
                      rng.random(n) < 0.3, np.ones(n, bool), np.zeros(n), np.zeros(n))
    rel = CROSSWALK.center - xy
    speed = np.sqrt(velocity[:, 0] ** 2 + velocity[:, 1] ** 2)
    closing = np.einsum("kd,kd->k", rel, velocity) / np.maximum(speed, 1e-6)
    gap = np.sqrt(rel[:, 0] ** 2 + rel[:, 1] ** 2) - 0.5 * CROSSWALK.width_m - 0.5 * length
    want = ~tracks.is_pedestrian & (closing > 0.0) & (speed ** 2 / (2.0 * 4.0) < gap)
    got = vehicles_expected_to_yield(tracks, CROSSWALK, 4.0)
    assert got.dtype == bool and np.array_equal(got, want)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8), one_hot=st.booleans())
def test_pedestrian_sampler_equals_generator_choice(seed, n, one_hot):
    import marl_social
    from marl_social.agents.pedestrian import BoltzmannPedestrian

    env = marl_social.parallel_env(pedestrian="crossing")
    ped = BoltzmannPedestrian(env.agent_specs["pedestrian_0"], env.obs_layout, env.road_map)
    rng = np.random.default_rng(seed)
    p = rng.dirichlet(np.full(n, rng.uniform(0.05, 3.0)))
    if one_hot:
        p = np.eye(n)[rng.integers(n)]
    ped.reset(seed)
    reference = np.random.default_rng(seed)
    assert [ped.choose(p) for _ in range(20)] == [int(reference.choice(n, p=p))
                                                  for _ in range(20)]

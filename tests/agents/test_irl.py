"""Inverse optimal control (agents/irl/laplace.py): exact derivatives, regularization, recovery of a known
theta from near-rational demonstrations, the recorder and the CLI."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from marl_social.agents.irl import laplace as irl
from marl_social.agents.irl.jets import Jet
from marl_social.agents.irl.synthetic import near_rational_demonstrations
from marl_social.data.demonstrations import Demonstration, load_demonstrations, save_demonstrations
from marl_social.models.candidates import PlanningEgo, Surroundings
from marl_social.sim.costs import FEATURE_NAMES, CostWeights
from marl_social.sim.road_map import Crosswalk

THETA_TRUE = np.array([0.0, 3.0, 1.5, 0.6, 6.0, 150.0])  # unnormalized: direction x beta


def _busy_demo(seed=0, controls=None) -> Demonstration:
    """A bent path, a lead car close ahead and a pedestrian in a crosswalk the path crosses."""
    rng = np.random.default_rng(seed)
    n = 30
    t = (np.arange(n) + 1) * 0.1
    lead = np.stack([14.0 + 4.0 * t, 0.3 * t], -1)
    ped = np.stack([np.full(n, 22.0), -2.0 + 1.2 * t], -1)
    return Demonstration(
        controls_mps2=rng.normal(0.0, 1.5, n) if controls is None else controls, dt_s=0.1,
        s0_m=5.0, v0_mps=8.0, prev_accel_mps2=0.5, v_ref_mps=11.0,
        path_xy=np.array([[0.0, 0.0], [12.0, 0.0], [40.0, 4.0], [80.0, 20.0]]),
        others_xy=np.stack([lead, ped]), others_heading=np.stack([np.full(n, 0.07),
                                                                  np.full(n, math.pi / 2)]),
        others_length_m=[4.5, 0.6], others_width_m=[1.9, 0.6],
        others_is_pedestrian=[False, True],
        crosswalks=(Crosswalk(np.array([22.0, 0.5]), math.pi / 2, 7.0, 4.0),))


def test_exact_gradient_and_hessian_match_finite_differences():
    for seed in range(3):
        demo = _busy_demo(seed)
        exact = irl.feature_derivatives(demo)
        fd_grad, fd_hess = irl.finite_difference_derivatives(demo, step=1e-5)
        # every position feature is really exercised in this scene
        assert np.all(np.abs(exact.grad[1:]).max(axis=1) > 1e-4)
        for k, name in enumerate(FEATURE_NAMES):
            scale = max(1.0, np.abs(fd_grad[k]).max())
            assert np.allclose(exact.grad[k], fd_grad[k], atol=1e-5 * scale), name
            hscale = max(1.0, np.abs(fd_hess[k]).max())
            assert np.allclose(exact.hess[k], fd_hess[k], atol=1e-4 * hscale), name


def test_feature_totals_equal_the_planners_cost_module():
    """The IRL's cost of a control sequence is the planners' cost of the same rollout."""
    from marl_social.models.candidates import evaluate_candidates
    from marl_social.models.rollouts import CandidateSet
    from marl_social.models.scene_prediction import ScenePrediction
    from marl_social.sim.agent_spec import VehicleParams

    demo = _busy_demo(1, controls=np.r_[np.full(10, -2.0), np.full(20, 1.0)])
    theta = np.array([0.0, 1.0, 0.1, 0.1, 1.0, 1000.0])
    cands = CandidateSet((-2.0,), (1.0,), 1.0, 3.0, 0.1)
    scene = ScenePrediction(demo.others_xy[None], demo.others_heading[None],
                            demo.others_length_m[None], demo.others_width_m[None],
                            0.5 * np.hypot(demo.others_length_m, demo.others_width_m)[None],
                            demo.others_is_pedestrian[None], np.ones((1, 2), bool))
    ev = evaluate_candidates(
        PlanningEgo(cands, theta, demo.v_ref_mps, VehicleParams(), demo.route, demo.s0_m,
                    demo.v0_mps, demo.prev_accel_mps2), Surroundings(scene, demo.crosswalks))
    ours = theta @ irl.feature_derivatives(demo).totals
    assert ours == pytest.approx(ev.step_cost.sum(), rel=1e-9)


def test_jets_refuse_operations_without_a_derivative_rule():
    with pytest.raises(TypeError, match="no derivative rule"):
        np.sin(Jet(np.ones(3), np.ones(3)))


def test_regularization_path_on_an_ill_conditioned_demo():
    """A car passing right next to an obstacle: exp(-gap) is concave there, and with (almost)
    no comfort weight the Hessian is indefinite. It is shifted by the smallest lambda of the
    sequence delta * 10^j that makes it positive definite; the likelihood stays finite."""
    n = 20
    demo = Demonstration(np.zeros(n), 0.1, 10.0, 6.0, 0.0, 6.0, [[0.0, 0.0], [100.0, 0.0]],
                         others_xy=np.tile([[[14.0, 2.45]]], (1, n, 1)),
                         others_heading=np.zeros((1, n)), others_length_m=[4.5],
                         others_width_m=[1.9], others_is_pedestrian=[False])
    theta = np.array([0.0, 1e-4, 1e-6, 0.0, 50.0, 0.0])
    d = irl.feature_derivatives(demo)
    h = np.einsum("f,ftu->tu", theta, d.hess)[None]
    h_reg, lam, eig_min = irl.regularize(h)
    delta = 1e-6 * max(1.0, np.abs(np.diag(h[0])).max())
    assert eig_min[0] < 0 < lam[0]
    assert np.linalg.eigvalsh(h_reg[0])[0] >= delta * (1 - 1e-9)
    assert eig_min[0] + lam[0] / 10 < delta  # the previous step of the path was not enough
    assert round(math.log10(lam[0] / delta)) == pytest.approx(math.log10(lam[0] / delta))
    terms = irl.laplace_terms(theta, irl.DemoSet.from_demos([demo]))
    assert terms.regularization[0] == pytest.approx(lam[0])
    assert np.isfinite(terms.log_lik).all() and np.isfinite(terms.grad_theta).all()


def test_theta_gradient_of_the_laplace_likelihood_matches_finite_differences():
    data = irl.DemoSet.from_demos(near_rational_demonstrations(THETA_TRUE, 6, seed=2))
    theta = np.array([0.0, 2.0, 1.0, 0.5, 4.0, 80.0])
    grad = irl.laplace_terms(theta, data).grad_theta.sum(axis=0)
    for k in range(1, 6):
        step = 1e-6 * max(1.0, theta[k])
        up, down = theta.copy(), theta.copy()
        up[k] += step
        down[k] -= step
        fd = (irl.laplace_terms(up, data).log_lik.sum()
              - irl.laplace_terms(down, data).log_lik.sum()) / (2 * step)
        assert grad[k] == pytest.approx(fd, rel=1e-4, abs=1e-6), FEATURE_NAMES[k]


@pytest.fixture(scope="module")
def synthetic():
    demos = near_rational_demonstrations(THETA_TRUE, 140, seed=0)
    return demos[:100], demos[100:]


@pytest.mark.slow
def test_recovers_a_known_theta_from_100_near_rational_demonstrations(synthetic):
    train, held_out = synthetic
    result = irl.fit_theta(train)
    assert result.converged
    assert irl.cosine_similarity(result.theta, THETA_TRUE) >= 0.95
    # not only the dominant crosswalk weight: the trade-offs between the other features too
    assert irl.cosine_similarity(result.theta, THETA_TRUE,
                                 ("speed", "accel", "jerk", "safety")) >= 0.95
    assert result.scale == pytest.approx(np.linalg.norm(THETA_TRUE[1:]), rel=0.2)
    assert math.isnan(result.theta[0])  # tracking: not identifiable, not fitted
    # held-out likelihood beats uniform and random directions, each with its best scale
    learned = irl.neg_log_likelihood(result.theta, held_out)
    rng = np.random.default_rng(7)
    rivals = [np.r_[0.0, np.ones(5)]] + [np.r_[0.0, rng.random(5)] for _ in range(5)]
    for direction in rivals:
        c = irl.best_scale(direction, train)
        assert learned < irl.neg_log_likelihood(c * direction, held_out)


@pytest.mark.slow
def test_an_irrelevant_feature_gets_a_weight_near_zero():
    theta = THETA_TRUE.copy()
    theta[3] = 0.0  # the demonstrator does not care about jerk
    result = irl.fit_theta(near_rational_demonstrations(theta, 100, seed=1))
    assert result.theta[3] < 0.05 * result.theta[2]  # vs the accel weight it does care about
    assert abs(result.direction[3]) < 0.01


def test_fit_rejects_unknown_features_and_mixed_lengths():
    demos = near_rational_demonstrations(THETA_TRUE, 2, seed=0)  # any will do: no fit runs
    with pytest.raises(ValueError, match="cannot fit"):
        irl.fit_theta(demos, fitted=("speed", "tracking"))
    short = replace(demos[0], controls_mps2=np.zeros(5), others_xy=np.zeros((0, 5, 2)),
                    others_heading=np.zeros((0, 5)), others_length_m=[], others_width_m=[],
                    others_is_pedestrian=[])
    with pytest.raises(ValueError, match="share T"):
        irl.fit_theta([demos[0], short])


def test_recorded_human_segments_replay_the_simulator(tmp_path):
    """`marl-social record`: a human's segment, integrated with the IRL's dynamics, reproduces
    where the human really drove; its true theta and beta are kept; the file round-trips."""
    from marl_social.evaluation.record import episode_demonstrations
    from marl_social.evaluation.run import run_episode

    result = run_episode("occluded_crosswalk", seed=3, max_cycles=80, robot_planner="cruise",
                         human_beta=7.0)
    demos = episode_demonstrations(result, segment_steps=30, stride_steps=10)
    assert demos and all(d.agent == "human_0" for d in demos)
    assert np.allclose(demos[0].theta_true, CostWeights().as_array())
    assert demos[0].beta_true == 7.0
    h = result.trace.names.index("human_0")
    for d in demos:
        k0 = round(d.t0_s / 0.1)
        speed_map, dist_map, _ = irl.linear_maps(d.n_steps, d.dt_s)
        s = d.s0_m + (np.arange(d.n_steps) + 1) * d.dt_s * d.v0_mps + dist_map @ d.controls_mps2
        xy, _ = d.route.point_at(s)
        true_xy = result.trace.states[k0 + 1:k0 + d.n_steps + 1, h, :2]
        assert np.abs(xy[:, 0] - true_xy[:, 0]).max() < 0.05
        assert np.allclose(d.v0_mps + speed_map @ d.controls_mps2,
                           result.trace.states[k0 + 1:k0 + d.n_steps + 1, h, 3], atol=1e-3)
    path = save_demonstrations(tmp_path / "demos.npz", demos)
    back = load_demonstrations(path)
    assert len(back) == len(demos)
    assert np.array_equal(back[-1].controls_mps2, demos[-1].controls_mps2)
    assert np.array_equal(back[-1].others_xy, demos[-1].others_xy)


def test_cli_fit_writes_theta_json_that_a_scenario_loads(tmp_path, capsys):
    from marl_social.cli import main
    from marl_social.scenarios import make_scenario

    demos = near_rational_demonstrations(THETA_TRUE, 60, seed=0)  # the fixture's first 60
    demos_file = save_demonstrations(tmp_path / "demos.npz", demos)
    out = tmp_path / "theta.json"
    assert main(["irl", "fit", str(demos_file), "-o", str(out)]) == 0
    fit = json.loads(out.read_text())
    assert fit["fitted"] == ["speed", "accel", "jerk", "safety", "crosswalk"]
    assert fit["theta"][0] is None and fit["scale"] > 0
    scenario = make_scenario("occluded_crosswalk", robot_theta_hat=str(out))
    theta_hat = np.array(scenario.params.robot_theta_hat)
    theta_hat_dir = theta_hat[1:] / np.linalg.norm(theta_hat[1:])
    assert np.allclose(theta_hat_dir, np.array(fit["direction"][1:]), atol=1e-9)
    with pytest.raises(ValueError, match="not a marl-social IRL result"):
        (tmp_path / "bad.json").write_text("{}")
        make_scenario("occluded_crosswalk", robot_theta_hat=str(tmp_path / "bad.json"))
    capsys.readouterr()
    assert main(["irl", "fit", str(tmp_path / "bad.json"), "-o", str(out)]) == 2
    assert "not a demonstrations .npz file" in capsys.readouterr().err

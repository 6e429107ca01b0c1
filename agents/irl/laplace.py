"""Continuous inverse optimal control with the Laplace approximation.

Paper section III-C, eq. 13-17; Levine & Koltun 2012, "Continuous Inverse Optimal Control with
Locally Optimal Examples".

A demonstration (marl_social/data/demonstrations.py) is a control sequence u_D in R^T along a path.
Its cost is linear in the weights, C(u; theta) = sum_k theta_k C_k(u), C_k(u) = sum_t phi_k(x_t,
u_t) * dt / DT_S with the features of sim/costs.py (the planners' units: one simulator step
of 0.1 s is one unit). The demonstrator is modelled as P(u | theta) ∝ exp(-C(u; theta)); theta
is unnormalized, so its scale is the rationality beta and its direction the trade-off between
features. Around the demonstration the Laplace approximation gives

    log P(u_D | theta) ≈ -1/2 g^T H^-1 g + 1/2 log det H - T/2 log 2 pi          (eq. 16-17)

with g = sum_k theta_k g_k and H = sum_k theta_k H_k the gradient and Hessian of C with respect
to u at u_D. They are exact here:

* speed, acceleration, jerk are quadratic in u (v = v0 + V u, jerk = D u - prev):
  g_k, H_k in closed form;
* safety and crosswalk depend on u through the arc lengths s = s0 + ds0 + S u (linear, the
  trapezoidal rule of models/rollouts.rollout_speeds without the v >= 0 limit); their
  per-step derivatives d phi / d s_t and d^2 phi / d s_t^2 come from running the planners' own
  feature code on second-order jets (agents/irl/jets.py), so g = S^T phi', H = S^T diag(phi'') S;
* tracking (squared lateral offset) is constant along the path and cannot be identified from
  longitudinal controls: it is not fitted (its weight is reported as NaN).

A Hessian that is not positive definite (a concave safety term can make it so) is regularized
as Levine & Koltun do (section 6.1 of their paper): H + lambda I with the smallest lambda of the
geometric sequence delta * 10^j that makes the smallest eigenvalue at least delta; the lambda
used for each demonstration is reported (`LaplaceTerms.regularization`).

theta is fitted by maximizing sum_demos log P with scipy's L-BFGS-B (theta >= 0) and the exact
gradient d log P / d theta_k = -g_k^T h + 1/2 h^T H_k h + 1/2 tr(H^-1 H_k), h = H^-1 g.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from marl_social.agents.irl.fit_file import check_fit, load_fit  # noqa: F401 (load_fit public here)
from marl_social.agents.irl.jets import Jet
from marl_social.data import strict_json
from marl_social.data.demonstrations import Demonstration
from marl_social.sim.costs import (
    FEATURE_NAMES,
    N_FEATURES,
    CostWeights,
    StepInputs,
    _feature_terms,
)
from marl_social.sim.dynamics import DT_S
from marl_social.sim.footprint import covering_circles

FITTABLE = ("speed", "accel", "jerk", "safety", "crosswalk")
_POSITION_FEATURES = (False, False, False, False, True, True)  # safety, crosswalk


# -- exact derivatives of a demonstration's cost ------------------------------------------------
def linear_maps(n_steps: int, dt_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Controls to states for T = n_steps steps of dt_s.

    V (T, T): v_t = v0 + (V u)_t, speed after step t [m/s];
    S (T, T): ds_t = (t + 1) dt v0 + (S u)_t, distance after step t (trapezoidal) [m];
    D (T, T): jerk residual e = D u - prev e_0 (first difference) [m/s^2].
    """
    j = np.arange(n_steps)
    lower = j[None, :] <= j[:, None]
    speed_map = dt_s * lower.astype(np.float64)
    dist_map = dt_s * dt_s * np.where(lower, j[:, None] - j[None, :] + 0.5, 0.0)
    diff = np.eye(n_steps) - np.eye(n_steps, k=-1)
    return speed_map, dist_map, diff


PROGRESS_MIN_DEMOS = 1000  # fits of this many demonstrations or more show progress bars


@dataclass(frozen=True)
class FeatureDerivatives:
    """Per-feature totals and derivatives of one demonstration's cost at a control sequence.

    Attributes:
        totals: (F,) C_k(u) in FEATURE_NAMES order (simulator-step units).
        grad: (F, T) dC_k / du.
        hess: (F, T, T) d^2 C_k / du^2.
    """

    totals: np.ndarray
    grad: np.ndarray
    hess: np.ndarray


def feature_derivatives(demo: Demonstration, controls=None) -> FeatureDerivatives:
    """Exact C_k, g_k, H_k of every feature at `controls` (default the demonstration's own)."""
    u = demo.controls_mps2 if controls is None else np.asarray(controls, dtype=np.float64)
    n, dt = len(u), demo.dt_s
    speed_map, dist_map, diff = linear_maps(n, dt)
    scale = dt / DT_S
    v = demo.v0_mps + speed_map @ u
    s = demo.s0_m + (np.arange(n) + 1) * dt * demo.v0_mps + dist_map @ u
    totals = np.zeros(N_FEATURES)
    grad = np.zeros((N_FEATURES, n))
    hess = np.zeros((N_FEATURES, n, n))
    # quadratic features
    r = v - demo.v_ref_mps
    totals[1], grad[1], hess[1] = r @ r, 2.0 * speed_map.T @ r, 2.0 * speed_map.T @ speed_map
    totals[2], grad[2], hess[2] = u @ u, 2.0 * u, 2.0 * np.eye(n)
    e = diff @ u
    e[0] -= demo.prev_accel_mps2
    totals[3], grad[3], hess[3] = e @ e, 2.0 * diff.T @ e, 2.0 * diff.T @ diff
    # position features on jets: d/ds_t per step, chained through S
    for k, (value, d1, d2) in zip((4, 5), _position_feature_jets(demo, s)):
        totals[k] = value.sum()
        grad[k] = dist_map.T @ d1
        hess[k] = dist_map.T @ (d2[:, None] * dist_map)
    return FeatureDerivatives(totals * scale, grad * scale, hess * scale)


def _position_feature_jets(demo: Demonstration, s: np.ndarray):
    """(value, d/ds, d^2/ds^2) per step (T,) of the safety and crosswalk features.

    They are evaluated by sim/costs._feature_terms on jets. The path is a polyline: within a
    segment the position is linear in s and the heading constant (derivatives at vertices are
    one-sided).
    """
    route = demo.route
    xy, heading = route.point_at(s)  # (T, 2), (T,)
    tangent = np.stack([np.cos(heading), np.sin(heading)], axis=-1)
    circles, circle_r = covering_circles(xy, heading, demo.length_m, demo.width_m, False)
    ego_circles = Jet(circles, np.broadcast_to(tangent[:, None, :], circles.shape))
    ego_xy = Jet(xy, tangent)
    m = len(demo.others_length_m)
    n = len(s)
    if m:
        oc, orad = covering_circles(demo.others_xy, demo.others_heading,
                                    demo.others_length_m[:, None], demo.others_width_m[:, None],
                                    demo.others_is_pedestrian[:, None])  # (M, T, C, 2)
        other_circles, other_r = np.moveaxis(oc, 0, 1), np.moveaxis(orad, 0, 1)
        other_xy = np.moveaxis(demo.others_xy, 0, 1)  # (T, M, 2)
        other_radius = 0.5 * np.hypot(demo.others_length_m, demo.others_width_m)
        terms = _feature_terms(StepInputs(
            lateral_m=0.0, speed_mps=0.0, v_ref_mps=0.0, accel_mps2=0.0, prev_accel_mps2=0.0,
            ego_xy=ego_xy, ego_radius=0.5 * math.hypot(demo.length_m, demo.width_m),
            ego_is_ped=np.zeros(n, bool), ego_circles=ego_circles, ego_circle_r=circle_r,
            other_xy=other_xy, other_radius=other_radius,
            other_is_ped=np.broadcast_to(demo.others_is_pedestrian, (n, m)),
            other_circles=other_circles, other_circle_r=other_r,
            other_mask=np.ones((n, m), bool), crosswalks=demo.crosswalks), _POSITION_FEATURES)
    else:
        terms = [None] * 4 + [0.0, 0.0]
    out = []
    for term in terms[4:]:
        jet = term if isinstance(term, Jet) else Jet(np.broadcast_to(term, (n,)))
        out.append((np.broadcast_to(jet.value, (n,)), np.broadcast_to(jet.d1, (n,)),
                    np.broadcast_to(jet.d2, (n,))))
    return out


def finite_difference_derivatives(demo: Demonstration, controls=None, step: float = 1e-4):
    """Central finite differences: the tested fallback / check of `feature_derivatives`.

    Differences of C_k give the gradient (F, T), differences of the exact gradient the Hessian
    (F, T, T).
    """
    u = demo.controls_mps2 if controls is None else np.asarray(controls, dtype=np.float64)
    n = len(u)
    grad = np.zeros((N_FEATURES, n))
    hess = np.zeros((N_FEATURES, n, n))
    for t in range(n):
        du = np.zeros(n)
        du[t] = step
        plus, minus = feature_derivatives(demo, u + du), feature_derivatives(demo, u - du)
        grad[:, t] = (plus.totals - minus.totals) / (2 * step)
        hess[:, :, t] = (plus.grad - minus.grad) / (2 * step)
    return grad, hess


# -- Laplace likelihood -------------------------------------------------------------------------
@dataclass(frozen=True)
class DemoSet:
    """Derivatives of N demonstrations, stacked; all demonstrations share T.

    Attributes:
        grad: (N, F, T) dC_k / du of each demonstration.
        hess: (N, F, T, T) d^2 C_k / du^2 of each demonstration.
        totals: (N, F) C_k(u) of each demonstration (simulator-step units).
    """

    grad: np.ndarray
    hess: np.ndarray
    totals: np.ndarray

    @classmethod
    def from_demos(cls, demos: list[Demonstration]) -> DemoSet:
        if not demos:
            raise ValueError("IRL: no demonstrations")
        lengths = {d.n_steps for d in demos}
        if len(lengths) != 1:
            raise ValueError(f"IRL: demonstrations must share T, got lengths {sorted(lengths)}")
        derivs = [feature_derivatives(d) for d in tqdm(
            demos, desc="IRL: derivatives of the demonstrations", unit="demo", leave=False,
            disable=len(demos) < PROGRESS_MIN_DEMOS, dynamic_ncols=True)]
        return cls(np.stack([x.grad for x in derivs]), np.stack([x.hess for x in derivs]),
                   np.stack([x.totals for x in derivs]))

    def subset(self, index) -> DemoSet:
        return DemoSet(self.grad[index], self.hess[index], self.totals[index])

    def __len__(self) -> int:
        return len(self.grad)


@dataclass(frozen=True)
class LaplaceTerms:
    """Laplace log-likelihood of each demonstration and its gradient with respect to theta.

    Attributes:
        log_lik: (N,) log P(u_D | theta).
        grad_theta: (N, F) d log P / d theta_k.
        regularization: (N,) lambda added to H (0 where H was positive definite).
        min_eigenvalue: (N,) smallest eigenvalue of the unregularized H.
    """

    log_lik: np.ndarray
    grad_theta: np.ndarray
    regularization: np.ndarray
    min_eigenvalue: np.ndarray


def regularize(hessians: np.ndarray, delta_rel: float = 1e-6,
               max_steps: int = 40) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Make each (T, T) Hessian positive definite.

    H + lambda I with the smallest lambda of delta * 10^j, j = 0, 1, ..., whose smallest
    eigenvalue is >= delta, where delta = delta_rel * max(1, max |diag H|). Returns
    (H_reg (N, T, T), lambda (N,), eig_min (N,)).
    """
    eig_min = np.linalg.eigvalsh(hessians)[:, 0]
    delta = delta_rel * np.maximum(1.0, np.abs(np.diagonal(hessians, axis1=1, axis2=2)).max(1))
    lam = np.zeros(len(hessians))
    need = eig_min < delta
    for _ in range(max_steps):  # the path: lambda = delta, 10 delta, 100 delta, ...
        if not need.any():
            break
        lam = np.where(need, np.where(lam == 0.0, delta, 10.0 * lam), lam)
        need = eig_min + lam < delta
    eye = np.eye(hessians.shape[-1])
    return hessians + lam[:, None, None] * eye, lam, eig_min


def laplace_terms(theta: np.ndarray, demos: DemoSet) -> LaplaceTerms:
    """Log P(u_D | theta) (Laplace, eq. 17) of every demonstration and its theta-gradient."""
    theta = np.asarray(theta, dtype=np.float64)
    g = np.einsum("f,nft->nt", theta, demos.grad)
    h_mat = np.einsum("f,nftu->ntu", theta, demos.hess)
    h_reg, lam, eig_min = regularize(0.5 * (h_mat + np.swapaxes(h_mat, 1, 2)))
    chol = np.linalg.cholesky(h_reg)
    logdet = 2.0 * np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1)
    n_t = g.shape[1]
    h_inv = np.linalg.solve(h_reg, np.broadcast_to(np.eye(n_t), h_reg.shape))
    sol = np.einsum("ntu,nu->nt", h_inv, g)  # h = H^-1 g
    log_lik = -0.5 * np.einsum("nt,nt->n", g, sol) + 0.5 * logdet - 0.5 * n_t * math.log(
        2 * math.pi)
    grad_theta = (-np.einsum("nft,nt->nf", demos.grad, sol)
                  + 0.5 * np.einsum("nt,nftu,nu->nf", sol, demos.hess, sol)
                  + 0.5 * np.einsum("ntu,nfut->nf", h_inv, demos.hess))
    return LaplaceTerms(log_lik, grad_theta, lam, eig_min)


# -- fitting ------------------------------------------------------------------------------------
@dataclass
class IrlResult:
    """A fitted theta.

    Attributes:
        theta: (F,) unnormalized weights in FEATURE_NAMES order (NaN where not fitted).
        fitted: names of the fitted features.
        direction: (F,) theta / ||theta|| over the fitted features (NaN elsewhere).
        scale: ||theta|| over the fitted features: the rationality in simulator-step cost units.
        neg_log_lik: -sum log P(u_D | theta) over the training demonstrations.
        n_demos: number of training demonstrations; n_regularized: how many Hessians needed
            regularization at the optimum; fit_time_s: wall-clock time of the fit [s].
        converged, message: from scipy.optimize.
    """

    theta: np.ndarray
    fitted: tuple
    direction: np.ndarray
    scale: float
    neg_log_lik: float
    n_demos: int
    n_regularized: int
    fit_time_s: float
    converged: bool
    message: str
    extra: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        nan_none = lambda a: [None if not np.isfinite(x) else float(x) for x in a]
        return {
            "format": "marl-social-irl/1",
            "features": list(FEATURE_NAMES), "fitted": list(self.fitted),
            "theta": nan_none(self.theta), "direction": nan_none(self.direction),
            "scale": self.scale, "neg_log_lik": self.neg_log_lik, "n_demos": self.n_demos,
            "n_regularized": self.n_regularized, "fit_time_s": self.fit_time_s,
            "converged": self.converged, "message": self.message, **self.extra,
        }

    def save(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(strict_json.dumps(self.to_json(), indent=2) + "\n")
        return path


def fit_theta(demos, fitted=FITTABLE, theta0=None, max_iter: int = 500) -> IrlResult:
    """Maximize sum_demos log P(u_D | theta) over theta >= 0 for the `fitted` features.

    The other features are held at 0 and reported as NaN.

    Args:
        demos: list of Demonstration or a DemoSet.
        fitted: feature names to fit (tracking cannot be identified, see module docstring).
        theta0: (F,) initial weights (default: 1 per fitted feature, scaled so that each
            feature's mean Hessian trace is the same).
        max_iter: iteration limit of L-BFGS-B.
    """
    t_start = time.perf_counter()
    unknown = sorted(set(fitted) - set(FITTABLE))
    if unknown:
        raise ValueError(f"IRL: cannot fit feature(s) {unknown}; fittable: {list(FITTABLE)}")
    data = demos if isinstance(demos, DemoSet) else DemoSet.from_demos(list(demos))
    idx = np.array([FEATURE_NAMES.index(f) for f in fitted])
    # per-feature scaling so the optimizer's variables are O(1): a unit variable contributes
    # the same mean Hessian trace (curvature) for every feature
    trace = np.abs(np.trace(data.hess[:, idx], axis1=2, axis2=3)).mean(axis=0)
    unit = np.where(trace > 0, 1.0 / np.maximum(trace, 1e-300), 1.0) * trace[trace > 0].mean()
    if theta0 is None:
        w0 = np.ones(len(idx))
    else:
        w0 = np.asarray(theta0, dtype=np.float64)[idx] / unit

    def objective(w):
        theta = np.zeros(N_FEATURES)
        theta[idx] = w * unit
        terms = laplace_terms(theta, data)
        return -terms.log_lik.sum(), -terms.grad_theta[:, idx].sum(axis=0) * unit

    from scipy.optimize import minimize  # here: scipy.optimize takes ~0.7 s to import

    with tqdm(total=max_iter, desc="IRL: L-BFGS-B iterations (at most)", unit="it",
              leave=False, disable=len(data) < PROGRESS_MIN_DEMOS, dynamic_ncols=True) as bar:
        res = minimize(objective, w0, jac=True, method="L-BFGS-B",
                       bounds=[(0.0, None)] * len(idx), options={"maxiter": max_iter},
                       callback=lambda _: bar.update(1))
    theta = np.full(N_FEATURES, np.nan)
    theta[idx] = res.x * unit
    full = np.nan_to_num(theta)
    terms = laplace_terms(full, data)
    norm = float(np.linalg.norm(theta[idx]))
    direction = theta / norm if norm > 0 else theta * np.nan
    return IrlResult(theta, tuple(fitted), direction, norm, float(-terms.log_lik.sum()),
                     len(data), int((terms.regularization > 0).sum()),
                     time.perf_counter() - t_start, bool(res.success), str(res.message))


def neg_log_likelihood(theta, demos) -> float:
    """-sum log P(u_D | theta) (Laplace) of demonstrations (list or DemoSet)."""
    data = demos if isinstance(demos, DemoSet) else DemoSet.from_demos(list(demos))
    return float(-laplace_terms(np.nan_to_num(np.asarray(theta, dtype=np.float64)),
                                data).log_lik.sum())


def best_scale(direction, demos, bounds=(1e-3, 1e4)) -> float:
    """The scale c maximizing sum log P(u_D | c * direction).

    A fair rival for a fixed direction: its rationality fitted.
    """
    from scipy.optimize import minimize_scalar

    data = demos if isinstance(demos, DemoSet) else DemoSet.from_demos(list(demos))
    d = np.nan_to_num(np.asarray(direction, dtype=np.float64))
    res = minimize_scalar(lambda logc: neg_log_likelihood(math.exp(logc) * d, data),
                          bounds=tuple(math.log(b) for b in bounds), method="bounded")
    return math.exp(res.x)


def cosine_similarity(a, b, features=FITTABLE) -> float:
    """Cosine between two weight vectors over `features`."""
    idx = [FEATURE_NAMES.index(f) for f in features]
    x, y = np.asarray(a, dtype=np.float64)[idx], np.asarray(b, dtype=np.float64)[idx]
    return float(x @ y / (np.linalg.norm(x) * np.linalg.norm(y)))


# -- synthetic near-rational demonstrations -----------------------------------------------------
def optimal_controls(demo: Demonstration, theta, iterations: int = 50,
                     tol: float = 1e-9) -> np.ndarray:
    """The optimal controls argmin_u C(u; theta) for the demonstration's scene.

    The demonstration's controls are the start; damped Newton steps with the exact derivatives
    and a backtracking line search.
    """
    theta = np.nan_to_num(np.asarray(theta, dtype=np.float64))
    u = demo.controls_mps2.copy()
    cost = lambda d: float(theta @ d.totals)
    cur = feature_derivatives(demo, u)
    for _ in range(iterations):
        g = theta @ cur.grad
        h_reg, _, _ = regularize(np.einsum("f,ftu->tu", theta, cur.hess)[None])
        step = -np.linalg.solve(h_reg[0], g)
        if -g @ step < tol:
            break
        alpha = 1.0
        while alpha > 1e-8:
            cand = feature_derivatives(demo, u + alpha * step)
            if cost(cand) <= cost(cur) + 1e-4 * alpha * (g @ step):
                break
            alpha *= 0.5
        u, cur = u + alpha * step, cand
    return u


def sample_demonstration(demo: Demonstration, theta, rng: np.random.Generator
                         ) -> Demonstration:
    """A near-rational demonstration: u ~ N(u*, H(u*)^-1).

    This is the Laplace (Gaussian) form of P(u) ∝ exp(-C(u; theta)) around the optimum u*
    (larger ||theta|| = more rational).
    """
    from dataclasses import replace

    theta = np.nan_to_num(np.asarray(theta, dtype=np.float64))
    u_star = optimal_controls(demo, theta)
    d = feature_derivatives(demo, u_star)
    h_reg, _, _ = regularize(np.einsum("f,ftu->tu", theta, d.hess)[None])
    chol = np.linalg.cholesky(h_reg[0])
    # u = u* + L^-T z has covariance (L L^T)^-1 = H^-1
    noise = np.linalg.solve(chol.T, rng.standard_normal(len(u_star)))
    return replace(demo, controls_mps2=u_star + noise, theta_true=theta,
                   beta_true=float(np.linalg.norm(theta)))


def robot_model_from_fit(result_json: dict, reference: CostWeights | None = None
                         ) -> tuple[CostWeights, float]:
    """The robot's model of the humans from a fit: (theta_hat, beta_hat).

    theta_hat = the learned direction scaled to the norm of `reference` (default CostWeights,
    over the fitted features; unfitted features keep the reference's weights) and beta_hat =
    the learned scale / that norm, so that beta_hat * theta_hat equals the learned unnormalized
    theta on the fitted features.

    Args:
        result_json: a fit result (`LaplaceFit.to_json()` or `load_fit`); a ValueError names
            the first bad field.
        reference: the weights whose norm theta_hat gets; None for the default CostWeights.
    """
    check_fit(result_json, "IRL result")
    reference = reference or CostWeights()
    ref = reference.as_array()
    fitted = result_json["fitted"]
    idx = [FEATURE_NAMES.index(f) for f in fitted]
    direction = np.array([result_json["direction"][i] for i in idx], dtype=np.float64)
    ref_norm = float(np.linalg.norm(ref[idx]))
    theta = ref.copy()
    theta[idx] = np.maximum(direction, 0.0) * ref_norm
    return CostWeights(*theta.tolist()), float(result_json["scale"]) / ref_norm

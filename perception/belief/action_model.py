"""The noisily-rational action model: how likely a human's observed acceleration is (eq. 9-10).

The robot predicts a human's action distribution from its Q-values (Boltzmann, rationality
beta) and weighs the acceleration it observed with a heavy-tailed (Student-t) kernel of the
observation noise about each action; `bounded_log_likelihood` caps what one observation can do
to a belief.
`perception/belief/social.py` (hidden agents, traffic speed) and `phase.py` (signal phases)
both score humans with it.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.models.boltzmann import boltzmann
from marl_social.perception.belief import compiled

# the model of a human averaged over the robot's estimate of its speed: three-point Gauss-Hermite
# nodes at -sqrt 3, 0, +sqrt 3 standard deviations of the estimate, weights 1/6, 2/3, 1/6
# (`speed_nodes_mps`, `speed_averaged_log_likelihood`)
SPEED_NODES_SIGMA = np.array([-math.sqrt(3.0), 0.0, math.sqrt(3.0)])
LOG_SPEED_NODE_WEIGHTS = np.log(np.array([1.0, 4.0, 1.0]) / 6.0)
for _constant in (SPEED_NODES_SIGMA, LOG_SPEED_NODE_WEIGHTS):
    _constant.setflags(write=False)
SIGMA_MIN_MPS2 = 1e-3  # the observation noise on a_obs is at least this [m/s^2]


def action_log_likelihood(q_values: np.ndarray, beta: float, a_obs: float,
                          actions_mps2: np.ndarray, sigma_mps2: float,
                          tail_dof: float = math.inf) -> np.ndarray:
    """Log P(a_obs | x) of one observed acceleration under several hypotheses x (eq. 9-10).

        P(a_obs | x) = sum_u softmax(-beta Q*(x, .))[u] t_nu(a_obs - u; sigma)

    with t_nu the Student-t density of nu = tail_dof degrees of freedom and scale sigma
    (`observation_log_kernel`; nu = inf is the normal density of eq. 10). Its tails are heavy:
    an observation far from every candidate (a tracking glitch, an emergency stop the model
    does not predict) still favours the hypotheses whose actions lie nearest to it, by a
    bounded factor, instead of counting for nothing or for everything.

    Args:
        q_values: (..., A) Q*_H(x, u) of the A candidate actions (eq. 11) per hypothesis.
        beta: rationality of the model (inf = argmin).
        a_obs: observed acceleration [m/s^2]; non-finite values give zeros (uninformative).
        actions_mps2: (A,) accelerations the candidate actions execute as [m/s^2].
        sigma_mps2: scale of the observation noise on a_obs [m/s^2].
        tail_dof: nu > 0 (inf: normal).

    Returns:
        (...) log-likelihoods.
    """
    q = np.asarray(q_values, dtype=np.float64)
    actions = np.asarray(actions_mps2, dtype=np.float64)
    if q.shape[-1] == 0:
        raise ValueError("action_log_likelihood: no candidate actions (q_values' last axis is "
                         "empty)")
    if not math.isfinite(a_obs) or (math.isinf(beta) and not np.all(np.isfinite(q))):
        return np.zeros(q.shape[:-1])
    log_kernel = observation_log_kernel(a_obs, actions, sigma_mps2, tail_dof)
    if math.isinf(beta):
        with np.errstate(divide="ignore"):
            log_p = np.log(boltzmann(q, math.inf))
        return logsumexp(log_p + log_kernel, axis=-1)
    # numpy's np.exp and np.log, the steps between them compiled
    log_model = _compiled_log_model(q, beta, log_kernel)
    return np.zeros(q.shape[:-1]) if log_model is None else log_model


def observation_log_kernel(a_obs: float, actions_mps2: np.ndarray, sigma_mps2: float,
                           tail_dof: float = math.inf) -> np.ndarray:
    """(A,) log t_nu(a_obs - u; sigma) of each candidate action u (nu = inf: normal).

        log t_nu(d; sigma) = lgamma((nu + 1) / 2) - lgamma(nu / 2) - log(sqrt(nu pi) sigma)
                             - (nu + 1) / 2 log(1 + (d / sigma)^2 / nu)

    sigma is at least SIGMA_MIN_MPS2. An absurd a_obs gives -inf everywhere (uninformative
    downstream).

    Args:
        a_obs: observed acceleration [m/s^2].
        actions_mps2: (A,) candidate accelerations [m/s^2].
        sigma_mps2: scale [m/s^2].
        tail_dof: degrees of freedom nu > 0.
    """
    sigma = max(float(sigma_mps2), SIGMA_MIN_MPS2)
    nu = float(tail_dof)
    if not nu > 0:
        raise ValueError(f"observation_log_kernel: tail_dof must be > 0, got {tail_dof!r}")
    with np.errstate(over="ignore"):
        d2 = ((a_obs - np.asarray(actions_mps2, dtype=np.float64)) / sigma) ** 2
    if math.isinf(nu):
        return -0.5 * d2 - math.log(sigma * math.sqrt(2 * math.pi))
    norm = (math.lgamma(0.5 * (nu + 1.0)) - math.lgamma(0.5 * nu)
            - math.log(math.sqrt(nu * math.pi) * sigma))
    return norm - 0.5 * (nu + 1.0) * np.log1p(d2 / nu)


def speed_nodes_mps(v_mps: float, std_mps: float) -> np.ndarray:
    """(3,) speeds [m/s] at which a human's Q* is evaluated to average over its speed estimate.

    v_mps + SPEED_NODES_SIGMA * std_mps, the estimate and its std [m/s], at least 0 (a car
    does not reverse).
    """
    return np.maximum(float(v_mps) + SPEED_NODES_SIGMA * max(float(std_mps), 0.0), 0.0)


def speed_averaged_log_likelihood(q_nodes: np.ndarray, beta: float, a_obs: float,
                                  actions_mps2: np.ndarray, sigma_mps2: float,
                                  tail_dof: float = math.inf) -> np.ndarray:
    """`action_log_likelihood` averaged over the robot's uncertainty about the human's speed.

        P(a_obs | x) = sum_s w_s P(a_obs | x, v_s)

    over the Gauss-Hermite nodes v_s of `speed_nodes_mps` (weights 1/6, 2/3, 1/6). A human's
    best action can change across ~0.1 m/s of its speed (whether it can still make its curve
    speed, or stop before a crosswalk): a model evaluated at the robot's estimate alone is then
    confidently wrong about a human whose true speed lies on the other side, and the belief
    reads that human's ordinary braking as evidence of a hidden agent.

    Args:
        q_nodes: (3, ..., A) Q*_H from each node's speed.
        beta: rationality of the model (inf = argmin).
        a_obs: observed acceleration [m/s^2].
        actions_mps2: (A,) accelerations the candidate actions execute as [m/s^2].
        sigma_mps2: std of the observation noise on a_obs [m/s^2].
        tail_dof: the kernel's degrees of freedom (action_log_likelihood).

    Returns:
        (...) log-likelihoods; zeros (uninformative) where any is not finite.
    """
    ll = action_log_likelihood(q_nodes, beta, a_obs, actions_mps2, sigma_mps2, tail_dof)
    # logsumexp(ll + log w, axis=0) with numpy's np.exp and np.log, the steps between them
    # compiled (belief_kernels.node_average_terms, column_sums; the numpy formulation they
    # replaced: tests/perception/test_belief_kernels.py)
    kernels = compiled.kernels()
    shifted, top = kernels.node_average_terms(
        np.ascontiguousarray(ll).reshape(len(ll), -1), LOG_SPEED_NODE_WEIGHTS)
    if not len(shifted):  # a log-likelihood is not finite
        return np.zeros(ll.shape[1:])
    return (np.log(kernels.column_sums(np.exp(shifted))) + top).reshape(ll.shape[1:])


def _compiled_log_model(q: np.ndarray, beta: float, log_kernel: np.ndarray
                        ) -> np.ndarray | None:
    """Log sum_u softmax(-beta q)[u] exp(log_kernel[u]) (...), finite beta; None if not finite.

    numpy's np.exp and np.log; belief_kernels.boltzmann_exponents, row_sums and
    shifted_log_model_terms do the rest in the order of the numpy formulation they replaced
    (tests/perception/test_belief_kernels.py compares them bit for bit, any row length).

    Args:
        q: (..., A) Q-values.
        beta: rationality (finite).
        log_kernel: (A,) log density of the observation under each action
            (`observation_log_kernel`).
    """
    kernels = compiled.kernels()
    rows = np.ascontiguousarray(q).reshape(-1, q.shape[-1])
    z = kernels.boltzmann_exponents(rows, float(beta))
    if not len(z) and len(rows):  # a Q-value is not finite
        return None
    log_norm = np.log(kernels.row_sums(np.exp(z)))  # each sum >= exp(0) = 1
    shifted, top = kernels.shifted_log_model_terms(z, log_norm,
                                                   np.ascontiguousarray(log_kernel))
    with np.errstate(divide="ignore"):
        log_sum = np.log(kernels.row_sums(np.exp(shifted)))
    return (log_sum + top).reshape(q.shape[:-1])


def bounded_log_likelihood(log_lik: np.ndarray, max_ratio: float) -> np.ndarray:
    """Log-likelihoods (...) of one observation, none more than max_ratio below the maximum.

    Then no single observation changes the log-odds between any two sets of hypotheses by more
    than max_ratio [nats] (each set's likelihood is a belief-weighted mean of values within a
    factor exp(max_ratio) of each other). Non-finite input is returned unchanged (the filter
    ignores it).

    Args:
        log_lik: (...) log P(a_obs | hypothesis).
        max_ratio: the bound [nats], > 0.
    """
    ll = np.asarray(log_lik, dtype=np.float64)
    if not ll.size:
        return ll
    return compiled.kernels().bounded(np.ascontiguousarray(ll).ravel(),
                                      float(max_ratio)).reshape(ll.shape)


def logsumexp(x: np.ndarray, axis: int) -> np.ndarray:
    """Log sum exp along axis, safe for -inf entries (all -inf gives -inf).

    Kept local: scipy.special.logsumexp (>= 1.15, log1p of the non-max terms) differs in the
    last bits, which would change seeded episodes.
    """
    top = np.max(x, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.exp(x - top).sum(axis=axis, keepdims=True)) + top
    return np.squeeze(out, axis=axis)

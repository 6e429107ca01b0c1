"""Noisy measurements of what each observer sees.

Every (observer, target) pair that is visible gets Gaussian noise on position, velocity and
heading with the observer's own noise levels, drawn from the episode's seeded generator in a
fixed order (so an episode is reproducible bit for bit).
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.observation import Measurements


def measure(visible, xy, heading, speed, pos_noise_m, vel_noise_mps, heading_noise_rad,
            rng: np.random.Generator) -> Measurements:
    """Measure every visible target.

    Args:
        visible: (n, n) bool from the field of view, visible[observer, target].
        xy: (n, 2) true positions [m].
        heading: (n,) true headings [rad].
        speed: (n,) true speeds [m/s].
        pos_noise_m: (n,) each observer's position noise std [m].
        vel_noise_mps: (n,) each observer's velocity noise std [m/s].
        heading_noise_rad: (n,) each observer's heading noise std [rad].
        rng: the episode's generator.

    Returns:
        Measurements, one row per visible pair, sorted by observer then true distance.
    """
    obs, tgt = np.nonzero(visible)
    d = xy[tgt] - xy[obs]
    dist = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])  # np.linalg.norm, without its wrapper
    order = np.lexsort((tgt, dist, obs))
    obs, tgt, dist = obs[order], tgt[order], dist[order]
    noise = rng.standard_normal((len(obs), 5))
    true_vel = np.empty((len(speed), 2))
    true_vel[:, 0] = speed * np.cos(heading)
    true_vel[:, 1] = speed * np.sin(heading)
    m_xy = xy[tgt] + noise[:, 0:2] * pos_noise_m[obs, None]
    m_vel = true_vel[tgt] + noise[:, 2:4] * vel_noise_mps[obs, None]
    m_heading = heading[tgt] + noise[:, 4] * heading_noise_rad[obs]
    return Measurements(obs, tgt, m_xy, m_vel, m_heading, dist)

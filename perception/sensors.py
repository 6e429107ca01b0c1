"""Noisy measurements of what each observer sees.

Every (observer, target) pair that is visible gets Gaussian noise on position, velocity and
heading with the observer's own noise levels, drawn from the episode's seeded generator in a
fixed order (so an episode is reproducible bit for bit).
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.kernel_cache import cached_kernels
from marl_social.sim.observation import Measurements

sensor_kernels = cached_kernels("marl_social.perception", "sensor_kernels",
                                "the sensors' numba kernels", 2)


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
    kernels = sensor_kernels()
    # compiled (perception/sensor_kernels.py): np.nonzero's pairs, their distances and
    # np.lexsort((target, distance, observer))'s order; then the noise, in the same order
    obs, tgt, dist = kernels.visible_pairs(visible, xy)
    noise = rng.standard_normal((len(obs), 5))
    m_xy, m_vel, m_heading = kernels.noisy_values(
        obs, tgt, noise, (xy, np.cos(heading), np.sin(heading), speed, heading),
        (pos_noise_m, vel_noise_mps, heading_noise_rad))
    return Measurements(obs, tgt, m_xy, m_vel, m_heading, dist)

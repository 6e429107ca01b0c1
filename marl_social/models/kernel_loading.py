"""Loading the compiled (numba) kernels once per process, with a word when they compile.

`models/gap_kernels.py`, `cost_kernels.py`, `scene_kernels.py` and `zone_kernels.py` are compiled at
their import (one fixed signature each, `cache=True`). From numba's on-disk cache that takes under a second; with no
cache -- the first run after an install or after an edit of a kernel file -- numba compiles
them, about 30 s on a 2-core machine, before the first decision. So that such a first run
does not look hung, `load` then logs one warning (logger ``marl_social``; stderr when logging
is not configured) before it compiles.
"""

from __future__ import annotations

import functools

from marl_social.sim.kernel_cache import load_kernels

_KERNEL_FILES = ("gap_kernels", "cost_kernels", "scene_kernels", "zone_kernels")


@functools.cache  # called at every decision: a cached call, not load_kernels' lookup
def load_all() -> tuple:
    """(models.gap_kernels, cost_kernels, scene_kernels, zone_kernels), imported once."""
    return load_kernels("marl_social.models", _KERNEL_FILES, "the planners' numba kernels", 30)


@functools.cache
def load() -> tuple:
    """(models.gap_kernels, models.cost_kernels), imported (and if need be compiled) once.

    Every kernel file is loaded (`load_all`): one warning, one compilation for all of them.
    """
    return load_all()[:2]

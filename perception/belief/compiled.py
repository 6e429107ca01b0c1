"""The belief's compiled kernels (belief_kernels.py, view_kernels.py), imported when first used.

Importing numba and loading the kernels from numba's on-disk cache takes a while; the belief
modules ask for them here, when they first need them, not at `import marl_social`. Without
a cache (the first run after an install or an edit of their files) numba compiles them
then, about 15 s on a 2-core machine: `kernels` says so first (logger ``marl_social``;
sim/kernel_cache.load_kernels, which loads the planners' kernels too).
"""

from __future__ import annotations

import functools
from types import ModuleType

from marl_social.sim.kernel_cache import load_kernels

KERNEL_FILES = ("belief_kernels", "view_kernels")


@functools.cache  # called at every belief kernel use: a cached call, not load_kernels' lookup
def kernels() -> ModuleType:
    """perception.belief.belief_kernels, imported (and if need be compiled) once."""
    return load_kernels("marl_social.perception.belief", KERNEL_FILES,
                        "the belief's numba kernels", 15)[0]


@functools.cache
def view() -> ModuleType:
    """perception.belief.view_kernels, imported (and if need be compiled) once."""
    return load_kernels("marl_social.perception.belief", KERNEL_FILES,
                        "the belief's numba kernels", 15)[1]

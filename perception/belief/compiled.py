"""The belief's compiled kernels (belief_kernels.py), imported at the first update.

Importing numba and loading the kernels from numba's on-disk cache takes a while; the belief
modules ask for them here, when they first need them, not at `import marl_social`. Without
a cache (the first run after an install or an edit of belief_kernels.py) numba compiles them
then, about 15 s on a 2-core machine: `kernels` says so first (logger ``marl_social``), as
models/kernel_loading does for the planners' kernels.
"""

from __future__ import annotations

import logging
from pathlib import Path
from types import ModuleType

from marl_social.sim.kernel_cache import will_compile

# the longest contiguous sum the kernels take (belief_kernels._pairwise_sum: numpy's pairwise
# block, no further split); longer rows stay in numpy
PAIRWISE_MAX = 128
_LOADED: list[ModuleType] = []


def kernels() -> ModuleType:
    """perception.belief.belief_kernels, imported (and if need be compiled) once."""
    if not _LOADED:
        if _will_compile():
            logging.getLogger("marl_social").warning(
                "compiling the belief's numba kernels once (about 15 s; cached in %s for "
                "later runs)", Path(__file__).with_name("__pycache__"))
        from marl_social.perception.belief import belief_kernels

        _LOADED.append(belief_kernels)
    return _LOADED[0]


def _will_compile() -> bool:
    """Whether belief_kernels.py has no numba cache index at least as new as it."""
    return will_compile(Path(__file__).parent, ("belief_kernels",))

"""The belief's compiled kernels (belief_kernels.py), imported at the first update.

Importing numba and loading the kernels from numba's on-disk cache takes a while; the belief
modules ask for them here, when they first need them, not at `import marl_social`. Without
a cache (the first run after an install or an edit of belief_kernels.py) numba compiles them
then, a few seconds.
"""

from __future__ import annotations

from types import ModuleType

# the longest contiguous sum the kernels take (belief_kernels._pairwise_sum: numpy's pairwise
# block, no further split); longer rows stay in numpy
PAIRWISE_MAX = 128
_LOADED: list[ModuleType] = []


def kernels() -> ModuleType:
    """perception.belief.belief_kernels, imported (and if need be compiled) once."""
    if not _LOADED:
        from marl_social.perception.belief import belief_kernels

        _LOADED.append(belief_kernels)
    return _LOADED[0]

"""Whether a numba kernel file will compile at its import (no current cache on disk).

numba's `cache=True` keeps a kernel's machine code in the __pycache__ beside its file; a
process that finds none as new as the file compiles it, which takes seconds to tens of
seconds. The loaders of the compiled kernels (models/kernel_loading.py, sim/road_map.py's
route kernels, perception/belief/compiled.py, agents/robot/tree_ipm.py) ask here first and
say so before a cold compile, so that the first run does not look hung;
agents/compile_kernels.py compiles what is missing ahead of a parallel run.
"""

from __future__ import annotations

import os
from pathlib import Path


def will_compile(folder: Path, names: tuple[str, ...]) -> bool:
    """Whether a kernel file folder/NAME.py has no numba cache index at least as new as it.

    False when the cache folder cannot be written: numba then caches elsewhere
    (NUMBA_CACHE_DIR or the user's cache) and this cannot tell.

    Args:
        folder: the kernel modules' folder (numba caches in its __pycache__).
        names: the kernel modules' names, without ".py".
    """
    cache = folder / "__pycache__"
    if os.environ.get("NUMBA_CACHE_DIR") or (cache.exists() and not os.access(cache, os.W_OK)):
        return False
    for name in names:
        source = (folder / f"{name}.py").stat().st_mtime
        index = list(cache.glob(f"{name}.*.nbi")) if cache.exists() else []
        # index files of functions at old line numbers stay behind: the newest one counts
        if not index or max(p.stat().st_mtime for p in index) < source:
            return True
    return False

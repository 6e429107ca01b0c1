"""Loading the compiled (numba) kernels once per process, with a word when they compile.

`models/gap_kernels.py` and `models/cost_kernels.py` are compiled at their import (one fixed
signature each, `cache=True`). From numba's on-disk cache that takes under a second; with no
cache -- the first run after an install or after an edit of a kernel file -- numba compiles
them, about 30 s on a 2-core machine, before the first decision. So that such a first run
does not look hung, `load` then logs one warning (logger ``marl_social``; stderr when logging
is not configured) before it compiles.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

_LOADED: list = []  # [gap_kernels, cost_kernels] once imported
_KERNEL_FILES = ("gap_kernels", "cost_kernels")


def load() -> tuple:
    """(models.gap_kernels, models.cost_kernels), imported (and if need be compiled) once."""
    if not _LOADED:
        if _will_compile():
            logging.getLogger("marl_social").warning(
                "compiling the planners' numba kernels once (about 30 s; cached in %s for "
                "later runs)", _cache_dir())
        from marl_social.models import cost_kernels, gap_kernels
        _LOADED.extend((gap_kernels, cost_kernels))
    return tuple(_LOADED)


def _cache_dir() -> Path:
    """Where numba keeps the kernels' machine code when it can write there (__pycache__)."""
    return Path(__file__).with_name("__pycache__")


def _will_compile(here: Path | None = None) -> bool:
    """Whether a planner kernel file in `here` (default: this package) will compile."""
    return will_compile(Path(__file__).parent if here is None else here, _KERNEL_FILES)


def will_compile(folder: Path, names: tuple[str, ...]) -> bool:
    """Whether a kernel file folder/NAME.py has no numba cache index at least as new as it.

    False when the cache folder cannot be written: numba then caches elsewhere
    (NUMBA_CACHE_DIR or the user's cache) and this cannot tell. Also used by the belief's
    kernels (perception/belief/compiled.py).

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

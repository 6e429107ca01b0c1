"""Loading the compiled (numba) kernels once per process, with a word when they compile.

`models/gap_kernels.py` and `models/cost_kernels.py` are compiled at their import (one fixed
signature each, `cache=True`). From numba's on-disk cache that takes under a second; with no
cache -- the first run after an install or after an edit of a kernel file -- numba compiles
them, about 30 s on a 2-core machine, before the first decision. So that such a first run
does not look hung, `load` then logs one warning (logger ``marl_social``; stderr when logging
is not configured) before it compiles.
"""

from __future__ import annotations

from pathlib import Path

from marl_social.sim.kernel_cache import load_kernels, will_compile

_KERNEL_FILES = ("gap_kernels", "cost_kernels")


def load() -> tuple:
    """(models.gap_kernels, models.cost_kernels), imported (and if need be compiled) once."""
    return load_kernels("marl_social.models", _KERNEL_FILES, "the planners' numba kernels", 30)


def _cache_dir() -> Path:
    """Where numba keeps the kernels' machine code when it can write there (__pycache__)."""
    return Path(__file__).with_name("__pycache__")


def _will_compile(here: Path | None = None) -> bool:
    """Whether a planner kernel file in `here` (default: this package) will compile."""
    return will_compile(Path(__file__).parent if here is None else here, _KERNEL_FILES)

"""Loading numba kernel files once per process, with a word first when they will compile.

numba's `cache=True` keeps a kernel's machine code in the __pycache__ beside its file; a
process that finds none as new as the file compiles it, which takes seconds to tens of
seconds. `load_kernels` imports a package's kernel files at the first call of a process
(numba compiles or loads them then, not at the import of marl_social), after one warning
if `will_compile` says they have no current cache, so that the first run does not look hung:
the planners' kernels (models/kernel_loading.py), the route projection (`route_kernels`
here), the contact test's broad phase (`geometry_kernels` here), the observation's encoding
(`observation_kernels` here), the env's pairwise cost features (`feature_kernels` here), the
field of view's (perception/fov.py) and the belief's (perception/belief/compiled.py); the MPC's
tree solver (agents/robot/tree_ipm.py) asks `will_compile` at its own import.
agents/compile_kernels.py compiles what is missing ahead of a parallel run.
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import logging
import os
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

# (package, kernel module names) -> the imported modules, once per process
_LOADED: dict[tuple[str, tuple[str, ...]], tuple[ModuleType, ...]] = {}


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


def load_kernels(package: str, names: tuple[str, ...], what: str,
                 about_s: int) -> tuple[ModuleType, ...]:
    """The kernel modules package.NAME for NAME in names, imported (and compiled) once.

    The first call of a process imports them; if one will compile (`will_compile`), it first
    logs one warning (logger ``marl_social``; stderr when logging is not configured) naming
    `what`, about how long it takes and where the cache goes.

    Args:
        package: the dotted package holding the kernel files, e.g. "marl_social.models".
        names: the kernel modules' names, without ".py".
        what: what compiles, for the warning, e.g. "the planners' numba kernels".
        about_s: about how long the cold compile takes on a 2-core machine [s].

    Returns:
        The modules, in the order of `names`.
    """
    key = (package, tuple(names))
    if key not in _LOADED:
        folder = Path(importlib.util.find_spec(package).submodule_search_locations[0])
        if will_compile(folder, key[1]):
            logging.getLogger("marl_social").warning(
                "compiling %s once (about %d s; cached in %s for later runs)", what, about_s,
                folder / "__pycache__")
        _LOADED[key] = tuple(importlib.import_module(f"{package}.{name}") for name in key[1])
    return _LOADED[key]


def cached_kernels(package: str, name: str, what: str, about_s: int) -> Callable[[], ModuleType]:
    """A function that returns package.NAME (`load_kernels`), cached after its first call.

    The simulator and the field of view ask for their kernel modules every step (the route
    projection ~10-30 times): a cached call is cheaper than load_kernels' lookup.

    Args:
        package: the dotted package holding the kernel file.
        name: the kernel module's name, without ".py".
        what: what compiles, for the warning.
        about_s: about how long the cold compile takes on a 2-core machine [s].
    """
    @functools.cache
    def kernels() -> ModuleType:
        return load_kernels(package, (name,), what, about_s)[0]

    kernels.__doc__ = f"{package}.{name} ({what}), loaded once."
    return kernels


# the simulator's kernel modules (the route projection and the lane test, the contact test's
# broad phase, the observation's encoding, the env's pairwise cost features)
route_kernels = cached_kernels("marl_social.sim", "route_kernels",
                               "the route projection's numba kernel", 3)
geometry_kernels = cached_kernels("marl_social.sim", "geometry_kernels",
                                  "the contact test's numba kernel", 2)
observation_kernels = cached_kernels("marl_social.sim", "observation_kernels",
                                     "the observation's numba kernel", 2)
feature_kernels = cached_kernels("marl_social.sim", "feature_kernels",
                                 "the cost features' numba kernels", 3)

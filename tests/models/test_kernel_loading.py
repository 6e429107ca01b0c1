"""The compiled kernels load once per process and say so before a cold compile."""

from __future__ import annotations

import os
from pathlib import Path

from marl_social.models import kernel_loading
from marl_social.sim.kernel_cache import will_compile

_CACHE_DIR = Path(kernel_loading.__file__).with_name("__pycache__")


def _kernel_files(folder, cached: bool, cache_older: bool = False):
    (folder / "__pycache__").mkdir()
    for name in kernel_loading._KERNEL_FILES:
        source = folder / f"{name}.py"
        source.write_text("# kernels\n")
        if cached:
            index = folder / "__pycache__" / f"{name}.plan-10.py311.nbi"
            index.write_bytes(b"")
            stamp = source.stat().st_mtime + (-60 if cache_older else 60)
            os.utime(index, (stamp, stamp))
            orphan = folder / "__pycache__" / f"{name}.plan-3.py311.nbi"  # before an edit
            orphan.write_bytes(b"")
            os.utime(orphan, (stamp - 600, stamp - 600))


def test_a_cold_or_stale_cache_is_told_apart_from_a_fresh_one(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    cold, stale, fresh = (tmp_path / d for d in ("cold", "stale", "fresh"))
    for folder in (cold, stale, fresh):
        folder.mkdir()
    _kernel_files(cold, cached=False)
    _kernel_files(stale, cached=True, cache_older=True)  # a kernel file edited since
    _kernel_files(fresh, cached=True)
    assert will_compile(cold, kernel_loading._KERNEL_FILES)
    assert will_compile(stale, kernel_loading._KERNEL_FILES)
    assert not will_compile(fresh, kernel_loading._KERNEL_FILES)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))  # cached elsewhere: cannot tell
    assert not will_compile(cold, kernel_loading._KERNEL_FILES)


def test_the_kernels_load_once_and_are_then_cached_beside_their_source():
    first = kernel_loading.load()
    assert kernel_loading.load() == first
    assert [k.__name__ for k in first] == ["marl_social.models.gap_kernels",
                                           "marl_social.models.cost_kernels"]
    if os.access(_CACHE_DIR, os.W_OK) and not os.environ.get("NUMBA_CACHE_DIR"):
        # what was compiled is on disk now
        assert not will_compile(_CACHE_DIR.parent, kernel_loading._KERNEL_FILES)

"""load_kernels: a package's kernel modules import once per process, with one warning first when
they have no numba cache (a cold compile would otherwise look like a hang)."""

from __future__ import annotations

import logging
import sys

from marl_social.sim import kernel_cache


def test_a_cold_kernel_package_warns_once_and_loads_once(tmp_path, monkeypatch, caplog):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    package = tmp_path / "cold_kernels_pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "first.py").write_text("VALUE = 1\n")
    (package / "second.py").write_text("VALUE = 2\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(kernel_cache, "_LOADED", {})
    with caplog.at_level(logging.WARNING, logger="marl_social"):
        loaded = kernel_cache.load_kernels("cold_kernels_pkg", ("first", "second"),
                                           "the test's kernels", 7)
        again = kernel_cache.load_kernels("cold_kernels_pkg", ("first", "second"),
                                          "the test's kernels", 7)
    assert [m.VALUE for m in loaded] == [1, 2] and again == loaded
    warnings = [r.getMessage() for r in caplog.records]
    assert len(warnings) == 1, warnings  # no numba cache index beside the files: one word
    assert "the test's kernels" in warnings[0] and "about 7 s" in warnings[0]
    assert str(package / "__pycache__") in warnings[0]
    for name in ("cold_kernels_pkg", "cold_kernels_pkg.first", "cold_kernels_pkg.second"):
        sys.modules.pop(name, None)


def test_the_route_kernels_are_the_sim_module():
    from marl_social.sim import route_kernels

    assert kernel_cache.route_kernels() is route_kernels

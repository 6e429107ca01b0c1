"""The installed package holds every subpackage of the source tree (pyproject lists them)."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]


def _source_packages() -> set[str]:
    """Dotted names of every folder with an __init__.py, as pyproject's package-dir maps them."""
    config = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    package_dir = config["tool"]["setuptools"]["package-dir"]
    names = set()
    for package, folder in package_dir.items():
        for init in (REPO_ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(REPO_ROOT / folder)
            names.add(".".join([package, *rel.parts]))
    return names


def test_every_source_package_is_installed():
    config = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    listed = set(config["tool"]["setuptools"]["packages"])
    missing = _source_packages() - listed
    assert not missing, f"pyproject.toml [tool.setuptools] packages misses {sorted(missing)}"


def test_import_leaves_the_heavy_dependencies_for_their_first_use():
    """`import marl_social` (issue 17: < 1 s) imports no solver, compiler or statistics
    package: the MPC's QP solvers come with the first robot planner, numba with the first
    kernel, filterpy and scipy.stats never in a simulation (~1.5 s of every process before)."""
    heavy = ("osqp", "daqp", "scipy.sparse", "scipy.stats", "filterpy", "numba")
    code = ("import sys\nimport marl_social\n"
            f"print([m for m in {heavy!r} if m in sys.modules])\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]", done.stdout

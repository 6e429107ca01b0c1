"""MkDocs hook: a source tree in which mkdocstrings finds every marl_social package.

pyproject's package-dir maps `marl_social.agents` to the top-level folder agents/ and
`marl_social.perception` to perception/; griffe's static analysis only sees marl_social/.
This hook asks the installed package where each of these lives (importlib, no import of the
code: `pip install -e .` from a clean clone is enough) and builds build/api-src/marl_social,
a tree of symlinks that has them all in their places; mkdocs.yml points the python handler's
`paths` at build/api-src.
"""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TREE = ROOT / "build" / "api-src"
PACKAGE = "marl_social"
MAPPED = ("agents", "perception")  # subpackages that live outside marl_social/


def _location(name: str) -> Path:
    """Folder of an installed package, found without importing it."""
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError(f"api_sources: package {name!r} is not installed; run "
                           f"`pip install -e .` first")
    return Path(list(spec.submodule_search_locations)[0]).resolve()


def build_tree() -> Path:
    """(Re)build build/api-src/marl_social with symlinks to the real sources."""
    root = _location(PACKAGE)
    mapped = {sub: _location(f"{PACKAGE}.{sub}") for sub in MAPPED}
    target = TREE / PACKAGE
    if TREE.exists():
        shutil.rmtree(TREE)
    target.mkdir(parents=True)
    for child in root.iterdir():
        if child.name not in mapped and child.name != "__pycache__":
            (target / child.name).symlink_to(child)
    for sub, path in mapped.items():
        (target / sub).symlink_to(path, target_is_directory=True)
    return TREE


def on_startup(command, dirty) -> None:  # noqa: ARG001 - MkDocs hook signature
    """Build the tree before MkDocs loads its plugins."""
    build_tree()


build_tree()  # also at import: mkdocstrings may read its paths before on_startup

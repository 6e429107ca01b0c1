"""MkDocs hook: the static player's script and style, from the teaching app's package folder.

docs/teach/player.html loads assets/render.js, assets/player.js and assets/teach.css; they live
once, in marl_social/teach/page-assets/ (the live app serves the same files), and are copied into
the built site's teach/assets/ after the build.
"""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
STATIC = ROOT / "marl_social" / "teach" / "page-assets"
PLAYER_ASSETS = ("render.js", "player.js", "teach.css")


def copy_player_assets(folder) -> None:
    """Copy the player's assets into `folder` (created if missing)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name in PLAYER_ASSETS:
        shutil.copyfile(STATIC / name, folder / name)


def on_post_build(config, **kwargs) -> None:
    copy_player_assets(Path(config["site_dir"]) / "teach" / "assets")

"""Precomputed episodes for the docs site's static player (no server): compact JSON.

`python -m marl_social.teach.export docs/teach/episodes` writes one file per lecture episode
(DOCS_EPISODES) and an index.json listing them. Each file holds the panes' headers and every
frame, as the live app sends them (scene_json.py), with every other depth ray of the fields of
view kept (a drawing, not a measurement).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from marl_social.teach.session import EpisodeConfig, EpisodeSession

EXPORT_MAX_CYCLES = 120  # 12 s: each lecture episode's story is told by then
FOV_STRIDE = 2  # keep every this many depth rays of a field of view
# (file name, title, {leaf: value}, planners side by side)
DOCS_EPISODES = (
    ("social-vs-aggressive", "social against aggressive: the human warns, who listens?",
     {}, ("social", "aggressive")),
    ("blind-human", "a blind human: its behaviour tells the robot nothing",
     {"human.blind": True}, ("social",)),
    ("erratic-human", "an erratic human (β = 0): random braking looks like a warning",
     {"human.beta": 0.0}, ("social", "social+beta")),
    ("wrong-model", "a wrong θ̂: the robot thinks humans ignore crosswalks",
     {"robot.theta_hat": (1.0, 1.0, 0.2, 0.2, 1.0, 1.0)}, ("social",)),
)


def _thin(frame: dict) -> dict:
    fov = []
    for i, outline in frame["fov"]:
        cone = len(outline) % 2 == 1  # apex + an even number of rays
        rays = outline[1:] if cone else outline
        kept = rays[::FOV_STRIDE] + ([rays[-1]] if (len(rays) - 1) % FOV_STRIDE else [])
        fov.append([i, ([outline[0]] if cone else []) + kept])
    return {**frame, "fov": fov}


def export_episode(settings: dict, planners, seed: int = 0,
                   max_cycles: int = EXPORT_MAX_CYCLES) -> dict:
    """{"panes": [{"header", "frames"}, ...]}: one pane per planner, the same seed.

    Args:
        settings: {settings-tree leaf: value} of the occluded crosswalk.
        planners: the robot planners shown side by side.
        seed: the episode's seed.
        max_cycles: the step limit.
    """
    panes = []
    for planner in planners:
        session = EpisodeSession(EpisodeConfig(
            "occluded_crosswalk", {**settings, "robot.planner": planner}, seed, max_cycles))
        frames = [_thin(session.frame())]
        while not session.done:
            frames.append(_thin(session.step()))
        panes.append({"header": session.header(), "frames": frames})
        session.close()
    return {"panes": panes}


def export_docs_episodes(folder) -> list[Path]:
    """Write DOCS_EPISODES and index.json into `folder`; returns the files written."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written, index = [], []
    for name, title, settings, planners in DOCS_EPISODES:
        path = folder / f"{name}.json"
        episode = {"title": title, **export_episode(settings, planners)}
        path.write_text(json.dumps(episode, separators=(",", ":")), encoding="utf-8")
        index.append({"name": name, "title": title, "file": path.name})
        written.append(path)
    (folder / "index.json").write_text(json.dumps(index, indent=1) + "\n", encoding="utf-8")
    return [*written, folder / "index.json"]


if __name__ == "__main__":  # pragma: no cover - a maintainer's command
    for written_path in export_docs_episodes(sys.argv[1] if len(sys.argv) > 1 else "."):
        print(written_path, written_path.stat().st_size, "bytes")

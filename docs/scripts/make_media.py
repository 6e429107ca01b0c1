"""Regenerate the pictures of the docs and README: the demo GIF and the paper's figures.

    python docs/scripts/make_media.py [--gif docs/demo.gif] [--out docs/img]

Writes the GIF (the occluded crosswalk with the social robot and a crossing pedestrian,
every agent's field of view, the legend and the robot's belief under each frame; every
second step, < 1.5 MB) and the paper-style figures of `marl-social reproduce` (Figs. 3-6,
seed 0) as small PNGs into --out. Deterministic: the same files for the same code.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image

from marl_social.evaluation.reproduce import write_figures
from marl_social.evaluation.run import run_episode
from marl_social.viz.animation import write_animation
from marl_social.viz.overlay import caption_frames, crosswalk_ahead

FRAME_STRIDE = 2  # keep every second step: 5 frames per simulated second
FIGURE_WIDTH_PX = 900  # the docs' PNGs are downscaled to this width [px]


def demo_gif(path: Path, seed: int = 0) -> Path:
    """The captioned demo animation of the social robot, crossing pedestrian."""
    res = run_episode("occluded_crosswalk", seed=seed, render=True, pedestrian="crossing",
                      robot_planner="social")
    tr = res.trace
    robot = tr.names.index("robot_0")
    ahead = crosswalk_ahead(tr.states, tr.active, res.road_map, robot)
    frames = caption_frames(tr.frames, tr.extras["p_pedestrian"], tr.extras["perceived"],
                            ahead)
    # end a second after the robot has driven off the map's end
    on_map = tr.active[:, robot] & (tr.states[:, robot, 0] < res.road_map.extent[1])
    last = min(len(frames), int(np.flatnonzero(on_map)[-1]) + 1 + 10)
    frames = frames[:last]
    fps = round(10 / FRAME_STRIDE)
    return write_animation(frames[::FRAME_STRIDE], path, fps=fps)


def figures(out: Path, seed: int = 0) -> list[Path]:
    """The paper's Figs. 3-6 (`marl-social reproduce`), downscaled PNGs."""
    paths = write_figures(out, seed=seed)
    for path in paths:
        img = Image.open(path)
        if img.width > FIGURE_WIDTH_PX:
            h = round(img.height * FIGURE_WIDTH_PX / img.width)
            img.convert("RGB").resize((FIGURE_WIDTH_PX, h), Image.LANCZOS).save(
                path, optimize=True)
    return paths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    docs = Path(__file__).resolve().parents[1]
    parser.add_argument("--gif", default=str(docs / "demo.gif"))
    parser.add_argument("--out", default=str(docs / "img"))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    gif = demo_gif(Path(args.gif), args.seed)
    print(f"{gif}: {gif.stat().st_size / 1e6:.2f} MB")
    for path in figures(out, args.seed):
        print(f"{path}: {path.stat().st_size / 1e3:.0f} kB")


if __name__ == "__main__":
    main()

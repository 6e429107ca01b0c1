"""Animated GIFs: every frame, in order, at the requested rate."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from marl_social.viz.animation import write_animation
from tests.viz.pixels import red_pixels


def test_write_animation_writes_a_gif_with_every_frame(tmp_path):
    frames = []
    for k in range(5):
        frame = np.full((40, 60, 3), 200, np.uint8)
        frame[10:20, 5 + 10 * k:15 + 10 * k] = (220, 30, 30)  # a red box moving right
        frames.append(frame)
    path = write_animation(frames, tmp_path / "nested" / "dir" / "anim.gif", fps=5)
    assert path.exists()
    with Image.open(path) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == 5
        assert gif.size == (60, 40)
        assert gif.info["duration"] == 200
        gif.seek(4)
        last = np.asarray(gif.convert("RGB"))
    assert red_pixels(last)[15, 50] and not red_pixels(last)[15, 10]
    with pytest.raises(ValueError):
        write_animation([], tmp_path / "empty.gif")
    with pytest.raises(ValueError):
        write_animation([frames[0], frames[0][:20]], tmp_path / "ragged.gif")

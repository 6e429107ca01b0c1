"""Animated GIFs of rendered frames (Pillow)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image

GIF_DELAY_UNIT_MS = 10  # GIF frame delays are whole multiples of this [ms]
PALETTE_SAMPLE_PIXELS = 4_000_000  # about how many pixels of all frames choose the palette


def write_animation(frames: Sequence[np.ndarray], path, fps: int = 10) -> Path:
    """Write frames as a looping animated GIF.

    Args:
        frames: non-empty list of (H, W, 3) (or (H, W, 4)) uint8 RGB(A) frames, all one size.
        path: output file (parent directories are created); ".gif" is the natural suffix.
        fps: frames per second (GIF delays are whole 10 ms units).

    Returns:
        The path written. Pillow merges consecutive identical frames into one longer frame.

    All frames share one palette of 256 colours (`_palette`), each pixel its nearest colour
    (no dithering): an identical background stays identical from frame to frame, and the
    colours are chosen once, not for each frame.
    """
    if len(frames) == 0:
        raise ValueError("write_animation: no frames")
    if isinstance(fps, bool) or not fps > 0:
        raise ValueError(f"write_animation: fps must be > 0, got {fps!r}")
    shape = np.shape(frames[0])
    images = []
    for k, frame in enumerate(frames):
        arr = np.asarray(frame)
        if arr.shape != shape or arr.ndim != 3 or arr.shape[2] not in (3, 4):
            raise ValueError(f"write_animation: frame {k} has shape {arr.shape}; expected every "
                             f"frame (H, W, 3|4) like frame 0 {shape}")
        if arr.dtype != np.uint8:
            raise ValueError(f"write_animation: frame {k} has dtype {arr.dtype}, expected uint8")
        images.append(np.ascontiguousarray(arr[..., :3]))
    palette = _palette(images)
    images = [Image.fromarray(rgb).quantize(palette=palette, dither=Image.Dither.NONE)
              for rgb in images]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:],
                   duration=max(GIF_DELAY_UNIT_MS, round(1000.0 / fps)), loop=0)
    return path


def _palette(frames: list[np.ndarray]) -> Image.Image:
    """A "P" image whose 256-colour palette (Pillow's fast octree) fits every (H, W, 3) frame.

    The octree sees every frame, on a grid of every s-th row and column (s so that about
    PALETTE_SAMPLE_PIXELS pixels in all: s = 1 for small animations).
    """
    height, width = frames[0].shape[:2]
    stride = max(1, int(np.sqrt(len(frames) * height * width / PALETTE_SAMPLE_PIXELS)))
    sample = np.concatenate([frame[::stride, ::stride] for frame in frames], axis=0)
    return Image.fromarray(sample).quantize(256, method=Image.Quantize.FASTOCTREE)

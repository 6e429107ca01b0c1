"""Pixel masks of the role colours, shared by the viz tests."""

from __future__ import annotations

import numpy as np


def red_pixels(frame: np.ndarray) -> np.ndarray:
    """(H, W) bool: the robot's saturated red in an (H, W, 3) image."""
    r, g, b = (frame[..., c].astype(int) for c in range(3))
    return (r > 190) & (g < 90) & (b < 90)


def green_pixels(frame: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pedestrian's saturated green in an (H, W, 3) image."""
    r, g, b = (frame[..., c].astype(int) for c in range(3))
    return (g > 120) & (r < 80) & (b < 80)

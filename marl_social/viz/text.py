"""Text pasted into frames as pre-rendered sprites: name labels and a fast monospace time stamp.

Matplotlib text costs about a millisecond per string per frame. Here each string is rasterised
once on its own small Agg canvas (never pyplot) into an RGBA `Sprite`, and frames only
alpha-blend the cached pixels with numpy. Sizes are in typographic points [pt] converted with
the frame's dpi [px per inch]; positions are pixel rows and columns [px], row 0 at the top.
"""

from __future__ import annotations

import numpy as np
from matplotlib import patheffects
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from marl_social.viz.style import LABEL_COLOR, LABEL_HALO_COLOR, TIME_COLOR

HALO_WIDTH_PT = 2.2  # white stroke around label text [pt]
MONO_CACHE_SIZE = 4096  # composed monospace strings kept before the cache is emptied
TIME_BOX_PAD_PX = 3  # padding of the time stamp's box [px]
TIME_BOX_ALPHA = 0.8  # opacity of the time stamp's white box


class Sprite:
    """A small pre-rendered RGBA image pasted into frames with numpy.

    Attributes:
        rgb: (h, w, 3) float32 colour premultiplied by alpha, 0..255.
        alpha: (h, w, 1) float32 opacity, 0..1.
        anchor: (row, col) pixel of the sprite placed at the requested frame position.
    """

    __slots__ = ("alpha", "anchor", "rgb")

    def __init__(self, rgba: np.ndarray, anchor: tuple[int, int]):
        """Premultiply an (h, w, 4) uint8 straight-alpha image; anchor is (row, col) [px]."""
        rgba = np.asarray(rgba, dtype=np.float32)
        self.alpha = rgba[..., 3:4] / 255.0
        self.rgb = rgba[..., :3] * self.alpha
        self.anchor = anchor

    def paste(self, frame: np.ndarray, row: int, col: int) -> None:
        """Alpha-blend into frame (H, W, 3) uint8 in place, anchor at (row, col) [px]; clipped."""
        h, w = self.alpha.shape[:2]
        r0, c0 = row - self.anchor[0], col - self.anchor[1]
        ra, rb = max(r0, 0), min(r0 + h, frame.shape[0])
        ca, cb = max(c0, 0), min(c0 + w, frame.shape[1])
        if ra >= rb or ca >= cb:
            return
        src = (slice(ra - r0, rb - r0), slice(ca - c0, cb - c0))
        region = frame[ra:rb, ca:cb].astype(np.float32)
        out = self.rgb[src] + region * (1.0 - self.alpha[src])
        frame[ra:rb, ca:cb] = (out + 0.5).astype(np.uint8)


def render_text(text: str, fontsize: float, dpi: float, color: str, family: str = "sans-serif",
                stroke: str | None = None) -> tuple[np.ndarray, int, int]:
    """Rasterise one line of text on a transparent background.

    Args:
        text: the line.
        fontsize: font size [pt].
        dpi: resolution [px per inch].
        color: text colour (any matplotlib colour).
        family: font family.
        stroke: colour of a halo around the glyphs, or None.

    Returns:
        rgba (h, w, 4) uint8 (straight alpha), baseline row and left column of the text [px].
    """
    px = fontsize * dpi / 72.0
    w, h = int(len(text) * px * 0.8 + 4 * px) + 8, int(3 * px) + 8
    left, base = int(px) + 4, int(h - 1.1 * px)  # baseline row counted from the top
    fig = Figure(figsize=(w / dpi, h / dpi), dpi=dpi, facecolor=(0.0, 0.0, 0.0, 0.0))
    canvas = FigureCanvasAgg(fig)
    effects = ([patheffects.withStroke(linewidth=HALO_WIDTH_PT, foreground=stroke)]
               if stroke is not None else None)
    fig.text(left / w, 1.0 - base / h, text, fontsize=fontsize, color=color, family=family,
             ha="left", va="baseline", path_effects=effects)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy(), base, left


def label_sprite(text: str, fontsize: float, dpi: float) -> Sprite:
    """Dark text with a white halo, cropped to its ink, anchored at its bottom centre.

    Args:
        text: the label.
        fontsize: font size [pt].
        dpi: resolution [px per inch].
    """
    rgba, _, _ = render_text(text, fontsize, dpi, LABEL_COLOR, stroke=LABEL_HALO_COLOR)
    rows, cols = np.nonzero(rgba[..., 3])
    if rows.size == 0:
        return Sprite(np.zeros((1, 1, 4)), (0, 0))
    rgba = rgba[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
    return Sprite(rgba, (rgba.shape[0], rgba.shape[1] // 2))


class MonoText:
    """Fast changing text (the time stamp): monospace glyphs rendered once, then composed.

    Args:
        fontsize: font size [pt].
        dpi: resolution [px per inch].
        color: text colour.
    """

    def __init__(self, fontsize: float, dpi: float, color: str = TIME_COLOR):
        """Measure the glyph advance [px] of the monospace font at this size."""
        self.fontsize, self.dpi, self.color = fontsize, dpi, color
        probe, _, _ = render_text("0" * 20, fontsize, dpi, color, family="monospace")
        ink = np.nonzero(probe[..., 3].any(axis=0))[0]
        # 20 glyphs span 19 advances plus one glyph's ink width: measure two probes
        probe1, _, _ = render_text("0", fontsize, dpi, color, family="monospace")
        ink1 = np.nonzero(probe1[..., 3].any(axis=0))[0]
        self.advance = ((ink.max() - ink.min()) - (ink1.max() - ink1.min())) / 19.0
        self._glyphs: dict[str, tuple[Sprite, int, int]] = {}
        self._cache: dict[str, Sprite] = {}  # composed strings (time stamps repeat)

    def _glyph(self, ch: str) -> tuple[Sprite, int, int]:
        """Sprite, baseline row and left column [px] of one character (rendered once)."""
        if ch not in self._glyphs:
            rgba, base, left = render_text(ch, self.fontsize, self.dpi, self.color,
                                           family="monospace")
            self._glyphs[ch] = (Sprite(rgba, (base, left)), base, left)
        return self._glyphs[ch]

    def sprite(self, text: str, pad_px: int = TIME_BOX_PAD_PX,
               box_alpha: float = TIME_BOX_ALPHA) -> Sprite:
        """The text on a translucent white box, anchored at the box's top-left corner.

        Args:
            text: the string (composed from cached glyphs; composed strings are cached too).
            pad_px: padding between the text and the box's edge [px].
            box_alpha: opacity of the white box, 0..1.
        """
        sprite = self._cache.get(text)
        if sprite is None:
            if len(self._cache) >= MONO_CACHE_SIZE:
                self._cache.clear()
            sprite = self._cache[text] = self._compose(text, pad_px, box_alpha)
        return sprite

    def _compose(self, text: str, pad_px: int, box_alpha: float) -> Sprite:
        """Blend the glyphs of `text` one advance apart onto the box (see `sprite`)."""
        glyphs = [self._glyph(ch) for ch in text]
        px = self.fontsize * self.dpi / 72.0
        ascent, descent = int(1.0 * px), int(0.3 * px) + 1
        h = ascent + descent + 2 * pad_px
        w = int(np.ceil(len(text) * self.advance)) + 2 * pad_px + 2
        rgb = np.full((h, w, 3), 255.0 * box_alpha, dtype=np.float32)  # premultiplied white
        alpha = np.full((h, w, 1), box_alpha, dtype=np.float32)
        base_row = pad_px + ascent
        for k, (glyph, base, left) in enumerate(glyphs):
            a, c = glyph.alpha, glyph.rgb
            r0 = base_row - base
            c0 = pad_px + round(k * self.advance) - left
            ra, rb = max(r0, 0), min(r0 + a.shape[0], h)
            ca, cb = max(c0, 0), min(c0 + a.shape[1], w)
            src = (slice(ra - r0, rb - r0), slice(ca - c0, cb - c0))
            rgb[ra:rb, ca:cb] = c[src] + rgb[ra:rb, ca:cb] * (1.0 - a[src])
            alpha[ra:rb, ca:cb] = a[src] + alpha[ra:rb, ca:cb] * (1.0 - a[src])
        sprite = Sprite(np.zeros((1, 1, 4)), (0, 0))
        sprite.rgb, sprite.alpha = rgb, alpha
        return sprite

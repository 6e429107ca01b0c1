"""Rendering with matplotlib: live frames, GIF animations and paper-style episode figures.

* `Renderer` draws the current scene of a `World` into an (H, W, 3) uint8 RGB array: road and
  lane markings, crosswalk stripes, houses, vehicles (robot red, human drivers yellow),
  pedestrians (green discs), name labels, the time and, optionally, every agent's field of view
  as a translucent fan. It draws on its own Agg canvas (`matplotlib.figure.Figure` +
  `FigureCanvasAgg`, never pyplot), so it works headless and in parallel worker processes. The
  static map is rasterised once (in cached tiles) and copied; each frame only draws the agents.
* `write_animation` writes frames as an animated GIF (Pillow).
* `plot_episode` draws a figure like Figs. 3-6 of Sun et al. 2019: (a) trajectory snapshots on
  the map, (b) the cars' speeds, (c) whether the robot (and the human) perceive the pedestrian,
  plus any extra belief time series.

Colours follow the paper: red box robot, yellow box human-driven car, green dot pedestrian.
All coordinates are metres in the world frame, angles radians counter-clockwise from +x.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Self

import numpy as np
from matplotlib import patheffects
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon
from PIL import Image

from marl_social.sim.footprint import box_corners
from marl_social.sim.road_map import RoadMap, Route

ROLE_COLORS = {"robot": "#e3211c", "human": "#f5c000", "pedestrian": "#12a31a"}
ROLE_EDGE_COLORS = {"robot": "#7a0d0a", "human": "#8a6a00", "pedestrian": "#05520a"}
OTHER_COLOR, OTHER_EDGE_COLOR = "#8c8c8c", "#404040"  # agents with an unknown role
BACKGROUND_COLOR = "#ebe8e0"  # sidewalks, gardens: everything off the road
ROAD_COLOR = "#7b7d80"
MARKING_COLOR = "#ffffff"
HOUSE_COLOR, HOUSE_EDGE_COLOR = "#b48c69", "#6d4f36"
CROSSWALK_STRIPE_M = 0.5  # zebra stripe thickness along the walking direction [m]
CROSSWALK_PERIOD_M = 1.0  # stripe + gap [m]
LANE_DASH_M = (3.0, 6.0)  # dashed lane line: painted, gap [m]
FAN_ALPHA = {"robot": 0.18, "human": 0.13, "pedestrian": 0.09}  # fill opacity of the fans
PED_MIN_RADIUS_PX = 5.0  # pedestrians are drawn at least this large so they stay visible [px]
SEEN_MARGIN_M = 0.45  # gap between an agent and the robot's "I see you" outline [m]


def _role_color(role: str) -> tuple[str, str]:
    """Face and edge colour of a role."""
    return ROLE_COLORS.get(role, OTHER_COLOR), ROLE_EDGE_COLORS.get(role, OTHER_EDGE_COLOR)


# -- static map -------------------------------------------------------------------------------
def _dash_segments(polyline: np.ndarray, on_m: float, off_m: float) -> list[np.ndarray]:
    """Painted pieces of a dashed line along a polyline (P, 2) [m], in data units [m]."""
    route = Route(polyline)
    starts = np.arange(0.5 * off_m, route.length_m, on_m + off_m)
    pieces = []
    for s0 in starts:
        s1 = min(s0 + on_m, route.length_m)
        inner = route._cum_s[(route._cum_s > s0) & (route._cum_s < s1)]  # keep corners
        xy, _ = route.point_at(np.concatenate([[s0], inner, [s1]]))
        pieces.append(xy)
    return pieces


def _point_in_lane(point: np.ndarray, lane, tol_m: float = 0.05) -> bool:
    """Whether a point (2,) [m] lies inside or on the outline of a lane."""
    route = Route(lane.centerline)
    s, lateral, _ = route.project(point)
    return bool(-tol_m <= s <= route.length_m + tol_m and abs(lateral) <= 0.5 * lane.width_m + tol_m)


def _lane_markings(road_map: RoadMap) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Solid road edges and dashed lane dividers as polylines (P, 2) [m].

    A lane edge whose midpoint lies on another lane is a divider (drawn once, dashed); any other
    edge borders the road (solid).
    """
    solid, dashed = [], []
    for i, lane in enumerate(road_map.lanes):
        outline = lane.polygon()
        p = len(lane.centerline)
        for edge in (outline[:p], outline[p:][::-1]):
            mid = 0.5 * (edge[0] + edge[1])
            shared = [j for j, other in enumerate(road_map.lanes)
                      if j != i and _point_in_lane(mid, other)]
            if not shared:
                solid.append(edge)
            elif i < min(shared):
                dashed.extend(_dash_segments(edge, *LANE_DASH_M))
    return solid, dashed


def _crosswalk_stripes(crosswalk) -> list[np.ndarray]:
    """Zebra stripes (4, 2) [m] of a crosswalk: bars parallel to the traffic, spaced along the
    walking direction.
    """
    c, s = math.cos(crosswalk.walk_heading_rad), math.sin(crosswalk.walk_heading_rad)
    along, across = np.array([c, s]), np.array([-s, c])
    half_len, half_w = 0.5 * crosswalk.length_m, 0.5 * crosswalk.width_m
    n = max(1, int((crosswalk.length_m + CROSSWALK_PERIOD_M - CROSSWALK_STRIPE_M)
                   // CROSSWALK_PERIOD_M))
    used = (n - 1) * CROSSWALK_PERIOD_M + CROSSWALK_STRIPE_M
    u0 = -half_len + 0.5 * (crosswalk.length_m - used)
    stripes = []
    for k in range(n):
        a = u0 + k * CROSSWALK_PERIOD_M
        b = min(a + CROSSWALK_STRIPE_M, half_len)
        stripes.append(np.array([
            crosswalk.center + a * along - half_w * across,
            crosswalk.center + b * along - half_w * across,
            crosswalk.center + b * along + half_w * across,
            crosswalk.center + a * along + half_w * across,
        ]))
    return stripes


def _draw_road_map(ax, road_map: RoadMap, line_scale: float = 1.0) -> None:
    """Draw the static map (road, markings, crosswalks, houses) on a matplotlib Axes.

    Args:
        ax: the Axes (data units metres).
        road_map: the map.
        line_scale: multiplies the marking line widths (points).
    """
    lanes = [lane.polygon() for lane in road_map.lanes]
    if lanes:
        ax.add_collection(PolyCollection(lanes, facecolors=ROAD_COLOR, edgecolors=ROAD_COLOR,
                                         linewidths=0.5, zorder=0.5))
    solid, dashed = _lane_markings(road_map)
    if solid:
        ax.add_collection(LineCollection(solid, colors=MARKING_COLOR, linewidths=1.6 * line_scale,
                                         zorder=0.7))
    if dashed:
        ax.add_collection(LineCollection(dashed, colors=MARKING_COLOR,
                                         linewidths=1.2 * line_scale, zorder=0.7))
    stripes = [st for cw in road_map.crosswalks for st in _crosswalk_stripes(cw)]
    if stripes:
        ax.add_collection(PolyCollection(stripes, facecolors=MARKING_COLOR, edgecolors="none",
                                         zorder=0.8))
    if road_map.static_polygons:
        ax.add_collection(PolyCollection(list(road_map.static_polygons), facecolors=HOUSE_COLOR,
                                         edgecolors=HOUSE_EDGE_COLOR, linewidths=0.8 * line_scale,
                                         zorder=0.9))


def _nice_length(target_m: float) -> float:
    """Largest 1, 2 or 5 x 10^k not above target_m [m] (scale bar length)."""
    base = 10.0 ** math.floor(math.log10(target_m))
    return max(m * base for m in (1.0, 2.0, 5.0) if m * base <= target_m)


def _check_view(view) -> tuple[float, float, float, float] | None:
    """Validate a view (xmin, xmax, ymin, ymax) [m]."""
    if view is None:
        return None
    v = tuple(float(x) for x in view)
    if len(v) != 4 or not all(math.isfinite(x) for x in v) or v[0] >= v[1] or v[2] >= v[3]:
        raise ValueError(f"view must be finite (xmin, xmax, ymin, ymax) with xmin < xmax and "
                         f"ymin < ymax, got {view!r}")
    return v


def _gui_backend_available() -> bool:
    """Whether pyplot's backend can open a window (False on a headless machine)."""
    import matplotlib.pyplot as plt

    name = plt.get_backend().lower()
    try:
        from matplotlib.backends import BackendFilter, backend_registry
    except ImportError:  # matplotlib < 3.9
        from matplotlib import rcsetup

        interactive = {b.lower() for b in rcsetup.interactive_bk}
    else:
        interactive = set(backend_registry.list_builtin(BackendFilter.INTERACTIVE))
    return name in interactive and name != "webagg"


# -- text sprites -----------------------------------------------------------------------------
class _Sprite:
    """A small pre-rendered RGBA image pasted into frames with numpy.

    Attributes:
        rgb: (h, w, 3) float32 colour premultiplied by alpha, 0..255.
        alpha: (h, w, 1) float32 opacity, 0..1.
        anchor: (row, col) pixel of the sprite placed at the requested frame position.
    """

    __slots__ = ("alpha", "anchor", "rgb")

    def __init__(self, rgba: np.ndarray, anchor: tuple[int, int]):
        rgba = np.asarray(rgba, dtype=np.float32)
        self.alpha = rgba[..., 3:4] / 255.0
        self.rgb = rgba[..., :3] * self.alpha
        self.anchor = anchor

    def paste(self, frame: np.ndarray, row: int, col: int) -> None:
        """Alpha-blend into frame (H, W, 3) uint8 in place, anchor at (row, col); clipped."""
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


def _render_text(text: str, fontsize: float, dpi: float, color: str, family: str = "sans-serif",
                 stroke: str | None = None) -> tuple[np.ndarray, int, int]:
    """Rasterise one line of text on a transparent background.

    Returns:
        rgba (h, w, 4) uint8 (straight alpha), baseline row and left column of the text [px].
    """
    px = fontsize * dpi / 72.0
    w, h = int(len(text) * px * 0.8 + 4 * px) + 8, int(3 * px) + 8
    left, base = int(px) + 4, int(h - 1.1 * px)  # baseline row counted from the top
    fig = Figure(figsize=(w / dpi, h / dpi), dpi=dpi, facecolor=(0.0, 0.0, 0.0, 0.0))
    canvas = FigureCanvasAgg(fig)
    effects = ([patheffects.withStroke(linewidth=2.2, foreground=stroke)]
               if stroke is not None else None)
    fig.text(left / w, 1.0 - base / h, text, fontsize=fontsize, color=color, family=family,
             ha="left", va="baseline", path_effects=effects)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy(), base, left


def _label_sprite(text: str, fontsize: float, dpi: float) -> _Sprite:
    """Dark text with a white halo, cropped to its ink, anchored at its bottom centre."""
    rgba, _, _ = _render_text(text, fontsize, dpi, "#1a1a1a", stroke="white")
    rows, cols = np.nonzero(rgba[..., 3])
    if rows.size == 0:
        return _Sprite(np.zeros((1, 1, 4)), (0, 0))
    rgba = rgba[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
    return _Sprite(rgba, (rgba.shape[0], rgba.shape[1] // 2))


class _MonoText:
    """Fast changing text (the time stamp): monospace glyphs rendered once, then composed."""

    def __init__(self, fontsize: float, dpi: float, color: str = "#111111"):
        self.fontsize, self.dpi, self.color = fontsize, dpi, color
        probe, _, _ = _render_text("0" * 20, fontsize, dpi, color, family="monospace")
        ink = np.nonzero(probe[..., 3].any(axis=0))[0]
        # 20 glyphs span 19 advances plus one glyph's ink width: measure two probes
        probe1, _, _ = _render_text("0", fontsize, dpi, color, family="monospace")
        ink1 = np.nonzero(probe1[..., 3].any(axis=0))[0]
        self.advance = ((ink.max() - ink.min()) - (ink1.max() - ink1.min())) / 19.0
        self._glyphs: dict[str, tuple[_Sprite, int, int]] = {}
        self._cache: dict[str, _Sprite] = {}  # composed strings (time stamps repeat)

    def _glyph(self, ch: str) -> tuple[_Sprite, int, int]:
        if ch not in self._glyphs:
            rgba, base, left = _render_text(ch, self.fontsize, self.dpi, self.color,
                                            family="monospace")
            self._glyphs[ch] = (_Sprite(rgba, (base, left)), base, left)
        return self._glyphs[ch]

    def sprite(self, text: str, pad_px: int = 3, box_alpha: float = 0.8) -> _Sprite:
        """The text on a translucent white box, anchored at the box's top-left corner."""
        sprite = self._cache.get(text)
        if sprite is None:
            if len(self._cache) >= 4096:
                self._cache.clear()
            sprite = self._cache[text] = self._compose(text, pad_px, box_alpha)
        return sprite

    def _compose(self, text: str, pad_px: int, box_alpha: float) -> _Sprite:
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
        sprite = _Sprite(np.zeros((1, 1, 4)), (0, 0))
        sprite.rgb, sprite.alpha = rgb, alpha
        return sprite


# -- live frames ------------------------------------------------------------------------------
_DISC = np.column_stack([np.cos(np.linspace(0.0, 2 * np.pi, 24, endpoint=False)),
                         np.sin(np.linspace(0.0, 2 * np.pi, 24, endpoint=False))])
_TILE_CACHE = 6  # static-map tiles kept per Renderer


class Renderer:
    """Draws a World into RGB frames, reusing one Agg figure.

    Args:
        road_map: the static map.
        show: "human" mode: also display every frame in a pyplot window if a GUI backend is
            available; otherwise (headless) silently behave like rgb_array.
        width_px, height_px: frame size [px].
        view: (xmin, xmax, ymin, ymax) region to show [m]; default the map's `extent`. It is grown
            in one direction to keep 1 m the same length on both axes (no distortion).
        follow: name of an agent to keep horizontally centred (e.g. "robot_0"); None = fixed
            view.
        fan_agents: names of the agents whose field of view is drawn when `draw` gets a fov;
            None = every agent (on crowded maps pass e.g. ["robot_0"]: fans cost fill time).
        dpi: resolution for font sizes and line widths [px per inch].

    `view`, `follow` and `fan_agents` are attributes that may be changed between frames.

    Speed: the static map is rasterised once into tiles of one frame width (cached); a frame
    copies the background pixels, draws the agents as four matplotlib collections (fans, bodies,
    car fronts, "seen" outlines) and pastes pre-rendered name labels, time stamp and scale bar
    with numpy. Pedestrians are drawn at least PED_MIN_RADIUS_PX in radius; a name label that
    would overlap an earlier one (robots first) is left out.
    """

    def __init__(self, road_map: RoadMap, show: bool = False, width_px: int = 1000,
                 height_px: int = 360, view: tuple | None = None, follow: str | None = None,
                 fan_agents: Sequence[str] | None = None, dpi: int = 100):
        for label, value in (("width_px", width_px), ("height_px", height_px), ("dpi", dpi)):
            if isinstance(value, bool) or int(value) != value or value < 16:
                raise ValueError(f"{label} must be an integer >= 16, got {value!r}")
        self.road_map = road_map
        self.show = bool(show)
        self.width_px, self.height_px = int(width_px), int(height_px)
        self.view = view
        self.follow = follow
        self.fan_agents = fan_agents
        self.fig = Figure(figsize=(self.width_px / dpi, self.height_px / dpi), dpi=dpi,
                          facecolor=BACKGROUND_COLOR)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.0, 0.0, 1.0, 1.0))
        self.ax.set_axis_off()
        _draw_road_map(self.ax, road_map)
        self._fans = PolyCollection([], linewidths=0.6, animated=True)
        self._bodies = PolyCollection([], linewidths=0.9, animated=True)
        self._fronts = PolyCollection([], edgecolors="none", animated=True)
        self._seen = PolyCollection([], facecolors="none", edgecolors=ROLE_COLORS["robot"],
                                    linewidths=1.3, linestyles=[(0, (2.0, 1.2))], animated=True)
        for coll in (self._fans, self._bodies, self._fronts, self._seen):
            self.ax.add_collection(coll)
        self._time_text = _MonoText(9, dpi)
        self._agents_key = None
        self._labels: list[_Sprite] = []
        self._tiles: dict[int, np.ndarray] = {}
        self._tiles_key = None
        self._limits = None  # (xmin, xmax, ymin, ymax) of the last frame [m]
        self._axes_limits = None  # limits the Axes currently has
        self._scale_key, self._scale = None, None
        self._window = None  # pyplot figure of "human" mode
        self._window_image = None
        self._window_failed = False
        self._closed = False

    @property
    def view(self) -> tuple[float, float, float, float] | None:
        """(xmin, xmax, ymin, ymax) to show [m], or None for the map's extent."""
        return self._view

    @view.setter
    def view(self, value) -> None:
        self._view = _check_view(value)

    # -- geometry ----------------------------------------------------------------------------
    def _base_view(self) -> tuple[float, float, float, float, float]:
        """The view grown to the frame's aspect ratio: (xmin, xmax, ymin, ymax) [m], m per px."""
        x0, x1, y0, y1 = self._view if self._view is not None else self.road_map.extent
        m_per_px = max((x1 - x0) / self.width_px, (y1 - y0) / self.height_px)
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        half_w, half_h = 0.5 * m_per_px * self.width_px, 0.5 * m_per_px * self.height_px
        return cx - half_w, cx + half_w, cy - half_h, cy + half_h, m_per_px

    def _frame_column(self, world, x0: float, m_per_px: float) -> int:
        """Left pixel column of the frame, counted from the base view's left edge."""
        if self.follow is None or world is None:
            return 0
        if self.follow not in world.names:
            raise ValueError(f"follow={self.follow!r} is not an agent; agents: {world.names}")
        cx = float(world.state[world.names.index(self.follow), 0])
        return round((cx - x0) / m_per_px - 0.5 * self.width_px)

    def view_limits(self, world=None) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) [m] that a frame of `world` shows: the view (or the map's
        extent) grown to the frame's aspect ratio, with `follow` centred on that agent's x
        (to the nearest pixel).
        """
        x0, _, y0, y1, m_per_px = self._base_view()
        left = x0 + self._frame_column(world, x0, m_per_px) * m_per_px
        return (left, left + self.width_px * m_per_px, y0, y1)

    def world_to_pixel(self, xy) -> np.ndarray:
        """Pixel coordinates (..., 2) [column, row] (row 0 at the top) of world points (..., 2) [m]
        in the last drawn frame.
        """
        if self._limits is None:
            raise RuntimeError("world_to_pixel() needs a frame: call draw() first")
        x0, x1, y0, y1 = self._limits
        xy = np.asarray(xy, dtype=np.float64)
        col = (xy[..., 0] - x0) / (x1 - x0) * self.width_px
        row = (y1 - xy[..., 1]) / (y1 - y0) * self.height_px
        return np.stack([col, row], axis=-1)

    # -- static background -------------------------------------------------------------------
    def _tile(self, k: int, x0: float, y0: float, y1: float, m_per_px: float) -> np.ndarray:
        """(H, W, 4) uint8 static map over columns [k W, (k + 1) W) of the base view."""
        tile = self._tiles.pop(k, None)
        if tile is None:
            left = x0 + k * self.width_px * m_per_px
            self.ax.set_xlim(left, left + self.width_px * m_per_px)
            self.ax.set_ylim(y0, y1)
            self._axes_limits = None
            self.canvas.draw()  # animated collections are skipped: only the static map
            tile = np.asarray(self.canvas.buffer_rgba()).copy()
            if len(self._tiles) >= _TILE_CACHE:
                self._tiles.pop(next(iter(self._tiles)))
        self._tiles[k] = tile  # most recently used last
        return tile

    def _paint_background(self, world) -> tuple[float, float, float, float]:
        """Write the static map of this frame into the canvas; return the frame's limits."""
        x0, _, y0, y1, m_per_px = self._base_view()
        key = (x0, y0, y1, m_per_px, self.width_px, self.height_px)
        if key != self._tiles_key:
            self._tiles, self._tiles_key = {}, key
        col = self._frame_column(world, x0, m_per_px)
        k, within = divmod(col, self.width_px)
        first = self._tile(k, x0, y0, y1, m_per_px)
        second = self._tile(k + 1, x0, y0, y1, m_per_px) if within else None
        buf = np.asarray(self.canvas.buffer_rgba())
        buf[:, :self.width_px - within] = first[:, within:]
        if second is not None:
            buf[:, self.width_px - within:] = second[:, :within]
        left = x0 + col * m_per_px
        limits = (left, left + self.width_px * m_per_px, y0, y1)
        if limits != self._axes_limits:  # setting limits costs ~0.5 ms: only when they move
            self.ax.set_xlim(limits[0], limits[1])
            self.ax.set_ylim(y0, y1)
            self._axes_limits = limits
        return limits

    def _scale_bar(self, m_per_px: float) -> tuple[int, _Sprite]:
        """Length [px] and label of a 1-2-5 scale bar about 12 % of the frame wide."""
        if self._scale_key != m_per_px:
            length = _nice_length(0.12 * self.width_px * m_per_px)
            self._scale = (round(length / m_per_px),
                           _label_sprite(f"{length:g} m", 7, self.fig.dpi))
            self._scale_key = m_per_px
        return self._scale

    # -- drawing -----------------------------------------------------------------------------
    def _ensure_agents(self, world) -> None:
        """Per-agent colours and label sprites, rebuilt when the set of agents changes."""
        key = tuple((s.name, s.role) for s in world.specs)
        if key == self._agents_key:
            return
        faces = [_role_color(role) for _, role in key]
        self._face = np.array([to_rgba(f) for f, _ in faces])
        self._edge = np.array([to_rgba(e) for _, e in faces])
        fan_alpha = np.array([FAN_ALPHA.get(role, 0.1) for _, role in key])
        self._fan_face = np.column_stack([self._face[:, :3], fan_alpha])
        self._fan_edge = self._face * [1, 1, 1, 0] + [0, 0, 0, 0.45]
        self._front = self._edge * [1, 1, 1, 0] + [0, 0, 0, 0.8]
        self._labels = [_label_sprite(name, 7, self.fig.dpi) for name, _ in key]
        self._is_robot = np.array([role == "robot" for _, role in key], dtype=bool)
        self._agents_key = key

    def draw(self, world, fov=None) -> np.ndarray:
        """Render the current scene.

        Args:
            world: a World (state (n, 4) [x m, y m, heading rad, speed m/s], specs, active,
                is_pedestrian, length_m / width_m (n,) [m], time_s [s]).
            fov: optional FovResult of this step (visible (n, n) bool, depth_m (n, R) [m],
                ray_angles_rad (n, R) [rad] relative to the heading): draws each active agent's
                visibility polygon as a translucent fan and outlines (dashed red) every agent a
                robot currently sees.

        Returns:
            (height_px, width_px, 3) uint8 RGB frame.
        """
        if self._closed:
            raise RuntimeError("Renderer.draw() after close()")
        self._ensure_agents(world)
        limits = self._paint_background(world)
        self._limits = limits
        m_per_px = (limits[1] - limits[0]) / self.width_px

        state = np.asarray(world.state, dtype=np.float64)
        xy, heading = state[:, :2], state[:, 2]
        active = np.asarray(world.active, dtype=bool)
        is_ped = np.asarray(world.is_pedestrian, dtype=bool)
        length = np.asarray(world.length_m, dtype=np.float64)
        width = np.asarray(world.width_m, dtype=np.float64)
        ped_r = np.maximum(0.5 * width, PED_MIN_RADIUS_PX * m_per_px)
        corners = box_corners(xy, heading, length, width)  # (n, 4, 2)
        discs = xy[:, None, :] + ped_r[:, None, None] * _DISC  # (n, 24, 2)
        veh = np.flatnonzero(active & ~is_ped)
        ped = np.flatnonzero(active & is_ped)

        if fov is not None:  # fans first: under every body
            depth = np.asarray(fov.depth_m, dtype=np.float64)
            ang = heading[:, None] + np.asarray(fov.ray_angles_rad, dtype=np.float64)
            ends = xy[:, None, :] + depth[..., None] * np.stack([np.cos(ang), np.sin(ang)], -1)
            full = np.asarray(world.sensor_half_angle_rad) >= math.pi
            fan_mask = active & (depth > 0.0).any(axis=1)
            if self.fan_agents is not None:
                fan_mask &= np.isin(np.asarray(world.names), list(self.fan_agents))
            fan = np.flatnonzero(fan_mask)
            self._fans.set_verts([ends[i] if full[i] else np.vstack([xy[i], ends[i]])
                                  for i in fan])
            self._fans.set_facecolor(self._fan_face[fan])
            self._fans.set_edgecolor(self._fan_edge[fan])
            self.ax.draw_artist(self._fans)

        order = np.concatenate([veh, ped])
        self._bodies.set_verts([corners[i] for i in veh] + [discs[i] for i in ped])
        self._bodies.set_facecolor(self._face[order])
        self._bodies.set_edgecolor(self._edge[order])
        self.ax.draw_artist(self._bodies)
        if veh.size:  # a dark triangle marks the front of each car
            fwd = np.stack([np.cos(heading), np.sin(heading)], -1)[veh]
            lat = fwd[:, ::-1] * [-1.0, 1.0]
            lv, wv, cv = length[veh, None], width[veh, None], xy[veh]
            tri = np.stack([cv + 0.45 * lv * fwd, cv + 0.15 * lv * fwd + 0.3 * wv * lat,
                            cv + 0.15 * lv * fwd - 0.3 * wv * lat], axis=1)
            self._fronts.set_verts(list(tri))
            self._fronts.set_facecolor(self._front[veh])
            self.ax.draw_artist(self._fronts)
        if fov is not None:
            seen = np.asarray(fov.visible, dtype=bool)[self._is_robot & active].any(axis=0)
            seen &= active
            if seen.any():
                grow = max(SEEN_MARGIN_M, 2.0 * m_per_px)
                grown = box_corners(xy, heading, length + 2 * grow, width + 2 * grow)
                self._seen.set_verts([xy[i] + (ped_r[i] + grow) * _DISC if is_ped[i]
                                      else grown[i] for i in np.flatnonzero(seen)])
                self.ax.draw_artist(self._seen)

        buf = np.asarray(self.canvas.buffer_rgba())
        frame = np.empty((self.height_px, self.width_px, 3), dtype=np.uint8)
        for c in range(3):  # per channel: much faster than one strided (H, W, 3) copy
            frame[..., c] = buf[..., c]
        # labels above each agent, time stamp, scale bar
        cos_h, sin_h = np.abs(np.cos(heading)), np.abs(np.sin(heading))
        top = np.where(is_ped, ped_r, 0.5 * (length * sin_h + width * cos_h))
        if fov is not None:  # clear the dashed "seen" outline
            top = top + np.where(seen, max(SEEN_MARGIN_M, 2.0 * m_per_px), 0.0)
        anchor = self.world_to_pixel(np.column_stack([xy[:, 0], xy[:, 1] + top]))
        placed = np.empty((0, 4))  # label boxes [left, top, right, bottom] [px]
        live = np.flatnonzero(active)
        for i in np.concatenate([live[self._is_robot[live]], live[~self._is_robot[live]]]):
            sprite = self._labels[i]
            row, col = round(anchor[i, 1]) - 3, round(anchor[i, 0])
            h, w = sprite.alpha.shape[:2]
            box = np.array([col - sprite.anchor[1], row - h, col - sprite.anchor[1] + w, row])
            if np.any((placed[:, 0] < box[2]) & (box[0] < placed[:, 2])
                      & (placed[:, 1] < box[3]) & (box[1] < placed[:, 3])):
                continue  # would overlap a label already drawn
            sprite.paste(frame, row, col)
            placed = np.vstack([placed, box])
        self._time_text.sprite(f"t = {world.time_s:.2f} s").paste(frame, 4, 4)
        bar_px, bar_label = self._scale_bar(m_per_px)
        row, col = self.height_px - 12, 14
        frame[row:row + 3, col:col + bar_px] = (34, 34, 34)
        bar_label.paste(frame, row - 3, col + bar_px // 2)

        if self.show:
            self._display(frame)
        return frame

    # -- "human" mode ------------------------------------------------------------------------
    def _display(self, frame: np.ndarray) -> None:
        """Show a frame in a pyplot window; on a headless machine do nothing."""
        if self._window_failed:
            return
        try:
            import matplotlib.pyplot as plt

            if self._window is None:
                if not _gui_backend_available():
                    self._window_failed = True
                    return
                dpi = self.fig.dpi
                self._window = plt.figure(figsize=(self.width_px / dpi, self.height_px / dpi),
                                          dpi=dpi)
                ax = self._window.add_axes((0.0, 0.0, 1.0, 1.0))
                ax.set_axis_off()
                self._window_image = ax.imshow(frame, interpolation="nearest")
                plt.show(block=False)
            elif not plt.fignum_exists(self._window.number):  # the user closed the window
                self._window, self._window_failed = None, True
                return
            self._window_image.set_data(frame)
            self._window.canvas.draw_idle()
            self._window.canvas.flush_events()
        except Exception:  # noqa: BLE001 - a display that cannot open (no X server, Tcl errors)
            self._window, self._window_failed = None, True  # must never break the simulation

    def close(self) -> None:
        """Free the figure (and close the window of "human" mode). Idempotent."""
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window)
            self._window = None
        if not self._closed:
            self.fig.clear()
            self._tiles = {}
            self._labels = []
            self._closed = True

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# -- animations -------------------------------------------------------------------------------
def write_animation(frames: Sequence[np.ndarray], path, fps: int = 10) -> Path:
    """Write frames as a looping animated GIF.

    Args:
        frames: non-empty list of (H, W, 3) (or (H, W, 4)) uint8 RGB(A) frames, all one size.
        path: output file (parent directories are created); ".gif" is the natural suffix.
        fps: frames per second (GIF delays are whole 10 ms units).

    Returns:
        The path written. Pillow merges consecutive identical frames into one longer frame.
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
        images.append(Image.fromarray(np.ascontiguousarray(arr[..., :3])))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:],
                   duration=max(10, round(1000.0 / fps)), loop=0)
    return path


# -- episode figures --------------------------------------------------------------------------
def _snapshot_indices(times_s: np.ndarray, every_s: float) -> np.ndarray:
    """Indices of the steps closest after t0, t0 + every_s, ... (T,) times [s]."""
    targets = np.arange(times_s[0], times_s[-1] + 1e-9, every_s)
    idx = np.searchsorted(times_s, targets - 1e-9)
    return np.unique(np.clip(idx, 0, len(times_s) - 1))


def plot_episode(road_map: RoadMap, names: Sequence[str], roles: Sequence[str], times_s,
                 states, active, visible, path, title: str = "",
                 beliefs: Mapping[str, np.ndarray] | None = None,
                 lengths_m=None, widths_m=None, snapshot_every_s: float = 1.0) -> Path:
    """Paper-style episode figure (like Figs. 3-6 of Sun et al. 2019), saved as PNG.

    Panels: (a) snapshots every `snapshot_every_s` on the map, older ones fainter (robot red
    boxes, human cars yellow boxes, pedestrians green dots) with the paths travelled; (b) speed
    of every car vs time; (c) "perceived" probability of each pedestrian: 1 while a robot sees it
    (visible[t, robot, pedestrian]) else 0, the same for every human driver (dashed), and the
    extra series in `beliefs`. Curves have gaps where an agent has left the episode.

    Args:
        road_map: the static map.
        names, roles: (n,) agent names and roles ("robot", "human", "pedestrian").
        times_s: (T,) increasing times [s].
        states: (T, n, 4) [x m, y m, heading rad, speed m/s].
        active: (T, n) bool, agent still in the episode (inactive steps are not drawn).
        visible: (T, n, n) bool, visible[t, o, j] = observer o sees agent j at step t.
        path: output PNG (parent directories are created).
        title: figure title.
        beliefs: optional {label: (T,) values in [0, 1]} drawn in panel (c), e.g. the robot's
            inferred belief that a pedestrian is there.
        lengths_m, widths_m: optional (n,) footprints [m]; default 4.5 x 1.8 m cars.
        snapshot_every_s: time between snapshots in panel (a) [s].

    Returns:
        The path written.
    """
    names, roles = list(names), list(roles)
    n = len(names)
    times_s = np.asarray(times_s, dtype=np.float64).reshape(-1)
    t_len = len(times_s)
    states = np.asarray(states, dtype=np.float64)
    active = np.asarray(active, dtype=bool)
    visible = np.asarray(visible, dtype=bool)
    checks = (("roles", (len(roles),), (n,)), ("states", states.shape, (t_len, n, 4)),
              ("active", active.shape, (t_len, n)), ("visible", visible.shape, (t_len, n, n)))
    for label, got, want in checks:
        if got != want:
            raise ValueError(f"plot_episode: {label} has shape {got}, expected {want} "
                             f"(T={t_len} times, n={n} names)")
    if t_len == 0:
        raise ValueError("plot_episode: no time steps")
    if np.any(np.diff(times_s) <= 0):
        raise ValueError("plot_episode: times_s must be strictly increasing")
    beliefs = dict(beliefs or {})
    for label, series in beliefs.items():
        if np.shape(series) != (t_len,):
            raise ValueError(f"plot_episode: belief {label!r} has shape {np.shape(series)}, "
                             f"expected ({t_len},)")
    length = np.full(n, 4.5) if lengths_m is None else np.asarray(lengths_m, dtype=np.float64)
    width = np.full(n, 1.8) if widths_m is None else np.asarray(widths_m, dtype=np.float64)
    is_ped = np.array([r == "pedestrian" for r in roles], dtype=bool)
    vehicles = [i for i in range(n) if not is_ped[i]]
    robots = [i for i in range(n) if roles[i] == "robot"]
    humans = [i for i in range(n) if roles[i] == "human"]
    peds = np.flatnonzero(is_ped).tolist()

    # x range of panel (a): where the agents went, plus a margin, inside the map's extent
    ex0, ex1, ey0, ey1 = road_map.extent
    xs = states[..., 0][active]
    x0, x1 = (float(xs.min()) - 8.0, float(xs.max()) + 8.0) if xs.size else (ex0, ex1)
    x0, x1 = max(x0, ex0), min(x1, ex1)
    if x1 - x0 < 20.0:
        x0, x1 = 0.5 * (x0 + x1) - 10.0, 0.5 * (x0 + x1) + 10.0

    fig_w, left, right = 10.0, 0.08, 0.97
    map_h = min(4.0, max(1.2, fig_w * (right - left) * (ey1 - ey0) / (x1 - x0)))
    plot_h = 2.0
    fig_h = map_h + 2 * plot_h + 2.1
    fig = Figure(figsize=(fig_w, fig_h), dpi=120, facecolor="white")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(3, 1, height_ratios=[map_h, plot_h, plot_h], left=left, right=right,
                            top=1.0 - (0.6 if title else 0.3) / fig_h, bottom=0.5 / fig_h,
                            hspace=0.45)
    ax_map = fig.add_subplot(grid[0])
    ax_v = fig.add_subplot(grid[1])
    ax_p = fig.add_subplot(grid[2], sharex=ax_v)
    if title:
        fig.suptitle(title, fontsize=12, y=1.0 - 0.12 / fig_h, va="top")

    # (a) snapshots
    ax_map.set_facecolor(BACKGROUND_COLOR)
    _draw_road_map(ax_map, road_map, line_scale=0.8)
    snaps = _snapshot_indices(times_s, snapshot_every_s)
    alphas = np.linspace(0.25, 1.0, len(snaps)) if len(snaps) > 1 else np.ones(1)
    for i in range(n):
        face, edge = _role_color(roles[i])
        track = np.where(active[:, i, None], states[:, i, :2], np.nan)
        ax_map.plot(track[:, 0], track[:, 1], color=edge, linewidth=0.7, alpha=0.6, zorder=2)
        for k, alpha in zip(snaps, alphas, strict=True):
            if not active[k, i]:
                continue
            x, y, h, _ = states[k, i]
            if is_ped[i]:
                ax_map.scatter([x], [y], s=28, color=to_rgba(face, alpha),
                               edgecolors=[to_rgba(edge, alpha)], linewidths=0.6, zorder=4)
            else:
                box = box_corners(np.array([x, y]), h, length[i], width[i])
                ax_map.add_patch(Polygon(box, closed=True, facecolor=to_rgba(face, alpha),
                                         edgecolor=to_rgba(edge, alpha), linewidth=0.7,
                                         zorder=3))
    # equal metres on both axes: grow the x or the y range to the panel's aspect ratio
    pos = ax_map.get_position()
    box_w, box_h = pos.width * fig_w, pos.height * fig_h  # [inch]
    cx, cy = 0.5 * (x0 + x1), 0.5 * (ey0 + ey1)
    span_x, span_y = x1 - x0, ey1 - ey0
    if span_y / span_x < box_h / box_w:
        span_y = span_x * box_h / box_w
    else:
        span_x = span_y * box_w / box_h
    ax_map.set_xlim(cx - 0.5 * span_x, cx + 0.5 * span_x)
    ax_map.set_ylim(cy - 0.5 * span_y, cy + 0.5 * span_y)
    ax_map.set_xlabel("x [m]", fontsize=9, labelpad=1)
    ax_map.set_ylabel("y [m]", fontsize=9)
    ax_map.tick_params(labelsize=8)
    ax_map.set_title(f"(a) snapshots every {snapshot_every_s:g} s (later = darker)",
                     fontsize=10, loc="left")
    present = [r for r in ROLE_COLORS if r in roles] + sorted(set(roles) - set(ROLE_COLORS))
    handles = []
    for role in present:
        face, edge = _role_color(role)
        marker = "o" if role == "pedestrian" else "s"
        handles.append(Line2D([], [], linestyle="none", marker=marker, markersize=7,
                              markerfacecolor=face, markeredgecolor=edge,
                              label={"human": "human car"}.get(role, role)))
    if handles:
        ax_map.legend(handles=handles, loc="lower right", bbox_to_anchor=(1.0, 1.0),
                      fontsize=8, ncol=len(handles), frameon=False, borderaxespad=0.2)

    # (b) speeds of the cars
    for i in sorted(vehicles, key=lambda j: roles[j] == "robot"):  # robots on top
        face, _ = _role_color(roles[i])
        speed = np.where(active[:, i], states[:, i, 3], np.nan)
        color = face if roles[i] != "human" else "#d99a00"
        ax_v.plot(times_s, speed, color=color, linewidth=1.6 if roles[i] == "robot" else 2.6,
                  label=names[i])
        ax_v.scatter(times_s[snaps], speed[snaps], s=10, color=color, zorder=3)
    ax_v.set_ylabel("speed [m/s]", fontsize=9)
    ax_v.set_title("(b) speed of the cars", fontsize=10, loc="left")
    ax_v.grid(alpha=0.3)
    ax_v.tick_params(labelsize=8, labelbottom=True)
    if vehicles:
        ax_v.legend(fontsize=8, loc="best")
        top = np.nanmax(np.where(active[:, vehicles], states[:, vehicles, 3], np.nan),
                        initial=1.0)
        ax_v.set_ylim(0.0, 1.15 * top)

    # (c) perceived probability of each pedestrian
    extra_colors = ["#1f77b4", "#9467bd", "#17becf", "#8c564b", "#e377c2", "#7f7f7f"]
    def sees(o: int, p: int) -> np.ndarray:  # 1/0 while both are in the episode, else a gap
        return np.where(active[:, o] & active[:, p], visible[:, o, p].astype(float), np.nan)

    for p in peds:
        for r in robots:
            ax_p.step(times_s, sees(r, p), where="post", color=ROLE_COLORS["robot"],
                      linewidth=2.0, label=f"{names[r]} sees {names[p]}")
        for h in humans:
            ax_p.step(times_s, sees(h, p), where="post", color="#d99a00", linewidth=1.6,
                      linestyle="--", label=f"{names[h]} sees {names[p]}")
    for k, (label, series) in enumerate(beliefs.items()):
        ax_p.plot(times_s, np.asarray(series, dtype=np.float64),
                  color=extra_colors[k % len(extra_colors)], linewidth=1.6, label=label)
    if not peds and not beliefs:
        ax_p.text(0.5, 0.5, "no pedestrian in this episode", transform=ax_p.transAxes,
                  ha="center", va="center", fontsize=9, color="#666666")
    ax_p.set_ylim(-0.05, 1.1)
    ax_p.set_ylabel("perceived prob.", fontsize=9)
    ax_p.set_xlabel("time [s]", fontsize=9)
    ax_p.set_title("(c) probability of the pedestrian perceived", fontsize=10, loc="left")
    ax_p.grid(alpha=0.3)
    ax_p.tick_params(labelsize=8)
    if peds or beliefs:
        ax_p.legend(fontsize=8, loc="best")
    ax_v.set_xlim(times_s[0], times_s[-1] if t_len > 1 else times_s[0] + 1.0)

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, format="png", facecolor="white")
    fig.clear()
    return path

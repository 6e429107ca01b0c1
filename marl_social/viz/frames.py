"""Live frames: `Renderer` draws the current scene of a `World` into (H, W, 3) uint8 RGB arrays.

A frame shows the road and lane markings, crosswalk stripes, houses, vehicles (robot red, human
drivers yellow), pedestrians (green discs), name labels, the time, a scale bar and, optionally,
every agent's field of view as a translucent fan. The Renderer draws on its own Agg canvas
(`matplotlib.figure.Figure` + `FigureCanvasAgg`, never pyplot), so it works headless and in
parallel worker processes; only the "human" mode opens a pyplot window. The static map is
rasterised once (in cached tiles) and copied; each frame only draws the agents.

All coordinates are metres in the world frame, angles radians counter-clockwise from +x; pixel
positions are (column, row) with row 0 at the top.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Self

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure

from marl_social.sim.footprint import box_corners
from marl_social.sim.road_map import RoadMap
from marl_social.viz.road import draw_road_map, signal_head_squares
from marl_social.viz.style import (
    BACKGROUND_COLOR,
    BODY_EDGE_PT,
    CAR_FRONT_ALPHA,
    DEFAULT_FRAME_SIZE,
    FAN_ALPHA,
    FAN_EDGE_ALPHA,
    FAN_EDGE_PT,
    LABEL_FONT_PT,
    LABEL_LIFT_PX,
    OTHER_FAN_ALPHA,
    PED_DISC_VERTICES,
    PED_MIN_RADIUS_PX,
    ROLE_COLORS,
    SCALE_BAR_BOTTOM_PX,
    SCALE_BAR_FRACTION,
    SCALE_BAR_LEFT_PX,
    SCALE_BAR_RGB,
    SCALE_BAR_THICKNESS_PX,
    SEEN_DASH_PT,
    SEEN_EDGE_PT,
    SEEN_MARGIN_M,
    SEEN_MIN_MARGIN_PX,
    SIGNAL_HEAD_EDGE_COLOR,
    SIGNAL_STATE_COLORS,
    TILE_CACHE,
    TIME_FONT_PT,
    TIME_OFFSET_PX,
    FrameSize,
    role_colors,
)
from marl_social.viz.text import MonoText, Sprite, label_sprite

_DISC_ANGLES_RAD = np.linspace(0.0, 2 * np.pi, PED_DISC_VERTICES, endpoint=False)
_DISC = np.column_stack([np.cos(_DISC_ANGLES_RAD), np.sin(_DISC_ANGLES_RAD)])  # (24, 2) unit
# the dark triangle on a car's front: tip and base along the heading (shares of the length),
# half base across it (share of the width)
CAR_FRONT_TIP, CAR_FRONT_BASE, CAR_FRONT_HALF_BASE = 0.45, 0.15, 0.3


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


class Renderer:
    """Draws a World into RGB frames, reusing one Agg figure.

    Args:
        road_map: the static map.
        show: "human" mode: also display every frame in a pyplot window if a GUI backend is
            available; otherwise (headless) silently behave like rgb_array.
        size: the frames' width and height [px] and resolution for font sizes and line widths
            [px per inch] (style.FrameSize; default 1000 x 240 px at 100 dpi).
        view: (xmin, xmax, ymin, ymax) region to show [m]; default the map's `extent`. It is grown
            in one direction to keep 1 m the same length on both axes (no distortion).
        follow: name of an agent to keep horizontally centred (e.g. "robot_0"); None = fixed
            view.
        follow_within_map: with `follow`, stop the view at the map's ends (the agent is off
            centre there) when the map is longer than the view, so that no frame shows empty
            ground beyond the road while there is road to show (from t = 0 the scene ahead of
            the robot is in view).
        fan_agents: names of the agents whose field of view is drawn when `draw` gets a fov;
            None = every agent (on crowded maps pass e.g. ["robot_0"]: fans cost fill time).

    `view`, `follow` and `fan_agents` are attributes that may be changed between frames.

    Speed: the static map is rasterised once into tiles of one frame width (cached); a frame
    copies the background pixels, draws the agents as four matplotlib collections (fans, bodies,
    car fronts, "seen" outlines) and pastes pre-rendered name labels, time stamp and scale bar
    with numpy. Pedestrians are drawn at least PED_MIN_RADIUS_PX in radius; a name label that
    would overlap an earlier one (robots first) is left out.
    """

    def __init__(self, road_map: RoadMap, show: bool = False, size: FrameSize = DEFAULT_FRAME_SIZE,
                 view: tuple | None = None, follow: str | None = None,
                 fan_agents: Sequence[str] | None = None, follow_within_map: bool = True):
        """Build the Agg figure with the static map; frames rasterise its tiles on demand."""
        width_px, height_px, dpi = size.width_px, size.height_px, size.dpi
        for label, value in (("width_px", width_px), ("height_px", height_px), ("dpi", dpi)):
            if isinstance(value, bool) or int(value) != value or value < 16:
                raise ValueError(f"{label} must be an integer >= 16, got {value!r}")
        self.road_map = road_map
        self.show = bool(show)
        self.width_px, self.height_px = int(width_px), int(height_px)
        self.view = view
        self.follow = follow
        self.follow_within_map = bool(follow_within_map)
        self.fan_agents = fan_agents
        self.fig = Figure(figsize=(self.width_px / dpi, self.height_px / dpi), dpi=dpi,
                          facecolor=BACKGROUND_COLOR)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.0, 0.0, 1.0, 1.0))
        self.ax.set_axis_off()
        draw_road_map(self.ax, road_map)
        self._fans = PolyCollection([], linewidths=FAN_EDGE_PT, animated=True)
        self._bodies = PolyCollection([], linewidths=BODY_EDGE_PT, animated=True)
        self._fronts = PolyCollection([], edgecolors="none", animated=True)
        self._seen = PolyCollection([], facecolors="none", edgecolors=ROLE_COLORS["robot"],
                                    linewidths=SEEN_EDGE_PT, linestyles=[(0, SEEN_DASH_PT)],
                                    animated=True)
        self._heads = PolyCollection(signal_head_squares(road_map),
                                     edgecolors=SIGNAL_HEAD_EDGE_COLOR,
                                     linewidths=BODY_EDGE_PT, animated=True)
        for coll in (self._fans, self._bodies, self._fronts, self._seen, self._heads):
            self.ax.add_collection(coll)
        self._time_text = MonoText(TIME_FONT_PT, dpi)
        self._agents_key = None
        self._labels: list[Sprite] = []
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
        col = round((cx - x0) / m_per_px - 0.5 * self.width_px)
        if self.follow_within_map:
            map_x0, map_x1 = self.road_map.extent[:2]
            first = math.ceil((map_x0 - x0) / m_per_px - 1e-9)  # frame's left edge on the map
            last = math.floor((map_x1 - x0) / m_per_px + 1e-9) - self.width_px
            if first <= last:  # the map is longer than the frame
                col = min(max(col, first), last)
        return col

    def view_limits(self, world=None) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) [m] that a frame of `world` shows.

        That is the view (or the map's extent) grown to the frame's aspect ratio, with `follow`
        centred on that agent's x (to the nearest pixel; with `follow_within_map`, held inside
        the map's ends).

        Args:
            world: the World to be drawn (needed only with `follow`), or None.
        """
        x0, _, y0, y1, m_per_px = self._base_view()
        left = x0 + self._frame_column(world, x0, m_per_px) * m_per_px
        return (left, left + self.width_px * m_per_px, y0, y1)

    def world_to_pixel(self, xy) -> np.ndarray:
        """Pixel coordinates (..., 2) (column, row) of world points in the last drawn frame.

        Args:
            xy: (..., 2) world points [m].

        Returns:
            (..., 2) (column, row) [px], row 0 at the top, not rounded.
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
            if len(self._tiles) >= TILE_CACHE:
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

    def _scale_bar(self, m_per_px: float) -> tuple[int, Sprite]:
        """Length [px] and label of a 1-2-5 scale bar about 12 % of the frame wide."""
        if self._scale_key != m_per_px:
            length = _nice_length(SCALE_BAR_FRACTION * self.width_px * m_per_px)
            self._scale = (round(length / m_per_px),
                           label_sprite(f"{length:g} m", LABEL_FONT_PT, self.fig.dpi))
            self._scale_key = m_per_px
        return self._scale

    # -- drawing -----------------------------------------------------------------------------
    def _ensure_agents(self, world) -> None:
        """Per-agent colours and label sprites, rebuilt when the set of agents changes."""
        key = tuple((s.name, s.role) for s in world.specs)
        if key == self._agents_key:
            return
        faces = [role_colors(role) for _, role in key]
        self._face = np.array([to_rgba(f) for f, _ in faces])
        self._edge = np.array([to_rgba(e) for _, e in faces])
        fan_alpha = np.array([FAN_ALPHA.get(role, OTHER_FAN_ALPHA) for _, role in key])
        self._fan_face = np.column_stack([self._face[:, :3], fan_alpha])
        self._fan_edge = self._face * [1, 1, 1, 0] + [0, 0, 0, FAN_EDGE_ALPHA]
        self._front = self._edge * [1, 1, 1, 0] + [0, 0, 0, CAR_FRONT_ALPHA]
        self._labels = [label_sprite(name, LABEL_FONT_PT, self.fig.dpi) for name, _ in key]
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

        heads = getattr(world, "signal_states", None)
        if self.road_map.signal_heads and heads is not None:  # each head in the colour it shows
            self._heads.set_facecolor([SIGNAL_STATE_COLORS[k] for k in heads()])
            self.ax.draw_artist(self._heads)

        order = np.concatenate([veh, ped])
        self._bodies.set_verts([corners[i] for i in veh] + [discs[i] for i in ped])
        self._bodies.set_facecolor(self._face[order])
        self._bodies.set_edgecolor(self._edge[order])
        self.ax.draw_artist(self._bodies)
        if veh.size:  # a dark triangle marks the front of each car
            fwd = np.stack([np.cos(heading), np.sin(heading)], -1)[veh]
            lat = fwd[:, ::-1] * [-1.0, 1.0]
            lv, wv, cv = length[veh, None], width[veh, None], xy[veh]
            base, half_base = cv + CAR_FRONT_BASE * lv * fwd, CAR_FRONT_HALF_BASE * wv * lat
            tri = np.stack([cv + CAR_FRONT_TIP * lv * fwd, base + half_base, base - half_base],
                           axis=1)
            self._fronts.set_verts(list(tri))
            self._fronts.set_facecolor(self._front[veh])
            self.ax.draw_artist(self._fronts)
        if fov is not None:
            seen = np.asarray(fov.visible, dtype=bool)[self._is_robot & active].any(axis=0)
            seen &= active
            if seen.any():
                grow = max(SEEN_MARGIN_M, SEEN_MIN_MARGIN_PX * m_per_px)
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
            top = top + np.where(seen, max(SEEN_MARGIN_M, SEEN_MIN_MARGIN_PX * m_per_px), 0.0)
        anchor = self.world_to_pixel(np.column_stack([xy[:, 0], xy[:, 1] + top]))
        placed = np.empty((0, 4))  # label boxes [left, top, right, bottom] [px]
        live = np.flatnonzero(active)
        for i in np.concatenate([live[self._is_robot[live]], live[~self._is_robot[live]]]):
            sprite = self._labels[i]
            row, col = round(anchor[i, 1]) - LABEL_LIFT_PX, round(anchor[i, 0])
            h, w = sprite.alpha.shape[:2]
            box = np.array([col - sprite.anchor[1], row - h, col - sprite.anchor[1] + w, row])
            if np.any((placed[:, 0] < box[2]) & (box[0] < placed[:, 2])
                      & (placed[:, 1] < box[3]) & (box[1] < placed[:, 3])):
                continue  # would overlap a label already drawn
            sprite.paste(frame, row, col)
            placed = np.vstack([placed, box])
        stamp = self._time_text.sprite(f"t = {world.time_s:.2f} s")
        stamp.paste(frame, TIME_OFFSET_PX, TIME_OFFSET_PX)
        bar_px, bar_label = self._scale_bar(m_per_px)
        row, col = self.height_px - SCALE_BAR_BOTTOM_PX, SCALE_BAR_LEFT_PX
        frame[row:row + SCALE_BAR_THICKNESS_PX, col:col + bar_px] = SCALE_BAR_RGB
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
        """Use as a context manager: `close()` on exit."""
        return self

    def __exit__(self, *exc) -> None:
        """Close the renderer."""
        self.close()



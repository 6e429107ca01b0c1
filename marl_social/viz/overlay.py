"""Demo caption: a strip under each live frame with the legend and the robot's belief bar.

The strip never covers the scene. Its first line is the legend of the live frames: the
translucent fans are each agent's field of view in its role's colour (robot red, human driver
yellow, pedestrian green) and a dashed red outline marks every agent the robot itself sees
this step. Its second line is the robot's belief that a pedestrian is crossing (the paper's
"inferred probability", `trace.extras["p_pedestrian"]`), as a bar and a number, with whether
the robot sees the pedestrian itself or infers it (from the humans' behaviour and its own
depth rays).

Once the robot has passed every crosswalk the belief no longer steers it, and it drifts: the
motion model lets hidden pedestrians arrive at the crosswalk at the hazard rate
(`BeliefConfig.hazard_per_s`) and the robot no longer looks there, so P(pedestrian) creeps
back towards its prior (about 0.1 to 0.2). The bar is then drawn grey and says so.

The strip is drawn with matplotlib on its own Agg canvas (never pyplot), once per distinct
(value to 0.01, status): an episode of 200 frames renders a few dozen strips. Sizes are
pixels [px] and typographic points [pt]; positions in the world are metres [m].
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from marl_social.viz.style import (
    BACKGROUND_COLOR,
    BELIEF_COLORS,
    FAN_ALPHA,
    FRAME_DPI,
    LABEL_COLOR,
    ROLE_COLORS,
    ROLE_EDGE_COLORS,
    SEEN_DASH_PT,
    SEEN_EDGE_PT,
)

CAPTION_HEIGHT_PX = 52  # height of the strip under each frame [px]
CAPTION_FONT_PT = 8  # legend and belief text [pt]
CAPTION_COLOR = "#fbfaf7"  # the strip's background
BAR_WIDTH_PX = 220  # belief bar [px]
BAR_HEIGHT_PX = 11
PASSED_COLOR = "#a0a0a0"  # the belief bar once every crosswalk is behind the robot
BELIEF_STEP = 0.01  # the bar's resolution (strips are cached per value) [probability]
STATUS_TEXT = {
    "sees": "the robot sees the pedestrian",
    "inferred": "inferred: not seen, from the humans' behaviour and the robot's own rays",
    "passed": "crosswalk passed, belief unused: hazard-rate arrivals pull it back to ~0.15",
}
ROLE_LABELS = {"robot": "robot", "human": "human driver", "pedestrian": "pedestrian"}


def _blend(color: str, alpha: float, background: str = BACKGROUND_COLOR) -> tuple:
    """RGB of a colour drawn with this opacity over the background (a fan's look)."""
    c, b = np.asarray(to_rgb(color)), np.asarray(to_rgb(background))
    return tuple(alpha * c + (1.0 - alpha) * b)


def crosswalk_ahead(states, active, road_map, agent_index: int,
                    margin_m: float = 2.5) -> np.ndarray:
    """(T,) bool: some crosswalk of the map still lies ahead of an agent.

    A crosswalk is ahead while its far edge (half its width along the road beyond its centre,
    plus `margin_m` for the agent's own half length) is in front of the agent along its
    heading. False where the agent has left the episode or the map has no crosswalk.

    Args:
        states: (T, n, 4) [x m, y m, heading rad, speed m/s].
        active: (T, n) bool, agent still in the episode.
        road_map: the static map (its `crosswalks`: center (2,) [m], width_m [m]).
        agent_index: the agent's column in states.
        margin_m: extra distance past the crosswalk's far edge [m].
    """
    states = np.asarray(states, dtype=np.float64)
    active = np.asarray(active, dtype=bool)
    if states.ndim != 3 or states.shape[2] != 4 or active.shape != states.shape[:2]:
        raise ValueError(f"crosswalk_ahead: states must be (T, n, 4) and active (T, n), got "
                         f"{states.shape} and {active.shape}")
    if not 0 <= agent_index < states.shape[1]:
        raise ValueError(f"crosswalk_ahead: agent_index {agent_index} is not in 0..n-1 "
                         f"(n = {states.shape[1]})")
    crosswalks = list(road_map.crosswalks)
    if not crosswalks:
        return np.zeros(len(states), dtype=bool)
    xy, heading = states[:, agent_index, :2], states[:, agent_index, 2]
    fwd = np.stack([np.cos(heading), np.sin(heading)], axis=-1)  # (T, 2)
    centers = np.array([c.center for c in crosswalks], dtype=np.float64)  # (C, 2)
    reach = np.array([0.5 * c.width_m for c in crosswalks]) + margin_m  # (C,)
    along = np.einsum("tcd,td->tc", centers[None] - xy[:, None], fwd)  # (T, C) [m]
    return (along > -reach).any(axis=1) & active[:, agent_index]


class DemoCaption:
    """Adds the legend and belief strip under live frames.

    Args:
        width_px: frame width [px] (the strip's width).
        roles: roles whose field-of-view colour the legend lists, in order.
        dpi: resolution of the font sizes [px per inch].
        height_px: the strip's height [px].
    """

    def __init__(self, width_px: int, roles: Sequence[str] = ("robot", "human", "pedestrian"),
                 dpi: int = FRAME_DPI, height_px: int = CAPTION_HEIGHT_PX):
        """Check the sizes; strips are rendered on first use."""
        for label, value in (("width_px", width_px), ("height_px", height_px), ("dpi", dpi)):
            if isinstance(value, bool) or int(value) != value or value < 16:
                raise ValueError(f"DemoCaption: {label} must be an integer >= 16, got {value!r}")
        unknown = [r for r in roles if r not in ROLE_COLORS]
        if unknown:
            raise ValueError(f"DemoCaption: unknown roles {unknown}; known: {list(ROLE_COLORS)}")
        self.width_px, self.height_px, self.dpi = int(width_px), int(height_px), int(dpi)
        self.roles = tuple(roles)
        self._cache: dict[tuple, np.ndarray] = {}

    def strip(self, p_pedestrian: float | None, status: str = "inferred") -> np.ndarray:
        """(height_px, width_px, 3) uint8 strip: the legend and (if given) the belief bar.

        Args:
            p_pedestrian: the robot's P(pedestrian) in [0, 1], or None / NaN for no bar (no
                belief, or the robot has left).
            status: "sees", "inferred" or "passed" (see the module docstring).
        """
        if status not in STATUS_TEXT:
            raise ValueError(f"DemoCaption: status must be one of {list(STATUS_TEXT)}, "
                             f"got {status!r}")
        if p_pedestrian is not None and math.isnan(p_pedestrian):
            p_pedestrian = None
        if p_pedestrian is not None:
            if not 0.0 <= p_pedestrian <= 1.0:
                raise ValueError(f"DemoCaption: p_pedestrian must be in [0, 1], "
                                 f"got {p_pedestrian!r}")
            p_pedestrian = round(p_pedestrian / BELIEF_STEP) * BELIEF_STEP
        key = (p_pedestrian, status if p_pedestrian is not None else "")
        if key not in self._cache:
            self._cache[key] = self._render(*key)
        return self._cache[key]

    def _render(self, p: float | None, status: str) -> np.ndarray:
        """Draw one strip with matplotlib (pixel coordinates, row 0 at the bottom)."""
        w, h = self.width_px, self.height_px
        fig = Figure(figsize=(w / self.dpi, h / self.dpi), dpi=self.dpi, facecolor=CAPTION_COLOR)
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
        ax.set_axis_off()
        ax.set_xlim(0, w)
        ax.set_ylim(0, h)
        text = {"fontsize": CAPTION_FONT_PT, "color": LABEL_COLOR, "va": "center"}
        sw, sh = 18, 10  # legend swatch [px]
        y1 = 0.73 * h if p is not None else 0.5 * h  # the legend's line (alone: centred)
        ax.text(8, y1, "field of view:", **text)
        x = 90
        for role in self.roles:
            ax.add_patch(Rectangle((x, y1 - sh / 2), sw, sh, lw=0.8,
                                   facecolor=_blend(ROLE_COLORS[role], 2.5 * FAN_ALPHA[role]),
                                   edgecolor=ROLE_EDGE_COLORS[role]))
            ax.text(x + sw + 5, y1, ROLE_LABELS[role], **text)
            x += sw + 12 + 6.2 * len(ROLE_LABELS[role])
        ax.add_patch(Rectangle((x + 10, y1 - sh / 2), sw, sh, facecolor="none",
                               edgecolor=ROLE_COLORS["robot"], lw=SEEN_EDGE_PT,
                               linestyle=(0, SEEN_DASH_PT)))
        ax.text(x + sw + 15, y1, "seen by the robot's own sensors this step", **text)
        if p is not None:
            y2 = 0.28 * h
            ax.text(8, y2, f"robot's P(pedestrian) = {p:.2f}", **text)
            x0 = 185
            fill = PASSED_COLOR if status == "passed" else BELIEF_COLORS[0]
            ax.add_patch(Rectangle((x0, y2 - BAR_HEIGHT_PX / 2), BAR_WIDTH_PX * p,
                                   BAR_HEIGHT_PX, facecolor=fill, edgecolor="none"))
            ax.add_patch(Rectangle((x0, y2 - BAR_HEIGHT_PX / 2), BAR_WIDTH_PX, BAR_HEIGHT_PX,
                                   facecolor="none", edgecolor=LABEL_COLOR, lw=0.8))
            ax.text(x0 + BAR_WIDTH_PX + 10, y2, STATUS_TEXT[status], **text)
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()

    def add(self, frame: np.ndarray, p_pedestrian: float | None = None,
            status: str = "inferred") -> np.ndarray:
        """The frame with the strip below it: (H + height_px, W, 3) uint8.

        Args:
            frame: (H, W, 3) uint8 RGB frame, W = width_px.
            p_pedestrian: the robot's P(pedestrian), or None / NaN for the legend alone.
            status: "sees", "inferred" or "passed".
        """
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[1:] != (self.width_px, 3) or frame.dtype != np.uint8:
            raise ValueError(f"DemoCaption: frame must be (H, {self.width_px}, 3) uint8, got "
                             f"{frame.shape} {frame.dtype}")
        return np.concatenate([frame, self.strip(p_pedestrian, status)], axis=0)


def caption_frames(frames: Sequence[np.ndarray], p_pedestrian=None, perceived=None,
                   ahead=None, roles: Sequence[str] = ("robot", "human", "pedestrian"),
                   dpi: int = FRAME_DPI) -> list[np.ndarray]:
    """Frames of an episode with the legend and the robot's belief under each.

    Args:
        frames: T' (H, W, 3) uint8 frames, one per recorded state (trace.frames).
        p_pedestrian: optional (T,) robot's P(pedestrian) per state (NaN once it has left);
            None: the legend alone.
        perceived: optional (T,) 1.0 where the robot sees the pedestrian itself.
        ahead: optional (T,) bool, a crosswalk is still ahead of the robot (`crosswalk_ahead`);
            where False the bar is grey and explains the belief's drift.
        roles: roles listed in the legend.
        dpi: resolution of the font sizes [px per inch].

    Series shorter than the frames are held at their last value.

    Returns:
        The captioned frames, (H + CAPTION_HEIGHT_PX, W, 3) uint8 each.
    """
    if len(frames) == 0:
        return []
    caption = DemoCaption(np.shape(frames[0])[1], roles, dpi)

    def at(series, k, default):
        if series is None or len(series) == 0:
            return default
        return series[min(k, len(series) - 1)]

    out = []
    for k, frame in enumerate(frames):
        p = at(p_pedestrian, k, None)
        status = "sees" if at(perceived, k, 0.0) > 0.5 else "inferred"
        if not at(ahead, k, True):
            status = "passed"
        out.append(caption.add(frame, None if p is None else float(p), status))
    return out

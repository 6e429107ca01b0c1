"""Paper-style episode figure (like Figs. 3-6 of Sun et al. 2019): `plot_episode`.

Three panels, top to bottom: (a) trajectory snapshots on the map, (b) the cars' speeds, (c)
whether the robot (and the human drivers) perceive the pedestrian, plus any extra belief time
series. Drawn on an Agg canvas (never pyplot) and saved as PNG. Coordinates are metres in the
world frame, headings radians counter-clockwise from +x, figure sizes inches.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon

from marl_social.sim.footprint import box_corners
from marl_social.sim.road_map import RoadMap
from marl_social.viz.road import draw_road_map
from marl_social.viz.style import (
    BACKGROUND_COLOR,
    BELIEF_COLORS,
    DEFAULT_CAR_LENGTH_M,
    DEFAULT_CAR_WIDTH_M,
    FIGURE_DPI,
    FIGURE_WIDTH_IN,
    HUMAN_CURVE_COLOR,
    ROLE_COLORS,
    SIGNAL_STATE_COLORS,
    role_colors,
)

MAP_MARGIN_M = 8.0  # panel (a) shows this much beyond where the agents went [m]
MAP_MIN_SPAN_M = 20.0  # ... and at least this much road [m]
MAP_HEIGHT_IN = (1.2, 4.0)  # panel (a)'s height: at least, at most [inch]
PLOT_HEIGHT_IN = 2.0  # height of panels (b) and (c) [inch]
MAP_LINE_SCALE = 0.8  # lane markings in panel (a), relative to the live frames
_TIME_EPS_S = 1e-9  # tolerance when matching snapshot times [s]


@dataclass(frozen=True, eq=False)
class EpisodeArrays:
    """What `plot_episode` draws of an episode (n agents, T steps), as given.

    Attributes:
        names: (n,) agent names.
        roles: (n,) agent roles ("robot", "human", "pedestrian").
        times_s: (T,) increasing times [s].
        states: (T, n, 4) [x m, y m, heading rad, speed m/s].
        active: (T, n) bool, agent still in the episode (inactive steps are not drawn).
        visible: (T, n, n) bool, visible[t, o, j] = observer o sees agent j at step t.
        lengths_m: optional (n,) footprint lengths [m]; default 4.5 m cars.
        widths_m: optional (n,) footprint widths [m]; default 1.8 m cars.
    """

    names: Sequence[str]
    roles: Sequence[str]
    times_s: np.ndarray
    states: np.ndarray
    active: np.ndarray
    visible: np.ndarray
    lengths_m: np.ndarray | None = None
    widths_m: np.ndarray | None = None

    @classmethod
    def from_trace(cls, trace) -> EpisodeArrays:
        """The arrays of an evaluation Trace: its agents, times, states and visibility."""
        return cls(trace.names, trace.roles, trace.times_s, trace.states, trace.active,
                   trace.visible)


@dataclass(frozen=True, eq=False)
class _Episode:
    """An episode's validated arrays (n agents, T steps).

    Attributes:
        names: (n,) agent names.
        roles: (n,) roles ("robot", "human", "pedestrian").
        times_s: (T,) increasing times [s].
        states: (T, n, 4) [x m, y m, heading rad, speed m/s].
        active: (T, n) bool, agent still in the episode.
        visible: (T, n, n) bool, visible[t, o, j] = observer o sees agent j at step t.
        length_m: (n,) footprint lengths [m].
        width_m: (n,) footprint widths [m].
    """

    names: list[str]
    roles: list[str]
    times_s: np.ndarray
    states: np.ndarray
    active: np.ndarray
    visible: np.ndarray
    length_m: np.ndarray
    width_m: np.ndarray

    @property
    def is_pedestrian(self) -> np.ndarray:
        """(n,) bool, the agent is a pedestrian."""
        return np.array([r == "pedestrian" for r in self.roles], dtype=bool)

    def of_role(self, role: str) -> list[int]:
        """Indices of the agents with this role."""
        return [i for i, r in enumerate(self.roles) if r == role]


def _snapshot_indices(times_s: np.ndarray, every_s: float) -> np.ndarray:
    """Indices of the steps closest after t0, t0 + every_s, ... of (T,) times [s].

    Args:
        times_s: (T,) increasing times [s].
        every_s: time between snapshots [s].
    """
    targets = np.arange(times_s[0], times_s[-1] + _TIME_EPS_S, every_s)
    idx = np.searchsorted(times_s, targets - _TIME_EPS_S)
    return np.unique(np.clip(idx, 0, len(times_s) - 1))


def plot_episode(road_map: RoadMap, arrays: EpisodeArrays, path, title: str = "",
                 beliefs: Mapping[str, np.ndarray] | None = None,
                 snapshot_every_s: float = 1.0,
                 belief_title: str = "probability of the pedestrian perceived",
                 signal_states=None) -> Path:
    """Paper-style episode figure (like Figs. 3-6 of Sun et al. 2019), saved as PNG.

    Panels: (a) snapshots every `snapshot_every_s` on the map, older ones fainter (robot red
    boxes, human cars yellow boxes, pedestrians green dots) with the paths travelled; (b) speed
    of every car vs time; (c) "perceived" probability of each pedestrian: 1 while a robot sees it
    (visible[t, robot, pedestrian]) else 0, the same for every human driver (dashed), and the
    extra series in `beliefs`. Curves have gaps where an agent has left the episode.

    Args:
        road_map: the static map.
        arrays: the episode's agents, times, states, activity, visibility and footprints
            (`EpisodeArrays`; of an evaluation Trace: `EpisodeArrays.from_trace`).
        path: output PNG (parent directories are created).
        title: figure title.
        beliefs: optional {label: (T,) values in [0, 1]} drawn in panel (c), e.g. the robot's
            inferred belief that a pedestrian is there.
        snapshot_every_s: time between snapshots in panel (a) [s].
        belief_title: the title of panel (c) (after "(c) "), e.g. what `beliefs` are about.
        signal_states: optional (T, H) states (sim/signals RED, YELLOW, GREEN) of the map's H
            signal heads (Trace.signal_states): panel (b) gets one strip per head in the
            colour it shows over time, named by the head (what each driver could read, the
            truth the robot infers).

    Returns:
        The path written.
    """
    episode = _checked_episode(arrays)
    t_len = len(episode.times_s)
    beliefs = dict(beliefs or {})
    for label, series in beliefs.items():
        if np.shape(series) != (t_len,):
            raise ValueError(f"plot_episode: belief {label!r} has shape {np.shape(series)}, "
                             f"expected ({t_len},)")

    # x range of panel (a): where the agents went, plus a margin, inside the map's extent
    ex0, ex1, ey0, ey1 = road_map.extent
    xs = episode.states[..., 0][episode.active]
    x0, x1 = ((float(xs.min()) - MAP_MARGIN_M, float(xs.max()) + MAP_MARGIN_M) if xs.size
              else (ex0, ex1))
    x0, x1 = max(x0, ex0), min(x1, ex1)
    if x1 - x0 < MAP_MIN_SPAN_M:
        x0, x1 = 0.5 * (x0 + x1) - 0.5 * MAP_MIN_SPAN_M, 0.5 * (x0 + x1) + 0.5 * MAP_MIN_SPAN_M

    fig_w, left, right = FIGURE_WIDTH_IN, 0.08, 0.97
    map_h = min(MAP_HEIGHT_IN[1],
                max(MAP_HEIGHT_IN[0], fig_w * (right - left) * (ey1 - ey0) / (x1 - x0)))
    plot_h = PLOT_HEIGHT_IN
    fig_h = map_h + 2 * plot_h + 2.1  # + titles, tick labels and margins [inch]
    fig = Figure(figsize=(fig_w, fig_h), dpi=FIGURE_DPI, facecolor="white")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(3, 1, height_ratios=[map_h, plot_h, plot_h], left=left, right=right,
                            top=1.0 - (0.6 if title else 0.3) / fig_h, bottom=0.5 / fig_h,
                            hspace=0.45)
    ax_map = fig.add_subplot(grid[0])
    ax_v = fig.add_subplot(grid[1])
    ax_p = fig.add_subplot(grid[2], sharex=ax_v)
    if title:
        fig.suptitle(title, fontsize=12, y=1.0 - 0.12 / fig_h, va="top")

    snaps = _snapshot_indices(episode.times_s, snapshot_every_s)
    _draw_snapshots(ax_map, road_map, episode, snaps, snapshot_every_s)
    _fit_equal_aspect(ax_map, (x0, x1, ey0, ey1), fig_w, fig_h)
    _draw_legend(ax_map, episode.roles)
    _draw_speeds(ax_v, episode, snaps)
    if signal_states is not None and road_map.signal_heads:
        _draw_signal_strips(ax_v, episode.times_s, signal_states,
                            [h.name for h in road_map.signal_heads])
    _draw_perception(ax_p, episode, beliefs, belief_title)
    ax_v.set_xlim(episode.times_s[0],
                  episode.times_s[-1] if t_len > 1 else episode.times_s[0] + 1.0)

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=FIGURE_DPI, format="png", facecolor="white")
    fig.clear()
    return path


def _checked_episode(arrays: EpisodeArrays) -> _Episode:
    """`arrays` as numpy arrays, with every shape checked (ValueError naming the array).

    The times must increase strictly; footprints left None are DEFAULT_CAR_LENGTH_M and
    DEFAULT_CAR_WIDTH_M.
    """
    names, roles = list(arrays.names), list(arrays.roles)
    lengths_m, widths_m = arrays.lengths_m, arrays.widths_m
    n = len(names)
    times_s = np.asarray(arrays.times_s, dtype=np.float64).reshape(-1)
    t_len = len(times_s)
    states = np.asarray(arrays.states, dtype=np.float64)
    active = np.asarray(arrays.active, dtype=bool)
    visible = np.asarray(arrays.visible, dtype=bool)
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
    length = (np.full(n, DEFAULT_CAR_LENGTH_M) if lengths_m is None
              else np.asarray(lengths_m, dtype=np.float64))
    width = (np.full(n, DEFAULT_CAR_WIDTH_M) if widths_m is None
             else np.asarray(widths_m, dtype=np.float64))
    return _Episode(names, roles, times_s, states, active, visible, length, width)


def _draw_snapshots(ax, road_map: RoadMap, episode: _Episode, snaps: np.ndarray,
                    every_s: float) -> None:
    """Panel (a): the map, every agent's path and its snapshots (later = more opaque).

    Args:
        ax: the map's Axes (data units metres).
        road_map: the static map.
        episode: the episode.
        snaps: (S,) step indices of the snapshots.
        every_s: time between snapshots [s] (for the title).
    """
    ax.set_facecolor(BACKGROUND_COLOR)
    draw_road_map(ax, road_map, line_scale=MAP_LINE_SCALE)
    alphas = np.linspace(0.25, 1.0, len(snaps)) if len(snaps) > 1 else np.ones(1)
    is_ped, states, active = episode.is_pedestrian, episode.states, episode.active
    for i, role in enumerate(episode.roles):
        face, edge = role_colors(role)
        track = np.where(active[:, i, None], states[:, i, :2], np.nan)
        ax.plot(track[:, 0], track[:, 1], color=edge, linewidth=0.7, alpha=0.6, zorder=2)
        for k, alpha in zip(snaps, alphas, strict=True):
            if not active[k, i]:
                continue
            x, y, h, _ = states[k, i]
            if is_ped[i]:
                ax.scatter([x], [y], s=28, color=to_rgba(face, alpha),
                           edgecolors=[to_rgba(edge, alpha)], linewidths=0.6, zorder=4)
            else:
                box = box_corners(np.array([x, y]), h, episode.length_m[i], episode.width_m[i])
                ax.add_patch(Polygon(box, closed=True, facecolor=to_rgba(face, alpha),
                                     edgecolor=to_rgba(edge, alpha), linewidth=0.7, zorder=3))
    ax.set_xlabel("x [m]", fontsize=9, labelpad=1)
    ax.set_ylabel("y [m]", fontsize=9)
    ax.tick_params(labelsize=8)
    ax.set_title(f"(a) snapshots every {every_s:g} s (later = darker)", fontsize=10, loc="left")


def _fit_equal_aspect(ax, region: tuple[float, float, float, float], fig_w: float,
                      fig_h: float) -> None:
    """Show `region` with equal metres on both axes, growing its x or y range to the panel.

    Args:
        ax: the map's Axes.
        region: (xmin, xmax, ymin, ymax) that must be visible [m].
        fig_w: figure width [inch].
        fig_h: figure height [inch].
    """
    x0, x1, y0, y1 = region
    pos = ax.get_position()
    box_w, box_h = pos.width * fig_w, pos.height * fig_h  # [inch]
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    span_x, span_y = x1 - x0, y1 - y0
    if span_y / span_x < box_h / box_w:
        span_y = span_x * box_h / box_w
    else:
        span_x = span_y * box_w / box_h
    ax.set_xlim(cx - 0.5 * span_x, cx + 0.5 * span_x)
    ax.set_ylim(cy - 0.5 * span_y, cy + 0.5 * span_y)


def _draw_legend(ax, roles: list[str]) -> None:
    """One marker per role present, above the map's top right corner.

    Args:
        ax: the map's Axes.
        roles: (n,) agent roles.
    """
    present = [r for r in ROLE_COLORS if r in roles] + sorted(set(roles) - set(ROLE_COLORS))
    handles = []
    for role in present:
        face, edge = role_colors(role)
        marker = "o" if role == "pedestrian" else "s"
        handles.append(Line2D([], [], linestyle="none", marker=marker, markersize=7,
                              markerfacecolor=face, markeredgecolor=edge,
                              label={"human": "human car"}.get(role, role)))
    if handles:
        ax.legend(handles=handles, loc="lower right", bbox_to_anchor=(1.0, 1.0),
                  fontsize=8, ncol=len(handles), frameon=False, borderaxespad=0.2)


def _draw_speeds(ax, episode: _Episode, snaps: np.ndarray) -> None:
    """Panel (b): speed of every car vs time [m/s], dots at the snapshots.

    Args:
        ax: the panel's Axes.
        episode: the episode.
        snaps: (S,) step indices of the snapshots.
    """
    roles, states, active, times_s = episode.roles, episode.states, episode.active, episode.times_s
    vehicles = np.flatnonzero(~episode.is_pedestrian).tolist()
    for i in sorted(vehicles, key=lambda j: roles[j] == "robot"):  # robots on top
        face, _ = role_colors(roles[i])
        speed = np.where(active[:, i], states[:, i, 3], np.nan)
        color = face if roles[i] != "human" else HUMAN_CURVE_COLOR
        ax.plot(times_s, speed, color=color, linewidth=1.6 if roles[i] == "robot" else 2.6,
                label=episode.names[i])
        ax.scatter(times_s[snaps], speed[snaps], s=10, color=color, zorder=3)
    ax.set_ylabel("speed [m/s]", fontsize=9)
    ax.set_title("(b) speed of the cars", fontsize=10, loc="left")
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=8, labelbottom=True)
    if vehicles:
        ax.legend(fontsize=8, loc="best")
        top = np.nanmax(np.where(active[:, vehicles], states[:, vehicles, 3], np.nan),
                        initial=1.0)
        ax.set_ylim(0.0, 1.15 * top)


def _draw_signal_strips(ax, times_s: np.ndarray, signal_states, head_names: list[str]) -> None:
    """One strip per signal head along the top of panel (b), coloured by its state over time.

    Args:
        ax: panel (b)'s Axes.
        times_s: (T,) times [s].
        signal_states: (T, H) head states (RED, YELLOW, GREEN: SIGNAL_STATE_COLORS' indices).
        head_names: (H,) the heads' names.

    Raises:
        ValueError: signal_states not (T, H) or a state outside the colours.
    """
    states = np.asarray(signal_states)
    if states.shape != (len(times_s), len(head_names)):
        raise ValueError(f"plot_episode: signal_states has shape {states.shape}, expected "
                         f"({len(times_s)}, {len(head_names)}) (steps, signal heads)")
    if states.size and not np.isin(states, np.arange(len(SIGNAL_STATE_COLORS))).all():
        raise ValueError("plot_episode: signal_states must hold 0 (red), 1 (yellow) or 2 (green)")
    dt = float(np.median(np.diff(times_s))) if len(times_s) > 1 else 0.1
    starts = np.concatenate([[0], np.flatnonzero(np.any(np.diff(states, axis=0) != 0,
                                                        axis=1)) + 1])
    x0, x1 = times_s[starts], np.append(times_s[starts[1:]], times_s[-1] + dt)
    height = 0.05
    bottom, top = ax.get_ylim()  # room above the speed curves for the strips
    ax.set_ylim(bottom, bottom + (top - bottom) / (1.0 - len(head_names) * (height + 0.01)))
    strip_axes = ax.get_xaxis_transform()  # x in seconds, y in axes fractions
    for h, name in enumerate(head_names):
        y0 = 0.97 - (h + 1) * (height + 0.01)
        ax.broken_barh(list(zip(x0, x1 - x0)), (y0, height), transform=strip_axes,
                       facecolors=[SIGNAL_STATE_COLORS[s] for s in states[starts, h]],
                       edgecolor="none", zorder=1)
        ax.text(times_s[0], y0 + 0.5 * height, f" {name} signal", transform=strip_axes,
                fontsize=6.5, va="center", ha="left", color="white", zorder=2)


def _draw_perception(ax, episode: _Episode, beliefs: dict[str, np.ndarray],
                     title: str = "probability of the pedestrian perceived") -> None:
    """Panel (c): 1 while a robot (solid) or human driver (dashed) sees a pedestrian, else 0.

    Args:
        ax: the panel's Axes (shares its time axis with panel (b)).
        episode: the episode.
        beliefs: {label: (T,) values in [0, 1]} drawn as extra curves.
        title: the panel's title (after "(c) ").
    """
    names, times_s, active, visible = (episode.names, episode.times_s, episode.active,
                                       episode.visible)
    peds = np.flatnonzero(episode.is_pedestrian).tolist()

    def sees(o: int, p: int) -> np.ndarray:  # 1/0 while both are in the episode, else a gap
        return np.where(active[:, o] & active[:, p], visible[:, o, p].astype(float), np.nan)

    for p in peds:
        for r in episode.of_role("robot"):
            ax.step(times_s, sees(r, p), where="post", color=ROLE_COLORS["robot"],
                    linewidth=2.0, label=f"{names[r]} sees {names[p]}")
        for h in episode.of_role("human"):
            ax.step(times_s, sees(h, p), where="post", color=HUMAN_CURVE_COLOR, linewidth=1.6,
                    linestyle="--", label=f"{names[h]} sees {names[p]}")
    for k, (label, series) in enumerate(beliefs.items()):
        ax.plot(times_s, np.asarray(series, dtype=np.float64),
                color=BELIEF_COLORS[k % len(BELIEF_COLORS)], linewidth=1.6, label=label)
    if not peds and not beliefs:
        ax.text(0.5, 0.5, "no pedestrian in this episode", transform=ax.transAxes,
                ha="center", va="center", fontsize=9, color="#666666")
    ax.set_ylim(-0.05, 1.1)
    ax.set_ylabel("perceived prob.", fontsize=9)
    ax.set_xlabel("time [s]", fontsize=9)
    ax.set_title(f"(c) {title}", fontsize=10, loc="left")
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=8)
    if peds or beliefs:
        ax.legend(fontsize=8, loc="best")

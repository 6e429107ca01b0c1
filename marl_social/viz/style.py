"""Colours, sizes and drawing constants shared by live frames and figures, and `RenderConfig`.

Colours follow Sun et al. 2019: red box robot, yellow box human-driven car, green dot
pedestrian. Lengths are metres [m] in the world frame, frame sizes pixels [px], line widths and
font sizes typographic points [pt] (1/72 inch; at the frames' 100 dpi 1 pt = 1.39 px).

This module imports no plotting library, so the env can hold a `RenderConfig` without loading
matplotlib until it draws.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# -- colours ----------------------------------------------------------------------------------
ROLE_COLORS = {"robot": "#e3211c", "human": "#f5c000", "pedestrian": "#12a31a"}
ROLE_EDGE_COLORS = {"robot": "#7a0d0a", "human": "#8a6a00", "pedestrian": "#05520a"}
OTHER_COLOR, OTHER_EDGE_COLOR = "#8c8c8c", "#404040"  # agents with an unknown role
BACKGROUND_COLOR = "#ebe8e0"  # sidewalks, gardens: everything off the road
ROAD_COLOR = "#7b7d80"
MARKING_COLOR = "#ffffff"
HOUSE_COLOR, HOUSE_EDGE_COLOR = "#b48c69", "#6d4f36"
LABEL_COLOR, LABEL_HALO_COLOR = "#1a1a1a", "white"  # agent names and the scale bar's length
TIME_COLOR = "#111111"  # the frame's time stamp
SCALE_BAR_RGB = (34, 34, 34)  # uint8 colour of the scale bar

# -- static map -------------------------------------------------------------------------------
CROSSWALK_STRIPE_M = 0.5  # zebra stripe thickness along the walking direction [m]
CROSSWALK_PERIOD_M = 1.0  # stripe + gap [m]
LANE_DASH_M = (3.0, 6.0)  # dashed lane line: painted, gap [m]
ROAD_EDGE_WIDTH_PT = 0.5  # outline of the lane polygons, in the road colour [pt]
ROAD_EDGE_LINE_PT = 1.6  # solid line at the road's border [pt]
LANE_DIVIDER_LINE_PT = 1.2  # dashed line between two lanes [pt]
HOUSE_EDGE_PT = 0.8  # outline of houses and parked cars [pt]
STOP_LINE_PT = 2.4  # stop lines (stop signs and signals) [pt]
SIGNAL_HEAD_M = 1.2  # side of the square drawn at a signal head [m]
SIGNAL_HEAD_EDGE_COLOR = "#111111"
SIGNAL_HEAD_OFF_COLOR = "#3a3a3a"  # a head whose state is not drawn (static map) [colour]
SIGNAL_STATE_COLORS = ("#e3211c", "#f5b800", "#19b33a")  # red, yellow, green (sim/signals.py)

# -- live frames ------------------------------------------------------------------------------
FRAME_WIDTH_PX = 1000  # default frame size [px]
FRAME_HEIGHT_PX = 240  # 1000 x 240 px: a 150 m view over the map's 25 m height plus margin
FRAME_DPI = 100  # resolution of the font sizes and line widths [px per inch]
FAN_ALPHA = {"robot": 0.18, "human": 0.13, "pedestrian": 0.09}  # fill opacity of the fans
OTHER_FAN_ALPHA = 0.1  # fan opacity of an unknown role
FAN_EDGE_ALPHA = 0.45  # opacity of a fan's outline
FAN_EDGE_PT = 0.6  # fan outline width [pt]
BODY_EDGE_PT = 0.9  # outline of car boxes and pedestrian discs [pt]
CAR_FRONT_ALPHA = 0.8  # opacity of the dark triangle on a car's front
PED_MIN_RADIUS_PX = 5.0  # pedestrians are drawn at least this large so they stay visible [px]
PED_DISC_VERTICES = 24  # polygon vertices of a pedestrian disc
SEEN_MARGIN_M = 0.45  # gap between an agent and the robot's "I see you" outline [m]
SEEN_MIN_MARGIN_PX = 2.0  # ... but at least this many pixels [px]
SEEN_EDGE_PT = 1.3  # "seen" outline width [pt]
SEEN_DASH_PT = (2.0, 1.2)  # "seen" outline: dash, gap [pt]
LABEL_FONT_PT = 7  # agent names and the scale bar's length [pt]
LABEL_LIFT_PX = 3  # gap between an agent's top and its name [px]
TIME_FONT_PT = 9  # time stamp [pt]
TIME_OFFSET_PX = 4  # time stamp's distance from the top-left corner [px]
SCALE_BAR_FRACTION = 0.12  # the scale bar is about this share of the frame's width
SCALE_BAR_THICKNESS_PX = 3
SCALE_BAR_BOTTOM_PX = 12  # scale bar's top row counted from the frame's bottom [px]
SCALE_BAR_LEFT_PX = 14  # scale bar's left column [px]
TILE_CACHE = 6  # static-map tiles (one frame wide each) kept per Renderer

# -- episode figures --------------------------------------------------------------------------
FIGURE_DPI = 120  # [px per inch]
FIGURE_WIDTH_IN = 10.0  # [inch]
DEFAULT_CAR_LENGTH_M, DEFAULT_CAR_WIDTH_M = 4.5, 1.8  # footprint when none is given [m]
HUMAN_CURVE_COLOR = "#d99a00"  # human cars' curves: darker than their yellow boxes
BELIEF_COLORS = ("#1f77b4", "#9467bd", "#17becf", "#8c564b", "#e377c2", "#7f7f7f")


def role_colors(role: str) -> tuple[str, str]:
    """Face and edge colour of a role ("robot", "human", "pedestrian"; grey otherwise)."""
    return ROLE_COLORS.get(role, OTHER_COLOR), ROLE_EDGE_COLORS.get(role, OTHER_EDGE_COLOR)


@dataclass(frozen=True)
class FrameSize:
    """A live frame's size (viz/frames.Renderer).

    Attributes:
        width_px: frame width [px].
        height_px: frame height [px].
        dpi: resolution for font sizes and line widths [px per inch].
    """

    width_px: int = FRAME_WIDTH_PX
    height_px: int = FRAME_HEIGHT_PX
    dpi: int = FRAME_DPI


DEFAULT_FRAME_SIZE = FrameSize()


@dataclass(frozen=True)
class RenderConfig:
    """How the env draws its frames (`render_mode="rgb_array"` or `"human"`).

    The view shows the map's full height and `view_width_m` of its length, keeping the
    `follow_agent` horizontally centred except near the map's ends, where the view stops (so
    that, in the occluded crosswalk, the robot, the human car, the crosswalk 60 m ahead and the
    pedestrian are all in view from t = 0); without that agent the view is the map's extent.

    Attributes:
        view_width_m: road length shown around the followed agent [m] (the map's own length if
            shorter); 150 m shows 60 m and more ahead of the robot at the start of the map.
        width_px: frame width [px].
        height_px: frame height [px].
        dpi: resolution for font sizes and line widths [px per inch].
        follow_agent: name of the agent the view follows, or None for a fixed view of the map.
        max_agents_with_fans: above this many agents only the followed agent's field of view is
            drawn (fans cost fill time on crowded maps).
    """

    view_width_m: float = 150.0
    width_px: int = FRAME_WIDTH_PX
    height_px: int = FRAME_HEIGHT_PX
    dpi: int = FRAME_DPI
    follow_agent: str | None = "robot_0"
    max_agents_with_fans: int = 10

    def __post_init__(self):
        """Reject a bad value with the field's name (ValueError)."""
        view = self.view_width_m
        self._check(not isinstance(view, bool) and isinstance(view, int | float)
                    and math.isfinite(view) and view > 0.0, "view_width_m",
                    "must be a finite number > 0 [m]")
        for name in ("width_px", "height_px", "dpi"):
            value = getattr(self, name)
            self._check(isinstance(value, int) and not isinstance(value, bool) and value >= 16,
                        name, "must be an integer >= 16")
        self._check(self.follow_agent is None or isinstance(self.follow_agent, str),
                    "follow_agent", "must be an agent name or None")
        fans = self.max_agents_with_fans
        self._check(isinstance(fans, int) and not isinstance(fans, bool) and fans >= 0,
                    "max_agents_with_fans", "must be an integer >= 0")

    @property
    def frame_size(self) -> FrameSize:
        """The frames' size (width_px, height_px, dpi)."""
        return FrameSize(self.width_px, self.height_px, self.dpi)

    def _check(self, ok: bool, field_name: str, message: str) -> None:
        if not ok:
            raise ValueError(f"{type(self).__name__}.{field_name}={getattr(self, field_name)!r}: "
                             f"{message}")

"""Render settings and colours: RenderConfig rejects bad values by name; unknown roles are grey."""

from __future__ import annotations

import dataclasses

import pytest

from marl_social.viz.style import (
    OTHER_COLOR,
    OTHER_EDGE_COLOR,
    ROLE_COLORS,
    ROLE_EDGE_COLORS,
    RenderConfig,
    role_colors,
)


def test_render_config_defaults_and_frozen():
    config = RenderConfig()
    assert (config.view_width_m, config.width_px, config.height_px) == (150.0, 1000, 240)
    assert config.follow_agent == "robot_0"
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.width_px = 10  # type: ignore[misc]
    assert dataclasses.replace(config, dpi=72).dpi == 72


@pytest.mark.parametrize(("field", "value"), [
    ("view_width_m", 0.0), ("view_width_m", float("nan")), ("view_width_m", True),
    ("width_px", 8), ("height_px", 360.5), ("dpi", False), ("follow_agent", 3),
    ("max_agents_with_fans", -1),
])
def test_render_config_rejects_bad_values_by_name(field, value):
    with pytest.raises(ValueError, match=f"RenderConfig.{field}"):
        RenderConfig(**{field: value})


def test_role_colors():
    assert role_colors("robot") == (ROLE_COLORS["robot"], ROLE_EDGE_COLORS["robot"])
    assert role_colors("cyclist") == (OTHER_COLOR, OTHER_EDGE_COLOR)

"""Live frames: they show the right things in the right places; the env renders them."""

from __future__ import annotations

import pickle
import subprocess
import sys

import numpy as np
import pytest

import marl_social
from marl_social.envs.world import World
from marl_social.perception.fov import FovResult
from marl_social.scenarios import make_scenario
from marl_social.viz.frames import Renderer
from marl_social.viz.style import FrameSize, RenderConfig
from tests.viz.pixels import green_pixels, red_pixels

W, H = 1000, 240


def _world(**overrides) -> World:
    return World(make_scenario("occluded_crosswalk", **overrides).build(np.random.default_rng(0)))


def _window(mask: np.ndarray, col: float, row: float, half: int) -> np.ndarray:
    r, c = round(row), round(col)
    return mask[max(r - half, 0):r + half + 1, max(c - half, 0):c + half + 1]


def _no_fov(world: World) -> FovResult:
    """A field of view in which nobody sees anything and no fan is drawn."""
    n = world.n
    return FovResult(np.zeros((n, n), bool), np.zeros((n, 8)), np.zeros((n, 8)), 0)


@pytest.fixture
def world() -> World:
    return _world()


# -- Renderer ---------------------------------------------------------------------------------
def test_frame_is_rgb_uint8_and_shows_the_robot_where_it_is(world):
    renderer = Renderer(world.road_map)
    frame = renderer.draw(world)
    assert frame.shape == (H, W, 3)
    assert frame.dtype == np.uint8
    assert frame.std() > 10.0  # not a blank image
    red = red_pixels(frame)
    col, row = renderer.world_to_pixel(world.state[0, :2])
    assert 0 <= col < W and 0 <= row < H
    # a 4.5 x 1.8 m car at ~0.18 m/px covers ~250 px; all the saturated red is the robot
    near = _window(red, col, row, 20)
    assert near.sum() > 100
    assert near.sum() == red.sum()
    rows, cols = np.nonzero(red)
    assert abs(cols.mean() - col) < 3.0 and abs(rows.mean() - row) < 2.0


def test_robot_box_moves_with_the_robot(world):
    renderer = Renderer(world.road_map)
    before = red_pixels(renderer.draw(world))
    m_per_px = (renderer.view_limits()[1] - renderer.view_limits()[0]) / W
    world.state[0, 0] += 10.0
    after = red_pixels(renderer.draw(world))
    shift = np.nonzero(after)[1].mean() - np.nonzero(before)[1].mean()
    assert shift == pytest.approx(10.0 / m_per_px, abs=1.5)
    assert abs(np.nonzero(after)[0].mean() - np.nonzero(before)[0].mean()) < 0.5


def test_pedestrian_is_a_visible_green_disc(world):
    renderer = Renderer(world.road_map)
    frame = renderer.draw(world)
    ped = world.names.index("pedestrian_0")
    col, row = renderer.world_to_pixel(world.state[ped, :2])
    assert _window(green_pixels(frame), col, row, 6).sum() >= 30  # at least a 5 px radius disc


def test_inactive_agents_are_not_drawn(world):
    renderer = Renderer(world.road_map)
    ped = world.names.index("pedestrian_0")
    assert red_pixels(renderer.draw(world)).sum() > 100
    col, row = renderer.world_to_pixel(world.state[ped, :2])
    world.deactivate(np.array([True, False, False]))
    frame = renderer.draw(world)
    assert red_pixels(frame).sum() == 0
    assert _window(green_pixels(frame), col, row, 6).sum() >= 30  # the others still are


def test_fov_fan_covers_the_visibility_polygon_only(world):
    renderer = Renderer(world.road_map)
    plain = renderer.draw(world, _no_fov(world)).astype(int)
    assert np.array_equal(plain, renderer.draw(world).astype(int))
    n, rays = world.n, 33
    depth = np.zeros((n, rays))
    depth[0] = 10.0  # the robot sees 10 m in every direction of its cone
    angles = np.tile(np.linspace(-1.0, 1.0, rays), (n, 1))
    fov = FovResult(np.zeros((n, n), bool), depth, angles, 0)
    fan = renderer.draw(world, fov).astype(int)
    x, y = world.state[0, :2]
    inside = renderer.world_to_pixel([x + 6.0, y - 0.5])
    beyond = renderer.world_to_pixel([x + 25.0, y - 0.5])
    px = (lambda img, p: img[round(p[1]), round(p[0])])
    assert np.abs(px(fan, inside) - px(plain, inside)).sum() > 15  # tinted red
    assert px(fan, inside)[0] > px(fan, inside)[1]
    assert np.array_equal(px(fan, beyond), px(plain, beyond))  # cut at the 10 m depth


def test_robot_marks_the_agents_it_sees(world):
    renderer = Renderer(world.road_map)
    human = world.names.index("human_0")
    fov = _no_fov(world)
    unseen = renderer.draw(world, fov)
    fov.visible[0, human] = True
    seen = renderer.draw(world, fov)
    col, row = renderer.world_to_pixel(world.state[human, :2])
    # the dashed red outline appears around the human car (and nowhere else changes colour)
    near_seen = _window(red_pixels(seen), col, row, 25).sum()
    near_unseen = _window(red_pixels(unseen), col, row, 25).sum()
    assert near_seen > near_unseen + 20
    assert red_pixels(seen).sum() - red_pixels(unseen).sum() == near_seen - near_unseen


def test_real_fov_changes_the_image(world):
    fov, _ = world.perceive(np.random.default_rng(0))
    renderer = Renderer(world.road_map)
    with_fov = renderer.draw(world, fov)
    without = renderer.draw(world)
    changed = np.any(with_fov != without, axis=-1).mean()
    assert changed > 0.02


def test_zoomed_view_makes_the_robot_bigger(world):
    wide = red_pixels(Renderer(world.road_map).draw(world)).sum()
    zoom = red_pixels(Renderer(world.road_map, view=(-10.0, 30.0, -5.0, 5.0)).draw(world)).sum()
    assert zoom > 10 * wide


def test_follow_keeps_the_agent_centred_and_stitches_the_map(world):
    follow = Renderer(world.road_map, follow="robot_0", view=(-10.0, 50.0, -12.5, 12.5),
                      follow_within_map=False)
    for dx in (0.0, 37.3, 81.9):  # crosses tile boundaries of the cached static map
        world.state[0, 0] = dx
        frame = follow.draw(world)
        col, _ = follow.world_to_pixel(world.state[0, :2])
        assert abs(col - W / 2) <= 0.5  # centred to the nearest pixel
        assert abs(np.nonzero(red_pixels(frame))[1].mean() - col) < 3.0  # and drawn there
        # the same limits drawn by a fixed-view renderer give the same picture
        fixed = Renderer(world.road_map, view=follow.view_limits(world)).draw(world)
        diff = np.abs(frame.astype(int) - fixed.astype(int))
        assert diff.mean() < 0.5 and (diff.max(axis=-1) > 30).mean() < 0.002


def test_frame_size_and_errors(world):
    small = Renderer(world.road_map, size=FrameSize(320, 200))
    assert small.draw(world).shape == (200, 320, 3)
    with pytest.raises(ValueError, match="view"):
        Renderer(world.road_map, view=(10.0, 0.0, -5.0, 5.0))
    with pytest.raises(ValueError, match="follow"):
        Renderer(world.road_map, follow="nobody").draw(world)
    small.close()
    small.close()  # idempotent
    with pytest.raises(RuntimeError):
        small.draw(world)


def test_show_mode_on_a_headless_machine_behaves_like_rgb_array(world):
    renderer = Renderer(world.road_map, show=True)
    frame = renderer.draw(world)
    assert frame.shape == (H, W, 3) and red_pixels(frame).sum() > 100
    renderer.close()


def test_rgb_rendering_never_imports_pyplot():
    code = (
        "import sys, numpy as np, marl_social\n"
        "env = marl_social.parallel_env(render_mode='rgb_array')\n"
        "env.reset(seed=0)\n"
        "frame = env.render()\n"
        "assert frame.shape == (240, 1000, 3), frame.shape\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


# -- the env ----------------------------------------------------------------------------------
@pytest.mark.parametrize("x_m", [-40.0, -12.0, 0.0, 33.3, 71.7, 118.0, 149.0, 170.0])
def test_follow_stops_at_the_map_ends_and_keeps_the_agent_in_view(world, x_m):
    x_map0, x_map1 = world.road_map.extent[:2]
    renderer = Renderer(world.road_map, follow="robot_0",
                        view=(x_map0, x_map0 + 80.0, -12.5, 12.5))
    world.state[0, 0] = x_m
    frame = renderer.draw(world)
    left, right = renderer.view_limits(world)[:2]
    m_per_px = (right - left) / W
    assert right - left < x_map1 - x_map0
    # the view never leaves the map ...
    assert left >= x_map0 - 0.5 * m_per_px and right <= x_map1 + 0.5 * m_per_px
    # ... is centred on the agent wherever that is possible ...
    centre = min(max(x_m, x_map0 + 0.5 * (right - left)), x_map1 - 0.5 * (right - left))
    assert 0.5 * (left + right) == pytest.approx(centre, abs=m_per_px)
    # ... and the agent is drawn where it is while it is on the map
    col, _ = renderer.world_to_pixel(world.state[0, :2])
    half_car_px = 0.5 * 4.5 / m_per_px + 2
    if half_car_px <= col < W - half_car_px:  # wholly in view
        assert abs(np.nonzero(red_pixels(frame))[1].mean() - col) < 3.0
    elif not -half_car_px < col < W + half_car_px:  # wholly out of view
        assert red_pixels(frame).sum() == 0


def test_follow_on_a_map_shorter_than_the_view_keeps_the_agent_centred(world):
    x_map0, x_map1 = world.road_map.extent[:2]
    renderer = Renderer(world.road_map, follow="robot_0",
                        view=(x_map0, x_map0 + 1.5 * (x_map1 - x_map0), -12.5, 12.5))
    for x_m in np.random.default_rng(4).uniform(x_map0, x_map1, size=4):
        world.state[0, 0] = x_m
        left, right = renderer.view_limits(world)[:2]
        assert 0.5 * (left + right) == pytest.approx(x_m, abs=(right - left) / W)


def test_env_render_shows_the_crosswalk_ahead_from_the_start_and_follows_the_robot():
    env = marl_social.parallel_env(render_mode="rgb_array", render_fov=False)
    env.reset(seed=0)
    first = env.render()
    assert first.shape == (H, W, 3) and first.dtype == np.uint8
    # at t = 0 the robot, the crosswalk 60 m ahead and the pedestrian beside it are all in view
    renderer = env._renderer
    for xy in (env.world.state[0, :2], env.road_map.crosswalks[0].center,
               env.world.state[env.world.names.index("pedestrian_0"), :2]):
        col, row = renderer.world_to_pixel(xy)
        assert 0 <= col < W and 0 <= row < H
    assert green_pixels(first).sum() > 20  # the pedestrian is drawn
    assert abs(np.nonzero(red_pixels(first))[1].mean()
               - renderer.world_to_pixel(env.world.state[0, :2])[0]) < 3.0
    left0 = renderer.view_limits(env.world)[0]
    assert left0 == pytest.approx(env.road_map.extent[0], abs=0.2)  # held at the map's start
    while env.agents and env.world.state[0, 0] < 70.0:  # past the middle of the view
        env.step({a: np.zeros(2) for a in env.agents})
    later = env.render()
    x_min, x_max = renderer.view_limits(env.world)[:2]
    m_per_px = (x_max - x_min) / W
    # then the view slides with the robot, which stays centred
    assert x_min > left0 + 10.0
    assert 0.5 * (x_min + x_max) == pytest.approx(env.world.state[0, 0], abs=m_per_px)
    assert np.nonzero(red_pixels(later))[1].mean() == pytest.approx(W / 2, abs=6)
    env.close()


def test_env_render_with_fov_and_human_mode():
    env = marl_social.parallel_env(render_mode="rgb_array")
    env.reset(seed=0)
    with_fov = env.render()
    env.close()
    env = marl_social.parallel_env(render_mode="rgb_array", render_fov=False)
    env.reset(seed=0)
    assert np.any(with_fov != env.render())
    env.close()
    env = marl_social.parallel_env(render_mode="human")
    env.reset(seed=0)
    env.step({a: np.zeros(2) for a in env.agents})
    assert env.render() is None
    env.close()


def test_env_render_config_sets_the_frame_size_and_view():
    config = RenderConfig(view_width_m=40.0, width_px=400, height_px=200)
    env = marl_social.parallel_env(render_mode="rgb_array", render_config=config)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (200, 400, 3)
    x_min, x_max, y_min, y_max = env._renderer.view_limits(env.world)
    # 40 m of road grown to the 2:1 frame over the map's 25 m height: 50 m x 25 m
    assert x_max - x_min == pytest.approx(2.0 * (y_max - y_min))
    assert x_max - x_min < RenderConfig().view_width_m
    assert 0.5 * (x_min + x_max) == pytest.approx(env.world.state[0, 0], abs=0.2)
    env.close()


def test_env_render_config_survives_pickling_and_is_checked():
    config = RenderConfig(width_px=320, height_px=180, follow_agent=None)
    env = marl_social.parallel_env(render_mode="rgb_array", render_config=config)
    clone = pickle.loads(pickle.dumps(env))
    assert clone.render_config == config
    clone.reset(seed=0)
    assert clone.render().shape == (180, 320, 3)
    clone.close()
    assert marl_social.parallel_env().render_config == RenderConfig()
    with pytest.raises(TypeError, match="render_config"):
        marl_social.parallel_env(render_config={"width_px": 320})

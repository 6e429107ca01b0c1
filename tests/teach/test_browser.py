"""The live page in a real browser: load it, move the human-β slider, blind the human, step.

Each check reads the page's own hooks (data-testid attributes, window.marlSocial.stats());
screenshots go to marl_social_out/test-artefacts/teach/.
"""

from __future__ import annotations

import hashlib
import time

import pytest

from tests.teach.browser import ServerThread, chromium_path, launch, screenshot

pytest.importorskip("starlette", reason='the teach extra is not installed: pip install -e ".[teach]"')
pytest.importorskip("uvicorn", reason='the teach extra is not installed: pip install -e ".[teach]"')

STATS = "window.marlSocial.stats()"


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    executable = chromium_path()
    with sync_playwright() as playwright:
        browser = launch(playwright, executable)
        yield browser
        browser.close()


@pytest.fixture(scope="module")
def server():
    from marl_social.teach.server import ServerOptions, create_app

    with ServerThread(create_app(ServerOptions(max_sessions=4, warm_up=False))) as running:
        yield running


@pytest.fixture
def page(browser, server):
    page = browser.new_page(viewport={"width": 1400, "height": 950})
    errors = []
    page.on("pageerror", lambda err: errors.append(str(err)))
    page.goto(server.url)
    page.wait_for_function(f"{STATS}.panes > 0 && {STATS}.step === 0", timeout=60_000)
    yield page
    page.close()
    assert not errors, errors


def stats(page) -> dict:
    return page.evaluate(STATS)


def step_to(page, n: int, suffix: str = "") -> dict:
    """Click "step" until the first pane shows step n."""
    for _ in range(n - stats(page)["step"]):
        before = stats(page)["step"]
        page.click("[data-testid=step]")
        page.wait_for_function(f"{STATS}.step === {before + 1}")
    page.wait_for_timeout(50)  # one more animation frame draws it
    return stats(page)


def scene_digest(page, testid: str = "scene") -> str:
    data = page.eval_on_selector(f"[data-testid={testid}]", "c => c.toDataURL()")
    return hashlib.sha1(data.encode()).hexdigest()


def change_control(page, name: str, value=None, check=None) -> dict:
    """Set a control like a user and wait for the restarted episode; returns the stats."""
    episode = stats(page)["episode"]
    control = page.locator(f'[data-testid="control-{name}"]')
    if check is not None:
        control.set_checked(check)
    elif control.evaluate("e => e.tagName") == "SELECT":
        control.select_option(str(value))
    else:
        control.fill(str(value))
    page.wait_for_function(f"{STATS}.episode > {episode} && {STATS}.latency_ms !== null"
                           f" && ['playing', 'paused'].includes({STATS}.state)")
    return stats(page)


def test_the_page_shows_scene_belief_and_hooks(page):
    for testid in ("scene", "belief", "play", "step", "restart", "control-human.beta",
                   "control-human.blind", "control-robot.planner", "control-scenario",
                   "control-seed", "control-robot.theta_hat", "control-robot.epsilon",
                   "control-robot.pos_noise_m", "control-pedestrian", "control-compare"):
        assert page.locator(f'[data-testid="{testid}"]').count() == 1, testid
    first = stats(page)
    assert set(first) >= {"t", "frames", "fps", "belief"} and first["t"] == 0
    assert 0 < first["belief"] < 1
    step_to(page, 25)
    assert stats(page)["t"] == pytest.approx(2.5)
    assert "crossing_right" in page.inner_text("[data-testid=belief]")
    screenshot(page, "live-step25")


def test_moving_the_beta_slider_restarts_and_changes_the_drawing(page):
    """β = 0 (erratic): with no pedestrian, the human's random braking looks like braking for
    one (with the default crossing pedestrian the human really warns by step 15)."""
    change_control(page, "pedestrian", "none")
    default = step_to(page, 15)
    drawn = scene_digest(page)
    changed = change_control(page, "human.beta", 0)
    assert changed["step"] == 0 and changed["latency_ms"] <= 1000  # shown within 1 s
    erratic = step_to(page, 15)
    assert scene_digest(page) != drawn
    assert default["belief"] < 0.1 and erratic["belief"] > 0.5
    screenshot(page, "live-erratic-human")


def test_a_blind_human_leaves_the_robot_uninformed(page):
    seeing = step_to(page, 28)
    blinded = change_control(page, "human.blind", check=True)
    assert blinded["latency_ms"] <= 1000
    blind = step_to(page, 28)
    assert seeing["belief"] > 0.9 and blind["belief"] < 0.01
    screenshot(page, "live-blind-human")


def test_bad_input_shows_one_line_and_the_page_goes_on(page):
    seed = page.locator('[data-testid="control-seed"]')
    seed.fill("-5")
    seed.dispatch_event("change")
    page.wait_for_function(f"{STATS}.error !== ''")
    error = page.inner_text("[data-testid=error]")
    assert "seed" in error and "outside" in error
    page.evaluate("window.marlSocial.send({type: 'configure', settings: {'human.bet': 1}})")
    page.wait_for_function(f"{STATS}.error.includes('did you mean')")
    step_to(page, 3)  # the session still plays


def test_play_at_1x_and_compare_mode_frame_rates(page):
    page.click("[data-testid=play]")
    page.wait_for_timeout(3000)
    single = stats(page)
    assert single["state"] == "playing" and single["fps"] >= 20
    assert 20 <= single["step"] <= 40  # about real time: 10 steps per second
    changed = change_control(page, "compare", "aggressive")
    assert changed["panes"] == 2 and changed["state"] == "playing"  # a change keeps playing
    page.wait_for_timeout(3000)
    both = stats(page)
    assert both["fps"] >= 10 and both["step"] >= 20
    assert None not in both["beliefs"][:1]
    screenshot(page, "live-compare-social-aggressive")


def test_speed_and_restart(page):
    page.select_option("[data-testid=speed]", "4")
    page.click("[data-testid=play]")
    start = time.monotonic()
    page.wait_for_function(f"{STATS}.step >= 40", timeout=10_000)
    assert time.monotonic() - start < 3.0  # 4x: 40 steps in about 1 s
    page.click("[data-testid=restart]")
    page.wait_for_function(f"{STATS}.step < 10")

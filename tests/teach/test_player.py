"""The docs site's static player: the precomputed episodes drawn by the live app's code."""

from __future__ import annotations

import functools
import http.server
import json
import threading
from pathlib import Path

import pytest

from tests.teach.browser import chromium_path, launch, screenshot

DOCS_TEACH = Path(__file__).resolve().parents[2] / "docs" / "teach"
STATS = "window.marlSocial.stats()"


def test_the_exported_episodes_are_listed_and_compact():
    index = json.loads((DOCS_TEACH / "episodes" / "index.json").read_text())
    assert [e["name"] for e in index] == ["social-vs-aggressive", "blind-human",
                                          "erratic-human", "wrong-model"]
    for entry in index:
        path = DOCS_TEACH / "episodes" / entry["file"]
        assert path.stat().st_size < 400_000
        episode = json.loads(path.read_text())
        assert episode["panes"] and all(p["frames"][0]["step"] == 0 for p in episode["panes"])


@pytest.fixture(scope="module")
def docs_server(tmp_path_factory):
    """docs/teach/ as the built site has it: the player's assets copied in by the docs hook."""
    import importlib.util
    import shutil

    site = tmp_path_factory.mktemp("site") / "teach"
    shutil.copytree(DOCS_TEACH, site)
    spec = importlib.util.spec_from_file_location(
        "teach_assets", DOCS_TEACH.parent / "scripts" / "teach_assets.py")
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    hook.copy_player_assets(site / "assets")
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(site))
    handler.log_message = lambda *a: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}/player.html"
    server.shutdown()


def test_the_static_player_plays_steps_and_switches(docs_server):
    from playwright.sync_api import sync_playwright

    executable = chromium_path()
    with sync_playwright() as playwright:
        browser = launch(playwright, executable)
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        errors = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        page.goto(docs_server)
        page.wait_for_function(f"{STATS}.panes === 2")  # social against aggressive
        page.click("[data-testid=step]")
        page.wait_for_function(f"{STATS}.step === 1")
        page.select_option("[data-testid=speed]", "4")
        page.click("[data-testid=play]")
        page.wait_for_function(f"{STATS}.step >= 30")
        assert page.evaluate(STATS)["fps"] >= 20
        screenshot(page, "player-social-vs-aggressive")
        page.select_option("[data-testid=control-episode]", "blind-human.json")
        page.wait_for_function(f"{STATS}.panes === 1 && {STATS}.step === 0")
        browser.close()
    assert not errors, errors

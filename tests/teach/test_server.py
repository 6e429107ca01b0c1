"""The app's server: pages, controls, the episode stream, and bad input of every kind."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("starlette", reason="the teach extra is not installed: "
                    'pip install -e ".[teach]"')
pytest.importorskip("httpx2", reason="starlette's TestClient needs httpx2 (the teach extra)")

from starlette.testclient import TestClient

from marl_social.teach.server import ServerOptions, create_app


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(ServerOptions(max_sessions=2, warm_up=False))) as c:
        yield c


def receive_until(ws, kind: str, limit: int = 20) -> dict:
    for _ in range(limit):
        message = json.loads(ws.receive_text())
        if message["type"] == kind:
            return message
    raise AssertionError(f"no {kind!r} message")


def test_page_and_static_files(client):
    page = client.get("/")
    assert page.status_code == 200 and 'data-testid="scene"' not in page.text  # drawn by JS
    assert 'data-testid="play"' in page.text and "/static/app.js" in page.text
    for name in ("app.js", "render.js", "teach.css"):
        assert client.get(f"/static/{name}").status_code == 200


@pytest.mark.parametrize("path", ["/static/../../pyproject.toml", "/static/%2e%2e/server.py",
                                  "/static/..%2f..%2fpyproject.toml", "/static//etc/passwd",
                                  "/../pyproject.toml", "/etc/passwd", "/static/nope.js"])
def test_no_path_outside_the_app(client, path):
    response = client.get(path)
    assert response.status_code == 404
    assert "[project]" not in response.text and "root:" not in response.text


def test_controls_api(client):
    controls = client.get("/api/controls", params={"scenario": "t_intersection"}).json()
    assert "hidden_vehicle" in [c["name"] for c in controls]
    bad = client.get("/api/controls", params={"scenario": "../../x"})
    assert bad.status_code == 400 and "unknown scene" in bad.json()["error"]


def test_configure_step_restart(client):
    with client.websocket_connect("/ws") as ws:
        assert receive_until(ws, "status")["state"] == "ready"
        ws.send_text(json.dumps({"type": "configure", "settings": {"human.beta": 2.0}}))
        episode = receive_until(ws, "episode")
        assert episode["panes"][0]["planner"] == "social"
        assert receive_until(ws, "frame")["panes"][0]["step"] == 0
        for k in (1, 2):
            ws.send_text(json.dumps({"type": "step"}))
            assert receive_until(ws, "frame")["panes"][0]["step"] == k
        ws.send_text(json.dumps({"type": "restart"}))
        assert receive_until(ws, "episode")["id"] == episode["id"] + 1
        assert receive_until(ws, "frame")["panes"][0]["step"] == 0


def test_compare_mode_runs_two_planners_on_one_seed(client):
    with client.websocket_connect("/ws") as ws:
        ws.send_text(json.dumps({"type": "configure", "settings": {"seed": 3},
                                 "compare": "aggressive"}))
        episode = receive_until(ws, "episode")
        assert [p["planner"] for p in episode["panes"]] == ["social", "aggressive"]
        assert {p["seed"] for p in episode["panes"]} == {3}
        assert [f["step"] for f in receive_until(ws, "frame")["panes"]] == [0, 0]
        ws.send_text(json.dumps({"type": "step"}))
        assert [f["step"] for f in receive_until(ws, "frame")["panes"]] == [1, 1]


@pytest.mark.parametrize(("command", "words"), [
    ("not json", "not JSON"),
    ('{"type": "configure", "settings": {"human.beta": 99}}', "outside [0, 30]"),
    ('{"type": "configure", "settings": {"human.beta": "fast"}}', "expected a number"),
    ('{"type": "configure", "settings": {"robot.nope": 1}}', "unknown control 'robot.nope'"),
    ('{"type": "configure", "settings": {}, "compare": "rm -rf"}', "is not a planner"),
    ('{"type": "speed", "value": 100}', "speed: expected a number in [0.25, 4]"),
    ('{"type": "launch"}', "unknown command 'launch'"),
    ('[]', "unknown command"),
    ('{"type": "controls", "scenario": "x"}', "unknown scene 'x'"),
    ("x" * 30_000, "refused"),
])
def test_bad_commands_get_one_line_and_the_server_keeps_serving(client, command, words):
    with client.websocket_connect("/ws") as ws:
        ws.send_text(command)
        message = receive_until(ws, "error")["message"]
        assert words in message and "\n" not in message
        ws.send_text(json.dumps({"type": "configure", "settings": {}}))  # still serving
        assert receive_until(ws, "episode")["panes"]
    assert client.get("/").status_code == 200


def test_closed_tabs_free_their_slot_and_past_the_limit_is_busy(client):
    for _ in range(3):  # tabs closed mid-play leave nothing behind
        with client.websocket_connect("/ws") as ws:
            ws.send_text(json.dumps({"type": "configure", "settings": {}}))
            receive_until(ws, "episode")
            ws.send_text(json.dumps({"type": "play"}))
            receive_until(ws, "frame")
    assert client.app.state.live == set()
    with client.websocket_connect("/ws") as one, client.websocket_connect("/ws") as two:
        receive_until(one, "status"), receive_until(two, "status")
        with client.websocket_connect("/ws") as third:
            busy = json.loads(third.receive_text())
            assert busy["type"] == "busy" and "the limit is 2" in busy["message"]
        page = client.get("/")
        assert page.status_code == 503 and "busy" in page.text
    assert client.get("/").status_code == 200


def test_twenty_tabs_at_once_are_bounded():
    """The default limit (4 tabs playing) holds with 20 tabs open; the rest read "busy"."""
    from contextlib import ExitStack

    from marl_social.teach.server import DEFAULT_MAX_SESSIONS

    with TestClient(create_app(ServerOptions(warm_up=False))) as client, ExitStack() as tabs:
        first = [json.loads(tabs.enter_context(client.websocket_connect("/ws")).receive_text())
                 for _ in range(20)]
        kinds = [m["type"] for m in first]
        assert kinds.count("status") == DEFAULT_MAX_SESSIONS
        assert kinds.count("busy") == 20 - DEFAULT_MAX_SESSIONS
        assert client.get("/").status_code == 503
    assert client.app.state.live == set()


def test_the_cli_binds_loopback_and_hints_without_the_extra(monkeypatch, capsys):
    import builtins

    from marl_social.cli.app import build_parser
    from marl_social.teach import launch

    args = build_parser().parse_args(["teach"])
    assert args.host == "127.0.0.1" and args.port == 8765 and not args.open
    real_import = builtins.__import__

    def no_uvicorn(name, *rest, **kw):
        if name == "uvicorn":
            raise ImportError(name)
        return real_import(name, *rest, **kw)

    monkeypatch.setattr(builtins, "__import__", no_uvicorn)
    assert launch.serve() == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and 'pip install -e ".[teach]"' in err

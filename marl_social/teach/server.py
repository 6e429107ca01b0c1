"""The teaching app's web server: Starlette, one websocket per tab, run by uvicorn.

Routes: `/` the page (a "busy" page, HTTP 503, once `max_sessions` tabs are playing), `/static/*`
its script and style (Starlette's StaticFiles: a path outside the folder is a 404), `/api/controls`
a scene's controls as JSON, `/ws` the episode stream. Over the websocket a page sends JSON
commands ({"type": "configure", "settings": {control: value}, "compare": planner or null},
"play", "pause", "step", "restart", {"type": "speed", "value": 0.25-4}, {"type": "controls",
"scenario": name}); the server answers with "status", "controls", "episode" (the headers of
one or two panes: map, agents, colours), "frame" (each pane's step) and "error" (one line; the
session goes on). Env steps run in a thread pool, so the event loop stays free; the numba
kernels are loaded (compiled if not cached) once at start-up in that pool, and pages that
connect meanwhile see the "compiling" state.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from importlib import resources

from starlette.applications import Starlette
from starlette.responses import HTMLResponse, JSONResponse
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect

from marl_social.agents.registry import ROBOT_PLANNERS
from marl_social.sim.dynamics import DT_S
from marl_social.teach.controls import SettingsError, scene_controls, validate_request
from marl_social.teach.session import EpisodeConfig, EpisodeSession

DEFAULT_MAX_SESSIONS = 4  # tabs playing at once; on 2 cores each still gets its frame rate
SPEEDS = (0.25, 4.0)  # slowest and fastest playback, x real time
MAX_MESSAGE_CHARS = 20_000  # a longer command is refused unread
BUSY_TEXT = ("busy: {n} tabs are already running episodes (the limit is {limit}; "
             "`marl-social teach --max-sessions N` raises it); close one and reload")


@dataclass(frozen=True)
class ServerOptions:
    """How the app runs.

    Attributes:
        max_sessions: the most tabs playing at once; more get the busy page.
        warm_up: load (compile if not cached) the numba kernels at start-up.
        threads: the pool stepping the envs.
    """

    max_sessions: int = DEFAULT_MAX_SESSIONS
    warm_up: bool = True
    threads: int = 2


def _static_dir():
    return resources.files("marl_social.teach") / "page-assets"


class Kernels:
    """The numba kernels' state: "compiling" (or loading) until they are ready."""

    def __init__(self):
        self.state = "ready"
        self.ready = asyncio.Event()
        self.ready.set()

    async def warm_up(self, pool) -> None:
        self.state, self.ready = "compiling", asyncio.Event()
        loop = asyncio.get_running_loop()
        try:
            await loop.run_in_executor(pool, _load_kernels)
        finally:
            self.state = "ready"
            self.ready.set()


def _load_kernels() -> None:
    from marl_social.agents.compile_kernels import compile_kernels, compile_side_by_side

    compile_side_by_side()  # the parts not cached yet, one process per core
    compile_kernels()  # every part into this process


class TabSession:
    """One tab: its episode panes (one, or two in compare mode), playback and pacing.

    Args:
        websocket: the tab's accepted websocket.
        pool: the thread pool stepping the envs.
        kernels: the kernels' state (the first episode waits for them).
    """

    def __init__(self, websocket: WebSocket, pool: ThreadPoolExecutor, kernels: Kernels):
        self.ws, self.pool, self.kernels = websocket, pool, kernels
        self.panes: list[EpisodeSession] = []
        self.episode_id = 0
        self.playing, self.pending_steps, self.speed = False, 0, 1.0
        self.lock = asyncio.Lock()
        self.wake = asyncio.Event()

    async def send(self, message: dict) -> None:
        await self.ws.send_text(json.dumps(message, separators=(",", ":")))

    async def error(self, text: str) -> None:
        await self.send({"type": "error", "message": text})

    # -- commands -------------------------------------------------------------------------------
    async def handle(self, text: str) -> None:
        """Run one command of the page; a bad one is answered with an error line."""
        if len(text) > MAX_MESSAGE_CHARS:
            return await self.error(f"command of {len(text)} characters refused (at most "
                                    f"{MAX_MESSAGE_CHARS})")
        try:
            command = json.loads(text)
        except ValueError:
            return await self.error("command is not JSON")
        kind = command.get("type") if isinstance(command, dict) else None
        try:
            if kind == "configure":
                await self.configure(command.get("settings", {}), command.get("compare"))
            elif kind == "controls":
                scenario = command.get("scenario", "occluded_crosswalk")
                await self.send({"type": "controls", "scenario": scenario, "controls": [
                    c.as_json() for c in scene_controls(str(scenario))]})
            elif kind in ("play", "pause"):
                self.playing = kind == "play" and bool(self.panes)
                self.wake.set()
            elif kind == "step":
                self.playing, self.pending_steps = False, self.pending_steps + 1
                self.wake.set()
            elif kind == "restart":
                await self.restart()
            elif kind == "speed":
                self.speed = _speed(command.get("value"))
            else:
                await self.error(f"unknown command {str(kind)[:40]!r} (configure, controls, "
                                 "play, pause, step, restart, speed)")
        except SettingsError as err:
            await self.error(str(err))

    async def configure(self, settings, compare) -> None:
        """Build the episode(s) of these settings from their seed (a change restarts)."""
        scenario, clean, seed = validate_request(settings)
        planners = [clean.get("robot.planner")]
        if compare is not None:
            if compare not in ROBOT_PLANNERS:
                raise SettingsError(f"compare: {str(compare)[:40]!r} is not a planner (one of "
                                    f"{', '.join(ROBOT_PLANNERS)})")
            planners.append(compare)
        configs = [EpisodeConfig(scenario, {**clean, **({"robot.planner": p} if p else {})},
                                 seed) for p in planners]
        if not self.kernels.ready.is_set():
            await self.send({"type": "status", "state": "compiling"})
            await self.kernels.ready.wait()
        async with self.lock:
            await self.send({"type": "status", "state": "building"})
            loop = asyncio.get_running_loop()
            try:
                panes = await loop.run_in_executor(
                    self.pool, lambda: [EpisodeSession(c) for c in configs])
            except (TypeError, ValueError) as err:  # what the env's own checks refuse
                raise SettingsError(str(err).splitlines()[0]) from None
            self._close_panes()
            self.panes = panes
            await self._announce()

    async def restart(self) -> None:
        async with self.lock:
            if not self.panes:
                return
            await asyncio.get_running_loop().run_in_executor(
                self.pool, lambda: [p.reset() for p in self.panes])
            await self._announce()

    async def _announce(self) -> None:
        """Send the new episode's headers and first frames (the lock is held)."""
        self.episode_id += 1
        self.pending_steps = 0
        await self.send({"type": "episode", "id": self.episode_id,
                         "panes": [p.header() for p in self.panes]})
        await self.send({"type": "frame", "id": self.episode_id,
                         "panes": [p.frame() for p in self.panes]})
        await self.send({"type": "status", "state": "playing" if self.playing else "paused"})

    # -- playback -------------------------------------------------------------------------------
    def _step_panes(self) -> list[dict]:
        return [p.step() for p in self.panes]

    async def play_loop(self) -> None:
        """Step while playing (one step every DT_S / speed of wall time) or when asked to."""
        loop = asyncio.get_running_loop()
        next_tick = time.monotonic()
        while True:
            if not (self.playing or self.pending_steps):
                self.wake.clear()
                await self.wake.wait()
                next_tick = time.monotonic()
            async with self.lock:
                if not self.panes or not (self.playing or self.pending_steps):
                    continue
                self.pending_steps = max(0, self.pending_steps - 1)
                frames = await loop.run_in_executor(self.pool, self._step_panes)
                await self.send({"type": "frame", "id": self.episode_id, "panes": frames})
                if all(f["done"] for f in frames):
                    self.playing, self.pending_steps = False, 0
                    await self.send({"type": "status", "state": "done"})
            if self.playing:
                next_tick = max(next_tick + DT_S / self.speed, time.monotonic() - DT_S)
                await asyncio.sleep(max(0.0, next_tick - time.monotonic()))

    def _close_panes(self) -> None:
        for pane in self.panes:
            pane.close()
        self.panes = []

    def close(self) -> None:
        self._close_panes()


def _speed(value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
            SPEEDS[0] <= value <= SPEEDS[1]):
        raise SettingsError(f"speed: expected a number in [{SPEEDS[0]:g}, {SPEEDS[1]:g}] "
                            f"(x real time), got {str(value)[:40]}")
    return float(value)


def create_app(options: ServerOptions = ServerOptions()) -> Starlette:
    """The Starlette app (run it with uvicorn; tests use Starlette's TestClient).

    Args:
        options: the session limit, the kernels' warm-up, the thread pool.
    """
    pool = ThreadPoolExecutor(max_workers=options.threads, thread_name_prefix="teach-step")
    kernels = Kernels()
    live: set[TabSession] = set()
    page = (_static_dir() / "index.html").read_text(encoding="utf-8")

    def busy_text() -> str:
        return BUSY_TEXT.format(n=len(live), limit=options.max_sessions)

    async def index(request):
        if len(live) >= options.max_sessions:
            return HTMLResponse(f"<!doctype html><title>marl-social teach: busy</title>"
                                f"<p data-testid=busy>{busy_text()}</p>", status_code=503)
        return HTMLResponse(page)

    async def controls(request):
        scenario = request.query_params.get("scenario", "occluded_crosswalk")
        try:
            return JSONResponse([c.as_json() for c in scene_controls(scenario)])
        except SettingsError as err:
            return JSONResponse({"error": str(err)}, status_code=400)

    async def stream(websocket: WebSocket):
        await websocket.accept()
        if len(live) >= options.max_sessions:
            await websocket.send_text(json.dumps({"type": "busy", "message": busy_text()}))
            await websocket.close(code=1013)  # "try again later"
            return
        tab = TabSession(websocket, pool, kernels)
        live.add(tab)
        player = asyncio.create_task(tab.play_loop())
        try:
            await tab.send({"type": "status", "state": kernels.state})
            while True:
                await tab.handle(await websocket.receive_text())
        except (WebSocketDisconnect, RuntimeError):  # a closed tab (RuntimeError: mid-send)
            pass
        finally:
            player.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await player
            live.discard(tab)
            async with tab.lock:
                tab.close()

    @contextlib.asynccontextmanager
    async def lifespan(app):
        warm = asyncio.create_task(kernels.warm_up(pool)) if options.warm_up else None
        yield
        if warm is not None:
            warm.cancel()
        pool.shutdown(wait=False, cancel_futures=True)

    app = Starlette(routes=[
        Route("/", index),
        Route("/api/controls", controls),
        WebSocketRoute("/ws", stream),
        Mount("/static", StaticFiles(directory=str(_static_dir())), name="static"),
    ], lifespan=lifespan)
    app.state.live = live
    return app

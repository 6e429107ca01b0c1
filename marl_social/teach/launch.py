"""`marl-social teach`: serve the teaching app on this machine (loopback unless told).

Without the `teach` extra (starlette, uvicorn) it prints a one-line hint and exits with 2.
"""

from __future__ import annotations

import sys
import threading
import webbrowser

INSTALL_HINT = ('marl-social teach: the teaching app needs the teach extra: '
                'pip install -e ".[teach]"')
LOOPBACK = "127.0.0.1"
DEFAULT_PORT = 8765


def serve(host: str = LOOPBACK, port: int = DEFAULT_PORT, open_browser: bool = False,
          max_sessions: int | None = None) -> int:
    """Run the app until interrupted; returns the exit code.

    Args:
        host: the address to bind (default loopback: only this machine reaches it).
        port: the TCP port.
        open_browser: also open the page in the default browser.
        max_sessions: the most tabs playing at once (None: server.DEFAULT_MAX_SESSIONS).
    """
    try:
        import uvicorn

        from marl_social.teach.server import DEFAULT_MAX_SESSIONS, ServerOptions, create_app
    except ImportError:
        print(INSTALL_HINT, file=sys.stderr)
        return 2
    limit = DEFAULT_MAX_SESSIONS if max_sessions is None else int(max_sessions)
    if limit < 1:
        raise ValueError(f"--max-sessions must be >= 1, got {limit}")
    if not 0 < port < 65536:
        raise ValueError(f"--port must be in 1-65535, got {port}")
    app = create_app(ServerOptions(max_sessions=limit))
    url = f"http://{'localhost' if host == LOOPBACK else host}:{port}/"
    print(f"marl-social teach: serving on {url} (Ctrl+C stops)", flush=True)
    if host not in (LOOPBACK, "localhost", "::1"):
        print(f"marl-social teach: bound to {host}: other machines can reach it", flush=True)
    if open_browser:
        threading.Timer(1.0, webbrowser.open, [url]).start()
    uvicorn.run(app, host=host, port=port, log_level="warning", ws_max_size=1 << 16)
    return 0

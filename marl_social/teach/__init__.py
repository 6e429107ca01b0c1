"""The teaching app: `marl-social teach`, the simulator in the browser.

The simulator runs server-side (session.py: one episode stepped like `run_episode`, each step
as a compact JSON frame); controls.py binds the page's controls to settings-tree leaves and
validates what a page sends; server.py is the Starlette app (one websocket per tab); export.py
writes precomputed episodes for the docs site's static player. The page (page-assets/, served at /static) draws
the frames on a canvas with the same script (page-assets/render.js) live and in the docs.

Only server.py needs the `teach` extra (starlette, uvicorn); the rest is plain Python.
"""

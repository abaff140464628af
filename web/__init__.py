"""``lunarsim view``: the digital twin in the browser (live 3D view, statistics, ground commands, scenario editor).

The Python side (``server``) subscribes to Zenoh and serves the page and a WebSocket; the page itself is
built from ``frontend/`` (three.js, bundled with esbuild when the package is built) into ``static/``.
"""

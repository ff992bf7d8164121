"""``pipegauge review``: the local web application over a run's output (docs/review.md).

``flows/review/app.py`` is the web layer (FastAPI, plain HTML/JS/CSS in ``static/``); everything domain is in
``pipeline.app.review``.
"""

from __future__ import annotations

from typing import Callable

__all__ = ["serve", "review_url"]

DEFAULT_PORT = 8765


def review_url(host: str, port: int, token: str) -> str:
    """The URL the verb prints: the night's page with the start's token."""
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/?token={token}"


def serve(out, inbox=None, *, host: str = "127.0.0.1", port: int = DEFAULT_PORT,
          announce: Callable[[str], None] = print) -> None:
    """Serve the review of ``out`` until interrupted; ``announce`` receives the URL with its token."""
    import uvicorn

    from flows.review.app import create_app
    from pipeline.app.review import ReviewService

    shown = f"[{host}]" if ":" in host else host
    hosts = {f"{shown}:{port}", f"localhost:{port}", f"127.0.0.1:{port}"}
    app, token = create_app(ReviewService(out, inbox), hosts=hosts)
    announce(review_url(host, port, token))
    uvicorn.run(app, host=host, port=port, log_level="warning")

"""The review's web layer: a FastAPI app that parses requests, checks who may make them, and renders.

Everything it shows or does is asked of ``pipeline.app.review.ReviewService`` (docs/review.md). What this layer
adds is the guard of a local web application on a shared machine:

* a per-start random token, required on every request: in the URL it prints (``?token=``), then in a cookie
  (SameSite=Strict, HttpOnly) for the page's own requests; a state-changing request (POST) must carry it in the
  ``X-Review-Token`` header, which no other site's form or image can send;
* the Host header must name the address it listens on (no DNS rebinding); an Origin header, when a browser sends
  one, must be that address too (no cross-site POST);
* request bodies of at most ``MAX_BODY_BYTES``, counted as they arrive (a lying Content-Length included);
* ids only: an inspection id, a row, a quantity, a frame index; every file is found by the service, inside OUT
  and the inbox.
"""

from __future__ import annotations

import dataclasses
import hmac
import json
import secrets
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs

import cv2
from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse, Response
from pydantic import BaseModel, Field
from starlette.staticfiles import StaticFiles

from pipeline.app.review import NotFound, ReviewError, ReviewService, View
from pipeline.core.errors import PipegaugeError

__all__ = ["create_app", "MAX_BODY_BYTES", "TOKEN_COOKIE", "TOKEN_HEADER"]

MAX_BODY_BYTES = 64 * 1024        # a save holds at most a few frames' points and a name
TOKEN_COOKIE = "pipegauge_review"
TOKEN_HEADER = "x-review-token"
STATIC = Path(__file__).resolve().parent / "static"
SAFE_METHODS = ("GET", "HEAD")


def _plain(status: int, text: str) -> tuple[int, bytes]:
    return status, text.encode()


class Guard:
    """ASGI middleware: Host, Origin, token and body size checked before the app sees a request (module docstring)."""

    def __init__(self, app, token: str, hosts: set[str], max_body: int = MAX_BODY_BYTES):
        self.app, self.token, self.hosts, self.max_body = app, token, hosts, max_body

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        refusal = self._refusal(scope, headers)
        if refusal is not None:
            return await _send_text(send, *refusal)
        length = headers.get("content-length")
        if length is not None and (not length.isdigit() or int(length) > self.max_body):
            return await _send_text(send, *_plain(413, f"request body over {self.max_body} bytes: refused"))
        # the body is read here, whole and counted, before the app sees the request (a few KiB at most)
        body = b""
        more = scope.get("method", "GET") not in SAFE_METHODS
        while more:
            message = await receive()
            if message["type"] != "http.request":
                return
            body += message.get("body", b"")
            if len(body) > self.max_body:
                return await _send_text(send, *_plain(413, f"request body over {self.max_body} bytes: refused"))
            more = message.get("more_body", False)
        replayed = False

        async def replay():
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)

    def _refusal(self, scope, headers: dict[str, str]) -> tuple[int, bytes] | None:
        host = headers.get("host", "")
        if host not in self.hosts:
            return _plain(400, f"Host {host[:80]!r} is not this review's address: refused (DNS rebinding guard)")
        origin = headers.get("origin")
        if origin is not None and origin not in {f"http://{h}" for h in self.hosts}:
            return _plain(403, "a request from another site (Origin): refused")
        method = scope.get("method", "GET")
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        cookies = _cookies(headers.get("cookie", ""))
        offered = headers.get(TOKEN_HEADER)
        if method in SAFE_METHODS:
            offered = offered or (query.get("token") or [None])[0] or cookies.get(TOKEN_COOKIE)
        elif origin is None and headers.get("sec-fetch-site") not in (None, "same-origin"):
            return _plain(403, "a cross-site request: refused")
        if not offered or not hmac.compare_digest(offered.encode(), self.token.encode()):
            return _plain(403, "no valid review token: open the URL pipegauge review printed")
        return None


def _cookies(text: str) -> dict[str, str]:
    out = {}
    for part in text.split(";"):
        if "=" in part:
            k, v = part.split("=", 1)
            out[k.strip()] = v.strip()
    return out


async def _send_text(send, status: int, body: bytes) -> None:
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"text/plain; charset=utf-8"), (b"content-length", str(len(body)).encode()),
                            (b"cache-control", b"no-store")]})
    await send({"type": "http.response.body", "body": body})


# -- requests ------------------------------------------------------------------------------------------------------

class ViewIn(BaseModel):
    frame: int = Field(ge=0, le=10_000_000)
    a: tuple[float, float]
    b: tuple[float, float]


class MarksIn(BaseModel):
    id: str = Field(min_length=1, max_length=300)
    row: int = Field(ge=0, le=1_000_000)
    quantity: str = Field(pattern="^Q[12]$")
    views: list[ViewIn] = Field(min_length=1, max_length=8)
    monte_carlo: bool = False


class SaveIn(MarksIn):
    reviewer: str = Field(default="", max_length=200)


class IdIn(BaseModel):
    id: str = Field(min_length=1, max_length=300)


class PointsIn(IdIn):
    to: str = Field(pattern="^(recorded|ideal)$")
    points: list[tuple[float, float]] = Field(min_length=1, max_length=32)


def _views(body: MarksIn) -> list[View]:
    return [View(v.frame, tuple(v.a), tuple(v.b)) for v in body.views]       # type: ignore[arg-type]


def _json(data: Any) -> JSONResponse:
    return JSONResponse(json.loads(json.dumps(data, default=_default)), headers={"cache-control": "no-store"})


def _default(value):
    if dataclasses.is_dataclass(value):
        return dataclasses.asdict(value)       # type: ignore[arg-type]
    if hasattr(value, "isoformat"):
        return value.isoformat()
    if hasattr(value, "item"):
        return value.item()
    return str(value)


def create_app(service: ReviewService, token: str | None = None, *, hosts: set[str] | None = None) -> tuple[Any, str]:
    """The review's ASGI app and its token (a new random one unless given).

    hosts : the Host header values accepted ("127.0.0.1:8765", "localhost:8765"); the default accepts the
    test client's "testserver" only.
    """
    token = token or secrets.token_urlsafe(24)
    app = FastAPI(title="pipegauge review", docs_url=None, redoc_url=None, openapi_url=None)

    @app.exception_handler(NotFound)
    async def not_found(request: Request, exc: NotFound):
        return JSONResponse({"error": str(exc)}, status_code=404)

    @app.exception_handler(PipegaugeError)
    async def refused(request: Request, exc: PipegaugeError):
        # a refused request, or the domain's reason (a package that cannot be read, the dataset locked by a run)
        return JSONResponse({"error": str(exc)}, status_code=422 if isinstance(exc, ReviewError) else 409)

    def page(name: str, request: Request) -> Response:
        response = FileResponse(STATIC / name, headers={"cache-control": "no-store"})
        # the token from the printed URL becomes a cookie for the page's own requests (and is not needed again)
        response.set_cookie(TOKEN_COOKIE, token, httponly=True, samesite="strict")
        return response

    @app.get("/")
    def night_page(request: Request):
        return page("night.html", request)

    @app.get("/observation")
    def observation_page(request: Request):
        return page("observation.html", request)

    @app.get("/api/token")
    def page_token():
        # the page's POSTs carry the token in a header; only a same-origin page holding the cookie can read it
        return _json({"token": token})

    @app.get("/api/night")
    def night():
        return _json({"inspections": service.night(), "out": str(service.out)})

    @app.get("/api/inspection")
    def inspection(id: str):
        return _json({"inspection_id": id, "observations": service.observations(id)})

    @app.get("/api/observation")
    def observation(id: str, row: int):
        return _json(service.observation(id, row))

    @app.get("/api/candidates")
    def candidates(id: str, row: int, quantity: str, fit: int = 0, frame: int | None = None):
        return _json({"candidates": service.candidate_table(id, row, quantity, fit=bool(fit), fit_frame=frame)})

    @app.post("/api/points")
    def points(body: PointsIn):
        return _json({"points": service.convert_points(body.id, body.points, body.to)})

    @app.get("/api/frame")
    def frame(id: str, n: int, view: str = "recorded"):
        if view not in ("recorded", "ideal"):
            raise ReviewError("view: recorded or ideal")
        image = service.frame_image(id, n, undistorted=view == "ideal")
        ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])
        return Response(jpeg.tobytes(), media_type="image/jpeg", headers={"cache-control": "private, max-age=600"})

    @app.get("/api/overlay")
    def overlay(id: str, n: int, feature_m: float | None = None):
        return _json(service.frame_overlay(id, n, feature_m))

    @app.get("/api/step")
    def step(id: str, n: int, by: str = "frame", dir: int = 1):
        return _json({"frame": service.step(id, n, by, dir)})

    @app.post("/api/measure")
    def measure(body: MarksIn):
        return _json(service.measure(body.id, body.row, body.quantity, _views(body), monte_carlo=body.monte_carlo))

    @app.post("/api/save")
    def save(body: SaveIn):
        path = service.save(body.id, body.row, body.quantity, _views(body), body.reviewer)
        return _json({"saved": str(path.relative_to(service.out))})

    @app.post("/api/measure-again")
    def measure_again(body: IdIn):
        return _json(service.measure_again(body.id))

    @app.get("/report")
    def report(id: str):
        return FileResponse(service.report_path(id), media_type="application/pdf")

    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    return Guard(app, token, hosts or {"testserver"}), token

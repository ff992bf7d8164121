"""How fast ``pipegauge review`` answers: a frame step, and a click's linear update (issue 33).

The sample S01 is a 720x576 MPEG-4 (FMP4) video. First the night is measured into a temporary OUT (as a run
would; not timed), then, through the review's own app (``flows.review.app`` over ``pipeline.app.review``, the
HTTP layer included, in process):

* a frame step: ``GET /api/frame`` (decode through ``vision.video.frame_source``: the seek index, the cache, and
  the JPEG encoding) for steps forward and back by one frame, by 0.1 m and to arbitrary frames; the first
  request of a video (opening it, learning its seek index) apart. Target: under 300 ms.
* a click's linear update: ``POST /api/measure`` with ``monte_carlo`` false, the points moved by a pixel each
  time (the package and its frame's contour loaded once before, as when the page opens). Target: under 100 ms.
  The Monte Carlo result that follows in the background is timed too, for the record.
* the best-frame table: ``GET /api/candidates`` with ``frame`` (one candidate frame's contour fitted: the page
  fits them one request at a time in the background), frame jumps timed meanwhile, and without (the table
  refreshed with the poses fitted: what a frame step triggers when it shows a candidate for the first time).

Prints the median and the worst of each. Tests never assert a time.

    python benchmarks/review.py [--steps 40]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import tempfile
import time
from pathlib import Path

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
PACKAGE = "S01-circular-clean"
ROW, QUANTITY = 2, "Q1"


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return 1000.0 * (time.perf_counter() - t0)


def _line(what: str, times: list[float], target: float | None) -> str:
    verdict = "" if target is None else (" (target < %g ms: %s)" % (target, "met" if max(times) < target else "NOT met"))
    return f"{what:<44} n={len(times):>3}  median {statistics.median(times):7.1f} ms  worst {max(times):7.1f} ms{verdict}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=40, help="requests per kind of step (default: %(default)s)")
    args = parser.parse_args()

    from fastapi.testclient import TestClient

    from flows.review.app import create_app
    from pipeline.app import Layout, process_package
    from pipeline.app.review import ReviewService
    from pipeline.vision.video.overlay_ocr import OverlayReader
    from pipeline.vision.video.reader import probe_video

    root = Path(tempfile.mkdtemp(prefix="pipegauge-review-bench-"))
    try:
        inbox = root / "inbox"
        shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
        shutil.copytree(SAMPLES / PACKAGE, inbox / PACKAGE, ignore=shutil.ignore_patterns("truth"))
        layout = Layout(root / "out")
        reader = OverlayReader()
        process_package(inbox / PACKAGE, layout.dataset, reader=reader, reports=layout.reports, review=layout.review)
        info = probe_video(inbox / PACKAGE / "video.mp4")
        print(f"video: {info.width}x{info.height} {info.codec}, {info.frame_count} frames at {info.fps:g} fps")

        service = ReviewService(layout.out, inbox, reader=reader)
        app, token = create_app(service, "bench")
        client = TestClient(app)
        headers = {"x-review-token": token}
        t_load = _timed(lambda: service.package(PACKAGE))
        print(f"opening the package (log, certificate, the overlay's chainage track; once per session): {t_load:.0f} ms")

        def frame(n: int) -> None:
            r = client.get(f"/api/frame?id={PACKAGE}&n={n}&token={token}")
            assert r.status_code == 200, r.text

        truth = json.loads((SAMPLES / PACKAGE / "truth" / "truth.json").read_text())
        q = next(o for o in truth["observations"] if o["row"] == ROW)
        start = q["frame"]
        pkg = service.package(PACKAGE)
        first = _timed(lambda: frame(start))
        print(f"first frame of the video (opens it, learns its seek index): {first:.1f} ms; "
              f"seeks exact: {pkg.frames.exact_seek}")
        n = args.steps
        forward = [_timed(lambda k=k: frame(start + k)) for k in range(1, n + 1)]
        back = [_timed(lambda k=k: frame(start + n - k)) for k in range(1, n + 1)]       # inside the cache
        pkg.frames._cache.clear()                    # a cold step back: nothing decoded yet
        cold_back = []
        here = start + 3 * n
        for _ in range(min(n, 15)):
            frame(here)
            pkg.frames._cache.clear()
            cold_back.append(_timed(lambda h=here: frame(h - 1)))
            here += 29
        track = pkg.location.track
        steps_01 = []
        here = start
        for _ in range(n):
            nxt = service.step(PACKAGE, here, "0.1m", 1)
            steps_01.append(_timed(lambda f=nxt: frame(f)))
            here = nxt if nxt < info.frame_count - 30 else start
        import random

        rng = random.Random(5)
        jumps = [_timed(lambda f=rng.randrange(info.frame_count): frame(f)) for _ in range(n)]
        print(_line("frame step +1 (read on)", forward, 300))
        print(_line("frame step -1 (cached)", back, 300))
        print(_line("frame step -1 (not cached: seek, decode)", cold_back, 300))
        print(_line("step by 0.1 m", steps_01, 300))
        print(_line("jump to any frame", jumps, 300))
        del track

        a, b = q["quantities"][0]["points_px_noise_free"]
        service.contour(pkg, start)                 # the frame's contour, fitted when the page opens the frame
        body = {"id": PACKAGE, "row": ROW, "quantity": QUANTITY, "views": [{"frame": start, "a": a, "b": b}]}
        client.post("/api/measure", json=body, headers=headers)      # warm: the first call imports the models
        clicks = []
        for k in range(n):
            moved = {**body, "views": [{"frame": start, "a": a, "b": [b[0] + (k % 5) - 2, b[1] + (k % 3) - 1]}]}
            clicks.append(_timed(lambda m=moved: client.post("/api/measure", json=m, headers=headers).raise_for_status()))
        mc = [_timed(lambda: client.post("/api/measure", json={**body, "monte_carlo": True},
                                         headers=headers).raise_for_status()) for _ in range(3)]
        print(_line("click: linear update", clicks, 100))
        print(_line("click: Monte Carlo (in the background)", mc, None))

        import threading

        def table(extra: str = "") -> list[dict]:
            r = client.get(f"/api/candidates?id={PACKAGE}&row={ROW}&quantity={QUANTITY}{extra}&token={token}")
            assert r.status_code == 200, r.text
            return r.json()["candidates"]

        # the page fits the candidates' poses one request at a time, in the background; meanwhile the reviewer
        # steps frames (another thread here, as the server's thread pool serves them)
        fits: list[float] = []
        done = threading.Event()

        def fit_all() -> None:
            for c in table():
                if not c["pose"]:
                    fits.append(_timed(lambda f=c["frame"]: table(f"&frame={f}")))
            done.set()

        worker = threading.Thread(target=fit_all)
        worker.start()
        during = []
        k = 0
        while not done.is_set() and k < 10 * n:
            during.append(_timed(lambda f=rng.randrange(info.frame_count): frame(f)))
            k += 1
            time.sleep(0.05)
        worker.join()
        tables = [_timed(lambda: table()) for _ in range(min(n, 20))]
        print(_line("best-frame table: one candidate's pose fitted", fits, None))
        print(_line("jump to any frame while poses are fitted", during, 300))
        print(_line("best-frame table with the poses (refresh)", tables, 300))
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()

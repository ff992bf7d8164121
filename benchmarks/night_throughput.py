"""A night's throughput: 20 long-inspection-like sections through ``pipegauge run``, one worker, two, and Dask.

Renders (once, into ``--dir``; reused while its files are there) one section
like the long inspection (``benchmarks/long_inspection.py``: the same 300 mm
concrete sewer, camera, speed, stops and kinds of observation), cut to its
first ``--blocks`` blocks of 7.5 m (default 0.5: its first 3.75 m, about 0.7
minutes of video with three coded observations, a crack around the pipe, a
lateral and a crack along it, and the water level; the whole long inspection
is 5 blocks, 6.3 minutes: 20 of those would take hours on this machine). ``--sections`` copies of it (default 20; the video
hard-linked, the package id renamed) make an inbox, which is measured three
times into fresh OUT folders, one call after the other:

1. ``pipegauge run INBOX --out OUT --workers 1``
2. ``pipegauge run INBOX --out OUT --workers 2``
3. ``pipegauge run INBOX --out OUT --dask ADDRESS`` on a local cluster started
   here as docs/operations.md starts a real one (``dask scheduler``, then
   ``dask worker ADDRESS --nworkers N --nthreads 1``; ``--dask-workers``, default 2).

For each: wall time and sections per hour; the CPU of every process of the
run (the command, its worker processes, the Dask workers; sampled, so a
process's last fraction of a second may be missed) per section, against the
CPU of decoding one section's video alone (a ``cv2`` grab loop, measured in
this run); the peak resident memory of each process that measured sections
(the command itself for one worker); and the speed-up of two workers (and of
the cluster) over one. The embedded Prefect server's start-up is in each
call's wall time, as a night pays it once.

    python benchmarks/night_throughput.py [--sections 20] [--blocks 0.5] [--dir /tmp/pipegauge-night] [--skip-dask]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

sys.path.insert(0, str(Path(__file__).resolve().parent))

from long_inspection import BLOCK_MM, decode_only_cpu, long_spec  # noqa: E402 (benchmarks/long_inspection.py)
from pipeline.formats.certificate import save_certificate  # noqa: E402
from pipeline.synth.package import PackageSpec, build_package  # noqa: E402
from pipeline.synth.samples import sample_certificate  # noqa: E402

ENVIRONMENT = {**os.environ, "DO_NOT_TRACK": "1", "PREFECT_SERVER_ANALYTICS_ENABLED": "false"}
CLI = [sys.executable, "-c", "import sys; from flows.cli import main; sys.exit(main())"]


def _position_mm(feature, unit_mm: float) -> float:
    """Where a feature of the scene starts along the pipe [mm]."""
    for name in ("z_mm", "z_from_mm"):
        if hasattr(feature, name):
            return float(getattr(feature, name))
    return float(feature.joint) * unit_mm        # a displaced joint: its joint's number


def section_spec(blocks: float) -> PackageSpec:
    """The long inspection cut to its first ``blocks`` blocks of 7.5 m (its extra stop kept when it lies inside)."""
    spec = long_spec()
    end = blocks * BLOCK_MM
    scene = spec.scene
    kept = tuple(f for f in scene.features if _position_mm(f, scene.pipe.unit_length_mm) < end)
    return dataclasses.replace(spec, package_id=f"N01-{end:.0f}mm", section_id="N01",
                               scene=dataclasses.replace(scene, features=kept),
                               extra_stops=tuple(s for s in spec.extra_stops if 1000.0 * s.chainage_m < end))


def rendered(folder: Path, blocks: float) -> Path:
    """The section under ``folder`` (rendered the first time, then reused)."""
    spec = section_spec(blocks)
    package = folder / spec.package_id
    if not (package / "truth" / "truth.json").exists():
        cert = sample_certificate(720, 576)
        save_certificate(cert, folder / "certificates" / f"{cert.certificate_id}.json")
        t0 = time.perf_counter()
        build_package(spec, cert, folder, workers=os.cpu_count() or 1)
        print(f"rendered {package} in {time.perf_counter() - t0:.0f} s", flush=True)
    return package


def inbox_of(package: Path, n: int, root: Path) -> Path:
    """An inbox of ``n`` copies of ``package`` (files hard-linked where possible, each with its own package id)."""
    inbox = root / "inbox"
    shutil.copytree(package.parent / "certificates", inbox / "certificates")
    for k in range(n):
        copy = inbox / f"{package.name}-{k + 1:02d}"
        shutil.copytree(package, copy, ignore=shutil.ignore_patterns("truth"), copy_function=_link_or_copy)
        manifest_path = copy / "package.json"
        manifest = json.loads(manifest_path.read_text())
        manifest["package_id"] = copy.name
        manifest_path.unlink()                       # a link to the original: written anew, not through it
        manifest_path.write_text(json.dumps(manifest, indent=2))
    return inbox


def _link_or_copy(src: str, dst: str) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


class TreeWatch:
    """CPU [s] and peak resident memory [bytes] of a process tree (and of extra roots), sampled every ``every`` s."""

    def __init__(self, roots: list[int], every: float = 0.25):
        self.roots, self.every = roots, every
        self.cpu: dict[int, float] = {}
        self.rss: dict[int, int] = {}
        self.names: dict[int, str] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> TreeWatch:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.sample()
            self._stop.wait(self.every)

    def sample(self) -> None:
        for root in self.roots:
            try:
                top = psutil.Process(root)
                procs = [top, *top.children(recursive=True)]
            except psutil.NoSuchProcess:
                continue
            for p in procs:
                try:
                    with p.oneshot():
                        t = p.cpu_times()
                        self.cpu[p.pid] = t.user + t.system
                        self.rss[p.pid] = max(self.rss.get(p.pid, 0), p.memory_info().rss)
                        self.names.setdefault(p.pid, " ".join(p.cmdline()[-3:]))
                except (psutil.NoSuchProcess, psutil.AccessDenied):
                    pass


def night(inbox: Path, out: Path, *, workers: int = 1, dask: str | None = None,
          extra_roots: tuple[int, ...] = ()) -> dict:
    """One ``pipegauge run`` of the inbox: wall [s], CPU [s] of every process, per-process peak memory [bytes]."""
    options = ["--dask", dask] if dask else ["--workers", str(workers)]
    baseline: dict[int, float] = {}
    for root in extra_roots:                         # the Dask workers' CPU before the night (their start-up)
        watch0 = TreeWatch([root])
        watch0.sample()
        baseline.update(watch0.cpu)
    t0 = time.perf_counter()
    child = subprocess.Popen([*CLI, "run", str(inbox), "--out", str(out), *options], env=ENVIRONMENT,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    with TreeWatch([child.pid, *extra_roots]) as watch:
        output, _ = child.communicate()
    wall = time.perf_counter() - t0
    if child.returncode != 0:
        raise SystemExit(f"pipegauge run failed ({child.returncode}):\n{output[-3000:]}")
    rows = [json.loads(line) for line in (out / "run-log.jsonl").read_text().splitlines()]
    bad = [r for r in rows if r.get("status") not in ("ok", "partial")]
    if bad or len(rows) != len(list(inbox.glob("*/package.json"))):
        raise SystemExit(f"not every section was measured: {len(rows)} rows, {bad[:2]}")
    cpu = {pid: c - baseline.get(pid, 0.0) for pid, c in watch.cpu.items()}
    measured_by = {r["worker"].rsplit(":", 1)[-1] for r in rows if r.get("worker")}
    worker_peaks = {pid: watch.rss[pid] for pid in watch.rss if str(pid) in measured_by}
    return {"wall": wall, "cpu": sum(cpu.values()), "worker_peaks": worker_peaks, "rows": rows,
            "workers_seen": len(measured_by)}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def local_cluster(n_workers: int) -> tuple[str, list[subprocess.Popen]]:
    """A Dask scheduler and one ``dask worker`` command with ``n_workers`` single-threaded processes, as on a real
    cluster (docs/speed.md), on this machine."""
    dask = str(Path(sys.executable).with_name("dask"))
    port, dashboard = free_port(), free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler = subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                  "--dashboard-address", f":{dashboard}"], env=ENVIRONMENT,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    worker = subprocess.Popen([dask, "worker", address, "--nworkers", str(n_workers), "--nthreads", "1",
                               "--no-dashboard", "--memory-limit", "0"], env=ENVIRONMENT,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    from distributed import Client
    with Client(address, timeout=60) as client:
        client.wait_for_workers(n_workers, timeout=120)
    return address, [worker, scheduler]


def stop(processes: list[subprocess.Popen]) -> None:
    for p in processes:            # each started here, in a session of its own: its group is its processes
        try:
            os.killpg(p.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


def report(name: str, result: dict, n: int, decode_cpu: float, one: dict | None) -> None:
    per_hour = 3600.0 * n / result["wall"]
    cpu_section = result["cpu"] / n
    peaks = sorted(result["worker_peaks"].values(), reverse=True)
    speedup = f"; speed-up over one worker {one['wall'] / result['wall']:.2f}" if one is not None else ""
    print(f"{name}: {result['wall']:.0f} s for {n} sections, {per_hour:.0f} sections per hour; CPU {result['cpu']:.0f} s, "
          f"{cpu_section:.1f} s per section = {cpu_section / decode_cpu:.1f} x its decoding; peak memory per worker "
          f"{', '.join(f'{p / 2**20:.0f}' for p in peaks)} MiB ({result['workers_seen']} worker(s) measured sections)"
          f"{speedup}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sections", type=int, default=20)
    ap.add_argument("--blocks", type=float, default=0.5,
                    help="7.5 m blocks of the long inspection per section (0.5: its first 3.75 m; 5: all of it)")
    ap.add_argument("--dir", type=Path, default=Path(tempfile.gettempdir()) / "pipegauge-night",
                    help="where the section is rendered once and reused (default: %(default)s)")
    ap.add_argument("--dask-workers", type=int, default=2, help="worker processes of the local Dask cluster")
    ap.add_argument("--skip-dask", action="store_true", help="only --workers 1 and 2")
    args = ap.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    package = rendered(args.dir, args.blocks)
    video = package / "video.mp4"
    frames = json.loads((package / "truth" / "truth.json").read_text()).get("frames")
    decode = min((decode_only_cpu(video) for _ in range(3)), key=lambda t: t[1])
    print(f"section {package.name}: {frames or '?'} frames; decoding alone (grab loop, least CPU of 3) "
          f"{decode[0]:.2f} s wall, {decode[1]:.2f} s CPU; {args.sections} copies; {os.cpu_count()} cores", flush=True)
    with tempfile.TemporaryDirectory(prefix="pipegauge-night-", dir=args.dir) as tmp:
        root = Path(tmp)
        inbox = inbox_of(package, args.sections, root)
        one = night(inbox, root / "out-1", workers=1)
        report("--workers 1", one, args.sections, decode[1], None)
        two = night(inbox, root / "out-2", workers=2)
        report("--workers 2", two, args.sections, decode[1], one)
        if not args.skip_dask:
            address, cluster = local_cluster(args.dask_workers)
            try:
                roots = tuple(p.pid for p in cluster)
                result = night(inbox, root / "out-dask", dask=address, extra_roots=roots)
            finally:
                stop(cluster)
            report(f"--dask (local cluster, {args.dask_workers} worker processes of 1 thread)", result, args.sections,
                   decode[1], one)


if __name__ == "__main__":
    main()

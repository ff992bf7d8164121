"""Test helpers: a delivery folder written from sample packages (one ISYBAU 2013 file for their sections, their
videos under MPEG/, their marks under marks/, delivery.json), and the same sections as package folders with the
ids the delivery gives them, so that both are measured with the same Monte Carlo seeds."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from pipeline.formats.delivery import inspection_id
from pipeline.formats.header import load_header
from pipeline.formats.isybau import write_isybau
from pipeline.formats.manifest import write_manifest
from pipeline.formats.observation_log import read_log
from pipeline.formats.reading import observation_record

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
TOLERANCE_FIELDS = ("height_tolerance_mm", "longitudinal_reference")     # what ISYBAU does not carry


def write_delivery(folder: Path, samples: list[str], *, delivery_id: str = "JOB1", videos: bool = True,
                   certificate_id: str | None = "SYN-720x576", marks: bool = True) -> Path:
    """A delivery folder of ``samples`` (package names in sample_videos/); returns the folder."""
    folder.mkdir(parents=True, exist_ok=True)
    sections, per_section = [], {}
    for name in samples:
        pkg = SAMPLES / name
        header = load_header(pkg / "header.json")
        observations = read_log(pkg / "observations.csv", header.section_length_m)
        video = f"MPEG/{header.section_id}.mp4"
        if videos:
            (folder / "MPEG").mkdir(exist_ok=True)
            shutil.copyfile(pkg / "video.mp4", folder / video)
        if marks:
            (folder / "marks").mkdir(exist_ok=True)
            shutil.copyfile(pkg / "marks.csv", folder / "marks" / f"{header.section_id}.csv")
        sections.append({"key": header.section_id, "header": header.as_record(),
                         "observations": [observation_record(o) for o in observations], "video": video})
        record = header.as_record()
        per_section[header.section_id] = {k: record[k] for k in TOLERANCE_FIELDS}
        first = header
    write_isybau(folder / "job.xml", sections, job="pipegauge test job", contractor=first.contractor, site=first.site)
    data: dict = {"delivery_id": delivery_id, "sections": per_section}
    if certificate_id:
        data["certificate_id"] = certificate_id
    (folder / "delivery.json").write_text(json.dumps(data, indent=1), encoding="utf-8")
    return folder


def write_twin_packages(inbox: Path, samples: list[str], *, delivery_id: str = "JOB1") -> list[Path]:
    """The same sections as package folders, each with the id the delivery gives it."""
    out = []
    for name in samples:
        pkg = SAMPLES / name
        header = load_header(pkg / "header.json")
        twin = inbox / name
        shutil.copytree(pkg, twin, ignore=shutil.ignore_patterns("truth"))
        manifest = json.loads((pkg / "package.json").read_text())
        write_manifest(twin, inspection_id(delivery_id, header.section_id), manifest["certificate_id"])
        out.append(twin)
    return out

"""The house's floors (docs/architecture.md): every import in pipeline/ points down, never up or sideways."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PIPELINE = ROOT / "pipeline"

# Floor of each room; a module may import its own room and the rooms of lower floors only.
FLOORS = {
    "errors": 0, "limits": 0, "atomic": 0, "text": 0, "pdf": 0, "__init__": 0,   # the ground: pipeline/*.py
    "metrology": 1, "profiles": 1,                                        # maths
    "camera": 2,                                                          # the camera and its models
    "coding": 3, "store": 3, "grading": 3,                                # formats; grading schemes as data
    "contour": 4, "verdicts": 4,                                          # the contour in images; log and survey rules
    "video": 5,                                                           # video ingest
    "measurement": 6, "exchange": 6, "report": 6, "calibration": 6, "paper": 6,
    "inspection": 7,                                                      # the conductor of one package
    "synth": 8,                                                           # the generator: a consumer, like a test
}


def _room(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in FLOORS else "__init__"    # `from .. import __version__`


def _imports(path: Path) -> list[tuple[str, int]]:
    """(imported pipeline module, line) of every import in a file, relative imports resolved."""
    module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    package = module.rsplit(".", 1)[0] if path.name != "__init__.py" else module.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [target] if node.module else [f"{target}.{a.name}" for a in node.names]
            out += [(t, node.lineno) for t in names if t.startswith("pipeline")]
        elif isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name.startswith("pipeline")]
    return out


def test_every_room_has_a_floor():
    rooms = {p.stem if p.is_file() else p.name for p in PIPELINE.iterdir()
             if (p.is_file() and p.suffix == ".py") or (p.is_dir() and (p / "__init__.py").exists())}
    assert rooms <= set(FLOORS), f"give these rooms a floor in tests/test_architecture.py: {sorted(rooms - set(FLOORS))}"


def test_no_module_imports_upward_or_sideways():
    violations = []
    for path in sorted(PIPELINE.rglob("*.py")):
        room = _room(".".join(path.relative_to(ROOT).with_suffix("").parts))
        for target, line in _imports(path):
            other = _room(target)
            if other != room and FLOORS[other] >= FLOORS[room] and FLOORS[other] > 0:
                violations.append(f"{path.relative_to(ROOT)}:{line} ({room}, floor {FLOORS[room]}) imports {target} "
                                  f"({other}, floor {FLOORS[other]})")
    assert not violations, "imports that climb:\n" + "\n".join(violations)


def test_no_production_module_imports_the_generator():
    users = [f"{p.relative_to(ROOT)}:{line}" for p in PIPELINE.rglob("*.py") if "synth" not in p.relative_to(PIPELINE).parts
             for target, line in _imports(p) if target.startswith("pipeline.synth")]
    flows = [f"{p.relative_to(ROOT)}:{line}" for p in (ROOT / "flows").glob("*.py") for target, line in _imports(p)
             if target.startswith("pipeline.synth") and p.name != "cli.py"]
    assert not users and not flows, users + flows


def _loaded_after(statement: str) -> set[str]:
    code = f"import sys; {statement}; print('\\n'.join(sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return set(out.split())


def test_the_library_never_loads_prefect_and_the_models_load_no_video_stack():
    everything = _loaded_after("import pipeline, pipeline.inspection, pipeline.store, pipeline.report, "
                               "pipeline.exchange, pipeline.measurement, pipeline.video, pipeline.contour")
    assert "prefect" not in everything
    models = _loaded_after("import pipeline.measurement, pipeline.camera, pipeline.metrology")
    assert not {m for m in models if m.startswith(("pipeline.video", "pipeline.report", "pipeline.synth", "rapidocr",
                                                   "reportlab", "onnxruntime"))}
    # scipy.stats costs a second at every start-up for two quantiles that scipy.special gives
    assert not {m for m in everything | models if m.startswith("scipy.stats")}
